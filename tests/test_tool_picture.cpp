// summary.png's canvas (src/tool/outputs.hpp, Picture): drawn where its
// pixels were allocated, a mapping of their own, not in memory from malloc.

#include <gtest/gtest.h>

#include <cmath>
#include <vector>

#include "aligned_buffer.hpp"
#include "outputs.hpp"
#include "sinks.hpp"

namespace {

using rost::tool::FrameRow;

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

} // namespace
