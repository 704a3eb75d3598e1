#pragma once

// The live camera source. Implemented with libcamera in camera_libcamera.cpp
// (every libcamera call of the project is in that one file), or by
// camera_none.cpp in builds without libcamera.

#include <memory>
#include <string>
#include <vector>

#include "rost/vision/frame_source.hpp"

namespace rost::vision {

// The size of a source's frames, whose first (or native) size is w x h: the
// options' (one alone keeps the aspect ratio), else w x h within
// kMaxModelSide (a note in `notes` when scaled). A size asked for that words
// cannot be extracted from is refused. Every source sizes its frames so.
Status chooseSize(const SourceOptions& o, int w, int h, SourceInfo& info, std::vector<std::string>& notes);

// Opens the index-th camera libcamera lists. Without one: nullptr and
// "camera:N: no camera found" with what libcamera can see.
std::unique_ptr<FrameSource> openCamera(int index, const SourceOptions& options, Status& status);

} // namespace rost::vision
