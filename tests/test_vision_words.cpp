// Word extraction: deterministic, ids in range and offset per extractor,
// positions inside the frame, the thumbnail words carry the right values.

#include <gtest/gtest.h>

#include <opencv2/imgproc.hpp>

#include "rost/random.hpp"
#include "rost/vision/words.hpp"

using namespace rost;
using namespace rost::vision;

namespace {

// A textured colour image: random rectangles and circles on noise, so ORB
// finds corners and every hue occurs.
cv::Mat texturedImage(int w, int h, uint64_t seed) {
    Rng rng(seed);
    cv::Mat img(h, w, CV_8UC3);
    for (int y = 0; y < h; ++y)
        for (int x = 0; x < w; ++x)
            img.at<cv::Vec3b>(y, x) = {static_cast<uint8_t>(rng.below(40)), static_cast<uint8_t>(rng.below(40)),
                                       static_cast<uint8_t>(rng.below(40))};
    for (int i = 0; i < 60; ++i) {
        const cv::Scalar c(rng.below(256), rng.below(256), rng.below(256));
        const cv::Point a(static_cast<int>(rng.below(static_cast<uint32_t>(w))), static_cast<int>(rng.below(static_cast<uint32_t>(h))));
        if (i % 2) cv::rectangle(img, a, a + cv::Point(10 + static_cast<int>(rng.below(60)), 10 + static_cast<int>(rng.below(60))), c, -1);
        else cv::circle(img, a, 5 + static_cast<int>(rng.below(30)), c, -1);
    }
    return img;
}

std::shared_ptr<const Vocabulary> vocabulary() {
    Status st;
    auto v = defaultVocabulary(st);
    EXPECT_TRUE(st.ok()) << st.message();
    return v;
}

} // namespace

TEST(VisionWords, DefaultVocabularyIsBuiltInWithFiveThousandWordsAndANote) {
    auto v = vocabulary();
    ASSERT_TRUE(v);
    EXPECT_EQ(v->size(), 5000u);
    EXPECT_NE(v->note().find("k-majority"), std::string::npos) << v->note();
}

// ORB's pyramid shrinks a frame under 4 pixels a side to nothing (OpenCV
// then throws): the extractor refuses every frame the size rule calls too small.
TEST(VisionWords, FramesTooSmallAreRefusedWithoutWords) {
    Status st;
    auto e = WordExtractor::create({}, vocabulary(), st);
    ASSERT_TRUE(e) << st.message();
    FrameWords w;
    for (auto [cols, rows] : {std::pair{1, 1}, {1, 300}, {300, 1}, {2, 2}, {15, 64}}) {
        EXPECT_FALSE(e->extract(cv::Mat(rows, cols, CV_8UC3, cv::Scalar(90, 20, 200)), w)) << cols << "x" << rows;
        EXPECT_EQ(w.size(), 0u);
    }
    EXPECT_TRUE(e->extract(cv::Mat(16, 16, CV_8UC3, cv::Scalar(90, 20, 200)), w));
    EXPECT_GT(w.size(), 0u);
}

TEST(VisionWords, LayoutOffsetsTheExtractorsIntoOneVocabularyOf5436) {
    ExtractorConfig c;
    const WordLayout l = makeLayout(c, 5000);
    EXPECT_EQ(l.orb_offset, 0u);
    EXPECT_EQ(l.intensity_offset, 5000u);
    EXPECT_EQ(l.hue_offset, 5256u);
    EXPECT_EQ(l.size(), 5436u);
    c.orb = false;
    const WordLayout m = makeLayout(c, 5000);
    EXPECT_EQ(m.intensity_offset, 0u);
    EXPECT_EQ(m.hue_offset, 256u);
    EXPECT_EQ(m.size(), 436u);
    c.intensity = false;
    EXPECT_EQ(makeLayout(c, 5000).size(), 180u);
}

TEST(VisionWords, ExtractionIsDeterministicAcrossCallsAndInstances) {
    Status st;
    auto a = WordExtractor::create({}, vocabulary(), st);
    auto b = WordExtractor::create({}, vocabulary(), st);
    ASSERT_TRUE(a && b) << st.message();
    const cv::Mat img = texturedImage(640, 480, 1);
    FrameWords w1, w2, w3;
    ASSERT_TRUE(a->extract(img, w1));
    ASSERT_TRUE(a->extract(img, w2));
    ASSERT_TRUE(b->extract(img.clone(), w3));
    EXPECT_EQ(w1.words, w2.words);
    EXPECT_EQ(w1.words, w3.words);
    ASSERT_EQ(w1.positions.size(), w3.positions.size());
    for (std::size_t i = 0; i < w1.positions.size(); ++i) {
        EXPECT_EQ(w1.positions[i].x, w3.positions[i].x);
        EXPECT_EQ(w1.positions[i].y, w3.positions[i].y);
    }
}

