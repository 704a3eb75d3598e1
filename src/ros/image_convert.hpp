#pragma once

// sensor_msgs images as rost reads them: 8-bit BGR or grey cv::Mat. C++17
// (includes ROS message headers). Encodings read: rgb8, bgr8, rgba8, bgra8,
// mono8, mono16 (top 8 bits), 8UC1, 8UC3 (as bgr8), 8UC4 (as bgra8); compressed
// images in any format OpenCV decodes (jpeg, png).

#include <string>

#include <opencv2/core.hpp>
#include <sensor_msgs/CompressedImage.h>
#include <sensor_msgs/Image.h>

namespace rost::bridge {

// The encodings toBgr reads, for messages: "rgb8, bgr8, ...".
const char* readableEncodings();
// False and `error` (one line: what is wrong with the message) when the
// image cannot be read: unknown encoding, size and data disagree, empty.
bool toBgr(const sensor_msgs::Image& msg, cv::Mat& out, std::string& error);
bool toBgr(const sensor_msgs::CompressedImage& msg, cv::Mat& out, std::string& error);

} // namespace rost::bridge
