#pragma once

// The live camera source. Implemented with libcamera in camera_libcamera.cpp
// (every libcamera call of the project is in that one file), or by
// camera_none.cpp in builds without libcamera.

#include <memory>
#include <string>
#include <vector>

#include "rost/vision/frame_source.hpp"

namespace rost::vision {

// Opens the index-th camera libcamera lists. Without one: nullptr and
// "camera:N: no camera found" with what libcamera can see.
std::unique_ptr<FrameSource> openCamera(int index, const SourceOptions& options, Status& status);

} // namespace rost::vision
