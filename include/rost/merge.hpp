#pragma once

// Merging topic models (a fleet: many missions or vehicles, one topic set;
// docs/fleet.md). Each model numbers its topics its own way; merging matches
// them to one global set by the Hellinger distance between their smoothed
// topic-word distributions and sums the counts of the topics matched.
//
// The models are taken in order. The first one's topics (those that hold a
// word) open the global set; each next model is matched against the global
// set as it stands: an optimal one-to-one assignment (Hungarian) of its
// topics to the global topics, kept where the distance is at most the
// threshold; a topic left unassigned then joins its nearest global topic if
// that is within the threshold (a topic the model split in two joins one
// global topic), and otherwise opens a global topic of its own. The global
// counts are the sums of the counts matched to them. Deterministic; the
// result depends on the order of the models (a different first model can
// open different global topics), never on anything else. Set-up code: allocates.

#include <cstdint>
#include <span>
#include <string>
#include <vector>

#include "rost/status.hpp"

namespace rost {

// A topic model's counts: K rows of V counts n_k^v (row-major, topic by word).
struct TopicCounts {
    int K = 0;
    int V = 0;
    std::vector<int64_t> counts;
    [[nodiscard]] int64_t at(int k, int v) const noexcept {
        return counts[static_cast<std::size_t>(k) * static_cast<std::size_t>(V) + static_cast<std::size_t>(v)];
    }
};

struct MergeOptions {
    // A topic matches a global topic at a Hellinger distance up to this
    // (distances lie in [0, 1]; 0: the same distribution, 1: disjoint words).
    double threshold = 0.6;
    // Smoothing of phi_k(v) = (n_k^v + beta) / (n_k + V beta) over the global V.
    double beta = 0.01;
    // How the face spells them (the tool's "--threshold", the node's
    // "~threshold"), for the messages.
    std::string threshold_name = "merge threshold";
    std::string beta_name = "merge beta";
    // Checks both; the message names the option and its range.
    [[nodiscard]] Status validate() const;
};

struct MergedTopics {
    TopicCounts global;  // one row per global topic; V = the largest input V
    // lifting[m][k]: model m's topic k in the global set, -1 for a topic that
    // holds no word (it labels nothing).
    std::vector<std::vector<int>> lifting;
    // distance[m][k]: the Hellinger distance of model m's topic k to the
    // global topic it joined as it stood then (0 for a topic that opened one;
    // -1 for an empty topic).
    std::vector<std::vector<double>> distance;
};

// Merges `models` (at least one; each K >= 1, V >= 1, counts non-negative).
Status mergeTopicModels(std::span<const TopicCounts> models, const MergeOptions& options, MergedTopics& out);

// The Hellinger distance of two smoothed topic-word distributions over V words
// (rows of `a` and `b`, each V counts; words past a row's length count 0).
double hellingerDistance(std::span<const int64_t> a, std::span<const int64_t> b, int V, double beta);

// An optimal assignment: rows to columns of a rows x cols cost matrix
// (row-major), minimising the total cost; assign[r] is row r's column, or -1
// when rows > cols leaves it out. O(n^2 m) (Kuhn-Munkres with potentials).
std::vector<int> optimalAssignment(std::span<const double> cost, int rows, int cols);

// Reads a topic model: a topicmodel.csv (K lines of V counts, every line as
// long as the first) or a rost checkpoint (its n_k^v, the open topics in
// label order as topicmodel.csv writes them). Errors name the file.
Status readTopicCounts(const std::string& path, TopicCounts& out);

// The global model as topicmodel.csv text, and the lifting as CSV with the
// header `model,local,global` (one row per topic of every model; `names`
// name the models, or their index from 0 when empty).
std::string formatTopicCountsCsv(const TopicCounts& model);
std::string formatLiftingCsv(const MergedTopics& merged, std::span<const std::string> names = {});

} // namespace rost
