// `rost run INPUT... --out DIR`: frames -> words -> engine -> outputs.
//
// Without --realtime everything runs on the calling thread: read a frame,
// extract its words, hand them to the engine with tryPush (the same producer
// call the camera path uses), let the engine take them up with its count
// budget (processPending), collect. Same seed and input => same outputs, bit
// for bit.
//
// With --realtime (always for camera:N) three threads run as onboard:
//   capture thread: reads frames (a file is paced at its frame rate),
//                   extracts words, tryPush (never waits; a full queue drops);
//   refiner thread: the engine's;
//   this thread:    drains the collector's records, writes the overlay,
//                   draws the progress bar.

#include <malloc.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <functional>
#include <cmath>
#include <csignal>
#include <filesystem>
#include <cstdio>
#include <thread>

#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#include <opencv2/videoio.hpp>

#include "collector.hpp"
#include "outputs.hpp"
#include "progress.hpp"
#include "spsc_ring.hpp"
#include "rost/checkpoint.hpp"
#include "rost/topic_model_csv.hpp"
#include "tool.hpp"

namespace rost::tool {

namespace {

std::atomic<bool> g_interrupted{false};
extern "C" void onInterrupt(int) { g_interrupted.store(true, std::memory_order_relaxed); }

// A captured frame on its way to the writer (overlay, thumbnails, frames.csv).
struct FrameSlot {
    int64_t frame = 0;
    int64_t timestamp_us = 0;
    uint32_t words = 0, orb = 0, intensity = 0, hue = 0;
    bool pushed = false;  // the engine queued it (false: refused by a full queue)
    cv::Mat image;
};

// Per-frame line of frames.csv.
struct CaptureRow {
    int64_t frame = 0, timestamp_us = 0;
    uint32_t words = 0, orb = 0, intensity = 0, hue = 0, kept = 0;
    bool ingested = false;
};

void tint(cv::Mat& img, const ObservationRecord& r, int cellSpace, int gridW) {
    // Blend in place (38% topic colour), without temporaries.
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
    char buf[96];
    std::snprintf(buf, sizeof buf, "frame %lld  surprise %.0f", static_cast<long long>(r.frame), r.surprise);
    int base = 0;
    const cv::Size ts = cv::getTextSize(buf, cv::FONT_HERSHEY_SIMPLEX, 0.5, 1, &base);
    cv::rectangle(img, {4, 4}, {12 + ts.width, 12 + ts.height + base}, cv::Scalar(0, 0, 0), -1);
    cv::putText(img, buf, {8, 8 + ts.height}, cv::FONT_HERSHEY_SIMPLEX, 0.5, cv::Scalar(255, 255, 255), 1,
                cv::LINE_AA);
}

std::string fmt(const char* f, double v) {
    char buf[64];
    std::snprintf(buf, sizeof buf, f, v);
    return buf;
}

// Picks up to n thumbnails: evenly spaced, with the surprise peaks swapped in
// for their nearest neighbours so a scene change shows in the strip.
void pickThumbs(const std::vector<cv::Mat>& thumbs, const std::vector<int64_t>& frames, std::span<const FrameRow> rows,
                std::size_t n, std::vector<cv::Mat>& outThumbs, std::vector<int64_t>& outFrames) {
    outThumbs.clear();
    outFrames.clear();
    if (thumbs.empty()) return;
    n = std::min(n, thumbs.size());
    std::vector<std::size_t> pick;
    for (std::size_t i = 0; i < n; ++i)
        pick.push_back(n == 1 ? 0 : static_cast<std::size_t>(std::lround(static_cast<double>(i) * (thumbs.size() - 1) / (n - 1))));
    for (std::size_t p : surprisePeaks(rows, std::min<std::size_t>(3, n / 3), std::max<std::size_t>(5, rows.size() / 20))) {
        const int64_t f = rows[p].frame;
        const auto at = static_cast<std::size_t>(
            std::lower_bound(frames.begin(), frames.end(), f) - frames.begin());
        if (at >= frames.size() || frames[at] != f) continue;
        std::size_t best = 0;
        int64_t bestD = INT64_MAX;
        for (std::size_t j = 0; j < pick.size(); ++j) {
            const int64_t d = std::llabs(frames[pick[j]] - f);
            if (d < bestD) best = j, bestD = d;
        }
        pick[best] = at;
    }
    std::sort(pick.begin(), pick.end());
    pick.erase(std::unique(pick.begin(), pick.end()), pick.end());
    for (std::size_t p : pick) {
        outThumbs.push_back(thumbs[p]);
        outFrames.push_back(frames[p]);
    }
}

// A short name for an input in titles: the file or directory name, with
// its directory for a glob ("mire-2/image.*.pgm").
std::string shortName(const std::string& input) {
    if (vision::isCameraInput(input)) return input;
    std::filesystem::path p(input);
    while (!p.empty() && p.filename().empty()) p = p.parent_path();  // "dir/" -> "dir"
    if (input.find_first_of("*?[") != std::string::npos && p.has_parent_path())
        return (p.parent_path().filename() / p.filename()).string();
    return p.filename().string();
}

} // namespace

int runCommand(const RunOptions& o) {
    using Clock = std::chrono::steady_clock;
    const auto started = Clock::now();

    // ---- set-up: everything that can fail on bad input fails here, before any output.
    vision::SourceOptions so;
    so.width = o.width;
    so.height = o.height;
    so.camera_width = o.camera_width;
    so.camera_height = o.camera_height;
    so.camera_format = o.camera_format;
    bool live = false;
    for (const auto& in : o.inputs) live = live || vision::isCameraInput(in);
    Status st;
    std::unique_ptr<vision::FrameSource> source = vision::openFrameSources(o.inputs, so, st);
    if (!source) return fail(st.message());
    const vision::SourceInfo info = source->info();

    const vision::ExtractorConfig extractors = vision::ExtractorConfig::from(o.model.settings.words);
    std::shared_ptr<const vision::Vocabulary> vocabulary;
    if (extractors.orb) {
        if (o.vocabulary.empty()) {
            vocabulary = vision::defaultVocabulary(st);
        } else {
            auto v = std::make_shared<vision::Vocabulary>();
            st = vision::Vocabulary::load(o.vocabulary, *v);
            vocabulary = std::move(v);
        }
        if (!st.ok()) return fail(st.message());
    }
    std::unique_ptr<vision::WordExtractor> extractor = vision::WordExtractor::create(extractors, vocabulary, st);
    if (!extractor) return fail(st.message());
    const auto wordsV = static_cast<int>(extractor->vocabularySize());
    const bool realtime = o.realtime || live;
    // --resume: the checkpoint's model, for frames of its size.
    const bool resuming = !o.model.resume.empty();
    EngineConfig ec;
    CheckpointInfo resumed;
    bool refinementChanged = false;
    if (resuming) {
        st = resumeConfig(o.model, info.width, info.height, realtime, ec, resumed, refinementChanged);
        if (!st.ok()) return fail(st.message());
    }
    const bool vGiven = o.model.isGiven("V");
    const int V = resuming ? ec.model.V : vGiven ? o.model.settings.engine.model.V : wordsV;
    // The word ids must mean what they meant: the extractors must produce the
    // checkpoint's V (unless -V, then equal to it, made room for more). The
    // checkpoint does not record which vocabulary made them: a different one
    // of the same size is not detected (docs/tool.md).
    if (resuming && (V < wordsV || (V != wordsV && !vGiven)))
        return fail("--resume " + o.model.resume + ": its model has V = " + std::to_string(V) + " words but the extractors produce " +
                    std::to_string(wordsV) + " (use the vocabulary and word options of the run that made it)");
    if (V < wordsV)
        return fail("-V " + std::to_string(V) + " is smaller than the " + std::to_string(wordsV) +
                    " words the extractors produce (ORB " + std::to_string(extractor->layout().orb_size) +
                    " + intensity " + std::to_string(extractor->layout().intensity_size) + " + hue " +
                    std::to_string(extractor->layout().hue_size) + ")");

    // Frames the checkpoint already has: a file's are skipped (its frame
    // index is at most the checkpoint's last time stamp); a camera's are
    // numbered after them.
    const int64_t skipThrough = resuming && resumed.observations > 0 ? resumed.last_timestamp : -1;
    // --max-frames counts the whole mission: with --resume, the checkpoint's frames too.
    const int64_t before = skipThrough + 1;
    int64_t frames = info.frames;
    if (o.max_frames > 0) frames = frames > 0 ? std::min(frames, o.max_frames) : o.max_frames;
    if (frames > 0) {
        frames -= before;
        if (frames <= 0)
            return fail(info.description + ": nothing to resume with: " + o.model.resume + " has every frame up to " +
                        std::to_string(skipThrough) +
                        (o.max_frames > 0 ? " (--max-frames " + std::to_string(o.max_frames) + " counts the mission)" : ""));
    }
    if (!resuming) {
        st = makeEngineConfig(o.model, info.width, info.height, V, frames, realtime, ec);
        if (!st.ok()) return fail(st.message());
    }
    std::unique_ptr<Engine> engine = Engine::create(ec, st);
    if (!engine) return fail(st.message());
    if (resuming) {
        st = loadResumed(o.model, refinementChanged, *engine);
        if (!st.ok()) return fail(st.message());
    }
    if (!o.model.in_topicmodel.empty()) {
        st = loadTopicModelCsv(o.model.in_topicmodel, engine->model());
        if (!st.ok()) return fail("--in.topicmodel: " + st.message());
    }

    OutputDir out;
    st = out.open(o.out);
    if (!st.ok()) return fail(st.message());

    // Overlay video, written as frames come.
    cv::VideoWriter overlay;
    std::string overlayName;
    if (o.overlay) {
        const double fps = info.fps > 0 ? info.fps : 10.0;
        const cv::Size size(info.width, info.height);
        if (o.overlay_format == "mp4") {
            overlayName = "overlay.mp4";
            overlay.open(out.staged(overlayName), cv::VideoWriter::fourcc('m', 'p', '4', 'v'), fps, size);
        }
        if (!overlay.isOpened()) {
            overlayName = "overlay.avi";
            overlay.open(out.staged(overlayName), cv::VideoWriter::fourcc('M', 'J', 'P', 'G'), fps, size);
        }
        if (!overlay.isOpened()) return fail(out.staged(overlayName) + ": cannot open a video writer (mp4v or MJPG)");
        out.track(overlayName);
    }

    if (!o.quiet) {
        const double mib = static_cast<double>(engine->memoryBytes()) / (1024.0 * 1024.0);
        std::fprintf(stderr, "rost: %s\nrost: V = %d, K = %d, %d cells of %d px, ring of %d steps, %s budget %s, model memory %.1f MiB%s\n",
                     info.description.c_str(), V, ec.model.K, ec.model.cellsPerStep(), ec.model.cell_space,
                     ec.model.ring_steps, toString(ec.strategy.kind),
                     ec.budget.kind == BudgetKind::Time ? fmt("%.3g ms", ec.budget.ms).c_str()
                                                        : (std::to_string(ec.budget.count) + " refines").c_str(),
                     mib, realtime ? ", realtime" : "");
        if (resuming)
            std::fprintf(stderr, "rost: resuming %s at observation %llu (frame %lld)%s%s\n", o.model.resume.c_str(),
                         static_cast<unsigned long long>(resumed.observations), static_cast<long long>(resumed.last_timestamp),
                         live ? "; camera frames are numbered after it" : "; earlier frames are skipped",
                         refinementChanged ? "; refinement settings changed (not bit for bit)" : "");
    }

    // Hand-off rings, sized once.
    Collector collector(*engine, realtime ? 256 : 4);
    collector.setFirstObservation(resumed.observations);
    st = collector.streamTo(out, true);
    if (!st.ok()) return fail(st.message());
    std::unique_ptr<CheckpointWriter> checkpoints;
    st = attachCheckpoints(*engine, o.model, checkpoints);
    if (!st.ok()) return fail(st.message());
    const std::size_t frameSlots = realtime ? static_cast<std::size_t>(ec.queue_slots) + 24 : 4;
    SpscRing<FrameSlot> frameRing(frameSlots, [&](FrameSlot& s) { s.image.create(info.height, info.width, CV_8UC3); });

    std::vector<CaptureRow> capture;
    // Thumbnails for summary.png, in one pool allocated now: per-frame
    // allocations interleaved with the video encoder's buffers fragment the
    // heap (measured: +0.36 MB of RSS per 640x480 frame). When the pool is
    // full every other thumbnail is dropped and only every 2nd frame kept.
    const int thumbW = 160, thumbH = std::max(1, info.height * 160 / std::max(1, info.width));
    const std::size_t thumbCap = static_cast<std::size_t>(frames > 0 ? std::min<int64_t>(frames, 512) : 512);
    std::vector<cv::Mat> thumbs;       // views into the pool
    std::vector<int64_t> thumbFrames;
    cv::Mat thumbPool;
    if (o.summary) {
        thumbPool.create(static_cast<int>(thumbCap) * thumbH, thumbW, CV_8UC3);
        thumbs.reserve(thumbCap);
        thumbFrames.reserve(thumbCap);
    }
    auto thumbSlot = [&](std::size_t i) { return thumbPool.rowRange(static_cast<int>(i) * thumbH, static_cast<int>(i + 1) * thumbH); };
    int thumbEvery = 1;
    cv::Mat canvas;
    uint64_t overlayMissing = 0;
    uint64_t overlayFrames = 0;

    // Writer side: pairs each observation record with its captured frame.
    auto takeFrame = [&](const FrameSlot& s, const ObservationRecord* r) {
        CaptureRow row;
        row.frame = s.frame;
        row.timestamp_us = s.timestamp_us;
        row.words = s.words;
        row.orb = s.orb;
        row.intensity = s.intensity;
        row.hue = s.hue;
        row.ingested = r && !r->rejected;
        row.kept = r ? r->kept : 0;
        capture.push_back(row);
        if (!r || r->rejected) return;
        if (overlay.isOpened()) {
            s.image.copyTo(canvas);
            tint(canvas, *r, ec.model.cell_space, ec.model.gridWidth());
            overlay.write(canvas);
            // The encoder's transient buffers, interleaved with the extractor's,
            // fragment the heap (measured: RSS +0.1 MB per frame without this);
            // give the free pages back now and then (writer side, not realtime).
            if (++overlayFrames % 32 == 0) ::malloc_trim(0);
        }
        if (o.summary && s.frame % thumbEvery == 0) {
            if (thumbs.size() == thumbCap) {  // full: keep every other one
                std::size_t j = 0;
                for (std::size_t i = 0; i < thumbs.size(); i += 2, ++j) {
                    if (i != j) thumbSlot(i).copyTo(thumbSlot(j));
                    thumbFrames[j] = thumbFrames[i];
                }
                thumbs.resize(j);
                thumbFrames.resize(j);
                thumbEvery *= 2;
                if (s.frame % thumbEvery != 0) return;
            }
            cv::Mat slot = thumbSlot(thumbs.size());
            cv::resize(s.image, slot, slot.size(), 0, 0, cv::INTER_AREA);
            thumbs.push_back(slot);
            thumbFrames.push_back(s.frame);
        }
    };
    auto onObservation = [&](const ObservationRecord& r) {
        // Frames before this one whose observation never arrived were dropped at the queue.
        while (FrameSlot* s = frameRing.front()) {
            if (s->frame > r.frame) break;
            const bool mine = s->frame == r.frame;
            takeFrame(*s, mine ? &r : nullptr);
            frameRing.pop();
            if (mine) return;
        }
        ++overlayMissing;
    };
    auto drainFrames = [&] {
        while (FrameSlot* s = frameRing.front()) {
            takeFrame(*s, nullptr);
            frameRing.pop();
        }
    };

    // Producer: one frame -> words -> engine. Returns false at the end of the input.
    vision::Frame frame;
    vision::FrameWords words;
    std::string readError;
    std::atomic<int64_t> captured{0};
    std::atomic<uint64_t> captureDropped{0};
    std::atomic<bool> producerDone{false};
    const double fps = info.fps > 0 ? info.fps : 10.0;
    auto produceOne = [&](bool pace, Clock::time_point t0) -> bool {
        if (o.max_frames > 0 && before + captured.load(std::memory_order_relaxed) >= o.max_frames) return false;
        for (;;) {
            const vision::ReadStatus rs = source->read(frame);
            if (rs == vision::ReadStatus::End) return false;
            if (rs == vision::ReadStatus::Error) {
                readError = source->error();
                return false;
            }
            if (info.live) frame.index += before;  // after the checkpoint's frames
            else if (frame.index <= skipThrough) continue;  // in the checkpoint already
            break;
        }
        if (pace && !info.live) {
            // File input at its own frame rate: frame i is due at t0 + i / fps
            // (i counted from the first frame this run plays).
            const auto due = t0 + std::chrono::duration_cast<Clock::duration>(std::chrono::duration<double>(
                                      static_cast<double>(frame.index - before) / fps));
            std::this_thread::sleep_until(due);
        }
        extractor->extract(frame.image, words);
        captured.fetch_add(1, std::memory_order_relaxed);
        FrameSlot* s = frameRing.beginPush();
        if (!s) {  // the writer is behind: skip this frame entirely (counted)
            captureDropped.fetch_add(1, std::memory_order_relaxed);
            return true;
        }
        s->frame = frame.index;
        s->timestamp_us = frame.timestamp_us;
        s->words = words.size();
        s->orb = words.orb;
        s->intensity = words.intensity;
        s->hue = words.hue;
        frame.image.copyTo(s->image);
        ObservationView view;
        view.timestamp = frame.index;
        view.words = words.words;
        view.positions = words.positions;
        s->pushed = engine->tryPush(view);
        frameRing.commitPush();
        return true;
    };

    std::signal(SIGINT, onInterrupt);
    std::signal(SIGTERM, onInterrupt);
    Progress progress(live ? "rost (Ctrl-C stops)" : "rost", frames, o.quiet);

    if (!realtime) {
        while (!g_interrupted.load(std::memory_order_relaxed) && produceOne(false, started)) {
            engine->processPending();
            collector.drain(onObservation);
            progress.update(captured.load(std::memory_order_relaxed));
        }
    } else {
        st = engine->start();
        if (!st.ok()) return fail(st.message());
        std::thread producer([&] {
            const auto t0 = Clock::now();
            while (!g_interrupted.load(std::memory_order_relaxed) && produceOne(true, t0)) {
            }
            producerDone.store(true, std::memory_order_release);
        });
        while (!producerDone.load(std::memory_order_acquire)) {
            if (g_interrupted.load(std::memory_order_relaxed)) source->interrupt();
            collector.drain(onObservation);
            const EngineCounters c = engine->counters();
            progress.update(captured.load(std::memory_order_relaxed),
                            c.dropped() ? std::to_string(c.dropped()) + " dropped" : std::string());
            std::this_thread::sleep_for(std::chrono::milliseconds(5));
        }
        producer.join();
        engine->stop(Engine::StopMode::Drain);
    }
    collector.drain(onObservation);
    progress.finish();
    std::signal(SIGINT, SIG_DFL);
    std::signal(SIGTERM, SIG_DFL);
    if (checkpoints && !collector.rows().empty()) {  // the state after the last observation (if any came)
        st = finishCheckpoints(*checkpoints);
        if (!st.ok()) return fail(st.message());
    }

    if (!readError.empty()) return fail(readError);
    if (g_interrupted.load() && !live)
        return std::fprintf(stderr, "rost: interrupted; no outputs written\n"), kExitInterrupted;
    if (!collector.rejection().empty()) return fail(collector.rejection());
    if (collector.lost() > 0)
        return fail("the output writer fell behind: " + std::to_string(collector.lost()) +
                    " records lost; outputs discarded (try a larger --queue or a slower input)");
    if (collector.rows().empty())
        return fail(info.description + ": no frames were processed" +
                    (skipThrough >= 0 ? " (" + o.model.resume + " has every frame up to " + std::to_string(skipThrough) + ")"
                                      : std::string()));

    collector.finish(o.model.settings.final_sweeps);
    st = collector.closeStreams();
    if (!st.ok()) return fail(st.message());
    drainFrames();
    overlay.release();
    const double seconds = std::chrono::duration<double>(Clock::now() - started).count();

    // ---- outputs
    std::string framesCsv = "frame,timestamp_us,words,orb,intensity,hue,ingested,kept\n";
    uint64_t totalWords = 0;
    for (const auto& r : capture) {
        framesCsv += std::to_string(r.frame) + ',' + std::to_string(r.timestamp_us) + ',' + std::to_string(r.words) +
                     ',' + std::to_string(r.orb) + ',' + std::to_string(r.intensity) + ',' + std::to_string(r.hue) +
                     ',' + (r.ingested ? "1" : "0") + ',' + std::to_string(r.kept) + '\n';
        totalWords += r.words;
    }
    struct File {
        const char* name;
        std::function<std::string()> body;  // made when written, one at a time
    };
    const EngineCounters counters = engine->counters();
    const std::vector<FrameRow>& rows = collector.rows();
    std::string runTxt;
    {
        char buf[512];
        runTxt += "command: " + o.command_line + "\n";
        runTxt += "input: " + info.description + "\n";
        if (resuming)
            runTxt += "resumed: " + o.model.resume + " at observation " + std::to_string(resumed.observations) + " (frame " +
                      std::to_string(resumed.last_timestamp) + ")" +
                      (refinementChanged ? ", refinement settings changed" : "") + "\n";
        if (vocabulary) {
            const std::string note = vocabulary->note();
            runTxt += "vocabulary: " + (o.vocabulary.empty() ? std::string("built-in default") : o.vocabulary) + ", " +
                      std::to_string(vocabulary->size()) + " words: " + note.substr(0, note.find('\n')) + "\n";
        }
        const auto& L = extractor->layout();
        std::snprintf(buf, sizeof buf,
                      "words: V = %d (orb %u at %u, intensity %u at %u, hue %u at %u), orb.features %d, thumb.cell %d\n",
                      V, L.orb_size, L.orb_offset, L.intensity_size, L.intensity_offset, L.hue_size, L.hue_offset,
                      extractors.orb_features, extractors.thumb_cell);
        runTxt += buf;
        std::snprintf(buf, sizeof buf,
                      "model: K = %d, alpha = %g, beta = %g, cell.space = %d, cell.time = %d, g.space = %d, g.time = %d, "
                      "ring.steps = %d, cell.capacity = %d, max.words = %d, eviction = %s, seed = %llu\n",
                      ec.model.K, ec.model.alpha, ec.model.beta, ec.model.cell_space, ec.model.cell_time,
                      ec.model.g_space, ec.model.g_time, ec.model.ring_steps, ec.model.cell_capacity,
                      ec.model.max_words_per_frame, toString(ec.model.eviction),
                      static_cast<unsigned long long>(ec.model.seed));
        runTxt += buf;
        std::snprintf(buf, sizeof buf, "refinement: sampler %s, eta = %g, q = %g, budget %s, final sweeps %d, %s\n",
                      toString(ec.strategy.kind), ec.strategy.eta, ec.strategy.q,
                      ec.budget.kind == BudgetKind::Time ? fmt("%g ms per observation", ec.budget.ms).c_str()
                                                         : (std::to_string(ec.budget.count) + " refines per observation").c_str(),
                      o.model.settings.final_sweeps,
                      realtime                               ? "realtime (capture and refiner threads)"
                      : ec.budget.kind == BudgetKind::Time ? "offline (time budget: not reproducible)"
                                                             : "offline (count budget, reproducible)");
        runTxt += buf;
        std::snprintf(buf, sizeof buf,
                      "frames: %zu captured, %zu ingested, %llu dropped at the queue, %llu skipped by the writer, "
                      "%llu without overlay; %.1f words per frame extracted\n",
                      capture.size(), rows.size(), static_cast<unsigned long long>(counters.dropped()),
                      static_cast<unsigned long long>(captureDropped.load()),
                      static_cast<unsigned long long>(overlayMissing),
                      capture.empty() ? 0.0 : static_cast<double>(totalWords) / static_cast<double>(capture.size()));
        runTxt += buf;
        std::snprintf(buf, sizeof buf, "time: %.2f s, %.1f frames/s; %llu refinements, %llu token updates; memory %zu bytes\n",
                      seconds, static_cast<double>(capture.size()) / std::max(1e-9, seconds),
                      static_cast<unsigned long long>(counters.refinements),
                      static_cast<unsigned long long>(counters.tokens), engine->memoryBytes());
        runTxt += buf;
    }
    const File files[] = {
        {"perplexity.csv", [&] { return collector.perplexityCsv(); }},
        {"surprise.csv", [&] { return collector.surpriseCsv(); }},
        {"surprise_cells.csv", [&] { return collector.cellSurpriseCsv(); }},
        {"frames.csv", [&] { return framesCsv; }},
        {"topicmodel.csv", [&] { return formatTopicModelCsv(engine->model()); }},
        {"run.txt", [&] { return runTxt; }},
    };
    for (const auto& f : files) {
        st = out.write(f.name, f.body());
        if (!st.ok()) return fail(st.message());
    }
    if (o.summary) {
        std::vector<cv::Mat> strip;
        std::vector<int64_t> stripFrames;
        pickThumbs(thumbs, thumbFrames, rows, 10, strip, stripFrames);
        SummaryInput si;
        si.title = "rost run: ";
        for (std::size_t i = 0; i < o.inputs.size(); ++i) si.title += (i ? " + " : "") + shortName(o.inputs[i]);
        char sub[256];
        std::snprintf(sub, sizeof sub, "%dx%d, K = %d, V = %d, sampler %s, %s, %zu frames, %.0f words/frame", info.width,
                      info.height, ec.model.K, V,
                      toString(ec.strategy.kind),
                      ec.budget.kind == BudgetKind::Time ? fmt("%g ms per frame", ec.budget.ms).c_str()
                                                         : (std::to_string(ec.budget.count) + " refines per frame").c_str(),
                      rows.size(), capture.empty() ? 0.0 : static_cast<double>(totalWords) / static_cast<double>(capture.size()));
        si.subtitle = sub;
        si.K = ec.model.K;
        si.rows = rows;
        si.thumbs = strip;
        si.thumb_frames = stripFrames;
        si.resumed = resuming;
        const cv::Mat img = drawSummary(si);
        if (!cv::imwrite(out.staged("summary.png"), img)) return fail(out.staged("summary.png") + ": cannot write");
        out.track("summary.png");
    }
    st = out.commit();
    if (!st.ok()) return fail(st.message());
    if (!o.quiet)
        std::fprintf(stderr, "rost: %zu frames in %.1f s (%.1f frames/s); outputs in %s\n", capture.size(), seconds,
                     static_cast<double>(capture.size()) / std::max(1e-9, seconds), o.out.c_str());
    return kExitOk;
}

} // namespace rost::tool
