// rost::bridge's merge (bridge.hpp): rost/merge.hpp for rost_merge_node, on
// the C++20 side.

#include <cmath>
#include <vector>

#include "bridge.hpp"
#include "rost/merge.hpp"

namespace rost::bridge {

std::string checkMergeOptions(double threshold, double beta) {
    if (!std::isfinite(threshold) || threshold < 0.0 || threshold > 1.0)
        return "~threshold = " + std::to_string(threshold) + ": expected a Hellinger distance in [0, 1]";
    if (!std::isfinite(beta) || beta <= 0.0)
        return "~beta = " + std::to_string(beta) + ": expected a finite number > 0";
    MergeOptions o;
    o.threshold = threshold;
    o.beta = beta;
    const Status st = o.validate();
    return st.ok() ? std::string() : "~threshold, ~beta: " + st.message();
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
