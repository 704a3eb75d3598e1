// `rost refine WORDS.csv [--positions POSITIONS.csv] --out DIR`: a word
// stream made elsewhere (earlier ROST tools, another extractor) through the
// same engine and outputs as `rost run`, with a count budget, reproducibly.

#include <chrono>
#include <cstdio>
#include <exception>
#include <system_error>
#include <thread>

#include "collector.hpp"
#include "outputs.hpp"
#include "png_file.hpp"
#include "progress.hpp"
#include "results.hpp"
#include "rost/text_io.hpp"
#include "stages.hpp"
#include "tool.hpp"

namespace rost::tool {

namespace {

// The engine takes each observation up with its count budget; the collector drains it.
Status play(const StreamStage& in, Collector& collector, bool quiet) {
    Progress progress("rost refine", static_cast<int64_t>(in.todo().size()), quiet);
    int64_t done = 0;
    for (const auto& ob : in.todo()) {
        if (interrupted()) break;
        ObservationView v;
        v.timestamp = ob.timestamp;
        v.words = ob.words;
        v.positions = ob.positions;
        if (!in.engine->tryPush(v)) return Status::error("internal: the engine queue refused an observation");
        in.engine->processPending();
        collector.drain();
        progress.update(++done);
    }
    progress.finish();
    return {};
}

// Draws and writes summary.png into the staging directory (tracked by the caller).
Status writeRefineSummary(const OutputDir& out, const RefineOptions& o, const StreamStage& in, const Collector& c) {
    SummaryInput si;
    si.title = "rost refine: " + o.words;
    char sub[200];
    std::snprintf(sub, sizeof sub, "K = %d, V = %d, %s, %s, %s", in.ec.model.K, in.ec.model.V,
                  toString(in.ec.strategy.kind), budgetText(in.ec.budget, " per observation").c_str(),
                  text::counted(static_cast<long long>(c.rows().size()), "observation").c_str());
    si.subtitle = sub;
    si.K = in.ec.model.K;
    si.rows = c.rows();
    si.resumed = in.resuming;
    return writePng(out.staged("summary.png"), drawSummary(si).image);
}

// The result files and summary.png. With two threads or more the summary is
// drawn and compressed on a second thread while the CSV files are formatted
// and written (the end of a command is otherwise serial: docs/design.md, "The
// rest of a command"); with --threads 1, or no thread to be had, one after the
// other: one thread means one, as for the reading and the set-up.
Status writeRefineOutputs(OutputDir& out, const RefineOptions& o, const StreamStage& in, const Collector& c) {
    Status png;
    const auto summarise = [&]() noexcept {
        try {
            png = writeRefineSummary(out, o, in, c);
        } catch (const std::exception& e) {  // out of memory drawing it: an error, not a crash
            png = Status::error(out.staged("summary.png") + ": cannot draw the summary: " + e.what());
        }
    };
    std::jthread summary;  // joined on every way out, an exception writing the files included
    if (o.summary && toolThreads(o.model, false) >= 2) {
        try {
            summary = std::jthread(summarise);
        } catch (const std::system_error&) {  // no thread to be had: drawn after the files
        }
    }
    Status st = writeResultFiles(out, c, *in.engine, {});
    if (summary.joinable())
        summary.join();
    else if (o.summary)
        summarise();
    if (st.ok()) st = png;
    if (st.ok() && o.summary) out.track("summary.png");
    return st;
}

} // namespace

int refineCommand(const RefineOptions& o) {
    const auto started = std::chrono::steady_clock::now();
    // Ctrl-C or SIGTERM from here on: exit 130, the staging directory removed.
    // While the inputs are read a blocked read or open fails at once (a FIFO
    // whose writer never comes); after, the run's calls restart.
    InterruptScope interrupts(InterruptScope::Reads::Interrupted);
    // Outputs first: an unwritable one fails before the input is read (nothing written).
    OutputDir out;
    if (Status st = out.open(o.out); !st.ok()) return fail(st.message());
    // Every file the command may write (an earlier run's are noted), but only those this run writes probed.
    const std::vector<std::string_view> skip = o.summary ? std::vector<std::string_view>{} : std::vector<std::string_view>{"summary.png"};
    if (Status st = out.probe({"topics.csv", "perplexity.csv", "surprise.csv", "surprise_cells.csv", "topicmodel.csv",
                               "summary.png"},
                              skip);
        !st.ok())
        return fail(st.message());
    if (Status st = probeMissionOutputs(o.model, {}, {o.words, o.positions}, out.paths()); !st.ok())
        return fail(st.message());
    // word stream -> engine -> sinks
    StreamStage in;
    const Status opened = in.open(o);
    if (interrupted()) return abandonedRun();
    if (!opened.ok()) return fail(opened.message());
    interrupts.reads(InterruptScope::Reads::Restarted);
    Collector collector(*in.engine, 4);
    collector.setFirstObservation(in.resumed.observations);
    if (Status st = collector.streamTo(out, false); !st.ok()) return fail(st.message());
    std::unique_ptr<CheckpointWriter> checkpoints;
    if (Status st = attachCheckpoints(*in.engine, o.model, checkpoints); !st.ok()) return fail(st.message());
    if (Status st = play(in, collector, o.quiet); !st.ok()) return fail(st.message());
    if (checkpoints)  // the state after the last observation
        if (Status st = finishCheckpoints(*checkpoints); !st.ok()) return fail(st.message());
    if (!collector.rejection().empty()) return fail(o.words + ": " + collector.rejection());
    if (collector.lost() > 0)  // drained after each observation: a bug, never the input's fault
        return fail("internal error: " + std::to_string(collector.lost()) + " result records lost");

    if (interrupted()) return abandonedRun();
    collector.finish(o.model.settings.final_sweeps, &interruptFlag());
    if (interrupted()) return abandonedRun();
    Status st = collector.closeStreams();
    if (st.ok()) st = writeRefineOutputs(out, o, in, collector);
    if (st.ok() && interrupted()) return abandonedRun();
    if (st.ok()) st = out.commit();
    if (!st.ok()) return fail(st.message());
    if (!o.quiet) {
        uint64_t offered = 0;
        for (const auto& ob : in.todo()) offered += ob.words.size();
        std::fputs(WordDrops::of(offered, collector).note(in.ec.model).c_str(), stderr);
        std::fputs(out.earlierFilesNote().c_str(), stderr);
        const double s = std::chrono::duration<double>(std::chrono::steady_clock::now() - started).count();
        std::fprintf(stderr, "rost: %s in %.1f s; outputs in %s\n",
                     text::counted(static_cast<long long>(in.todo().size()), "observation").c_str(), s, text::printable(o.out).c_str());
    }
    return kExitOk;
}

} // namespace rost::tool
