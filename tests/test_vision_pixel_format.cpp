// Camera pixel formats to BGR, with synthetic buffers laid out as libcamera
// hands them over (strided rows with padding, planes apart or back to back).
// No camera needed.

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>

#include "rost/random.hpp"
#include "rost/vision/pixel_format.hpp"

using namespace rost;
using namespace rost::vision;

namespace {

constexpr int W = 64, H = 48;
constexpr std::size_t kPad = 24;  // bytes of padding at the end of each row
constexpr uint8_t kJunk = 0x5A;

struct Yuv {
    std::vector<uint8_t> y, u, v;  // y: W x H, u/v: (W/2) x (H/2)
};

Yuv randomYuv(uint64_t seed) {
    Rng rng(seed);
    Yuv p;
    p.y.resize(W * H);
    p.u.resize(W / 2 * H / 2);
    p.v.resize(W / 2 * H / 2);
    for (auto& x : p.y) x = static_cast<uint8_t>(16 + rng.below(220));
    for (auto& x : p.u) x = static_cast<uint8_t>(16 + rng.below(225));
    for (auto& x : p.v) x = static_cast<uint8_t>(16 + rng.below(225));
    return p;
}

// ITU-R BT.601, limited range: the conversion every YUV format here must realise.
cv::Vec3b reference(int Y, int U, int V) {
    const double c = 1.164 * (Y - 16), d = U - 128, e = V - 128;
    auto sat = [](double x) { return static_cast<uint8_t>(std::clamp(std::lround(x), 0L, 255L)); };
    return {sat(c + 2.018 * d), sat(c - 0.391 * d - 0.813 * e), sat(c + 1.596 * e)};
}

void expectMatchesReference(const cv::Mat& bgr, const Yuv& p, const char* what) {
    ASSERT_EQ(bgr.rows, H);
    ASSERT_EQ(bgr.cols, W);
    ASSERT_EQ(bgr.type(), CV_8UC3);
    int worst = 0;
    for (int y = 0; y < H; ++y)
        for (int x = 0; x < W; ++x) {
            const std::size_t ci = static_cast<std::size_t>(y / 2) * (W / 2) + static_cast<std::size_t>(x / 2);
            const cv::Vec3b want = reference(p.y[static_cast<std::size_t>(y) * W + x], p.u[ci], p.v[ci]);
            const cv::Vec3b got = bgr.at<cv::Vec3b>(y, x);
            for (int k = 0; k < 3; ++k) worst = std::max(worst, std::abs(int(got[k]) - int(want[k])));
        }
    EXPECT_LE(worst, 3) << what << ": largest channel error against BT.601";
}

std::vector<uint8_t> padded(std::size_t rows, std::size_t rowBytes, std::size_t stride) {
    (void)rowBytes;
    return std::vector<uint8_t>(rows * stride, kJunk);
}

} // namespace

TEST(VisionPixelFormat, FourccCodesAndNamesRoundTrip) {
    for (PixelFormat f : supportedPixelFormats()) {
        EXPECT_EQ(fromFourcc(toFourcc(f)), f) << toString(f);
        EXPECT_EQ(parsePixelFormat(toString(f)), f);
    }
    EXPECT_EQ(toFourcc(PixelFormat::NV12), fourcc('N', 'V', '1', '2'));
    EXPECT_EQ(toFourcc(PixelFormat::YUV420), fourcc('Y', 'U', '1', '2'));
    EXPECT_EQ(fromFourcc(fourcc('M', 'J', 'P', 'G')), PixelFormat::Unknown);
    EXPECT_EQ(parsePixelFormat("nv12"), PixelFormat::Unknown);
}

TEST(VisionPixelFormat, PackedRgbFormatsFollowDrmByteOrderWithStridedRows) {
    Rng rng(1);
    cv::Mat want(H, W, CV_8UC3);
    for (int y = 0; y < H; ++y)
        for (int x = 0; x < W; ++x)
            want.at<cv::Vec3b>(y, x) = {static_cast<uint8_t>(rng.below(256)), static_cast<uint8_t>(rng.below(256)),
                                        static_cast<uint8_t>(rng.below(256))};
    struct Case {
        PixelFormat f;
        int bpp;
        int order[4];  // memory byte i holds BGR channel order[i] (-1: padding X)
    };
    const Case cases[] = {
        {PixelFormat::RGB888, 3, {0, 1, 2, -1}},   // B G R
        {PixelFormat::BGR888, 3, {2, 1, 0, -1}},   // R G B
        {PixelFormat::XRGB8888, 4, {0, 1, 2, -1}}, // B G R X
        {PixelFormat::XBGR8888, 4, {2, 1, 0, -1}}, // R G B X
    };
    for (const Case& c : cases) {
        const std::size_t stride = static_cast<std::size_t>(W * c.bpp) + kPad;
        auto buf = padded(H, W * c.bpp, stride);
        for (int y = 0; y < H; ++y)
            for (int x = 0; x < W; ++x)
                for (int i = 0; i < c.bpp; ++i)
                    buf[y * stride + x * c.bpp + i] =
                        c.order[i] < 0 ? 0x77 : want.at<cv::Vec3b>(y, x)[c.order[i]];
        ImageView v;
        ASSERT_TRUE(describeContiguous(c.f, W, H, stride, buf.data(), buf.size(), v).ok());
        cv::Mat out, scratch;
        ASSERT_TRUE(convertToBgr(v, out, scratch)) << toString(c.f);
        EXPECT_EQ(cv::norm(out, want, cv::NORM_INF), 0.0) << toString(c.f);
    }
}

