#pragma once

// The topic model alone, as the earlier ROST tools wrote it (`topicmodel.csv`,
// read back with `--in.topicmodel`): K lines of V comma-separated counts,
// line k+1 holding n_k^v for v = 0..V-1. Exported at the end of one mission
// and imported at the start of the next, its counts become a prior that
// refinement never removes (Model::addTopicCounts), so the new mission starts
// with the topics learned before. Blank lines and '#' lines are skipped.
// Set-up code: allocates.

#include <cstdint>
#include <string>
#include <string_view>
#include <vector>

#include "rost/model.hpp"
#include "rost/status.hpp"

namespace rost {

// The model's n_k^v as CSV text.
std::string formatTopicModelCsv(const Model& model);
// Written atomically (temporary file, fsync, rename).
Status writeTopicModelCsv(const Model& model, const std::string& path);

// Parses 1 to K lines of up to V counts, every line as long as the first,
// into K x V counts (row-major, topic by word, as addTopicCounts takes them;
// topics past the file's lines are 0: a growth run's topicmodel.csv has a
// line per topic open at its end; words past its lines are 0: a model of a
// mission with fewer words). Errors name the file, line and column:
// "topicmodel.csv:3:118: expected a count, found 'x'",
// "topicmodel.csv:2:1: 5435 counts, expected 5436 as on the first line",
// "topicmodel.csv:17:1: more than K = 16 topic lines". A topic's total must
// stay below 2^31 (n_k is 32-bit).
Status parseTopicModelCsv(std::string_view text, int K, int V, std::vector<int32_t>& counts,
                          std::string_view name = "topicmodel.csv");

// The topic lines of a topicmodel.csv and the counts on its first one (what
// a mission takes as K and V when they are not given); no other check (a
// file without lines has 0 rows: loadTopicModelCsv names the problem).
struct TopicModelShape {
    int rows = 0;
    int columns = 0;
};
Status readTopicModelShape(const std::string& path, TopicModelShape& shape);
// The same, of a file's text already read (`name` for its messages).
TopicModelShape topicModelShapeOf(std::string_view csv, const std::string& name);

// Reads `path` and adds its counts to `model` (Model::addTopicCounts);
// refuses counts that would overflow the model's n_k. Set-up only.
Status loadTopicModelCsv(const std::string& path, Model& model);

} // namespace rost
