// Merging topic models (rost/merge.hpp): the assignment is optimal, the
// distance is Hellinger's, topics of several models that describe the same
// words meet in one global topic whatever their numbers, a split topic joins
// one global topic, a topic of its own stays one, counts add up, and bad
// input is named.

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <numeric>
#include <vector>

#include "rost/merge.hpp"
#include "rost/random.hpp"

namespace {

// The cheapest total over every assignment of rows to distinct columns (rows <= cols).
double bruteForce(const std::vector<double>& cost, int rows, int cols) {
    std::vector<int> perm(static_cast<std::size_t>(cols));
    std::iota(perm.begin(), perm.end(), 0);
    double best = 1e300;
    do {
        double total = 0.0;
        for (int r = 0; r < rows; ++r) total += cost[static_cast<std::size_t>(r * cols + perm[static_cast<std::size_t>(r)])];
        best = std::min(best, total);
    } while (std::next_permutation(perm.begin(), perm.end()));
    return best;
}

TEST(Merge, AssignmentIsOptimalForSquareAndRectangularMatrices) {
    rost::Rng rng(5);
    for (int trial = 0; trial < 60; ++trial) {
        const int rows = 1 + static_cast<int>(rng.below(6)), cols = 1 + static_cast<int>(rng.below(6));
        std::vector<double> cost(static_cast<std::size_t>(rows * cols));
        for (double& c : cost) c = static_cast<double>(rng.below(20)) / 4.0;  // ties too
        const std::vector<int> a = rost::optimalAssignment(cost, rows, cols);
        ASSERT_EQ(a.size(), static_cast<std::size_t>(rows));
        std::vector<int> seen;
        double total = 0.0;
        for (int r = 0; r < rows; ++r) {
            const int c = a[static_cast<std::size_t>(r)];
            if (c < 0) continue;
            ASSERT_LT(c, cols);
            seen.push_back(c);
            total += cost[static_cast<std::size_t>(r * cols + c)];
        }
        std::sort(seen.begin(), seen.end());
        EXPECT_EQ(std::adjacent_find(seen.begin(), seen.end()), seen.end()) << "a column twice";
        EXPECT_EQ(seen.size(), static_cast<std::size_t>(std::min(rows, cols)));
        std::vector<double> t(cost.size());  // brute force over the smaller side
        if (rows > cols)
            for (int r = 0; r < rows; ++r)
                for (int c = 0; c < cols; ++c) t[static_cast<std::size_t>(c * rows + r)] = cost[static_cast<std::size_t>(r * cols + c)];
        const double best = rows <= cols ? bruteForce(cost, rows, cols) : bruteForce(t, cols, rows);
        EXPECT_NEAR(total, best, 1e-12) << rows << "x" << cols << " trial " << trial;
    }
}

TEST(Merge, HellingerDistanceIsZeroForOneDistributionAndNearOneForDisjointWords) {
    const std::vector<int64_t> a{1000, 2000, 0, 0}, b{10, 20, 0, 0}, c{0, 0, 3000, 500};
    EXPECT_EQ(rost::hellingerDistance(a, a, 4, 0.01), 0.0) << "exactly: --threshold 0 joins only identical topics";
    EXPECT_LT(rost::hellingerDistance(a, b, 4, 0.01), 0.05) << "the same shape, fewer words";
    EXPECT_GT(rost::hellingerDistance(a, c, 4, 0.01), 0.99);
    EXPECT_DOUBLE_EQ(rost::hellingerDistance(a, c, 4, 0.01), rost::hellingerDistance(c, a, 4, 0.01));
    // Words past a row's end count 0: a model of fewer words.
    EXPECT_NEAR(rost::hellingerDistance(std::vector<int64_t>{1000, 2000}, a, 4, 0.01), 0.0, 1e-7);
}

// A model of `topics` (planted topic ids) over blocks of 20 words each,
// `scale` words a topic, with some noise words.
rost::TopicCounts planted(const std::vector<int>& topics, int V, uint64_t seed, int scale = 500) {
    rost::TopicCounts m;
    m.K = static_cast<int>(topics.size());
    m.V = V;
    m.counts.assign(static_cast<std::size_t>(m.K * V), 0);
    rost::Rng rng(seed);
    for (int k = 0; k < m.K; ++k)
        for (int i = 0; i < scale; ++i) {
            const bool noise = rng.below(10) == 0;
            const int v = noise ? static_cast<int>(rng.below(static_cast<uint32_t>(V)))
                                : topics[static_cast<std::size_t>(k)] * 20 + static_cast<int>(rng.below(20));
            ++m.counts[static_cast<std::size_t>(k * V + v)];
        }
    return m;
}

TEST(Merge, TopicsOfTheSameWordsMeetWhateverTheirNumbers) {
    // Three missions share planted topics 0, 1, 2 in other orders; each has one of its own (3, 4, 5).
    std::vector<rost::TopicCounts> models{planted({0, 1, 2, 3}, 120, 1), planted({2, 4, 0, 1}, 120, 2),
                                          planted({5, 1, 2, 0}, 100, 3)};
    models[1].counts.resize(models[1].counts.size() + 120, 0);  // an empty fifth topic
    models[1].K = 5;
    rost::MergedTopics out;
    ASSERT_TRUE(rost::mergeTopicModels(models, {}, out).ok());
    EXPECT_EQ(out.global.K, 6) << "three shared topics and three of their own";
    EXPECT_EQ(out.global.V, 120) << "the largest V";
    const std::vector<std::vector<int>> planting{{0, 1, 2, 3}, {2, 4, 0, 1, -1}, {5, 1, 2, 0}};
    std::vector<int> globalOf(6, -1);  // planted topic -> global topic, the same in every model
    for (std::size_t m = 0; m < models.size(); ++m)
        for (std::size_t k = 0; k < planting[m].size(); ++k) {
            const int p = planting[m][k], g = out.lifting[m][k];
            if (p < 0) {
                EXPECT_EQ(g, -1) << "an empty topic labels nothing";
                EXPECT_EQ(out.distance[m][k], -1.0);
                continue;
            }
            if (globalOf[static_cast<std::size_t>(p)] < 0) globalOf[static_cast<std::size_t>(p)] = g;
            EXPECT_EQ(g, globalOf[static_cast<std::size_t>(p)]) << "model " << m << " topic " << k;
        }
    int64_t in = 0, merged = 0;
    for (const auto& m : models) in = std::accumulate(m.counts.begin(), m.counts.end(), in);
    merged = std::accumulate(out.global.counts.begin(), out.global.counts.end(), merged);
    EXPECT_EQ(merged, in) << "every word counted once";
    EXPECT_EQ(out.global.at(globalOf[3], 3 * 20 + 1), models[0].at(3, 3 * 20 + 1)) << "a topic of its own keeps its counts";
}

TEST(Merge, ASplitTopicJoinsOneGlobalTopicAndAThresholdOfZeroKeepsTopicsApart) {
    std::vector<rost::TopicCounts> models{planted({0, 1}, 40, 1), planted({0, 1, 1}, 40, 2)};
    rost::MergedTopics out;
    ASSERT_TRUE(rost::mergeTopicModels(models, {}, out).ok());
    EXPECT_EQ(out.global.K, 2);
    EXPECT_EQ(out.lifting[1][1], out.lifting[0][1]);
    EXPECT_EQ(out.lifting[1][2], out.lifting[0][1]) << "the split half joins its nearest";
    rost::MergeOptions strict;
    strict.threshold = 0.0;
    ASSERT_TRUE(rost::mergeTopicModels(models, strict, out).ok());
    EXPECT_EQ(out.global.K, 5) << "nothing within distance 0";
    // ... but identical topics are at exactly 0: a model merged with itself at
    // threshold 0 gives its own topics (1 - sum sqrt(p q) left about 1e-16
    // there, and some topic of the copy opened a global topic of its own).
    const std::vector<rost::TopicCounts> same{planted({0, 1, 2, 3}, 80, 3), planted({0, 1, 2, 3}, 80, 3)};
    ASSERT_TRUE(rost::mergeTopicModels(same, strict, out).ok());
    EXPECT_EQ(out.global.K, 4);
    EXPECT_EQ(out.lifting[1], out.lifting[0]);
    for (double d : out.distance[1]) EXPECT_EQ(d, 0.0);
}

// A model joins the global topics as the models before it left them: a
// topic that took a model's counts is compared by its new distribution.
// A = word 0; B = words 0 and 1 (100 : 60) joins it (distance 0.46 under
// the threshold 0.5); C = words 0 and 1 evenly is 0.54 from A alone but
// 0.20 from A + B, so it joins that topic and is not a topic of its own.
TEST(Merge, AModelIsMatchedToTheGlobalTopicsAsTheModelsBeforeItLeftThem) {
    const auto one = [](std::vector<int64_t> row) { return rost::TopicCounts{1, 4, std::move(row)}; };
    const std::vector<rost::TopicCounts> models{one({100, 0, 0, 0}), one({100, 60, 0, 0}), one({100, 100, 0, 0})};
    rost::MergeOptions o;
    o.threshold = 0.5;
    rost::MergedTopics out;
    ASSERT_TRUE(rost::mergeTopicModels(models, o, out).ok());
    EXPECT_EQ(out.global.K, 1) << "C opened a topic of its own";
    EXPECT_EQ(out.lifting[1][0], 0);
    EXPECT_EQ(out.lifting[2][0], 0);
    const std::vector<int64_t> ab{200, 60, 0, 0};
    EXPECT_DOUBLE_EQ(out.distance[2][0], rost::hellingerDistance(models[2].counts, ab, 4, o.beta));
    EXPECT_LT(out.distance[2][0], 0.25);
    EXPECT_GT(rost::hellingerDistance(models[2].counts, models[0].counts, 4, o.beta), o.threshold) << "the test's premise";
    EXPECT_EQ(out.global.counts, (std::vector<int64_t>{300, 160, 0, 0}));
}

// Models of different vocabularies are compared over the larger one (the
// global set's V): the smaller model's missing words count 0 with their
// prior beta, as hellingerDistance over V = 4 has them, not a distribution
// over its own two words alone.
TEST(Merge, TopicsOfDifferentVocabulariesAreComparedOverTheLargerOne) {
    const std::vector<rost::TopicCounts> models{{1, 4, {10, 0, 10, 0}}, {1, 2, {10, 0}}};
    rost::MergeOptions o;
    o.threshold = 1.0;  // every topic joins: its distance is recorded
    rost::MergedTopics out;
    ASSERT_TRUE(rost::mergeTopicModels(models, o, out).ok());
    ASSERT_EQ(out.lifting[1][0], 0);
    EXPECT_NEAR(out.distance[1][0], rost::hellingerDistance(models[1].counts, models[0].counts, 4, o.beta), 1e-12);
}

TEST(Merge, BadInputIsNamed) {
    rost::MergedTopics out;
    rost::MergeOptions o;
    o.threshold = 1.5;
    std::vector<rost::TopicCounts> one{planted({0}, 20, 1)};
    EXPECT_EQ(rost::mergeTopicModels(one, o, out).message(), "merge threshold 1.5 out of range [0, 1]");
    o = {};
    o.beta = 0.0;
    EXPECT_EQ(rost::mergeTopicModels(one, o, out).message(), "merge beta 0 out of range (0, 1e6]");
    EXPECT_EQ(rost::mergeTopicModels({}, {}, out).message(), "no topic models to merge");
    std::vector<rost::TopicCounts> bad{planted({0}, 20, 1), planted({0}, 20, 1)};
    bad[1].counts[7] = -2;
    EXPECT_EQ(rost::mergeTopicModels(bad, {}, out).message(), "model 1: count of topic 0, word 7 is negative");
    bad[1].counts.pop_back();
    EXPECT_EQ(rost::mergeTopicModels(bad, {}, out).message(), "model 1: 19 counts, expected K x V = 20");
    // A sum no topicmodel.csv can hold (its readers take counts below 2^31) is
    // refused, not written for --in.topicmodel to refuse later; so is a merge
    // of models without a count.
    rost::TopicCounts big;
    big.K = 2;
    big.V = 2;
    big.counts = {2000000000, 1, 1, 2000000000};
    const std::vector<rost::TopicCounts> twice{big, big};
    EXPECT_EQ(rost::mergeTopicModels(twice, {}, out).message(),
              "global topic 0, word 0: 4000000000 counts, more than a topic model file holds (2^31 - 1); merge fewer "
              "or smaller models");
    big.counts = {1000000000, 1, 1, 1000000000};
    EXPECT_TRUE(rost::mergeTopicModels(std::vector<rost::TopicCounts>{big, big}, {}, out).ok());
    EXPECT_EQ(out.global.at(0, 0), 2000000000);
    // A count no topicmodel.csv holds is refused as given: sums of counts near
    // 2^63 wrapped to negative (or zero) counts that were written out.
    big.counts = {int64_t{1} << 62, 1, 1, 2147483647};
    EXPECT_EQ(rost::mergeTopicModels(std::vector<rost::TopicCounts>{big, big}, {}, out).message(),
              "model 0: count of topic 0, word 0 is 4611686018427387904, more than a topic model file holds (2^31 - 1)");
    big.counts = {2147483647, 1, 1, 2147483648};
    EXPECT_EQ(rost::mergeTopicModels(std::vector<rost::TopicCounts>{big}, {}, out).message(),
              "model 0: count of topic 1, word 1 is 2147483648, more than a topic model file holds (2^31 - 1)");
    rost::TopicCounts empty;
    empty.K = 2;
    empty.V = 3;
    empty.counts.assign(6, 0);
    EXPECT_EQ(rost::mergeTopicModels(std::vector<rost::TopicCounts>{empty, empty}, {}, out).message(),
              "the topic models hold no counts: no topic to merge");
}

TEST(Merge, LiftingCsvNamesEveryTopicOfEveryModel) {
    std::vector<rost::TopicCounts> models{planted({0, 1}, 40, 1), planted({1, 0}, 40, 2)};
    rost::MergedTopics out;
    ASSERT_TRUE(rost::mergeTopicModels(models, {}, out).ok());
    EXPECT_EQ(rost::formatLiftingCsv(out), "model,local,global\n0,0,0\n0,1,1\n1,0,1\n1,1,0\n");
    const std::vector<std::string> names{"dive1", "dive2"};
    EXPECT_EQ(rost::formatLiftingCsv(out, names), "model,local,global\ndive1,0,0\ndive1,1,1\ndive2,0,1\ndive2,1,0\n");
    const std::string csv = rost::formatTopicCountsCsv(out.global);
    EXPECT_EQ(std::count(csv.begin(), csv.end(), '\n'), 2);
}

} // namespace
