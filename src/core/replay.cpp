#include "rost/replay.hpp"

#include <algorithm>
#include <chrono>
#include <string>

namespace rost {

Status replay(Engine& engine, const WordStream& stream, const ReplayOptions& options, ReplayResult& out) {
    if (engine.running()) return Status::error("replay: the engine is running; stop it first");
    const auto& obs = stream.observations;
    std::size_t maxWords = 0;
    for (std::size_t i = 0; i < obs.size(); ++i) {
        if (stream.has_positions && obs[i].positions.size() != obs[i].words.size())
            return Status::error("replay: observation " + std::to_string(i) + " (timestamp " +
                                 std::to_string(obs[i].timestamp) + ") has " + std::to_string(obs[i].words.size()) +
                                 " words but " + std::to_string(obs[i].positions.size()) + " positions");
        maxWords = std::max(maxWords, obs[i].words.size());
    }
    // Without positions every word sits at (0, 0): one cell, as in earlier tools.
    const std::vector<Position> origin(stream.has_positions ? 0 : maxWords);

    // Everything the hooks write is allocated here, before the engine runs.
    const Config& mc = engine.config().model;
    out.observations.assign(obs.size(), ReplayObservation{});
    for (std::size_t i = 0; i < obs.size(); ++i) {
        out.observations[i].timestamp = obs[i].timestamp;
        if (options.labels)
            out.observations[i].labels.reserve(std::min<std::size_t>(obs[i].words.size(),
                                                                      static_cast<std::size_t>(mc.max_words_per_frame)));
    }
    const uint64_t base = engine.counters().pushed;  // sequence number of obs[0]
    std::vector<std::size_t> openStep;               // stream indices of the newest step's observations
    openStep.reserve(static_cast<std::size_t>(mc.cell_time) + 1);
    int64_t finalStep = -1;
    double finalPpx = 0.0;

    auto indexOf = [&](uint64_t sequence) { return static_cast<std::size_t>(sequence - base); };
    auto settleStep = [&](int64_t step, double ppx) {
        for (std::size_t i : openStep)
            if (out.observations[i].step == step) out.observations[i].instantaneous_perplexity = ppx;
        openStep.clear();
    };

    const ObservationHook userObs = engine.observationHook();
    const EvictionHook userEvict = engine.evictionHook();
    engine.setObservationHook([&](const ObservationResult& r, const Model& m) {
        const std::size_t i = indexOf(r.sequence);
        if (i < out.observations.size()) {
            ReplayObservation& o = out.observations[i];
            o.step = r.step;
            o.add = r.add;
            o.surprise = r.surprise;
            if (r.previous_step >= 0)
                settleStep(r.previous_step, r.previous_perplexity);
            else if (!openStep.empty() && r.step >= 0 && out.observations[openStep.front()].step != r.step)
                openStep.clear();  // instantaneous perplexity switched off
            if (r.step >= 0) openStep.push_back(i);
        }
        if (userObs) userObs(r, m);
    });
    engine.setEvictionHook([&](const WindowObservation& w, const Model& m) {
        const std::size_t i = indexOf(w.sequence);
        if (i < out.observations.size()) {
            ReplayObservation& o = out.observations[i];
            if (w.step != finalStep) {
                finalStep = w.step;
                finalPpx = m.stepPerplexity(w.step);
            }
            o.final_perplexity = finalPpx;
            if (options.labels) {
                o.labels.resize(std::min<std::size_t>(m.observationSize(w.observation), o.labels.capacity()));
                m.observationLabels(w.observation, o.labels);
            }
        }
        if (userEvict) userEvict(w, m);
    });

    Status status;
    const auto t0 = std::chrono::steady_clock::now();
    auto view = [&](std::size_t i) {
        const auto& o = obs[i];
        return ObservationView{o.timestamp, o.words,
                               stream.has_positions ? std::span<const Position>(o.positions)
                                                    : std::span<const Position>(origin.data(), o.words.size())};
    };
    if (options.threaded) {
        status = engine.start();
        if (status.ok()) {
            for (std::size_t i = 0; i < obs.size(); ++i) {
                if (!engine.pushWait(view(i))) {
                    status = Status::error("replay: could not queue observation " + std::to_string(i));
                    break;
                }
            }
            engine.stop(Engine::StopMode::Drain);
        }
    } else {
        for (std::size_t i = 0; i < obs.size(); ++i) engine.processNow(view(i));
    }

    if (status.ok()) {
        // The newest step's instantaneous perplexity: after its budget, with
        // no later step to wait for.
        const Model& m = engine.model();
        if (engine.config().flags.instantaneous_perplexity && m.steps() > 0 && !openStep.empty())
            settleStep(m.steps() - 1, m.stepPerplexity(m.steps() - 1));
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
