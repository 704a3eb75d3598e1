// Image files cut short: every cut of a JPEG or PNG is found without decoding,
// a whole file never is, and a frame source names the file instead of
// modelling a half-grey frame.

#include <gtest/gtest.h>

#include <algorithm>
#include <iterator>

#include <opencv2/imgcodecs.hpp>

#include "rost/vision/frame_source.hpp"
#include "rost/vision/image_file.hpp"
#include "test_vision_support.hpp"

using namespace rost;
using namespace rost::vision;
using rost::testing::TempDir;

namespace {

// Noise with a flat band: the entropy-coded data holds stuffed 0xFF 0x00
// bytes, and the flat band long runs.
cv::Mat noisy(int w, int h, int channels) {
    cv::Mat m(h, w, channels == 3 ? CV_8UC3 : CV_8UC1);
    cv::RNG rng(7);
    rng.fill(m, cv::RNG::UNIFORM, 0, 256);
    m.rowRange(0, h / 3).setTo(cv::Scalar(200, 40, 90));
    return m;
}

std::vector<uint8_t> encode(const std::string& ext, const cv::Mat& m, const std::vector<int>& params = {}) {
    std::vector<uint8_t> out;
    EXPECT_TRUE(cv::imencode(ext, m, out, params)) << ext;
    return out;
}

std::string truncated(const std::vector<uint8_t>& b, std::size_t n) { return imageTruncated(b.data(), n); }

void writeBytes(const std::string& path, const std::vector<uint8_t>& b, std::size_t n) {
    rost::testing::writeText(path, std::string(reinterpret_cast<const char*>(b.data()), n));
}

} // namespace

TEST(VisionImageFile, EveryCutOfAJpegIsTruncatedAndTheWholeFileIsNot) {
    const std::vector<std::vector<int>> kinds = {
        {},
        {cv::IMWRITE_JPEG_PROGRESSIVE, 1},                              // several scans, tables between them
        {cv::IMWRITE_JPEG_RST_INTERVAL, 1},                             // restart markers inside the scan
        {cv::IMWRITE_JPEG_PROGRESSIVE, 1, cv::IMWRITE_JPEG_RST_INTERVAL, 2},
        {cv::IMWRITE_JPEG_OPTIMIZE, 1, cv::IMWRITE_JPEG_QUALITY, 100},
    };
    for (int channels : {3, 1})
        for (const auto& params : kinds) {
            const std::vector<uint8_t> b = encode(".jpg", noisy(83, 61, channels), params);
            ASSERT_GT(b.size(), 200u);
            EXPECT_EQ(truncated(b, b.size()), "") << "whole, " << channels << " channels, kind " << params.size();
            for (std::size_t n = 3; n < b.size(); ++n)
                ASSERT_EQ(truncated(b, n), "truncated JPEG: the file ends before its end-of-image marker")
                    << "cut at " << n << " of " << b.size() << ", " << channels << " channels, kind " << params.size();
            // Bytes after the end-of-image marker (a motion photo's video) are not a cut.
            std::vector<uint8_t> tail = b;
            tail.insert(tail.end(), {0x00, 0x00, 0x00, 0x18, 'f', 't', 'y', 'p', 0xFF, 0xD8});
            EXPECT_EQ(truncated(tail, tail.size()), "");
        }
}

TEST(VisionImageFile, EveryCutOfAPngIsTruncatedAndTheWholeFileIsNot) {
    for (int level : {0, 9}) {
        const std::vector<uint8_t> b = encode(".png", noisy(40, 30, 3), {cv::IMWRITE_PNG_COMPRESSION, level});
        EXPECT_EQ(truncated(b, b.size()), "");
        for (std::size_t n = 8; n < b.size(); ++n)
            ASSERT_EQ(truncated(b, n).rfind("truncated PNG: the file ends ", 0), 0u) << "cut at " << n << " of " << b.size();
    }
}

