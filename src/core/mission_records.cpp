#include "rost/mission_records.hpp"

#include <algorithm>

#include "rost/text_io.hpp"

namespace rost {

MissionRecords::MissionRecords(Engine& engine, std::size_t slots)
    : engine_(engine), K_(engine.model().K()), cells_(engine.model().cellsPerStep()) {
    publishing_ = engine_.publishResults(slots);
    published_ = engine_.makeResult();
    final_ = engine_.makeFinal();
    record_.dominant.resize(static_cast<std::size_t>(cells_));
    record_.cell_surprise.resize(static_cast<std::size_t>(cells_));
    record_.topic_share.resize(static_cast<std::size_t>(K_));
}

// The published histograms -> dominant topic per cell and topic shares.
void MissionRecords::fromPublished() {
    const ObservationResult& r = published_.result;
    ObservationRecord& o = record_;
    o.timestamp = r.timestamp;
    o.observation = r.observation;
    o.step = r.step;
    o.rejected = !r.add.ok();
    o.error = r.add.error;
    o.error_index = r.add.index;
    o.kept = r.add.kept;
    o.dropped_cell = r.add.dropped_cell;
    o.surprise = r.surprise;
    o.previous_step = r.previous_step;
    o.previous_perplexity = r.previous_perplexity;
    o.previous_plugin = r.previous_plugin;
    o.active_topics = r.active_topics;
    o.refinements = r.refinements;
    o.elapsed_ns = r.elapsed_ns;
    if (o.rejected) return;
    double total = 0.0;
    std::fill(o.topic_share.begin(), o.topic_share.end(), 0.f);
    const auto K = static_cast<std::size_t>(K_);
    for (std::size_t c = 0; c < static_cast<std::size_t>(cells_); ++c) {
        o.cell_surprise[c] = published_.cell_surprise[c];
        const int32_t* h = published_.histograms.data() + c * K;
        int best = -1;
        int32_t bestN = 0;
        for (std::size_t k = 0; k < K; ++k) {
            const int32_t n = h[k];
            o.topic_share[k] += static_cast<float>(n);
            total += n;
            if (n > bestN) best = static_cast<int>(k), bestN = n;
        }
        o.dominant[c] = best < 0 ? ObservationRecord::kNoTopic : static_cast<uint16_t>(best);
    }
    if (total > 0)
        for (auto& s : o.topic_share) s = static_cast<float>(s / total);
}

void MissionRecords::takeObservation(const ObservationRecord& o) {
    if (o.rejected) {
        if (!rejection_.any) rejection_ = {true, o.timestamp, o.error, o.error_index};
        return;
    }
    kept_ += o.kept;
    dropped_cell_ += o.dropped_cell;
    MissionRow row;
    row.timestamp = o.timestamp;
    row.observation = o.observation;
    row.step = o.step;
    row.kept = o.kept;
    row.surprise = o.surprise;
    row.topics = o.active_topics;
    row.refinements = o.refinements;
    row.refine_ms = static_cast<double>(o.elapsed_ns) * 1e-6;
    row.cell_surprise = o.cell_surprise;
    row.topic_share = o.topic_share;
    if (first_ + rows_.size() == o.observation) rows_.push_back(std::move(row));
    // The instantaneous perplexity of the step before, for each of its observations.
    if (o.previous_step >= 0)
        for (auto it = rows_.rbegin(); it != rows_.rend(); ++it) {
            if (it->step < o.previous_step) break;
            if (it->step == o.previous_step) {
                it->instantaneous = o.previous_perplexity;
                it->plugin = o.previous_plugin;
            }
        }
}

void MissionRecords::takeFinal(const FinalLabels& f) {
    const uint64_t ob = f.where.observation;
    if (ob >= first_ && ob - first_ < rows_.size()) rows_[ob - first_].final = f.perplexity;
    if (on_final_) on_final_(f);
    ++finals_;
}

void MissionRecords::fillFinal(const WindowObservation& w, const Model& m, double perplexity,
                               const uint16_t* labels) noexcept {
    FinalLabels& f = final_;
    f.where = w;
    f.perplexity = perplexity;
    f.n = std::min<uint32_t>(m.observationSize(w.observation), static_cast<uint32_t>(f.labels.size()));
    if (final_words_) {
        m.observationWords(w.observation, {f.words.data(), f.n});
        m.observationPositions(w.observation, {f.positions.data(), f.n});
    }
    std::copy_n(labels, f.n, f.labels.data());
}

void MissionRecords::drain() {
    // Observations first: a final record always refers to an earlier observation.
    while (engine_.readResult(published_)) {
        fromPublished();
        if (on_observation_) on_observation_(record_);
        takeObservation(record_);
    }
    while (engine_.readFinal(final_)) takeFinal(final_);
}

void MissionRecords::finish(int sweeps, const std::atomic<bool>* stop) {
    drain();
    Model& m = engine_.model();
    if (m.steps() > 0) {
        // The last step has no successor: its instantaneous perplexity is
        // taken now, at the end of its budget, before any final sweeps.
        const int64_t last = m.steps() - 1;
        const double p = m.stepPerplexity(last), plugin = m.stepPluginPerplexity(last);
        for (auto it = rows_.rbegin(); it != rows_.rend() && it->step == last; ++it) {
            it->instantaneous = p;
            it->plugin = plugin;
        }
    }
    if (sweeps > 0) engine_.finalPass(sweeps, stop);
    if (stop && stop->load(std::memory_order_relaxed)) return;  // interrupted: no final records
    // The window's observations in batches of consecutive ones: a batch's
    // perplexities and labels in one go (on the workers, a task an
    // observation), then its records, in order.
    std::vector<WindowObservation> window;
    engine_.visitWindow([&](const WindowObservation& w, const Model&) { window.push_back(w); });
    constexpr std::size_t kBatch = 128;
    const std::size_t stride = final_.labels.size();
    std::vector<double> perplexity(std::min(kBatch, window.size()));
    std::vector<uint16_t> labels(perplexity.size() * stride);
    for (std::size_t b = 0; b < window.size();) {
        std::size_t n = 1;
        while (n < kBatch && b + n < window.size() && window[b + n].observation == window[b].observation + n) ++n;
        m.finalMeasurements(window[b].observation, {perplexity.data(), n}, labels, stride);
        for (std::size_t i = 0; i < n; ++i) {
            fillFinal(window[b + i], m, perplexity[i], labels.data() + i * stride);
            takeFinal(final_);
        }
        b += n;
    }
}

std::string MissionRecords::perplexityCsv(const char* first) const {
    std::string s;
    text::TableWriter t(s);
    t.header({first, "instantaneous", "final", "plugin", "topics"});
    for (const auto& r : rows_) t.cell(r.timestamp).cell(r.instantaneous).cell(r.final).cell(r.plugin).cell(r.topics).end();
    return s;
}

std::string MissionRecords::surpriseCsv(const char* first) const {
    std::string s;
    text::TableWriter t(s);
    t.header({first, "surprise"});
    for (const auto& r : rows_) t.cell(r.timestamp).cell(r.surprise).end();
    return s;
}

std::string MissionRecords::cellSurpriseCsv(const char* first) const {
    std::string s;
    text::TableWriter t(s);
    t.cell(first);
    for (int c = 0; c < cells_; ++c) t.cell("cell" + std::to_string(c));
    t.end();
    for (const auto& r : rows_) {
        t.cell(r.timestamp);
        for (float v : r.cell_surprise) t.cell(v);
        t.end();
    }
    return s;
}

} // namespace rost
