// rost_node's bridge to the library (src/ros/bridge.hpp), without a ROS
// master: with topics.grow a frame's labels are the ranks of its topics'
// slots among the open ones, ~topic_model's rows are the slots, and the
// merge node's lifting (by those rows) is read through each frame's own
// slots (docs/ros.md, ~global_frame).

#include <gtest/gtest.h>

#include <algorithm>
#include <chrono>
#include <cstdint>
#include <string>
#include <thread>
#include <vector>

#include <opencv2/core.hpp>

#include "bridge.hpp"

namespace rost::bridge {
namespace {

TEST(RosBridgeLifting, EachLabelIsLiftedThroughItsSlot) {
    // Labels 0, 1, 2 are slots 0, 2, 3 (slot 1 closed); the lifting is by slot.
    const std::vector<uint16_t> slots = {0, 2, 3, 1};
    const std::vector<int32_t> lifting = {7, -1, 4, 9};
    std::vector<int32_t> byLabel;
    liftLabels(slots, lifting, 4, byLabel);
    EXPECT_EQ(byLabel, (std::vector<int32_t>{7, 4, 9, -1}));
    // A lifting shorter than the slots (a model of another K) and a frame
    // without slots lift to nothing rather than past the end.
    liftLabels(slots, {7, 8}, 4, byLabel);
    EXPECT_EQ(byLabel, (std::vector<int32_t>{7, -1, -1, 8}));
    liftLabels({}, lifting, 4, byLabel);
    EXPECT_EQ(byLabel, (std::vector<int32_t>(4, -1)));
}

// A growing model with a prior in slots 0 and 2 (slot 1 closed below an
// open one): the frames say their labels' slots, the open ones first in
// slot order; ~topic_model's rows are by slot (a closed slot's row zeros)
// where ~get_topic_model's are by label, and the two agree through the
// last frame's slots. What opens is the data's (growth's moves); the run is
// deterministic (a count budget, one thread, a seed), and the test checks
// that its last frame has a label that is not its slot.
TEST(RosBridgePipeline, GrowingTopicsAreNamedBySlotInFramesAndInTheTopicModel) {
    NodeSettings s;
    for (const auto& [key, value] : std::vector<std::pair<std::string, std::string>>{
             {"topics.grow", "true"}, {"K", "6"}, {"gamma", "1e-9"}, {"budget.refines", "4"}, {"threads", "1"}})
        ASSERT_EQ(s.set(key, value), "") << key;
    std::string error;
    auto p = Pipeline::create(s, Pipeline::Options{}, error);
    ASSERT_TRUE(p) << error;
    ASSERT_EQ(p->open(192, 128), "");
    const int K = p->K(), V = p->V();
    ASSERT_EQ(K, 6);
    std::vector<int32_t> prior(static_cast<std::size_t>(K) * static_cast<std::size_t>(V), 0);
    for (int v = 0; v < V; ++v) {
        prior[static_cast<std::size_t>(v)] = v % 2 == 0 ? 50 : 0;          // slot 0
        prior[static_cast<std::size_t>(2 * V + v)] = v % 2 == 1 ? 50 : 0;  // slot 2
    }
    ASSERT_EQ(p->addTopicModel(K, V, prior), "");
    ASSERT_EQ(p->start(), "");
    p->requestModel();  // copied by the refiner after the first frame (~topic_model's way)
    cv::RNG rng(5);
    constexpr int kFrames = 8;
    for (int f = 0; f < kFrames; ++f) {
        cv::Mat image(128, 192, CV_8UC3);
        rng.fill(image, cv::RNG::UNIFORM, 0, 256);
        const auto until = std::chrono::steady_clock::now() + std::chrono::seconds(60);
        while (!p->canPush()) {
            ASSERT_LT(std::chrono::steady_clock::now(), until) << "the refiner took up nothing for 60 s";
            std::this_thread::yield();
        }
        ASSERT_TRUE(p->push(image, f));
    }
    p->stop();
    FrameResult r;
    int frames = 0;
    std::vector<uint16_t> last, firstSlots;
    int lastActive = 0, firstActive = 0;
    while (p->next(r)) {
        ++frames;
        ASSERT_EQ(r.topic_slots.size(), static_cast<std::size_t>(K));
        // The open slots first, in slot order, then the closed ones in slot order.
        ASSERT_GE(r.active_topics, 2);
        ASSERT_LE(r.active_topics, K);
        const auto A = static_cast<std::size_t>(r.active_topics);
        EXPECT_TRUE(std::is_sorted(r.topic_slots.begin(), r.topic_slots.begin() + static_cast<std::ptrdiff_t>(A)));
        EXPECT_TRUE(std::is_sorted(r.topic_slots.begin() + static_cast<std::ptrdiff_t>(A), r.topic_slots.end()));
        std::vector<uint16_t> sorted = r.topic_slots;
        std::sort(sorted.begin(), sorted.end());
        for (int k = 0; k < K; ++k) EXPECT_EQ(sorted[static_cast<std::size_t>(k)], k);
        if (frames == 1) firstSlots = r.topic_slots, firstActive = r.active_topics;
        last = r.topic_slots;
        lastActive = r.active_topics;
    }
    ASSERT_EQ(frames, kFrames);
    auto row = [&](const std::vector<int32_t>& m, int k) {
        return std::vector<int32_t>(m.begin() + static_cast<std::ptrdiff_t>(k) * V,
                                    m.begin() + static_cast<std::ptrdiff_t>(k + 1) * V);
    };
    const std::vector<int32_t> zeros(static_cast<std::size_t>(V), 0);
    std::vector<int32_t> first, bySlot, byLabel;
    ASSERT_TRUE(p->takeModel(first));
    ASSERT_EQ(first.size(), prior.size());
    // The refiner's copy, made after the first frame: its rows holding words
    // are that frame's open slots.
    std::vector<uint16_t> openFirst;
    for (int k = 0; k < K; ++k)
        if (row(first, k) != zeros) openFirst.push_back(static_cast<uint16_t>(k));
    EXPECT_EQ(openFirst, std::vector<uint16_t>(firstSlots.begin(), firstSlots.begin() + firstActive));
    ASSERT_FALSE(openFirst.empty());
    EXPECT_NE(openFirst.back() + 1u, openFirst.size()) << "the first frame's open slots have a gap";
    ASSERT_TRUE(p->copyModelIfIdle(bySlot));
    ASSERT_EQ(p->getTopicModel(byLabel), "");
    ASSERT_EQ(bySlot.size(), prior.size());
    ASSERT_EQ(byLabel.size(), prior.size());
    for (int l = 0; l < K; ++l) EXPECT_EQ(row(byLabel, l), row(bySlot, last[static_cast<std::size_t>(l)])) << l;
    // The open slots are the rows holding words, and the last frame's first labels.
    std::vector<uint16_t> open;
    for (int k = 0; k < K; ++k)
        if (row(bySlot, k) != zeros) open.push_back(static_cast<uint16_t>(k));
    ASSERT_EQ(open.size(), static_cast<std::size_t>(lastActive));
    EXPECT_EQ(std::vector<uint16_t>(last.begin(), last.begin() + lastActive), open);
    bool renamed = false;
    for (int l = 0; l < lastActive; ++l) renamed = renamed || last[static_cast<std::size_t>(l)] != l;
    EXPECT_TRUE(renamed) << "no label differs from its slot: the test would not tell slots from labels";
    int64_t words = 0;
    for (int32_t c : row(bySlot, 2)) words += c;
    EXPECT_GT(words, int64_t{50} * (V / 2)) << "slot 2 holds its prior and words of the frames";
}

} // namespace
} // namespace rost::bridge
