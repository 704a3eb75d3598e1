#pragma once

// Image files read whole and decoded by OpenCV, after a check OpenCV does not
// make: whether a JPEG or PNG file ends where its own structure says it ends.
// OpenCV decodes a truncated JPEG with its missing rows grey (libjpeg only
// warns, on stderr) and refuses a truncated PNG after libpng prints its own
// line; a frame source would model the grey rows, and the one line a user
// gets would not be rost's. The check walks the file's markers (JPEG) or
// chunks (PNG) without decoding: a few hundred bytes looked at a file.

#include <cstddef>
#include <cstdint>
#include <string>

#include "rost/status.hpp"

namespace cv {
class Mat;
}

namespace rost::vision {

// No OpenCV here: the fuzz target (fuzz/fuzz_image_file.cpp) builds
// imageTruncated (src/vision/image_truncated.cpp) without it.

// Why the bytes of a JPEG or PNG file are cut short ("truncated JPEG: ..."),
// or "" when they end where their structure says (or are of another format,
// or too damaged to walk: OpenCV then decides). A JPEG ends at its
// end-of-image marker (bytes after it, such as a motion photo's video, are
// allowed); a PNG at its IEND chunk.
std::string imageTruncated(const uint8_t* bytes, std::size_t size);  // C++17: rost_node includes it

// Reads and decodes an image file as cv::imread(path, IMREAD_UNCHANGED) does,
// or an error naming the file: "PATH: cannot open: REASON",
// "PATH: cannot decode image: truncated JPEG: ...", "PATH: cannot decode image".
Status readImageFile(const std::string& path, cv::Mat& out);
// The same, the file's bytes read into `bytes`: a buffer the caller keeps from
// image to image (a frame source's), whose capacity is then reused.
Status readImageFile(const std::string& path, cv::Mat& out, std::string& bytes);

} // namespace rost::vision
