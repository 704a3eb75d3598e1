#pragma once

// summary.png without OpenCV's image codecs: libpng writes the 8-bit BGR
// image OpenCV drew. OpenCV's imgcodecs (and videoio) load about 240 shared
// libraries (GDAL, FFmpeg, GStreamer, ...) when a program starts, 0.15 s
// before main() on a desktop; `rost refine` and `rost config` need none of
// them (docs/tool.md, "Two programs").

#include <string>

#include <opencv2/core.hpp>

#include "rost/status.hpp"

namespace rost::tool {

// Writes `bgr` (CV_8UC3, rows of B, G, R bytes) as an 8-bit RGB PNG at
// `path`. Errors name the path and what failed.
Status writePng(const std::string& path, const cv::Mat& bgr);

} // namespace rost::tool
