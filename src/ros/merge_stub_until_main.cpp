// TEMPORARY (removed when main's src/core/merge.cpp is merged): a stand-in
// for rost::mergeTopicModels so the ROS merge node builds before it lands.
// Every topic that holds a word opens a global topic of its own.
#include <algorithm>

#include "rost/merge.hpp"

namespace rost {
Status MergeOptions::validate() const { return {}; }
Status mergeTopicModels(std::span<const TopicCounts> models, const MergeOptions&, MergedTopics& out) {
    out = {};
    for (const TopicCounts& m : models) out.global.V = std::max(out.global.V, m.V);
    for (const TopicCounts& m : models) {
        std::vector<int> lift(static_cast<std::size_t>(m.K), -1);
        for (int k = 0; k < m.K; ++k) {
            int64_t n = 0;
            for (int v = 0; v < m.V; ++v) n += m.at(k, v);
            if (n == 0) continue;
            lift[static_cast<std::size_t>(k)] = out.global.K++;
            out.global.counts.resize(static_cast<std::size_t>(out.global.K) * out.global.V, 0);
            for (int v = 0; v < m.V; ++v)
                out.global.counts[static_cast<std::size_t>(out.global.K - 1) * out.global.V + v] = m.at(k, v);
        }
        out.lifting.push_back(lift);
        out.distance.emplace_back(lift.size(), 0.0);
    }
    return {};
}
} // namespace rost