TEST(VisionWords, IdsAreInTheirExtractorsRangeAndPositionsInsideTheFrame) {
    Status st;
    auto e = WordExtractor::create({}, vocabulary(), st);
    ASSERT_TRUE(e) << st.message();
    const WordLayout& L = e->layout();
    for (cv::Size size : {cv::Size(640, 480), cv::Size(383, 287), cv::Size(64, 40)}) {
        const cv::Mat img = texturedImage(size.width, size.height, 7);
        FrameWords w;
        ASSERT_TRUE(e->extract(img, w));
        ASSERT_EQ(w.words.size(), w.positions.size());
        EXPECT_EQ(w.size(), w.orb + w.intensity + w.hue);
        if (size.width >= 300) {
            EXPECT_GT(w.orb, 100u) << "textured frame should give ORB words";
        }
        for (uint32_t i = 0; i < w.size(); ++i) {
            const uint32_t id = w.words[i];
            ASSERT_LT(id, e->vocabularySize());
            // ORB words first, then intensity, then hue.
            const bool inRange = i < w.orb                 ? id < L.orb_offset + L.orb_size
                                 : i < w.orb + w.intensity ? id >= L.intensity_offset && id < L.intensity_offset + 256
                                                           : id >= L.hue_offset && id < L.hue_offset + 180;
            ASSERT_TRUE(inRange) << "word " << i << " id " << id;
            ASSERT_GE(w.positions[i].x, 0);
            ASSERT_GE(w.positions[i].y, 0);
            ASSERT_LT(w.positions[i].x, size.width);
            ASSERT_LT(w.positions[i].y, size.height);
        }
        // One intensity word per thumbnail pixel.
        EXPECT_EQ(w.intensity, static_cast<uint32_t>(std::max(1, size.width / 16) * std::max(1, size.height / 16)));
    }
}

TEST(VisionWords, IntensityWordsAreTheBlockMeansAndHueWordsTheBlockHues) {
    ExtractorConfig c;
    c.orb = false;
    Status st;
    auto e = WordExtractor::create(c, nullptr, st);
    ASSERT_TRUE(e) << st.message();
    // Left half pure red, right half grey 100: 4 x 2 thumbnail of 16-px blocks.
    cv::Mat img(32, 64, CV_8UC3, cv::Scalar(100, 100, 100));
    img(cv::Rect(0, 0, 32, 32)).setTo(cv::Scalar(0, 0, 255));
    FrameWords w;
    ASSERT_TRUE(e->extract(img, w));
    ASSERT_EQ(w.intensity, 8u);
    const uint32_t redGrey = 76;  // 0.299 * 255, as OpenCV rounds it
    for (uint32_t i = 0; i < 8; ++i) {
        const bool left = w.positions[i].x < 32;
        EXPECT_EQ(w.words[i], e->layout().intensity_offset + (left ? redGrey : 100u)) << i;
        EXPECT_EQ(w.positions[i].x % 16, 8) << "block centre";
        EXPECT_EQ(w.positions[i].y % 16, 8) << "block centre";
    }
    // Hue only where colour is defined: the 4 red blocks, hue 0.
    ASSERT_EQ(w.hue, 4u);
    for (uint32_t i = 8; i < 12; ++i) {
        EXPECT_EQ(w.words[i], e->layout().hue_offset + 0u);
        EXPECT_LT(w.positions[i].x, 32);
    }
    // Green and blue blocks have OpenCV hues 60 and 120.
    img.setTo(cv::Scalar(0, 255, 0));
    img(cv::Rect(32, 0, 32, 32)).setTo(cv::Scalar(255, 0, 0));
    ASSERT_TRUE(e->extract(img, w));
    ASSERT_EQ(w.hue, 8u);
    for (uint32_t i = w.intensity; i < w.size(); ++i)
        EXPECT_EQ(w.words[i] - e->layout().hue_offset, w.positions[i].x < 32 ? 60u : 120u);
}

