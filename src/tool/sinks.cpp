#include "sinks.hpp"

#include <malloc.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>

#include <opencv2/imgproc.hpp>

#include "png_file.hpp"
#include "rost/text_io.hpp"

namespace rost::tool {

void tintCells(cv::Mat& img, const ObservationRecord& r, int cellSpace, int gridW) {
    constexpr int kAlpha = 97;  // of 256
    for (std::size_t c = 0; c < r.dominant.size(); ++c) {
        if (r.dominant[c] == ObservationRecord::kNoTopic) continue;
        const int cx = static_cast<int>(c) % gridW, cy = static_cast<int>(c) / gridW;
        cv::Rect cell(cx * cellSpace, cy * cellSpace, cellSpace, cellSpace);
        cell &= cv::Rect(0, 0, img.cols, img.rows);
        const cv::Scalar col = topicColour(r.dominant[c]);
        const int cb = static_cast<int>(col[0]) * kAlpha, cg = static_cast<int>(col[1]) * kAlpha,
                  cr = static_cast<int>(col[2]) * kAlpha;
        for (int y = cell.y; y < cell.y + cell.height; ++y) {
            auto* p = img.ptr<cv::Vec3b>(y);
            for (int x = cell.x; x < cell.x + cell.width; ++x) {
                p[x][0] = static_cast<uint8_t>((p[x][0] * (256 - kAlpha) + cb) >> 8);
                p[x][1] = static_cast<uint8_t>((p[x][1] * (256 - kAlpha) + cg) >> 8);
                p[x][2] = static_cast<uint8_t>((p[x][2] * (256 - kAlpha) + cr) >> 8);
            }
        }
    }
}

namespace {

void tint(cv::Mat& img, const ObservationRecord& r, int cellSpace, int gridW) {
    tintCells(img, r, cellSpace, gridW);
    char buf[96];
    std::snprintf(buf, sizeof buf, "frame %lld  surprise %.0f", static_cast<long long>(r.timestamp), r.surprise);
    int base = 0;
    const cv::Size ts = cv::getTextSize(buf, cv::FONT_HERSHEY_SIMPLEX, 0.5, 1, &base);
    cv::rectangle(img, {4, 4}, {12 + ts.width, 12 + ts.height + base}, cv::Scalar(0, 0, 0), -1);
    cv::putText(img, buf, {8, 8 + ts.height}, cv::FONT_HERSHEY_SIMPLEX, 0.5, cv::Scalar(255, 255, 255), 1,
                cv::LINE_AA);
}

// A short name for an input in titles: the file or directory name, with
// its directory for a glob ("mire-2/image.*.pgm").
std::string shortName(const std::string& input) {
    if (vision::isCameraInput(input)) return input;
    std::filesystem::path p(input);
    while (!p.empty() && p.filename().empty()) p = p.parent_path();  // "dir/" -> "dir"
    if (vision::isGlobInput(input) && p.has_parent_path())
        return (p.parent_path().filename() / p.filename()).string();
    return p.filename().string();
}


} // namespace

// ---- overlay -------------------------------------------------------------------

Status OverlaySink::open(OutputDir& out, const vision::SourceInfo& info, const std::string& format) {
    const double fps = info.fps > 0 ? info.fps : 10.0;
    const cv::Size size(info.width, info.height);
    std::string name;
    if (format == "mp4") {
        name = "overlay.mp4";
        video_.open(out.staged(name), cv::VideoWriter::fourcc('m', 'p', '4', 'v'), fps, size);
    }
    if (!video_.isOpened()) {
        name = "overlay.avi";
        video_.open(out.staged(name), cv::VideoWriter::fourcc('M', 'J', 'P', 'G'), fps, size);
    }
    if (!video_.isOpened()) return Status::error(out.staged(name) + ": cannot open a video writer (mp4v or MJPG)");
    out.track(name);
    return {};
}

void OverlaySink::write(const FrameSlot& s, const ObservationRecord& r, int cellSpace, int gridW) {
    s.image.copyTo(canvas_);
    tint(canvas_, r, cellSpace, gridW);
    video_.write(canvas_);
    // The encoder's transient buffers, interleaved with the extractor's,
    // fragment the heap (measured: RSS +0.1 MB per frame without this);
    // give the free pages back now and then (writer side, not realtime).
    if (++frames_ % 32 == 0) ::malloc_trim(0);
}

// ---- thumbnails ----------------------------------------------------------------

void ThumbnailSink::open(const vision::SourceInfo& info, int64_t frames) {
    on_ = true;
    w_ = 160;
    h_ = std::max(1, info.height * 160 / std::max(1, info.width));
    // Two at least: halving a full pool of one would free no slot. `frames` may
    // be a container's estimate below what the input holds (a count of 1 for
    // 79 frames): the pool then fills and halves as it would for any input.
    cap_ = static_cast<std::size_t>(frames > 0 ? std::clamp<int64_t>(frames, 2, 512) : 512);
    pool_.create(static_cast<int>(cap_) * h_, w_, CV_8UC3);
    thumbs_.reserve(cap_);
    frames_.reserve(cap_);
}

cv::Mat ThumbnailSink::slot(std::size_t i) const {
    return pool_.rowRange(static_cast<int>(i) * h_, static_cast<int>(i + 1) * h_);
}

void ThumbnailSink::halve() {  // full: keep every other one
    std::size_t j = 0;
    for (std::size_t i = 0; i < thumbs_.size(); i += 2, ++j) {
        if (i != j) slot(i).copyTo(slot(j));
        frames_[j] = frames_[i];
    }
    thumbs_.resize(j);
    frames_.resize(j);
    every_ *= 2;
}

void ThumbnailSink::take(const FrameSlot& s) {
    if (!on_ || s.frame % every_ != 0) return;
    if (thumbs_.size() == cap_) {
        halve();
        if (s.frame % every_ != 0) return;
    }
    cv::Mat to = slot(thumbs_.size());
    cv::resize(s.image, to, to.size(), 0, 0, cv::INTER_AREA);
    thumbs_.push_back(to);
    frames_.push_back(s.frame);
}

void ThumbnailSink::pick(std::span<const FrameRow> rows, std::size_t n, std::vector<cv::Mat>& outThumbs,
                         std::vector<int64_t>& outFrames) const {
    outThumbs.clear();
    outFrames.clear();
    if (thumbs_.empty()) return;
    n = std::min(n, thumbs_.size());
    std::vector<std::size_t> pick;
    for (std::size_t i = 0; i < n; ++i)
        pick.push_back(n == 1 ? 0 : static_cast<std::size_t>(std::lround(static_cast<double>(i) * (thumbs_.size() - 1) / (n - 1))));
    for (std::size_t p : surprisePeaks(rows, std::min<std::size_t>(3, n / 3), std::max<std::size_t>(5, rows.size() / 20))) {
        const int64_t f = rows[p].timestamp;
        const auto at = static_cast<std::size_t>(std::lower_bound(frames_.begin(), frames_.end(), f) - frames_.begin());
        if (at >= frames_.size() || frames_[at] != f) continue;
        std::size_t best = 0;
        int64_t bestD = INT64_MAX;
        for (std::size_t j = 0; j < pick.size(); ++j) {
            const int64_t d = std::llabs(frames_[pick[j]] - f);
            if (d < bestD) best = j, bestD = d;
        }
        pick[best] = at;
    }
    std::sort(pick.begin(), pick.end());
    pick.erase(std::unique(pick.begin(), pick.end()), pick.end());
    for (std::size_t p : pick) {
        outThumbs.push_back(thumbs_[p]);
        outFrames.push_back(frames_[p]);
    }
}

// ---- frames --------------------------------------------------------------------

void FrameSink::take(const FrameSlot& s, const ObservationRecord* r) {
    CaptureRow row;
    row.frame = s.frame;
    row.timestamp_us = s.timestamp_us;
    row.words = s.words;
    row.orb = s.orb;
    row.intensity = s.intensity;
    row.hue = s.hue;
    row.ingested = r && !r->rejected;
    row.kept = r ? r->kept : 0;
    capture_.push_back(row);
    if (!r || r->rejected) return;
    if (overlay_.enabled()) overlay_.write(s, *r, ec_.model.cell_space, ec_.model.gridWidth());
    if (thumbs_) thumbs_->take(s);
}

void FrameSink::onObservation(const ObservationRecord& r) {
    // Frames before this one whose observation never arrived were dropped at the queue.
    while (FrameSlot* s = ring_.front()) {
        if (s->frame > r.timestamp) break;
        const bool mine = s->frame == r.timestamp;
        take(*s, mine ? &r : nullptr);
        ring_.pop();
        if (mine) return;
    }
    ++missing_;
}

void FrameSink::drainFrames() {
    while (FrameSlot* s = ring_.front()) {
        take(*s, nullptr);
        ring_.pop();
    }
}

uint64_t FrameSink::totalWords() const noexcept {
    uint64_t n = 0;
    for (const auto& r : capture_) n += r.words;
    return n;
}

uint64_t FrameSink::ingestedWords() const noexcept {
    uint64_t n = 0;
    for (const auto& r : capture_)
        if (r.ingested) n += r.words;
    return n;
}

double FrameSink::wordsPerFrame() const noexcept {
    return capture_.empty() ? 0.0 : static_cast<double>(totalWords()) / static_cast<double>(capture_.size());
}

std::string FrameSink::framesCsv() const {
    std::string s;
    text::TableWriter t(s);
    t.header({"frame", "timestamp_us", "words", "orb", "intensity", "hue", "ingested", "kept"});
    for (const auto& r : capture_)
        t.cell(r.frame).cell(r.timestamp_us).cell(r.words).cell(r.orb).cell(r.intensity).cell(r.hue)
            .cell(r.ingested ? 1 : 0).cell(r.kept).end();
    return s;
}

// ---- run.txt -------------------------------------------------------------------

std::string RunReport::settingsText() const {
    const EngineConfig& ec = e.ec;
    std::string s;
    char buf[512];
    const auto& L = w.words.extractor->layout();
    std::snprintf(buf, sizeof buf,
                  "words: V = %d (orb %u at %u, intensity %u at %u, hue %u at %u), orb.features %d, thumb.cell %d\n",
                  e.V, L.orb_size, L.orb_offset, L.intensity_size, L.intensity_offset, L.hue_size, L.hue_offset,
                  w.words.extractors.orb_features, w.words.extractors.thumb_cell);
    s += buf;
    std::snprintf(buf, sizeof buf,
                  "model: K = %d, alpha = %g, beta = %g, cell.space = %d, cell.time = %d, g.space = %d, g.time = %d, "
                  "ring.steps = %d, cell.capacity = %d, max.words = %d, eviction = %s, seed = %llu\n",
                  ec.model.K, ec.model.alpha, ec.model.beta, ec.model.cell_space, ec.model.cell_time, ec.model.g_space,
                  ec.model.g_time, ec.model.ring_steps, ec.model.cell_capacity, ec.model.max_words_per_frame,
                  toString(ec.model.eviction), static_cast<unsigned long long>(ec.model.seed));
    s += buf;
    std::snprintf(buf, sizeof buf,
                  "refinement: sampler %s, eta = %g, q = %g, budget %s, final sweeps %d, refine.window %d, "
                  "threads %d, %s\n",
                  toString(ec.strategy.kind), ec.strategy.eta, ec.strategy.q,
                  budgetText(ec.budget, " per observation").c_str(),
                  o.model.settings.final_sweeps, ec.model.refine_window, ec.model.threads,
                  realtime                             ? "realtime (capture and refiner threads)"
                  : ec.budget.kind == BudgetKind::Time ? "offline (time budget: not reproducible)"
                                                       : "offline (count budget, reproducible)");
    s += buf;
    return s;
}

std::string RunReport::text() const {
    std::string s = "command: " + o.command_line + "\n";
    s += "input: " + w.info.description + "\n";
    if (e.resuming)
        s += "resumed: " + o.model.resume + " at observation " + std::to_string(e.resumed.observations) + " (frame " +
             std::to_string(e.resumed.last_timestamp) + ")" + (e.refinementChanged ? ", refinement settings changed" : "") +
             "\n";
    if (w.words.vocabulary) {
        const std::string note = w.words.vocabulary->note();
        s += "vocabulary: " + (o.vocabulary.empty() ? std::string("built-in default") : o.vocabulary) + ", " +
             std::to_string(w.words.vocabulary->size()) + " words: " + note.substr(0, note.find('\n')) + "\n";
    }
    s += settingsText();
    const EngineCounters counters = e.engine->counters();
    const std::size_t captured = frames.rows().size();
    char buf[512];
    std::snprintf(buf, sizeof buf,
                  "frames: %zu captured, %zu ingested, %llu dropped at the queue, %llu skipped by the writer, "
                  "%llu without overlay; %.1f words per frame extracted\n",
                  captured, ingested, static_cast<unsigned long long>(counters.dropped()),
                  static_cast<unsigned long long>(writerSkipped), static_cast<unsigned long long>(frames.missing()),
                  frames.wordsPerFrame());
    s += buf;
    s += drops.line(e.ec.model);
    s += topicsLine(e.engine->model());
    std::snprintf(buf, sizeof buf, "time: %.2f s, %.1f frames/s; %llu refinements, %llu token updates; memory %zu bytes\n",
                  seconds, static_cast<double>(captured) / std::max(1e-9, seconds),
                  static_cast<unsigned long long>(counters.refinements), static_cast<unsigned long long>(counters.tokens),
                  e.engine->memoryBytes());
    s += buf;
    // The refiner's share of the run: each observation from its take-up to its
    // publication (RunReport::busy); the rest it waited for frames (realtime:
    // the camera's rate; offline: the extraction).
    const long pct = std::lround(100.0 * std::clamp(busy / std::max(1e-9, seconds), 0.0, 1.0));
    std::snprintf(buf, sizeof buf, "refiner: busy %.2f s of %.2f s (%ld %%), idle %ld %%\n", busy, seconds, pct,
                  100 - pct);
    s += buf;
    return s;
}

// ---- summary -------------------------------------------------------------------

Status writeRunSummary(OutputDir& out, const RunOptions& o, const WordsStage& w, const RunEngine& e,
                       const FrameSink& frames, const ThumbnailSink& thumbs, const std::vector<FrameRow>& rows) {
    std::vector<cv::Mat> strip;
    std::vector<int64_t> stripFrames;
    thumbs.pick(rows, 10, strip, stripFrames);
    SummaryInput si;
    si.title = "rost run: ";
    for (std::size_t i = 0; i < o.inputs.size(); ++i) si.title += (i ? " + " : "") + shortName(o.inputs[i]);
    char sub[256];
    std::snprintf(sub, sizeof sub, "%dx%d, K = %d, V = %d, sampler %s, %s, %s, %.0f words/frame", w.info.width,
                  w.info.height, e.ec.model.K, e.V, toString(e.ec.strategy.kind),
                  budgetText(e.ec.budget, " per frame").c_str(),
                  text::counted(static_cast<long long>(rows.size()), "frame").c_str(), frames.wordsPerFrame());
    si.subtitle = sub;
    si.K = e.ec.model.K;
    si.rows = rows;
    si.thumbs = strip;
    si.thumb_frames = stripFrames;
    si.resumed = e.resuming;
    if (Status st = writePng(out.staged("summary.png"), drawSummary(si).image); !st.ok()) return st;
    out.track("summary.png");
    return {};
}

} // namespace rost::tool
