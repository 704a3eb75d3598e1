#include "rost/vision/pixel_format.hpp"

#include <cstring>

#include <opencv2/imgproc.hpp>

namespace rost::vision {

namespace {

struct FormatInfo {
    PixelFormat format;
    uint32_t code;
    const char* name;
    int planes;
};

constexpr FormatInfo kFormats[] = {
    {PixelFormat::RGB888, fourcc('R', 'G', '2', '4'), "RGB888", 1},
    {PixelFormat::BGR888, fourcc('B', 'G', '2', '4'), "BGR888", 1},
    {PixelFormat::XRGB8888, fourcc('X', 'R', '2', '4'), "XRGB8888", 1},
    {PixelFormat::XBGR8888, fourcc('X', 'B', '2', '4'), "XBGR8888", 1},
    {PixelFormat::YUYV, fourcc('Y', 'U', 'Y', 'V'), "YUYV", 1},
    {PixelFormat::UYVY, fourcc('U', 'Y', 'V', 'Y'), "UYVY", 1},
    {PixelFormat::NV12, fourcc('N', 'V', '1', '2'), "NV12", 2},
    {PixelFormat::NV21, fourcc('N', 'V', '2', '1'), "NV21", 2},
    {PixelFormat::YUV420, fourcc('Y', 'U', '1', '2'), "YUV420", 3},
    {PixelFormat::R8, fourcc('R', '8', ' ', ' '), "R8", 1},
};

const FormatInfo* info(PixelFormat f) noexcept {
    for (const auto& i : kFormats)
        if (i.format == f) return &i;
    return nullptr;
}

bool subsampled(PixelFormat f) noexcept {
    return f == PixelFormat::YUYV || f == PixelFormat::UYVY || f == PixelFormat::NV12 || f == PixelFormat::NV21 ||
           f == PixelFormat::YUV420;
}

int bytesPerPixel(PixelFormat f) noexcept {
    switch (f) {
    case PixelFormat::RGB888:
    case PixelFormat::BGR888: return 3;
    case PixelFormat::XRGB8888:
    case PixelFormat::XBGR8888: return 4;
    case PixelFormat::YUYV:
    case PixelFormat::UYVY: return 2;
    default: return 1;
    }
}

} // namespace

uint32_t toFourcc(PixelFormat f) noexcept {
    const FormatInfo* i = info(f);
    return i ? i->code : 0;
}

PixelFormat fromFourcc(uint32_t code) noexcept {
    for (const auto& i : kFormats)
        if (i.code == code) return i.format;
    return PixelFormat::Unknown;
}

const char* toString(PixelFormat f) noexcept {
    const FormatInfo* i = info(f);
    return i ? i->name : "unknown";
}

PixelFormat parsePixelFormat(const std::string& name) noexcept {
    for (const auto& i : kFormats)
        if (name == i.name) return i.format;
    return PixelFormat::Unknown;
}

int planeCount(PixelFormat f) noexcept {
    const FormatInfo* i = info(f);
    return i ? i->planes : 0;
}

std::array<PixelFormat, 10> supportedPixelFormats() noexcept {
    // Packed BGR needs no conversion at all; then the YUV formats cameras and
    // ISPs commonly produce; grey last (it has no hue words).
    return {PixelFormat::RGB888,   PixelFormat::XRGB8888, PixelFormat::BGR888, PixelFormat::XBGR8888,
            PixelFormat::YUV420,   PixelFormat::NV12,     PixelFormat::NV21,   PixelFormat::YUYV,
            PixelFormat::UYVY,     PixelFormat::R8};
}

std::size_t planeBytes(PixelFormat f, int plane, int width, int height, std::size_t stride) noexcept {
    if (width <= 0 || height <= 0) return 0;
    const auto w = static_cast<std::size_t>(width), h = static_cast<std::size_t>(height);
    if (plane >= planeCount(f)) return 0;
    if (plane == 0) {
        // The last row needs only its pixels, not the whole stride.
        const std::size_t row = w * static_cast<std::size_t>(bytesPerPixel(f));
        return (h - 1) * stride + row;
    }
    const std::size_t ch = h / 2;
    if (f == PixelFormat::NV12 || f == PixelFormat::NV21) return (ch - 1) * stride + w;
    // YUV420 chroma planes: half the stride, half the width.
    return (ch - 1) * (stride / 2) + w / 2;
}

Status describeContiguous(PixelFormat f, int width, int height, std::size_t stride, const uint8_t* data,
                          std::size_t bytes, ImageView& view) {
    const int n = planeCount(f);
    if (n == 0) return Status::error(std::string("pixel format ") + toString(f) + " is not supported");
    if (width <= 0 || height <= 0)
        return Status::error("image size " + std::to_string(width) + "x" + std::to_string(height) + " is empty");
    if (subsampled(f) && (width % 2 || height % 2))
        return Status::error(std::string(toString(f)) + " needs an even width and height, got " +
                             std::to_string(width) + "x" + std::to_string(height));
    if (stride < static_cast<std::size_t>(width) * bytesPerPixel(f))
        return Status::error(std::string(toString(f)) + ": stride " + std::to_string(stride) + " is below a row of " +
                             std::to_string(width) + " pixels");
    view = ImageView{};
    view.format = f;
    view.width = width;
    view.height = height;
    const auto h = static_cast<std::size_t>(height);
    std::size_t offset = 0;
    for (int p = 0; p < n; ++p) {
        const std::size_t ps = p == 0 ? stride : (f == PixelFormat::YUV420 ? stride / 2 : stride);
        const std::size_t rows = p == 0 ? h : h / 2;
        const std::size_t need = planeBytes(f, p, width, height, stride);
        if (offset + need > bytes)
            return Status::error(std::string(toString(f)) + " " + std::to_string(width) + "x" +
                                 std::to_string(height) + " stride " + std::to_string(stride) + ": buffer of " +
                                 std::to_string(bytes) + " bytes is too small for plane " + std::to_string(p));
        view.planes[static_cast<std::size_t>(p)] = {data + offset, ps, bytes - offset};
        offset += rows * ps;
    }
    return {};
}

bool convertToBgr(const ImageView& src, cv::Mat& bgr, cv::Mat& scratch) noexcept {
    const PixelFormat f = src.format;
    const int n = planeCount(f);
    const int W = src.width, H = src.height;
    if (n == 0 || W <= 0 || H <= 0) return false;
    if (subsampled(f) && (W % 2 || H % 2)) return false;
    for (int p = 0; p < n; ++p) {
        const PlaneView& pv = src.planes[static_cast<std::size_t>(p)];
        const std::size_t luma = p == 0 ? pv.stride : (f == PixelFormat::YUV420 ? pv.stride * 2 : pv.stride);
        if (!pv.data || pv.bytes < planeBytes(f, p, W, H, luma)) return false;
        if (p == 0 && pv.stride < static_cast<std::size_t>(W) * bytesPerPixel(f)) return false;
        if (p > 0 && pv.stride < static_cast<std::size_t>(f == PixelFormat::YUV420 ? W / 2 : W)) return false;
    }
    try {
        bgr.create(H, W, CV_8UC3);
        auto plane = [&](int p, int rows, int cols, int type) {
            const PlaneView& pv = src.planes[static_cast<std::size_t>(p)];
            return cv::Mat(rows, cols, type, const_cast<uint8_t*>(pv.data), pv.stride);
        };
        switch (f) {
        case PixelFormat::RGB888: plane(0, H, W, CV_8UC3).copyTo(bgr); break;
        case PixelFormat::BGR888: cv::cvtColor(plane(0, H, W, CV_8UC3), bgr, cv::COLOR_RGB2BGR); break;
        case PixelFormat::XRGB8888: cv::cvtColor(plane(0, H, W, CV_8UC4), bgr, cv::COLOR_BGRA2BGR); break;
        case PixelFormat::XBGR8888: cv::cvtColor(plane(0, H, W, CV_8UC4), bgr, cv::COLOR_RGBA2BGR); break;
        case PixelFormat::YUYV: cv::cvtColor(plane(0, H, W, CV_8UC2), bgr, cv::COLOR_YUV2BGR_YUYV); break;
        case PixelFormat::UYVY: cv::cvtColor(plane(0, H, W, CV_8UC2), bgr, cv::COLOR_YUV2BGR_UYVY); break;
        case PixelFormat::NV12:
            cv::cvtColorTwoPlane(plane(0, H, W, CV_8UC1), plane(1, H / 2, W / 2, CV_8UC2), bgr,
                                 cv::COLOR_YUV2BGR_NV12);
            break;
        case PixelFormat::NV21:
            cv::cvtColorTwoPlane(plane(0, H, W, CV_8UC1), plane(1, H / 2, W / 2, CV_8UC2), bgr,
                                 cv::COLOR_YUV2BGR_NV21);
            break;
        case PixelFormat::YUV420: {
            // OpenCV reads I420 as one (H * 3/2) x W matrix: Y rows, then U and V
            // each packed two chroma rows per matrix row. Repack when the planes
            // are strided or apart.
            scratch.create(H * 3 / 2, W, CV_8UC1);
            uint8_t* out = scratch.data;
            const PlaneView& y = src.planes[0];
            for (int r = 0; r < H; ++r) std::memcpy(out + static_cast<std::size_t>(r) * W, y.data + r * y.stride, W);
            out += static_cast<std::size_t>(W) * H;
            for (int p = 1; p <= 2; ++p) {
                const PlaneView& c = src.planes[static_cast<std::size_t>(p)];
                for (int r = 0; r < H / 2; ++r) {
                    std::memcpy(out, c.data + r * c.stride, static_cast<std::size_t>(W / 2));
                    out += W / 2;
                }
            }
            cv::cvtColor(scratch, bgr, cv::COLOR_YUV2BGR_I420);
            break;
        }
        case PixelFormat::R8: cv::cvtColor(plane(0, H, W, CV_8UC1), bgr, cv::COLOR_GRAY2BGR); break;
        case PixelFormat::Unknown: return false;
        }
    } catch (const cv::Exception&) {
        return false;
    } catch (...) {
        return false;
    }
    return true;
}

} // namespace rost::vision
