#include "png_file.hpp"

#include <png.h>

#include <cerrno>
#include <csetjmp>
#include <cstdio>
#include <cstring>
#include <memory>

namespace rost::tool {

namespace {

struct FileCloser {
    void operator()(std::FILE* f) const noexcept { std::fclose(f); }
};

// libpng reports errors by longjmp; the message is kept for the Status.
struct PngErrors {
    char message[256] = "";
};

[[noreturn]] void onPngError(png_structp png, png_const_charp msg) {
    auto* e = static_cast<PngErrors*>(png_get_error_ptr(png));
    std::snprintf(e->message, sizeof e->message, "%s", msg);
    png_longjmp(png, 1);
}

void onPngWarning(png_structp, png_const_charp) {}

// Everything libpng touches between setjmp and a longjmp lives in the
// caller: no object with a destructor is skipped by the jump.
bool encode(std::FILE* f, const cv::Mat& bgr, PngErrors& errors) {
    png_structp png = png_create_write_struct(PNG_LIBPNG_VER_STRING, &errors, onPngError, onPngWarning);
    if (!png) return false;
    png_infop info = png_create_info_struct(png);
    if (!info) {
        png_destroy_write_struct(&png, nullptr);
        return false;
    }
    if (setjmp(png_jmpbuf(png))) {
        png_destroy_write_struct(&png, &info);
        return false;
    }
    png_init_io(png, f);
    // Fast and small for plots: OpenCV's own defaults for PNG (level 1, run-length strategy).
    png_set_compression_level(png, 1);
    png_set_compression_strategy(png, 3);  // Z_RLE
    // One filter, not libpng's per-row trial of all five (which took 30 ms of
    // a 35 ms summary): a plot's runs of one colour compress as well with it.
    png_set_filter(png, PNG_FILTER_TYPE_BASE, PNG_FILTER_SUB);
    png_set_IHDR(png, info, static_cast<png_uint_32>(bgr.cols), static_cast<png_uint_32>(bgr.rows), 8,
                 PNG_COLOR_TYPE_RGB, PNG_INTERLACE_NONE, PNG_COMPRESSION_TYPE_DEFAULT, PNG_FILTER_TYPE_DEFAULT);
    png_write_info(png, info);
    png_set_bgr(png);
    for (int y = 0; y < bgr.rows; ++y) png_write_row(png, bgr.ptr<png_byte>(y));
    png_write_end(png, info);
    png_destroy_write_struct(&png, &info);
    return true;
}

} // namespace

Status writePng(const std::string& path, const cv::Mat& bgr) {
    if (bgr.type() != CV_8UC3 || bgr.empty()) return Status::error(path + ": cannot write: not an 8-bit 3-channel image");
    std::unique_ptr<std::FILE, FileCloser> f(std::fopen(path.c_str(), "wb"));
    if (!f) return Status::error(path + ": cannot write: " + std::strerror(errno));
    PngErrors errors;
    if (!encode(f.get(), bgr, errors))
        return Status::error(path + ": cannot write PNG: " + (errors.message[0] ? errors.message : "out of memory"));
    std::FILE* raw = f.release();
    if (std::ferror(raw) != 0 || std::fclose(raw) != 0) return Status::error(path + ": write failed: " + std::strerror(errno));
    return {};
}

} // namespace rost::tool