TEST(VisionPixelFormat, GreyR8BecomesEqualChannels) {
    std::vector<uint8_t> buf(H * (W + kPad), kJunk);
    for (int y = 0; y < H; ++y)
        for (int x = 0; x < W; ++x) buf[y * (W + kPad) + x] = static_cast<uint8_t>(x * 3 + y);
    ImageView v;
    ASSERT_TRUE(describeContiguous(PixelFormat::R8, W, H, W + kPad, buf.data(), buf.size(), v).ok());
    cv::Mat out, s;
    ASSERT_TRUE(convertToBgr(v, out, s));
    for (int y = 0; y < H; ++y)
        for (int x = 0; x < W; ++x) ASSERT_EQ(out.at<cv::Vec3b>(y, x), cv::Vec3b::all(static_cast<uint8_t>(x * 3 + y)));
}

TEST(VisionPixelFormat, PackedYuv422FormatsMatchBt601) {
    const Yuv p = randomYuv(2);
    for (PixelFormat f : {PixelFormat::YUYV, PixelFormat::UYVY}) {
        const std::size_t stride = W * 2 + kPad;
        auto buf = padded(H, W * 2, stride);
        for (int y = 0; y < H; ++y)
            for (int x = 0; x < W; x += 2) {
                const std::size_t ci = static_cast<std::size_t>(y / 2) * (W / 2) + x / 2;
                uint8_t* q = buf.data() + y * stride + x * 2;
                const uint8_t y0 = p.y[y * W + x], y1 = p.y[y * W + x + 1];
                if (f == PixelFormat::YUYV) q[0] = y0, q[1] = p.u[ci], q[2] = y1, q[3] = p.v[ci];
                else q[0] = p.u[ci], q[1] = y0, q[2] = p.v[ci], q[3] = y1;
            }
        ImageView v;
        ASSERT_TRUE(describeContiguous(f, W, H, stride, buf.data(), buf.size(), v).ok());
        cv::Mat out, s;
        ASSERT_TRUE(convertToBgr(v, out, s)) << toString(f);
        expectMatchesReference(out, p, toString(f));
    }
}

TEST(VisionPixelFormat, SemiPlanarNv12AndNv21MatchBt601WithPlanesApart) {
    const Yuv p = randomYuv(3);
    for (PixelFormat f : {PixelFormat::NV12, PixelFormat::NV21}) {
        const std::size_t stride = W + kPad;
        auto yPlane = padded(H, W, stride);
        auto cPlane = padded(H / 2, W, stride);  // a separate allocation, as a second dma-buf plane
        for (int y = 0; y < H; ++y)
            for (int x = 0; x < W; ++x) yPlane[y * stride + x] = p.y[y * W + x];
        for (int y = 0; y < H / 2; ++y)
            for (int x = 0; x < W / 2; ++x) {
                const uint8_t u = p.u[y * (W / 2) + x], v = p.v[y * (W / 2) + x];
                cPlane[y * stride + 2 * x] = f == PixelFormat::NV12 ? u : v;
                cPlane[y * stride + 2 * x + 1] = f == PixelFormat::NV12 ? v : u;
            }
        ImageView view;
        view.format = f;
        view.width = W;
        view.height = H;
        view.planes[0] = {yPlane.data(), stride, yPlane.size()};
        view.planes[1] = {cPlane.data(), stride, cPlane.size()};
        cv::Mat out, s;
        ASSERT_TRUE(convertToBgr(view, out, s)) << toString(f);
        expectMatchesReference(out, p, toString(f));

        // The same image in one buffer, planes back to back.
        std::vector<uint8_t> one(yPlane);
        one.insert(one.end(), cPlane.begin(), cPlane.end());
        ASSERT_TRUE(describeContiguous(f, W, H, stride, one.data(), one.size(), view).ok());
        ASSERT_TRUE(convertToBgr(view, out, s));
        expectMatchesReference(out, p, toString(f));
    }
}

