// `rost merge`: topic models of several missions matched into one global set
// (rost/merge.hpp; docs/fleet.md). Writes DIR/topicmodel.csv and
// DIR/lifting.csv through the staging directory, so a failed merge leaves
// nothing and a previous merge's files stay whole.

#include <cstdio>
#include <filesystem>

#include "outputs.hpp"
#include "progress.hpp"
#include "rost/merge.hpp"
#include "rost/mission.hpp"
#include "rost/text_io.hpp"
#include "tool.hpp"

namespace rost::tool {

int mergeCommand(const MergeCliOptions& o) {
    MergeOptions options;
    options.threshold = o.threshold;
    options.beta = o.beta;
    options.threshold_name = "--threshold";
    options.beta_name = "--beta";
    if (Status st = options.validate(); !st.ok()) return fail(st.message());
    // The merge's files over one of the models it merges would replace it: refused before reading.
    MissionOptions read;
    read.inputs = o.models;
    for (const char* name : {"topicmodel.csv", "lifting.csv"})
        if (Status st = checkMissionOutputOverlap(read, "--out", (std::filesystem::path(o.out) / name).string()); !st.ok())
            return fail(st.message());
    // Ctrl-C or SIGTERM from here on: exit 130, nothing written (a previous
    // merge's files kept, the staging directory removed), as a refine's. A
    // read blocked on a FIFO or pipe ends too (its failure is the signal's).
    InterruptScope interrupts(InterruptScope::Reads::Interrupted);
    std::vector<TopicCounts> models(o.models.size());
    for (std::size_t i = 0; i < o.models.size(); ++i) {
        const Status st = readTopicCounts(o.models[i], models[i]);
        if (interrupted()) return abandonedRun();
        if (!st.ok()) return fail(st.message());
    }
    MergedTopics merged;
    if (Status st = mergeTopicModels(models, options, merged); !st.ok()) return fail(st.message());
    if (interrupted()) return abandonedRun();
    OutputDir out;
    if (Status st = out.open(o.out); !st.ok()) return fail(st.message());
    if (Status st = out.probe({"topicmodel.csv", "lifting.csv"}); !st.ok()) return fail(st.message());
    if (Status st = out.write("topicmodel.csv", formatTopicCountsCsv(merged.global)); !st.ok()) return fail(st.message());
    if (Status st = out.write("lifting.csv", formatLiftingCsv(merged)); !st.ok()) return fail(st.message());
    if (interrupted()) return abandonedRun();
    if (Status st = out.commit(); !st.ok()) return fail(st.message());
    if (!o.quiet) {
        std::size_t topics = 0;
        for (const auto& l : merged.lifting) topics += l.size();
        const std::string counts = text::counted(static_cast<long long>(models.size()), "model") + ", " +
                                   text::counted(static_cast<long long>(topics), "topic") + " -> " +
                                   text::counted(merged.global.K, "global topic");
        std::fprintf(stderr, "rost merge: %s (V = %d) in %s\n", counts.c_str(), merged.global.V, text::printable(o.out).c_str());
        // --in.topicmodel ... --topicmodel.fixed takes K from the file's lines, at most K's bound.
        const auto most = static_cast<int>(settingSpec("K").hi);
        if (merged.global.K > most)
            std::fprintf(stderr,
                         "rost: note: %d global topics, more than the %d a model holds: --topicmodel.fixed cannot "
                         "label in them (a higher --threshold joins more)\n",
                         merged.global.K, most);
    }
    return kExitOk;
}

} // namespace rost::tool