TEST(VisionImageFile, OtherBytesAreLeftToTheDecoder) {
    for (const std::string text : {"", "x", "not an image at all", "\xFF\xD8", "\x89PNG\r\n\x1A"}) {
        const std::vector<uint8_t> b(text.begin(), text.end());
        EXPECT_EQ(truncated(b, b.size()), "") << text;
    }
    // A JPEG damaged where a marker must be (not a cut): OpenCV decides.
    std::vector<uint8_t> b = encode(".jpg", noisy(40, 30, 3));
    b[2] = 0x12;
    EXPECT_EQ(truncated(b, b.size()), "");
    // Stray FF 00 between two segments: libjpeg skips them (a warning) and decodes the image whole.
    b = encode(".jpg", noisy(40, 30, 3));
    const uint8_t tables[] = {0xFF, 0xDB};
    const auto dqt = std::search(b.begin(), b.end(), std::begin(tables), std::end(tables));
    ASSERT_NE(dqt, b.end());
    b.insert(dqt, {0xFF, 0x00});
    EXPECT_EQ(truncated(b, b.size()), "");
    // A byte damaged inside a scan's data (FF 12: a reserved code, no marker) is
    // not a cut, whatever the bytes after it would give as a segment's length.
    b = encode(".jpg", noisy(40, 30, 3));
    const std::size_t k = b.size() - 40;  // inside the scan, before the end-of-image marker
    b[k - 1] = 0x00, b[k] = 0xFF, b[k + 1] = 0x12, b[k + 2] = 0xFF, b[k + 3] = 0xFF;
    EXPECT_EQ(truncated(b, b.size()), "");
    const std::vector<uint8_t> bmp = encode(".bmp", noisy(40, 30, 3));
    EXPECT_EQ(truncated(bmp, bmp.size() / 2), "");
}

TEST(VisionImageFile, AFrameSourceNamesACutImageInsteadOfModellingIt) {
    TempDir t;
    std::filesystem::create_directories(t / "frames");
    const std::vector<uint8_t> jpg = encode(".jpg", noisy(64, 48, 3)), png = encode(".png", noisy(64, 48, 3));
    writeBytes(t / "frames/001.jpg", jpg, jpg.size());
    writeBytes(t / "frames/002.jpg", jpg, jpg.size() / 2);
    Status st;
    auto s = openFrameSource(t / "frames", {}, st);
    ASSERT_TRUE(s) << st.message();
    Frame f;
    EXPECT_EQ(s->read(f), ReadStatus::Ok);
    EXPECT_EQ(s->read(f), ReadStatus::Error);
    EXPECT_EQ(s->error(), (t / "frames/002.jpg") + ": cannot decode image: truncated JPEG: the file ends before its "
                                                   "end-of-image marker");
    // The first image cut: open() says it.
    writeBytes(t / "frames/000.png", png, png.size() - 5);
    EXPECT_FALSE(openFrameSource(t / "frames", {}, st));
    EXPECT_EQ(st.message(), (t / "frames/000.png") + ": cannot decode image: truncated PNG: the file ends before its "
                                                     "IEND chunk");
    // And a missing one is said as every reader says it.
    cv::Mat m;
    EXPECT_EQ(readImageFile(t / "none.png", m).message(), (t / "none.png") + ": cannot open: No such file or directory");
    EXPECT_EQ(readImageFile(t / "frames/001.jpg", m).message(), "");
    EXPECT_EQ(m.size(), cv::Size(64, 48));
}

