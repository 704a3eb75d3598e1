// summary.png's canvas (src/tool/outputs.hpp, Picture): drawn where its
// pixels were allocated, a mapping of their own, not in memory from malloc.

#include <gtest/gtest.h>

#include <cmath>
#include <vector>

#include "aligned_buffer.hpp"
#include "outputs.hpp"

namespace {

using rost::tool::FrameRow;

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
