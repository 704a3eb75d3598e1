#include "collector.hpp"

#include <algorithm>
#include <cerrno>
#include <cmath>
#include <cstring>

#include "rost/text_io.hpp"
#include "rost/word_stream.hpp"

namespace rost::tool {

Collector::Collector(Engine& engine, std::size_t slots)
    : engine_(engine), K_(engine.model().K()), cells_(engine.model().cellsPerStep()) {
    publishing_ = engine_.publishResults(slots);
    published_ = engine_.makeResult();
    final_ = engine_.makeFinal();
    record_.dominant.resize(static_cast<std::size_t>(cells_));
    record_.cell_surprise.resize(static_cast<std::size_t>(cells_));
    record_.topic_share.resize(static_cast<std::size_t>(K_));
}

// Writer side: the published histograms -> dominant topic per cell and topic shares.
void Collector::fromPublished() {
    const ObservationResult& r = published_.result;
    ObservationRecord& o = record_;
    o.frame = r.timestamp;
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

void Collector::fillFinal(const WindowObservation& w, const Model& m, double perplexity,
                          const uint16_t* labels) noexcept {
    FinalLabels& f = final_;
    f.where = w;
    f.perplexity = perplexity;
    f.n = std::min<uint32_t>(m.observationSize(w.observation), static_cast<uint32_t>(f.labels.size()));
    if (words_.file) m.observationWords(w.observation, {f.words.data(), f.n});
    if (positions_.file) m.observationPositions(w.observation, {f.positions.data(), f.n});
    std::copy_n(labels, f.n, f.labels.data());
}

Collector::~Collector() { (void)closeStreams(); }

Status Collector::streamTo(OutputDir& out, bool words) {
    if (!publishing_.ok()) return publishing_;
    auto open = [&](Stream& s, const char* name) -> Status {
        s.path = out.staged(name);
        s.file = std::fopen(s.path.c_str(), "wb");
        if (!s.file) return Status::error(s.path + ": cannot write: " + std::strerror(errno));
        out.track(name);
        return {};
    };
    Status st;
    if (words) {
        if (st = open(words_, "words.csv"); !st.ok()) return st;
        if (st = open(positions_, "positions.csv"); !st.ok()) return st;
    }
    return open(topics_, "topics.csv");
}

Status Collector::closeStreams() {
    std::string failed;
    for (Stream* s : {&words_, &positions_, &topics_}) {
        if (!s->file) continue;
        if (std::fclose(s->file) != 0 && failed.empty()) failed = s->path;
        s->file = nullptr;
    }
    if (writeFailed_ && failed.empty()) failed = topics_.path;
    if (!failed.empty()) return Status::error(failed + ": write failed: " + std::strerror(errno));
    return {};
}

void Collector::takeFinal(const FinalLabels& f) {
    const uint64_t ob = f.where.observation;
    if (ob >= first_ && ob - first_ < rows_.size()) rows_[ob - first_].final = f.perplexity;
    auto put = [&](Stream& s) {
        if (s.file && std::fwrite(line_.data(), 1, line_.size(), s.file) != line_.size()) writeFailed_ = true;
        line_.clear();
    };
    line_.clear();
    const int64_t frame = f.where.timestamp;
    // Only the files being written are formatted (`rost refine` writes topics.csv alone).
    if (words_.file) {
        appendCsvLine(line_, frame, f.words.data(), f.n);
        put(words_);
    }
    if (positions_.file) {
        appendPositionsLine(line_, frame, f.positions.data(), f.n);
        put(positions_);
    }
    appendCsvLine(line_, frame, f.labels.data(), f.n);
    put(topics_);
    ++finals_;
}

void Collector::takeObservation(const ObservationRecord& o) {
    if (o.rejected) {
        if (rejection_.empty())
            rejection_ = "frame " + std::to_string(o.frame) + ": the model rejected the observation (" +
                         toString(o.error) + " at word " + std::to_string(o.error_index) + ")";
        return;
    }
    kept_ += o.kept;
    dropped_cell_ += o.dropped_cell;
    FrameRow row;
    row.frame = o.frame;
    row.ingested = true;
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
    // Instantaneous perplexity of the step before, for each of its observations.
    if (o.previous_step >= 0)
        for (auto it = rows_.rbegin(); it != rows_.rend(); ++it) {
            if (it->step < o.previous_step) break;
            if (it->step == o.previous_step) {
                it->instantaneous = o.previous_perplexity;
                it->plugin = o.previous_plugin;
            }
        }
}

void Collector::drain(const std::function<void(const ObservationRecord&)>& onObservation) {
    // Observations first: a final record always refers to an earlier observation.
    while (engine_.readResult(published_)) {
        fromPublished();
        if (onObservation) onObservation(record_);
        takeObservation(record_);
    }
    while (engine_.readFinal(final_)) takeFinal(final_);
}

void Collector::finish(int sweeps) {
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
    if (sweeps > 0) engine_.finalPass(sweeps);
    // The window's observations in batches of consecutive ones: a batch's
    // perplexities and labels in one go (on the workers, a task an
    // observation), then its lines, in order.
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

std::string Collector::perplexityCsv() const {
    std::string s;
    text::TableWriter t(s);
    t.header({"frame", "instantaneous", "final", "plugin", "topics"});
    for (const auto& r : rows_) t.cell(r.frame).cell(r.instantaneous).cell(r.final).cell(r.plugin).cell(r.topics).end();
    return s;
}

std::string Collector::surpriseCsv() const {
    std::string s;
    text::TableWriter t(s);
    t.header({"frame", "surprise"});
    for (const auto& r : rows_) t.cell(r.frame).cell(r.surprise).end();
    return s;
}

std::string Collector::cellSurpriseCsv() const {
    std::string s;
    text::TableWriter t(s);
    t.cell("frame");
    for (int c = 0; c < cells_; ++c) t.cell("cell" + std::to_string(c));
    t.end();
    for (const auto& r : rows_) {
        t.cell(r.frame);
        for (float v : r.cell_surprise) t.cell(v);
        t.end();
    }
    return s;
}

} // namespace rost::tool