// A photo's EXIF orientation is applied, as image viewers and cv::imread
// show it: a 64x48 JPEG tagged "rotate 90 degrees" (orientation 6, as a phone
// held upright writes it) is a 48x64 frame, for an image read alone and for a
// directory of them; 16-bit and grey images keep their depth and channels.
TEST(VisionImageFile, ThePhotosOrientationIsApplied) {
    TempDir t;
    std::vector<uint8_t> jpg = encode(".jpg", noisy(64, 48, 3));
    // An APP1 segment after SOI: "Exif\0\0", a little-endian TIFF header, one
    // IFD entry: tag 0x0112 (Orientation), type SHORT, count 1, value 6.
    const std::vector<uint8_t> exif = {0xFF, 0xE1, 0x00, 34,  'E',  'x',  'i',  'f',  0, 0, 'I', 'I', 42, 0, 8, 0, 0, 0,
                                       1,    0,    0x12, 0x01, 3,   0,    1,    0,    0, 0, 6,   0,   0,  0, 0, 0, 0, 0};
    jpg.insert(jpg.begin() + 2, exif.begin(), exif.end());
    std::filesystem::create_directories(t / "photos");
    writeBytes(t / "photos/upright.jpg", jpg, jpg.size());
    cv::Mat m;
    ASSERT_TRUE(readImageFile(t / "photos/upright.jpg", m).ok());
    EXPECT_EQ(m.size(), cv::Size(48, 64)) << "rotated as its orientation tag says";
    EXPECT_EQ(m.size(), cv::imread(t / "photos/upright.jpg").size());
    Status st;
    auto s = openFrameSource(t / "photos", {}, st);
    ASSERT_TRUE(s) << st.message();
    EXPECT_EQ(cv::Size(s->info().width, s->info().height), cv::Size(48, 64));
    cv::Mat deep(40, 30, CV_16UC1, cv::Scalar(40000)), grey = noisy(30, 40, 1);
    ASSERT_TRUE(cv::imwrite(t / "deep.png", deep));
    ASSERT_TRUE(cv::imwrite(t / "grey.png", grey));
    ASSERT_TRUE(readImageFile(t / "deep.png", m).ok());
    EXPECT_EQ(m.type(), CV_16UC1);
    ASSERT_TRUE(readImageFile(t / "grey.png", m).ok());
    EXPECT_EQ(m.type(), CV_8UC1);
}

// A floating-point image (a 32-bit TIFF) holds its brightness in [0, 1]: it
// is the frame the same picture in 8 bits gives, not a black one.
TEST(VisionImageFile, AFloatingPointImageIsTheFrameItsEightBitPictureGives) {
    TempDir t;
    const cv::Mat eight = noisy(64, 48, 3);
    cv::Mat real;
    eight.convertTo(real, CV_32FC3, 1.0 / 255.0);
    std::filesystem::create_directories(t / "float");
    std::filesystem::create_directories(t / "eight");
    ASSERT_TRUE(cv::imwrite(t / "float/a.tiff", real, {cv::IMWRITE_TIFF_COMPRESSION, 1}));  // uncompressed: exact
    ASSERT_TRUE(cv::imwrite(t / "eight/a.png", eight));
    cv::Mat m;
    ASSERT_TRUE(readImageFile(t / "float/a.tiff", m).ok());
    ASSERT_EQ(m.depth(), CV_32F) << "the test needs a floating-point image";
    Frame a, b;
    for (const auto& [dir, frame] : {std::pair<std::string, Frame*>{t / "float", &a}, {t / "eight", &b}}) {
        Status st;
        auto s = openFrameSource(dir, {}, st);
        ASSERT_TRUE(s) << st.message();
        ASSERT_EQ(s->read(*frame), ReadStatus::Ok) << dir;
    }
    ASSERT_EQ(a.image.size(), b.image.size());
    EXPECT_LE(cv::norm(a.image, b.image, cv::NORM_INF), 1.0) << "the float frame is the 8-bit one";
    EXPECT_GT(cv::mean(a.image)[0], 50.0) << "not black";
}

// An image of 32-bit integers has no range viewers agree on: it is refused,
// and the message says why (its depth), not just that it cannot be decoded.
TEST(VisionImageFile, AThirtyTwoBitIntegerImageIsRefusedNamingItsDepth) {
    TempDir t;
    cv::Mat ints(48, 64, CV_32SC1);
    cv::randu(ints, 0, 1 << 20);
    std::filesystem::create_directories(t / "ints");
    ASSERT_TRUE(cv::imwrite(t / "ints/a.tiff", ints));
    cv::Mat m;
    ASSERT_TRUE(readImageFile(t / "ints/a.tiff", m).ok());
    ASSERT_EQ(m.depth(), CV_32S) << "the test needs a 32-bit integer image";
    Status st;
    auto s = openFrameSource(t / "ints", {}, st);
    ASSERT_TRUE(s) << st.message();
    Frame f;
    EXPECT_EQ(s->read(f), ReadStatus::Error);
    EXPECT_EQ(s->error(), (t / "ints/a.tiff") + ": cannot decode image: 32-bit integer pixels, which have no agreed "
                                                "range: convert it to 8 or 16 bits, or to floating point in [0, 1]");
}