// Hue is taken where colour is defined: saturation and value at least
// hue_min_saturation and hue_min_value (32 each), the bounds included.
TEST(VisionWords, HueWordsStartAtTheirSaturationAndValueBounds) {
    ExtractorConfig c;
    c.orb = false;
    c.intensity = false;
    Status st;
    auto e = WordExtractor::create(c, nullptr, st);
    ASSERT_TRUE(e) << st.message();
    ASSERT_EQ(c.hue_min_saturation, 32);
    ASSERT_EQ(c.hue_min_value, 32);
    // BGR: (223, 223, 255) is saturation 32 at value 255, (224, 224, 255) 31;
    // (0, 0, 32) is value 32 at saturation 255, (0, 0, 31) value 31. Hue 0 (red).
    const std::pair<cv::Scalar, uint32_t> cases[] = {{cv::Scalar(223, 223, 255), 4u},
                                                     {cv::Scalar(224, 224, 255), 0u},
                                                     {cv::Scalar(0, 0, 32), 4u},
                                                     {cv::Scalar(0, 0, 31), 0u}};
    for (const auto& [colour, words] : cases) {
        const cv::Mat img(32, 32, CV_8UC3, colour);
        cv::Mat hsv;
        cv::cvtColor(img, hsv, cv::COLOR_BGR2HSV);
        const cv::Vec3b at = hsv.at<cv::Vec3b>(0, 0);
        ASSERT_EQ(at[0], 0) << "the test's premise: red";
        ASSERT_EQ(std::min(at[1], at[2]), words ? 32 : 31) << "the test's premise: " << colour;
        FrameWords w;
        ASSERT_TRUE(e->extract(img, w));
        EXPECT_EQ(w.hue, words) << colour;
        for (uint32_t i = 0; i < w.size(); ++i) EXPECT_EQ(w.words[i], e->layout().hue_offset) << colour;
    }
}

TEST(VisionWords, GreyFramesGiveNoHueWordsAndGreyInputEqualsItsColourCopy) {
    Status st;
    auto e = WordExtractor::create({}, vocabulary(), st);
    ASSERT_TRUE(e);
    cv::Mat grey;
    cv::cvtColor(texturedImage(320, 240, 9), grey, cv::COLOR_BGR2GRAY);
    cv::Mat bgr;
    cv::cvtColor(grey, bgr, cv::COLOR_GRAY2BGR);
    FrameWords a, b;
    ASSERT_TRUE(e->extract(grey, a));
    ASSERT_TRUE(e->extract(bgr, b));
    EXPECT_EQ(a.hue, 0u);
    EXPECT_EQ(a.words, b.words);
}

TEST(VisionWords, SettingsChangeTheWordsAndBadSettingsAreNamed) {
    ExtractorConfig c;
    c.orb_features = 100;
    c.thumb_cell = 32;
    Status st;
    auto e = WordExtractor::create(c, vocabulary(), st);
    ASSERT_TRUE(e) << st.message();
    FrameWords w;
    ASSERT_TRUE(e->extract(texturedImage(640, 480, 2), w));
    EXPECT_LE(w.orb, 100u);
    EXPECT_EQ(w.intensity, 20u * 15u);

    c.thumb_cell = 0;
    EXPECT_FALSE(WordExtractor::create(c, vocabulary(), st));
    EXPECT_EQ(st.message(), "invalid configuration: thumb.cell = 0, allowed [1, 256]");
    c = {};
    c.orb = c.intensity = c.hue = false;
    EXPECT_FALSE(WordExtractor::create(c, vocabulary(), st));
    EXPECT_NE(st.message().find("no extractor"), std::string::npos);
    c = {};
    EXPECT_FALSE(WordExtractor::create(c, nullptr, st));
    EXPECT_NE(st.message().find("vocabulary"), std::string::npos);
    // A vocabulary with ORB words off would make no word: named, not ignored.
    c.orb = false;
    EXPECT_FALSE(WordExtractor::create(c, vocabulary(), st));
    EXPECT_EQ(st.message(), "vocabulary: given, but words.orb is false: no word would come from it");
    EXPECT_TRUE(WordExtractor::create(c, nullptr, st)) << st.message();
}

TEST(VisionWords, EmptyOrUnsupportedImagesAreRefused) {
    Status st;
    auto e = WordExtractor::create({}, vocabulary(), st);
    FrameWords w;
    EXPECT_FALSE(e->extract(cv::Mat(), w));
    EXPECT_FALSE(e->extract(cv::Mat(10, 10, CV_32FC3), w));
    EXPECT_EQ(w.size(), 0u);
}

