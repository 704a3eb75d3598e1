#include "image_convert.hpp"

#include <cstring>

#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "rost/vision/image_file.hpp"

namespace rost::bridge {

namespace {
struct EncodingInfo {
    const char* name;
    int type;  // OpenCV type of the message's pixels
    int code;  // cvtColor code to BGR (-1: as it is)
};
constexpr EncodingInfo kEncodings[] = {
    {"rgb8", CV_8UC3, cv::COLOR_RGB2BGR},   {"bgr8", CV_8UC3, -1},  {"rgba8", CV_8UC4, cv::COLOR_RGBA2BGR},
    {"bgra8", CV_8UC4, cv::COLOR_BGRA2BGR}, {"mono8", CV_8UC1, -1}, {"mono16", CV_16UC1, -1},
    {"8UC1", CV_8UC1, -1},                  {"8UC3", CV_8UC3, -1},  {"8UC4", CV_8UC4, cv::COLOR_BGRA2BGR},
};
} // namespace

const char* readableEncodings() { return "rgb8, bgr8, rgba8, bgra8, mono8, mono16, 8UC1, 8UC3, 8UC4"; }

bool toBgr(const sensor_msgs::Image& msg, cv::Mat& out, std::string& error) {
    const EncodingInfo* enc = nullptr;
    for (const EncodingInfo& e : kEncodings)
        if (msg.encoding == e.name) enc = &e;
    if (!enc) {
        error = "image encoding '" + msg.encoding + "' is not one rost reads (" + readableEncodings() + ")";
        return false;
    }
    const std::size_t pixel = CV_ELEM_SIZE(enc->type);
    if (msg.width == 0 || msg.height == 0 || msg.width > 65536 || msg.height > 65536) {
        error = "image of " + std::to_string(msg.width) + "x" + std::to_string(msg.height) + " pixels";
        return false;
    }
    if (msg.step < msg.width * pixel || msg.data.size() < static_cast<std::size_t>(msg.step) * msg.height) {
        error = "image data of " + std::to_string(msg.data.size()) + " bytes, expected " +
                std::to_string(static_cast<std::size_t>(msg.step) * msg.height) + " (" + std::to_string(msg.width) +
                "x" + std::to_string(msg.height) + " " + msg.encoding + ", step " + std::to_string(msg.step) + ")";
        return false;
    }
    if (enc->type == CV_16UC1 && msg.is_bigendian) {
        error = "big-endian mono16 images are not read";
        return false;
    }
    // The message's bytes, viewed without copying.
    const cv::Mat in(static_cast<int>(msg.height), static_cast<int>(msg.width), enc->type,
                     const_cast<uint8_t*>(msg.data.data()), msg.step);
    if (enc->type == CV_16UC1)
        in.convertTo(out, CV_8U, 1.0 / 256.0);
    else if (enc->code >= 0)
        cv::cvtColor(in, out, enc->code);
    else
        in.copyTo(out);
    return true;
}

bool toBgr(const sensor_msgs::CompressedImage& msg, cv::Mat& out, std::string& error) {
    if (msg.data.empty()) {
        error = "compressed image (format '" + msg.format + "') without data";
        return false;
    }
    if (const std::string why = rost::vision::imageTruncated(msg.data.data(), msg.data.size()); !why.empty()) {
        error = "compressed image (format '" + msg.format + "', " + std::to_string(msg.data.size()) + " bytes): " + why;
        return false;
    }
    const cv::Mat bytes(1, static_cast<int>(msg.data.size()), CV_8UC1, const_cast<uint8_t*>(msg.data.data()));
    try {
        out = cv::imdecode(bytes, cv::IMREAD_COLOR);
    } catch (const cv::Exception& e) {  // a header claiming more pixels than OpenCV decodes (CV_IO_MAX_IMAGE_PIXELS)
        error = "compressed image (format '" + msg.format + "', " + std::to_string(msg.data.size()) +
                " bytes) that OpenCV refuses to decode: " + e.err;
        return false;
    }
    if (out.empty()) {
        error = "compressed image (format '" + msg.format + "', " + std::to_string(msg.data.size()) +
                " bytes) that OpenCV cannot decode";
        return false;
    }
    return true;
}

} // namespace rost::bridge