TEST(VisionPixelFormat, PlanarYuv420MatchesBt601WithHalfStrideChroma) {
    const Yuv p = randomYuv(4);
    const std::size_t stride = W + 2 * kPad, cstride = stride / 2;
    std::vector<uint8_t> buf(H * stride + 2 * (H / 2) * cstride, kJunk);
    uint8_t* Y = buf.data();
    uint8_t* U = Y + H * stride;
    uint8_t* V = U + (H / 2) * cstride;
    for (int y = 0; y < H; ++y)
        for (int x = 0; x < W; ++x) Y[y * stride + x] = p.y[y * W + x];
    for (int y = 0; y < H / 2; ++y)
        for (int x = 0; x < W / 2; ++x) {
            U[y * cstride + x] = p.u[y * (W / 2) + x];
            V[y * cstride + x] = p.v[y * (W / 2) + x];
        }
    ImageView view;
    ASSERT_TRUE(describeContiguous(PixelFormat::YUV420, W, H, stride, buf.data(), buf.size(), view).ok());
    EXPECT_EQ(view.planes[1].stride, cstride);
    cv::Mat out, s;
    ASSERT_TRUE(convertToBgr(view, out, s));
    expectMatchesReference(out, p, "YUV420");
    // Converting again reuses the output's memory.
    const uint8_t* before = out.data;
    ASSERT_TRUE(convertToBgr(view, out, s));
    EXPECT_EQ(out.data, before);
    // A buffer that ends at the last chroma pixel (no padding after it) is enough.
    const std::size_t tight = H * stride + (H / 2) * cstride + (H / 2 - 1) * cstride + W / 2;
    ImageView exact;
    const Status st = describeContiguous(PixelFormat::YUV420, W, H, stride, buf.data(), tight, exact);
    ASSERT_TRUE(st.ok()) << st.message();
    cv::Mat tightOut;
    ASSERT_TRUE(convertToBgr(exact, tightOut, s));
    expectMatchesReference(tightOut, p, "YUV420 without padding after its last row");
}

TEST(VisionPixelFormat, InvalidViewsAreRefusedNotReadPastTheirEnd) {
    std::vector<uint8_t> buf(W * H * 3 / 2, 0);
    ImageView v;
    cv::Mat out, s;
    // Odd sizes for a subsampled format.
    Status st = describeContiguous(PixelFormat::NV12, W - 1, H, W, buf.data(), buf.size(), v);
    EXPECT_NE(st.message().find("even width and height"), std::string::npos) << st.message();
    st = describeContiguous(PixelFormat::NV12, W, H - 1, W, buf.data(), buf.size(), v);
    EXPECT_NE(st.message().find("even width and height"), std::string::npos) << st.message();
    // A buffer one byte short.
    st = describeContiguous(PixelFormat::NV12, W, H, W, buf.data(), buf.size() - 1, v);
    EXPECT_NE(st.message().find("too small"), std::string::npos) << st.message();
    // A stride below the row.
    st = describeContiguous(PixelFormat::RGB888, W, H, W, buf.data(), buf.size(), v);
    EXPECT_NE(st.message().find("stride"), std::string::npos) << st.message();
    // Hand-made views: unknown format, missing plane, plane too small.
    ASSERT_TRUE(describeContiguous(PixelFormat::NV12, W, H, W, buf.data(), buf.size(), v).ok());
    ImageView bad = v;
    bad.format = PixelFormat::Unknown;
    EXPECT_FALSE(convertToBgr(bad, out, s));
    bad = v;
    bad.planes[1] = {};
    EXPECT_FALSE(convertToBgr(bad, out, s));
    bad = v;
    bad.planes[0].bytes = W * H - 1;
    EXPECT_FALSE(convertToBgr(bad, out, s));
    EXPECT_TRUE(convertToBgr(v, out, s));
    // A chroma stride below its row (W bytes of interleaved U and V for NV12 and NV21, W / 2
    // for each of YUV420's planes): rows that overlap are refused, the row itself taken.
    for (const PixelFormat f : {PixelFormat::NV12, PixelFormat::NV21, PixelFormat::YUV420}) {
        ImageView ok;
        ASSERT_TRUE(describeContiguous(f, W, H, W, buf.data(), buf.size(), ok).ok());
        const std::size_t row = f == PixelFormat::YUV420 ? W / 2 : W;
        EXPECT_EQ(ok.planes[1].stride, row) << static_cast<int>(f);
        EXPECT_TRUE(convertToBgr(ok, out, s)) << static_cast<int>(f);
        for (std::size_t p = 1; p < (f == PixelFormat::YUV420 ? 3u : 2u); ++p) {
            bad = ok;
            bad.planes[p].stride = row - 1;
            EXPECT_FALSE(convertToBgr(bad, out, s)) << static_cast<int>(f) << " plane " << p;
            bad.planes[p].stride = row / 2;
            EXPECT_FALSE(convertToBgr(bad, out, s)) << static_cast<int>(f) << " plane " << p;
        }
    }
}
