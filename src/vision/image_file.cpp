// Image files read whole and decoded (rost/vision/image_file.hpp); the
// truncation check is in image_truncated.cpp.

#include "rost/vision/image_file.hpp"

#include <limits>

#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>

#include "rost/text_io.hpp"

namespace rost::vision {

Status readImageFile(const std::string& path, cv::Mat& out) {
    std::string bytes;
    return readImageFile(path, out, bytes);
}

Status readImageFile(const std::string& path, cv::Mat& out, std::string& bytes) {
    out.release();
    if (Status st = text::readFile(path, bytes); !st.ok()) return st;
    if (const std::string why = imageTruncated(reinterpret_cast<const uint8_t*>(bytes.data()), bytes.size());
        !why.empty())
        return Status::error(path + ": cannot decode image: " + why);
    if (bytes.size() > static_cast<std::size_t>(std::numeric_limits<int>::max()))
        return Status::error(path + ": cannot decode image: " + std::to_string(bytes.size()) +
                             " bytes, more than OpenCV decodes");
    if (!bytes.empty()) {
        const cv::Mat raw(1, static_cast<int>(bytes.size()), CV_8UC1, bytes.data());
        // Depth and channels as stored (16-bit, grey), and the EXIF orientation
        // applied as viewers show a photo (IMREAD_UNCHANGED ignores it); an
        // alpha channel is dropped, as the frames' BGR conversion would.
        out = cv::imdecode(raw, cv::IMREAD_ANYDEPTH | cv::IMREAD_ANYCOLOR);
    }
    if (out.empty()) return Status::error(path + ": cannot decode image");
    return {};
}

} // namespace rost::vision
