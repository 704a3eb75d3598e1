// The overlay's tint (src/tool/sinks.hpp), summary.png's thumbnails and time axis, and its canvas
// (src/tool/outputs.hpp, Picture): drawn where its pixels were allocated, a mapping of their own, not in memory from malloc.

#include <gtest/gtest.h>

#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <future>
#include <limits>
#include <memory>
#include <string>
#include <thread>
#include <vector>

#include "aligned_buffer.hpp"
#include "outputs.hpp"
#include "results.hpp"
#include "sinks.hpp"
#include "test_deadline.hpp"

namespace {

using rost::tool::FrameRow;

// The overlay's tint on a grid of 3 x 2 cells whose image is cut at the
// right and bottom edges: each cell is blended toward its own topic's colour
// (x is the cell's column, y its row: a square grid could not tell them
// apart), a cell without words and the pixels past the grid keep theirs.
TEST(ToolOverlay, EachCellOfANonSquareGridIsTintedWithItsOwnTopic) {
    constexpr int kSpace = 8, kGridW = 3;
    cv::Mat img(14, 22, CV_8UC3, cv::Scalar(40, 120, 200));  // the last column and row of cells cut short
    const cv::Mat before = img.clone();
    rost::ObservationRecord r;
    const uint16_t none = rost::ObservationRecord::kNoTopic;
    r.dominant = {0, none, 1, 2, 3, none};  // row 0: topics 0, -, 1; row 1: 2, 3, -
    rost::tool::tintCells(img, r, kSpace, kGridW);
    auto blended = [&](int y, int x, int topic) {
        const cv::Scalar c = rost::tool::topicColour(topic);
        cv::Vec3b want;
        for (int ch = 0; ch < 3; ++ch)
            want[ch] = static_cast<uint8_t>((before.at<cv::Vec3b>(y, x)[ch] * (256 - 97) + static_cast<int>(c[ch]) * 97) >> 8);
        return want;
    };
    for (int y = 0; y < img.rows; ++y)
        for (int x = 0; x < img.cols; ++x) {
            const std::size_t cell = static_cast<std::size_t>(y / kSpace * kGridW + x / kSpace);
            const cv::Vec3b got = img.at<cv::Vec3b>(y, x);
            const cv::Vec3b want = r.dominant[cell] == none ? before.at<cv::Vec3b>(y, x) : blended(y, x, r.dominant[cell]);
            ASSERT_EQ(got, want) << "pixel (" << x << ", " << y << ") of cell " << cell;
        }
    for (int k = 0; k < 4; ++k) ASSERT_NE(blended(0, 0, k), before.at<cv::Vec3b>(0, 0)) << "the test's premise: topic " << k;
}

// summary.png's thumbnails, their pool sized for the frames the input said it
// had: an input of more (a container's count of 1 for 79 frames) fills the
// pool, which halves, keeping every other frame, and never writes past it.
TEST(ToolThumbnails, APoolSizedForFewerFramesThanComeKeepsTakingThemEvenlySpaced) {
    for (const int64_t planned : {1, 2, 3, 7}) {
        SCOPED_TRACE(planned);
        rost::tool::ThumbnailSink t;
        rost::vision::SourceInfo info;
        info.width = 64;
        info.height = 48;
        t.open(info, planned);
        rost::tool::FrameSlot s;
        s.image = cv::Mat(48, 64, CV_8UC3, cv::Scalar(10, 20, 30));
        for (int64_t f = 0; f < 79; ++f) {
            s.frame = f;
            ASSERT_NO_THROW(t.take(s)) << "frame " << f;
        }
        std::vector<cv::Mat> thumbs;
        std::vector<int64_t> frames;
        t.pick({}, 100, thumbs, frames);
        ASSERT_GE(frames.size(), 2u);
        EXPECT_LE(frames.size(), static_cast<std::size_t>(std::max<int64_t>(planned, 2)));
        EXPECT_EQ(frames.front(), 0);
        for (std::size_t i = 1; i < frames.size(); ++i) EXPECT_EQ(frames[i] - frames[i - 1], frames[1] - frames[0]);
        for (const cv::Mat& m : thumbs) EXPECT_EQ(m.size(), cv::Size(160, 120));
    }
}

// Draws in a thread of its own and waits at most `limit` (test_deadline.hpp).
bool drawsWithin(const rost::tool::SummaryInput& in, std::chrono::seconds limit) {
    return rost::testing::endsWithin(limit, [in] { (void)rost::tool::drawSummary(in); });
}

TEST(ToolSummary, TimeStampsInNanosecondsOrAllAlikeAreDrawnAndTheDrawingEnds) {
    // Stamps near 1.7e18 (ROS's nanoseconds), one frame or frames 100 apart:
    // a double cannot tell x + step from x there; and the extremes of int64.
    const std::vector<std::vector<int64_t>> streams = {
        {1700000000000000000},
        {1700000000000000000, 1700000000000000100},
        {1700000000000000000, 1700000000000000100, 1700000000000000200, 1700000000040000000},
        {std::numeric_limits<int64_t>::min(), 0, std::numeric_limits<int64_t>::max()},
        {5},
    };
    for (const std::vector<int64_t>& stamps : streams) {
        SCOPED_TRACE(stamps.front());
        std::vector<FrameRow> rows(stamps.size());
        for (std::size_t i = 0; i < rows.size(); ++i) {
            rows[i].timestamp = stamps[i];
            rows[i].surprise = 40.0 + static_cast<double>(i);
            rows[i].instantaneous = 300.0 - static_cast<double>(i);
            rows[i].final = 280.0;
            rows[i].topic_share.assign(4, 0.25f);
        }
        // The axis is wide enough for its ticks (a tenth of it) to advance.
        const auto [f0, f1] = rost::tool::timeAxis(rows);
        EXPECT_EQ(f0, static_cast<double>(stamps.front()));
        EXPECT_GE(f1, static_cast<double>(stamps.back()));
        EXPECT_GT(f0 + (f1 - f0) / 10, f0);
        rost::tool::SummaryInput in;
        in.title = "stamps";
        in.K = 4;
        in.rows = rows;
        if (!drawsWithin(in, std::chrono::seconds(20))) rost::testing::endTheRun("summary.png's drawing did not end in 20 s");
    }
}

// The time axis's labels: short, side by side without touching, and, where
// the stamps are far larger than their span (a bag's nanoseconds), counted
// from an origin that is one of the ticks. Frame numbers read as they are.
TEST(ToolSummary, TimeLabelsFitTheAxisAndCountFromAnOriginWhereStampsAreLarge) {
    struct Axis {
        double x0, x1;
        bool from_origin;
        int width;  // 1468: the summary's plot
    };
    const Axis axes[] = {
        {0, 300, false, 1468},                                        // frames
        {0, 99999, false, 1468},                                      // a long video
        {0, 99999, false, 300},                                       // in a narrow box: fewer ticks
        {1700000000000000000.0, 1700000060000000000.0, true, 1468},  // a minute of a bag, ns
        {1700000000000000000.0, 1700000000400000000.0, true, 1468},  // 0.4 s of it
        {1.7e9, 1.7e9 + 3600, true, 1468},                          // a Unix time in s with an hour
        {-5e12, 5e12, false, 1468},
        {1.0e10, 1.24e10, false, 1468},                              // steps of 2.5e8: 1.025e+10 needs 4 digits
        {1.0e10, 1.025e10, false, 1468},                             // 2.5e7 would need 1.0025e+10: fewer ticks
        {1.7e9, 1.7e9 + 3.5e6, true, 1468},                         // steps of 2.5e5 from the origin
    };
    for (const Axis& a : axes) {
        SCOPED_TRACE(std::to_string(a.x0) + " to " + std::to_string(a.x1) + " in " + std::to_string(a.width));
        const int width = a.width;
        const rost::tool::TimeTicks t = rost::tool::timeTicks(a.x0, a.x1, width);
        ASSERT_GE(t.at.size(), 2u);
        ASSERT_EQ(t.labels.size(), t.at.size());
        EXPECT_EQ(t.origin != 0.0, a.from_origin);
        if (a.from_origin) {
            EXPECT_EQ(t.origin, t.at.front());
        }
        for (std::size_t i = 0; i < t.at.size(); ++i) {
            EXPECT_GE(t.at[i], a.x0);
            EXPECT_LE(t.at[i], a.x1);
            if (i > 0) {
                EXPECT_GT(t.at[i], t.at[i - 1]);
            }
            EXPECT_LE(t.labels[i].size(), 9u) << t.labels[i];
            // What a label reads is where its tick stands, from the origin.
            EXPECT_NEAR(std::strtod(t.labels[i].c_str(), nullptr) + t.origin, t.at[i],
                        std::abs(t.at[1] - t.at[0]) * 0.01)
                << t.labels[i];
            // Neighbours stand apart by half of each label and 12 pixels.
            if (i > 0) {
                const double apart = (t.at[i] - t.at[i - 1]) / (a.x1 - a.x0) * (width - 1);
                EXPECT_GE(apart, (rost::tool::tickLabelWidth(t.labels[i - 1]) + rost::tool::tickLabelWidth(t.labels[i])) / 2.0 + 12)
                    << "labels would touch: " << t.labels[i - 1] << " and " << t.labels[i];
            }
        }
    }
}

TEST(ToolSummary, TheCanvasIsDrawnInAMappingOfItsOwn) {
    std::vector<FrameRow> rows(120);
    for (std::size_t i = 0; i < rows.size(); ++i) {
        FrameRow& r = rows[i];
        r.timestamp = static_cast<int64_t>(i);
        r.surprise = 40.0 + 25.0 * std::sin(0.1 * static_cast<double>(i));
        r.instantaneous = 300.0 + 20.0 * std::cos(0.05 * static_cast<double>(i));
        r.final = 280.0;
        r.topic_share.assign(4, 0.25f);
    }
    rost::tool::SummaryInput in;
    in.title = "summary";
    in.K = 4;
    in.rows = rows;
    const std::size_t before = rost::mappedBytes();
    {
        const rost::tool::Picture p = rost::tool::drawSummary(in);
        ASSERT_EQ(p.image.type(), CV_8UC3);
        EXPECT_EQ(p.image.cols, 1600);
        EXPECT_TRUE(p.pixels.mapped()) << "a 3 MB canvas from the heap: faulted in a 4 KiB page at a time";
        EXPECT_GE(rost::mappedBytes(), before + p.image.total() * 3);
        EXPECT_EQ(static_cast<const void*>(p.image.data), static_cast<const void*>(p.pixels.data()))
            << "the image is not drawn in the picture's pixels";
        EXPECT_TRUE(p.image.isContinuous());
        // Drawn there: the curves and labels, not only the white fill.
        std::size_t inked = 0;
        for (int y = 0; y < p.image.rows; ++y)
            for (int x = 0; x < p.image.cols; ++x) inked += p.image.at<cv::Vec3b>(y, x) != cv::Vec3b(255, 255, 255);
        EXPECT_GT(inked, std::size_t{10000});
    }
    EXPECT_EQ(rost::mappedBytes(), before) << "the canvas's mapping outlived its picture";
    // A small picture is heap memory, and still the image's own.
    const rost::tool::Picture small = rost::tool::makePicture(4, 5);
    EXPECT_FALSE(small.pixels.mapped());
    EXPECT_EQ(static_cast<const void*>(small.image.data), static_cast<const void*>(small.pixels.data()));
    EXPECT_EQ(small.image.size(), cv::Size(5, 4));
}

// run.txt's lines: words dropped for both reasons at once, and the topics
// of a growing model before any move (no gamma learned yet).
TEST(ToolResults, RunTxtNamesBothDropsAndALearnedGammaOnlyOnceOneIsLearned) {
    rost::Config c;
    c.max_words_per_frame = 3000;
    c.cell_capacity = 8;
    const rost::tool::WordDrops both{1000, 30, 20};
    EXPECT_EQ(both.line(c), "words dropped: 50 of 1000 (5 %): 30 beyond max.words = 3000, 20 beyond cell.capacity = 8; "
                            "uniformly subsampled\n");
    EXPECT_NE(both.note(c).find("a larger --max.words and a larger --cell.capacity keeps them"), std::string::npos)
        << both.note(c);
    rost::Config g;
    g.V = 20;
    g.K = 12;
    g.grow = true;
    g.gamma = 0.5;
    const rost::Model m(g);
    ASSERT_EQ(m.learnedGamma(), 0.0);
    EXPECT_EQ(rost::tool::topicsLine(m), "topics: 0 open of at most K = 12 (topics.grow, gamma = 0.5 at the start; 0 "
                                         "split and merge moves accepted by this run)\n");
}

} // namespace
