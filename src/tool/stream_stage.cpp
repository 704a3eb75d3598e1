// `rost refine`'s input: a word stream (and its positions) read whole, the
// engine made for it (the library's openStreamMission). Apart from
// stages.cpp, whose frame sources need OpenCV's video and image I/O:
// `rost refine` is built without them.

#include <cstdio>

#include "rost/mission.hpp"
#include "rost/text_io.hpp"
#include "stages.hpp"

namespace rost::tool {

// stages.hpp
std::string budgetText(const Budget& b, const std::string& per) {
    if (b.kind == BudgetKind::Time) {
        char buf[64];
        std::snprintf(buf, sizeof buf, "%g ms", b.ms);
        return buf + per;
    }
    return std::to_string(b.count) + (b.kind == BudgetKind::Tokens ? " tokens" : " refines") + per;
}

// The library's word-stream mission (rost/mission.hpp, openStreamMission)
// reads, plans or resumes, and opens the engine; the tool says where it is.
Status StreamStage::open(const RefineOptions& o) {
    StreamMissionInput in;
    in.words = o.words;
    in.positions = o.positions;
    in.width = o.width;
    in.height = o.height;
    in.read_threads = toolThreads(o.model, false);  // the positions file read beside the words
    in.base = missionInput(o.model, false);
    StreamMission m;
    if (Status st = openStreamMission(missionOptions(o.model), in, m); !st.ok()) return st;
    ws = std::move(m.stream);
    plan = m.plan;
    ec = plan.config;
    resuming = plan.resuming;
    resumed = plan.checkpoint;
    refinementChanged = plan.refinement_changed;
    skipped = m.skipped;
    engine = std::move(m.engine);
    if (resuming && !o.quiet)
        std::fprintf(stderr, "rost: resuming %s at observation %llu (time stamp %lld); %s skipped%s\n",
                     text::printable(o.model.resume).c_str(), static_cast<unsigned long long>(resumed.observations),
                     static_cast<long long>(resumed.last_timestamp),
                     text::counted(static_cast<long long>(skipped), "observation").c_str(),
                     refinementChanged ? "; refinement settings changed (not bit for bit)" : "");
    return {};
}

} // namespace rost::tool
