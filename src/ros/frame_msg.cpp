#include "frame_msg.hpp"

#include <cmath>
#include <cstring>

namespace rost::bridge {

void fillFrameTopics(const FrameResult& r, rost_msgs::FrameTopics& msg) {
    msg.frame = r.frame;
    msg.perplexity = r.perplexity;
    msg.surprise = r.surprise;
    msg.active_topics = r.active_topics;
    msg.topic_weights = r.topic_weights;
    msg.cells_x = r.cells_x;
    msg.cells_y = r.cells_y;
    msg.cell_topics = r.cell_topics;
    msg.cell_surprise = r.cell_surprise;
}

namespace {
// A distinct colour per topic: hues spread by the golden angle, full value.
void topicColour(int k, uint8_t rgb[3]) {
    const double h = std::fmod(k * 137.508, 360.0) / 60.0;
    const int i = static_cast<int>(h);
    const double f = h - i;
    const double s = k % 2 ? 0.65 : 0.95;
    const auto b = [](double v) { return static_cast<uint8_t>(v * 255.0 + 0.5); };
    const double p = 1.0 - s, q = 1.0 - s * f, t = 1.0 - s * (1.0 - f);
    const double table[6][3] = {{1, t, p}, {q, 1, p}, {p, 1, t}, {p, q, 1}, {t, p, 1}, {1, p, q}};
    for (int c = 0; c < 3; ++c) rgb[c] = b(table[i % 6][c]);
}
} // namespace

void fillTopicMap(const FrameResult& r, int cell, sensor_msgs::Image& msg) {
    msg.encoding = "rgb8";
    msg.is_bigendian = 0;
    msg.width = static_cast<uint32_t>(r.cells_x * cell);
    msg.height = static_cast<uint32_t>(r.cells_y * cell);
    msg.step = msg.width * 3;
    msg.data.assign(static_cast<std::size_t>(msg.step) * msg.height, 0);
    for (int cy = 0; cy < r.cells_y; ++cy)
        for (int cx = 0; cx < r.cells_x; ++cx) {
            const int k = r.cell_topics[static_cast<std::size_t>(cy) * r.cells_x + cx];
            if (k < 0) continue;
            uint8_t rgb[3];
            topicColour(k, rgb);
            for (int y = cy * cell; y < (cy + 1) * cell; ++y) {
                uint8_t* row = msg.data.data() + static_cast<std::size_t>(y) * msg.step + cx * cell * 3;
                for (int x = 0; x < cell; ++x) std::memcpy(row + 3 * x, rgb, 3);
            }
        }
}

void fillSurpriseMap(const FrameResult& r, sensor_msgs::Image& msg) {
    msg.encoding = "32FC1";
    msg.is_bigendian = 0;
    msg.width = static_cast<uint32_t>(r.cells_x);
    msg.height = static_cast<uint32_t>(r.cells_y);
    msg.step = msg.width * 4;
    msg.data.resize(r.cell_surprise.size() * 4);
    std::memcpy(msg.data.data(), r.cell_surprise.data(), msg.data.size());
}

} // namespace rost::bridge
