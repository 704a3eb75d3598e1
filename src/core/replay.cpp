#include "rost/replay.hpp"

#include <algorithm>
#include <chrono>
#include <string>
#include <vector>

namespace rost {

namespace {

// Positions must match words; the longest observation's size.
Status checkStream(const WordStream& stream, std::size_t& maxWords) {
    const auto& obs = stream.observations;
    maxWords = 0;
    for (std::size_t i = 0; i < obs.size(); ++i) {
        if (stream.has_positions && obs[i].positions.size() != obs[i].words.size())
            return Status::error("replay: observation " + std::to_string(i) + " (timestamp " +
                                 std::to_string(obs[i].timestamp) + ") has " + std::to_string(obs[i].words.size()) +
                                 " words but " + std::to_string(obs[i].positions.size()) + " positions");
        maxWords = std::max(maxWords, obs[i].words.size());
    }
    return {};
}

// What the engine's hooks see, recorded per stream observation. Everything
// it writes is allocated in its constructor, before the engine runs.
class Recorder {
public:
    Recorder(const Engine& engine, const WordStream& stream, const ReplayOptions& options, ReplayResult& out)
        : out_(out), options_(options), base_(engine.counters().pushed) {  // base: sequence number of obs[0]
        const auto& obs = stream.observations;
        const Config& mc = engine.config().model;
        out.observations.assign(obs.size(), ReplayObservation{});
        for (std::size_t i = 0; i < obs.size(); ++i) {
            out.observations[i].timestamp = obs[i].timestamp;
            if (options.labels)
                out.observations[i].labels.reserve(
                    std::min<std::size_t>(obs[i].words.size(), static_cast<std::size_t>(mc.max_words_per_frame)));
        }
        openStep_.reserve(static_cast<std::size_t>(mc.cell_time) + 1);
    }

    void observed(const ObservationResult& r) {
        const std::size_t i = indexOf(r.sequence);
        if (i >= out_.observations.size()) return;
        ReplayObservation& o = out_.observations[i];
        o.step = r.step;
        o.add = r.add;
        o.surprise = r.surprise;
        if (r.previous_step >= 0)
            settleStep(r.previous_step, r.previous_perplexity);
        else if (!openStep_.empty() && r.step >= 0 && out_.observations[openStep_.front()].step != r.step)
            openStep_.clear();  // instantaneous perplexity switched off
        if (r.step >= 0) openStep_.push_back(i);
    }

    void evicted(const WindowObservation& w, const Model& m) {
        const std::size_t i = indexOf(w.sequence);
        if (i >= out_.observations.size()) return;
        ReplayObservation& o = out_.observations[i];
        if (w.step != finalStep_) {
            finalStep_ = w.step;
            finalPpx_ = m.stepPerplexity(w.step);
        }
        o.final_perplexity = finalPpx_;
        if (options_.labels) {
            o.labels.resize(std::min<std::size_t>(m.observationSize(w.observation), o.labels.capacity()));
            m.observationLabels(w.observation, o.labels);
        }
    }

    // The newest step's instantaneous perplexity: after its budget, with no
    // later step to wait for.
    void settleNewest(const Engine& engine) {
        const Model& m = engine.model();
        if (engine.config().flags.instantaneous_perplexity && m.steps() > 0 && !openStep_.empty())
            settleStep(m.steps() - 1, m.stepPerplexity(m.steps() - 1));
    }

private:
    std::size_t indexOf(uint64_t sequence) const { return static_cast<std::size_t>(sequence - base_); }
    void settleStep(int64_t step, double ppx) {
        for (std::size_t i : openStep_)
            if (out_.observations[i].step == step) out_.observations[i].instantaneous_perplexity = ppx;
        openStep_.clear();
    }

    ReplayResult& out_;
    const ReplayOptions& options_;
    const uint64_t base_;
    std::vector<std::size_t> openStep_;  // stream indices of the newest step's observations
    int64_t finalStep_ = -1;
    double finalPpx_ = 0.0;
};

// Every observation through the engine: processNow, or the threads.
Status feed(Engine& engine, const WordStream& stream, const std::vector<Position>& origin, bool threaded) {
    const auto& obs = stream.observations;
    auto view = [&](std::size_t i) {
        const auto& o = obs[i];
        return ObservationView{o.timestamp, o.words,
                               stream.has_positions ? std::span<const Position>(o.positions)
                                                    : std::span<const Position>(origin.data(), o.words.size())};
    };
    if (!threaded) {
        for (std::size_t i = 0; i < obs.size(); ++i) engine.processNow(view(i));
        return {};
    }
    Status status = engine.start();
    if (!status.ok()) return status;
    for (std::size_t i = 0; i < obs.size(); ++i) {
        if (!engine.pushWait(view(i))) {
            status = Status::error("replay: could not queue observation " + std::to_string(i));
            break;
        }
    }
    engine.stop(Engine::StopMode::Drain);
    return status;
}

} // namespace

Status replay(Engine& engine, const WordStream& stream, const ReplayOptions& options, ReplayResult& out) {
    if (engine.running()) return Status::error("replay: the engine is running; stop it first");
    std::size_t maxWords = 0;
    if (Status st = checkStream(stream, maxWords); !st.ok()) return st;
    // Without positions every word sits at (0, 0): one cell, as in earlier tools.
    const std::vector<Position> origin(stream.has_positions ? 0 : maxWords);

    Recorder rec(engine, stream, options, out);
    const ObservationHook userObs = engine.observationHook();
    const EvictionHook userEvict = engine.evictionHook();
    engine.setObservationHook([&](const ObservationResult& r, const Model& m) {
        rec.observed(r);
        if (userObs) userObs(r, m);
    });
    engine.setEvictionHook([&](const WindowObservation& w, const Model& m) {
        rec.evicted(w, m);
        if (userEvict) userEvict(w, m);
    });

    const auto t0 = std::chrono::steady_clock::now();
    const Status status = feed(engine, stream, origin, options.threaded);
    if (status.ok()) {
        rec.settleNewest(engine);
        if (options.final_sweeps > 0) engine.finalPass(options.final_sweeps);
        engine.flushWindowToEvictionHook();
    }
    out.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    out.counters = engine.counters();
    engine.setObservationHook(userObs);
    engine.setEvictionHook(userEvict);
    return status;
}

} // namespace rost
