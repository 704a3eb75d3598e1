#pragma once

// Camera pixel formats and their conversion to the 8-bit BGR image the word
// extractors take. Independent of libcamera: formats are named and coded as
// libcamera names them (DRM fourcc codes), so the conversions can be tested
// with synthetic buffers on a machine without a camera.

#include <array>
#include <cstddef>
#include <cstdint>
#include <string>

#include <opencv2/core.hpp>

#include "rost/status.hpp"

namespace rost::vision {

// Byte order in memory is given for each (DRM formats are little-endian
// words, so "RGB888" stores B, G, R).
enum class PixelFormat : uint8_t {
    Unknown,
    RGB888,    // 'RG24': B G R              (memory order)
    BGR888,    // 'BG24': R G B
    XRGB8888,  // 'XR24': B G R X
    XBGR8888,  // 'XB24': R G B X
    YUYV,      // 'YUYV': Y0 U Y1 V          (4:2:2 packed)
    UYVY,      // 'UYVY': U Y0 V Y1          (4:2:2 packed)
    NV12,      // 'NV12': Y plane, then U V interleaved (4:2:0)
    NV21,      // 'NV21': Y plane, then V U interleaved (4:2:0)
    YUV420,    // 'YU12': Y plane, U plane, V plane (4:2:0, I420)
    R8,        // 'R8  ': grey
};

constexpr uint32_t fourcc(char a, char b, char c, char d) noexcept {
    return static_cast<uint32_t>(static_cast<uint8_t>(a)) | static_cast<uint32_t>(static_cast<uint8_t>(b)) << 8 |
           static_cast<uint32_t>(static_cast<uint8_t>(c)) << 16 | static_cast<uint32_t>(static_cast<uint8_t>(d)) << 24;
}

// DRM fourcc of a format and back (Unknown for formats not listed above).
uint32_t toFourcc(PixelFormat f) noexcept;
PixelFormat fromFourcc(uint32_t code) noexcept;
// libcamera's name ("NV12", "RGB888", ...) and back.
const char* toString(PixelFormat f) noexcept;
PixelFormat parsePixelFormat(const std::string& name) noexcept;
// Number of planes the format uses (1 to 3).
int planeCount(PixelFormat f) noexcept;
// Formats this library converts, in the order a camera configuration should prefer them.
std::array<PixelFormat, 10> supportedPixelFormats() noexcept;

struct PlaneView {
    const uint8_t* data = nullptr;
    std::size_t stride = 0;  // bytes per row of this plane
    std::size_t bytes = 0;   // bytes available from data
};

// One image in camera memory: up to three planes, each with its stride.
struct ImageView {
    PixelFormat format = PixelFormat::Unknown;
    int width = 0;
    int height = 0;
    std::array<PlaneView, 3> planes{};
};

// Fills view.planes from one buffer holding all planes back to back with the
// given stride of the first plane (chroma strides follow libcamera's rules:
// NV12/NV21 share the luma stride, YUV420 uses half of it). Returns an error
// naming the format and sizes when the buffer is too small.
Status describeContiguous(PixelFormat f, int width, int height, std::size_t stride, const uint8_t* data,
                          std::size_t bytes, ImageView& view);

// Minimum bytes of each plane for a format, size and luma stride.
std::size_t planeBytes(PixelFormat f, int plane, int width, int height, std::size_t stride) noexcept;

// Converts to 8-bit 3-channel BGR in `bgr`, reusing its memory when it
// already has the right size and type (so steady-state capture does not
// allocate). YUV is ITU-R BT.601 limited range, as OpenCV decodes it.
// `scratch` holds the repacked planes of YUV420 when they are not
// contiguous. Returns false (and leaves bgr unspecified) on a view that does
// not describe a valid image: unknown format, odd size for a subsampled
// format, a plane too small or missing.
bool convertToBgr(const ImageView& src, cv::Mat& bgr, cv::Mat& scratch) noexcept;

} // namespace rost::vision
