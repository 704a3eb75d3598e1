// `rost refine WORDS.csv [--positions POSITIONS.csv] --out DIR`: a word
// stream made elsewhere (earlier ROST tools, another extractor) through the
// same engine and outputs as `rost run`, with a count budget, reproducibly.

#include <algorithm>
#include <chrono>
#include <functional>
#include <cstdio>
#include <span>

#include <opencv2/imgcodecs.hpp>

#include "collector.hpp"
#include "outputs.hpp"
#include "progress.hpp"
#include "rost/word_stream.hpp"
#include "rost/checkpoint.hpp"
#include "rost/topic_model_csv.hpp"
#include "tool.hpp"

namespace rost::tool {

int refineCommand(const RefineOptions& o) {
    const auto started = std::chrono::steady_clock::now();
    // --resume: the checkpoint fixes V and the frame size before the words are read.
    const bool resuming = !o.model.resume.empty();
    EngineConfig ec;
    CheckpointInfo resumed;
    bool refinementChanged = false;
    Status st;
    if (resuming) {
        st = resumeConfig(o.model, o.width, o.height, false, ec, resumed, refinementChanged);
        if (!st.ok()) return fail(st.message());
    }
    WordStreamLimits limits;
    const Config& given = o.model.settings.engine.model;
    limits.vocabulary = resuming ? static_cast<uint32_t>(ec.model.V) : o.model.isGiven("V") ? static_cast<uint32_t>(given.V) : 0;
    limits.width = resuming ? ec.model.frame_width : o.width;
    limits.height = resuming ? ec.model.frame_height : o.height;
    limits.max_words = static_cast<uint32_t>(std::max(1, resuming ? ec.model.max_words_per_frame : given.max_words_per_frame));
    WordStream ws;
    st = readWordStream(o.words, o.positions, limits, ws);
    if (!st.ok()) return fail(st.message());
    if (ws.observations.empty()) return fail(o.words + ": no observations (the file has no data lines)");
    if (!ws.has_positions)  // no positions: every word at (0, 0)
        for (auto& ob : ws.observations) ob.positions.assign(ob.words.size(), Position{});

    std::size_t skipped = 0;
    if (resuming) {
        if (!ws.has_positions && (ec.model.frame_width != 1 || ec.model.frame_height != 1))
            return fail(o.words + ": no --positions, but " + o.model.resume + " models " +
                        std::to_string(ec.model.frame_width) + "x" + std::to_string(ec.model.frame_height) +
                        " frames: give the words' positions");
        // What the checkpoint already has. Either this is the stream it was
        // made from (its first `observations` observations are the
        // checkpoint's: skip them), or what came after it (every time stamp
        // later than the checkpoint's last).
        const auto n = static_cast<std::size_t>(resumed.observations);
        const auto& obs = ws.observations;
        const std::string last = std::to_string(resumed.last_timestamp);
        if (n == 0) {
            skipped = 0;
        } else if (n <= obs.size() && obs[n - 1].timestamp == resumed.last_timestamp) {
            skipped = n;
        } else if (obs.front().timestamp > resumed.last_timestamp) {
            skipped = 0;
        } else if (n > obs.size()) {
            return fail(o.words + ": " + std::to_string(obs.size()) + " observations, fewer than the " + std::to_string(n) +
                        " " + o.model.resume + " holds, and not the ones after them (they would start after time stamp " +
                        last + ")");
        } else {
            return fail(o.words + ": neither the stream " + o.model.resume + " was made from (its observation " +
                        std::to_string(n) + " has time stamp " + last + ", here " +
                        std::to_string(obs[n - 1].timestamp) + ") nor what came after it (the first time stamp here, " +
                        std::to_string(obs.front().timestamp) + ", is not after " + last + ")");
        }
    } else {
        // V and the frame geometry from the data unless given.
        uint32_t maxWord = 0;
        int32_t maxX = 0, maxY = 0;
        for (const auto& ob : ws.observations) {
            for (uint32_t w : ob.words) maxWord = std::max(maxWord, w);
            for (const Position& p : ob.positions) maxX = std::max(maxX, p.x), maxY = std::max(maxY, p.y);
        }
        const int V = o.model.isGiven("V") ? given.V : static_cast<int>(maxWord) + 1;
        int width = o.width > 0 ? o.width : maxX + 1;
        int height = o.height > 0 ? o.height : maxY + 1;
        if (!ws.has_positions) width = height = 1;  // one cell per time step (a temporal topic model)
        st = makeEngineConfig(o.model, width, height, V, static_cast<int64_t>(ws.observations.size()), false, ec);
        if (!st.ok()) return fail(st.message());
    }
    if (resuming && skipped == ws.observations.size())
        return fail(o.words + ": nothing to resume with: its " + std::to_string(skipped) + " observations are all in " +
                    o.model.resume);
    const int V = ec.model.V;
    std::unique_ptr<Engine> engine = Engine::create(ec, st);
    if (!engine) return fail(st.message());
    if (resuming) {
        st = loadResumed(o.model, refinementChanged, *engine);
        if (!st.ok()) return fail(st.message());
        if (!o.quiet)
            std::fprintf(stderr, "rost: resuming %s at observation %llu (time stamp %lld); %zu observations skipped%s\n",
                         o.model.resume.c_str(), static_cast<unsigned long long>(resumed.observations),
                         static_cast<long long>(resumed.last_timestamp), skipped,
                         refinementChanged ? "; refinement settings changed (not bit for bit)" : "");
    }
    if (!o.model.in_topicmodel.empty()) {
        st = loadTopicModelCsv(o.model.in_topicmodel, engine->model());
        if (!st.ok()) return fail("--in.topicmodel: " + st.message());
    }
    OutputDir out;
    st = out.open(o.out);
    if (!st.ok()) return fail(st.message());

    Collector collector(*engine, 4);
    collector.setFirstObservation(resumed.observations);
    st = collector.streamTo(out, false);
    if (!st.ok()) return fail(st.message());
    std::unique_ptr<CheckpointWriter> checkpoints;
    st = attachCheckpoints(*engine, o.model, checkpoints);
    if (!st.ok()) return fail(st.message());
    const std::span<const StreamObservation> todo(ws.observations.data() + skipped, ws.observations.size() - skipped);
    Progress progress("rost refine", static_cast<int64_t>(todo.size()), o.quiet);
    int64_t done = 0;
    for (const auto& ob : todo) {
        ObservationView v;
        v.timestamp = ob.timestamp;
        v.words = ob.words;
        v.positions = ob.positions;
        if (!engine->tryPush(v)) return fail("internal: the engine queue refused an observation");
        engine->processPending();
        collector.drain();
        progress.update(++done);
    }
    progress.finish();
    if (checkpoints) {  // the state after the last observation
        st = finishCheckpoints(*checkpoints);
        if (!st.ok()) return fail(st.message());
    }
    if (!collector.rejection().empty()) return fail(o.words + ": " + collector.rejection());
    collector.finish(o.model.settings.final_sweeps);
    st = collector.closeStreams();
    if (!st.ok()) return fail(st.message());

    struct File {
        const char* name;
        std::function<std::string()> body;  // made when written, one at a time
    };
    const File files[] = {
        {"perplexity.csv", [&] { return collector.perplexityCsv(); }},
        {"surprise.csv", [&] { return collector.surpriseCsv(); }},
        {"surprise_cells.csv", [&] { return collector.cellSurpriseCsv(); }},
        {"topicmodel.csv", [&] { return formatTopicModelCsv(engine->model()); }},
    };
    for (const auto& f : files) {
        st = out.write(f.name, f.body());
        if (!st.ok()) return fail(st.message());
    }
    if (o.summary) {
        SummaryInput si;
        si.title = "rost refine: " + o.words;
        char sub[200];
        std::snprintf(sub, sizeof sub, "K = %d, V = %d, %s, %llu refines per observation, %zu observations", ec.model.K, V,
                      toString(ec.strategy.kind), static_cast<unsigned long long>(ec.budget.count),
                      collector.rows().size());
        si.subtitle = sub;
        si.K = ec.model.K;
        si.rows = collector.rows();
        si.resumed = resuming;
        if (!cv::imwrite(out.staged("summary.png"), drawSummary(si)))
            return fail(out.staged("summary.png") + ": cannot write");
        out.track("summary.png");
    }
    st = out.commit();
    if (!st.ok()) return fail(st.message());
    if (!o.quiet) {
        const double s = std::chrono::duration<double>(std::chrono::steady_clock::now() - started).count();
        std::fprintf(stderr, "rost: %zu observations in %.1f s; outputs in %s\n", todo.size(), s,
                     o.out.c_str());
    }
    return kExitOk;
}

} // namespace rost::tool