TEST(VisionWords, ExtractionNeverWritesIntoTheCallersImages) {
    // The extractor keeps scratch images between frames; none may alias a
    // caller's frame, or the next frame's conversion would overwrite it.
    ExtractorConfig c;
    c.thumb_cell = 1;
    Status st;
    auto e = WordExtractor::create(c, vocabulary(), st);
    ASSERT_TRUE(e) << st.message();
    cv::Mat grey;
    cv::cvtColor(texturedImage(96, 64, 4), grey, cv::COLOR_BGR2GRAY);
    const cv::Mat greyCopy = grey.clone();
    const cv::Mat colour = texturedImage(96, 64, 5);
    const cv::Mat colourCopy = colour.clone();
    FrameWords w;
    ASSERT_TRUE(e->extract(grey, w));
    ASSERT_TRUE(e->extract(colour, w));
    cv::Mat colour2 = texturedImage(96, 64, 6);
    ASSERT_TRUE(e->extract(colour2, w));
    ASSERT_TRUE(e->extract(grey, w));
    EXPECT_EQ(cv::norm(grey, greyCopy, cv::NORM_INF), 0.0);
    EXPECT_EQ(cv::norm(colour, colourCopy, cv::NORM_INF), 0.0);
}

// ---- the most words a frame gives (the tool's max.words) ------------------------

namespace {
// Blocks of `cell` px in saturated colours: every thumbnail pixel has a hue,
// and the block corners give ORB many keypoints.
cv::Mat saturatedBlocks(int w, int h, int cell, uint64_t seed) {
    Rng rng(seed);
    cv::Mat img(h, w, CV_8UC3);
    for (int y = 0; y < h; y += cell)
        for (int x = 0; x < w; x += cell) {
            const cv::Scalar colours[] = {{255, 0, 0}, {0, 255, 0}, {0, 0, 255}, {255, 255, 0}, {0, 255, 255}, {255, 0, 255}};
            img(cv::Rect(x, y, std::min(cell, w - x), std::min(cell, h - y))).setTo(colours[rng.below(6)]);
        }
    return img;
}
} // namespace

TEST(VisionWords, MaxWordsPerFrameIsTheMostExtractionGivesAndIsReached) {
    ExtractorConfig c;
    // The default extractors on 1280 x 720: 1000 ORB + 80 x 45 intensity + 80 x 45 hue.
    EXPECT_EQ(maxWordsPerFrame(c, 1280, 720), 8200u);
    EXPECT_EQ(maxWordsPerFrame(c, 640, 480), 1000u + 2u * 40u * 30u);
    EXPECT_EQ(maxWordsPerFrame(c, 8, 8), 1000u + 2u) << "a frame smaller than a block still has one thumbnail pixel";
    c.hue = false;
    c.thumb_cell = 8;
    c.orb_features = 300;
    EXPECT_EQ(maxWordsPerFrame(c, 383, 287), 300u + 47u * 35u) << "thumbnail pixels: whole blocks";
    c.orb = false;
    c.intensity = false;
    EXPECT_EQ(maxWordsPerFrame(c, 1280, 720), 0u);

    // Extraction never gives more; the thumbnail words reach their part when every block has a hue.
    Status st;
    ExtractorConfig d;
    d.orb_features = 50;
    auto e = WordExtractor::create(d, vocabulary(), st);
    ASSERT_TRUE(e) << st.message();
    FrameWords w;
    for (cv::Size size : {cv::Size(640, 480), cv::Size(1280, 720), cv::Size(383, 287)}) {
        for (uint64_t seed : {1u, 2u}) {
            ASSERT_TRUE(e->extract(texturedImage(size.width, size.height, seed), w));
            EXPECT_LE(w.size(), maxWordsPerFrame(d, size.width, size.height)) << size;
            EXPECT_LE(w.orb, 50u) << "orb.features is a maximum";
        }
        if (size.width % 16 == 0 && size.height % 16 == 0) {
            // Every block has a hue: the thumbnail words reach their part of the bound.
            ASSERT_TRUE(e->extract(saturatedBlocks(size.width, size.height, 16, 3), w));
            ExtractorConfig thumbOnly = d;
            thumbOnly.orb = false;
            EXPECT_EQ(w.intensity + w.hue, maxWordsPerFrame(thumbOnly, size.width, size.height)) << size;
            EXPECT_LE(w.orb, 50u) << size;
        }
    }
}
