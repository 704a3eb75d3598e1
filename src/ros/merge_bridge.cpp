// rost::bridge's merge (bridge.hpp): rost/merge.hpp for rost_merge_node, on
// the C++20 side.

#include <cmath>
#include <vector>

#include "bridge.hpp"
#include "rost/merge.hpp"

namespace rost::bridge {

// The library's check (MergeOptions::validate), in the node's spelling.
std::string checkMergeOptions(double threshold, double beta) {
    MergeOptions o;
    o.threshold = threshold;
    o.beta = beta;
    o.threshold_name = "~threshold";
    o.beta_name = "~beta";
    return o.validate().message();
}

std::string mergeModels(const std::vector<ModelCounts>& models, double threshold, double beta, MergedModel& out) {
    std::vector<TopicCounts> in(models.size());
    for (std::size_t m = 0; m < models.size(); ++m) {
        in[m].K = models[m].K;
        in[m].V = models[m].V;
        in[m].counts.assign(models[m].counts.begin(), models[m].counts.end());
    }
    MergeOptions o;
    o.threshold = threshold;
    o.beta = beta;
    MergedTopics merged;
    if (const Status st = mergeTopicModels(in, o, merged); !st.ok()) return st.message();
    out.K = merged.global.K;
    out.V = merged.global.V;
    out.counts = std::move(merged.global.counts);
    out.lifting = std::move(merged.lifting);
    return {};
}

} // namespace rost::bridge
