// `rost run INPUT... --out DIR`: frames -> words -> engine -> outputs.
//
// Without --realtime everything runs on the calling thread: read a frame,
// extract its words, hand them to the engine with tryPush (the same producer
// call the camera path uses), let the engine take them up with its count
// budget (processPending), collect. Same seed and input => same outputs, bit
// for bit.
//
// With --realtime (always for camera:N) three threads run as onboard:
//   capture thread: reads frames (a file is paced at its frames' times),
//                   extracts words, tryPush (never waits; a full queue drops);
//   refiner thread: the engine's;
//   this thread:    drains the collector's records, writes the overlay,
//                   draws the progress bar.

#include <atomic>
#include <chrono>
#include <optional>
#include <cstdio>
#include <thread>

#include "bag_sink.hpp"
#include "collector.hpp"
#include "outputs.hpp"
#include "progress.hpp"
#include "sinks.hpp"
#include "stages.hpp"
#include "rost/text_io.hpp"
#include "tool.hpp"

namespace rost::tool {

namespace {

// The sinks of a run, set up before any frame is read.
struct RunSinks {
    Collector collector;
    FrameRing frameRing;
    OverlaySink overlay;
    ThumbnailSink thumbs;
    FrameSink frames;
    BagSink bag;
    std::unique_ptr<CheckpointWriter> checkpoints;

    RunSinks(const RunOptions& o, const WordsStage& w, RunEngine& e, bool realtime)
        : collector(*e.engine, realtime ? 256 : 4),
          frameRing(realtime ? static_cast<std::size_t>(e.ec.queue_slots) + 24 : 4,
                    [&](FrameSlot& s) { s.image.create(w.info.height, w.info.width, CV_8UC3); }),
          frames(frameRing, overlay, o.summary ? &thumbs : nullptr, e.ec) {
        if (o.summary) thumbs.open(w.info, e.frames);
        collector.setObservationSink([this](const ObservationRecord& r) {
            frames.onObservation(r);
            bag.onObservation(r);
        });
    }
    Status open(const RunOptions& o, const WordsStage& w, RunEngine& e, OutputDir& out) {
        if (o.overlay)
            if (Status st = overlay.open(out, w.info, o.overlay_format); !st.ok()) return st;
        collector.setFirstObservation(e.resumed.observations);
        if (Status st = collector.streamTo(out, true); !st.ok()) return st;
        if (Status st = bag.open(o.out_bag, w.bag, e.ec.model); !st.ok()) return st;
        return attachCheckpoints(*e.engine, o.model, checkpoints);
    }
    void drain() { collector.drain(); }
};

// Offline: everything on this thread, the count budget taken per frame.
void playOffline(Capture& capture, Engine& engine, RunSinks& sinks, Progress& progress) {
    const auto t0 = std::chrono::steady_clock::now();
    while (!interrupted() && capture.produceOne(false, t0)) {
        engine.processPending();
        sinks.drain();
        progress.update(capture.captured());
    }
}

// Realtime: the capture thread and the engine's refiner; this thread drains the sinks.
Status playRealtime(Capture& capture, WordsStage& w, Engine& engine, RunSinks& sinks, Progress& progress) {
    if (Status st = engine.start(); !st.ok()) return st;
    std::atomic<bool> producerDone{false};
    std::thread producer([&] {
        const auto t0 = std::chrono::steady_clock::now();
        while (!interrupted() && capture.produceOne(true, t0)) {
        }
        producerDone.store(true, std::memory_order_release);
    });
    while (!producerDone.load(std::memory_order_acquire)) {
        if (interrupted()) w.source->interrupt();
        sinks.drain();
        const EngineCounters c = engine.counters();
        progress.update(capture.captured(), c.dropped() ? std::to_string(c.dropped()) + " dropped" : std::string());
        std::this_thread::sleep_for(std::chrono::milliseconds(5));
    }
    producer.join();
    engine.stop(Engine::StopMode::Drain);
    return {};
}

// Why a finished run has no outputs ("" when it has).
std::string runFailure(const RunOptions& o, const WordsStage& w, const RunEngine& e, const Capture& capture,
                       const Collector& c) {
    if (!capture.readError().empty()) return capture.readError();
    if (!c.rejection().empty()) return c.rejection();
    if (c.lost() > 0)
        return "the output writer fell behind: " + std::to_string(c.lost()) +
               " records lost; outputs discarded (try a larger --queue or a slower input)";
    if (c.rows().empty())
        return w.info.description + ": no frames were processed" +
               (e.skipThrough >= 0 ? " (" + o.model.resume + " has every frame up to " + std::to_string(e.skipThrough) + ")"
                                   : std::string());
    return {};
}

} // namespace

int runCommand(const RunOptions& o) {
    using Clock = std::chrono::steady_clock;
    const auto started = Clock::now();

    // A file run's Ctrl-C (or SIGTERM) abandons it, its final sweeps included
    // (exit 130, the staging directory removed); a camera run's ends the
    // capture and writes the outputs, and a second one kills as by default.
    std::optional<InterruptScope> interrupts(std::in_place);
    // Set-up: everything that can fail on bad input fails here, before any output.
    WordsStage words;
    RunEngine engine;
    const bool realtime = [&] {
        bool live = o.realtime;
        for (const auto& in : o.inputs) live = live || vision::isCameraInput(in);
        return live;
    }();
    std::vector<std::string> inputs = o.inputs;
    if (!o.vocabulary.empty()) inputs.push_back(o.vocabulary);
    OutputDir out;
    if (Status st = out.open(o.out); !st.ok()) return fail(st.message());
    // Every file the command may write (an earlier run's are noted), but only those this run writes probed.
    std::vector<std::string_view> skip;
    if (!o.summary) skip.push_back("summary.png");
    if (!o.overlay) skip.insert(skip.end(), {"overlay.mp4", "overlay.avi"});
    if (o.overlay && o.overlay_format == "avi") skip.push_back("overlay.mp4");  // avi is mp4's fallback, not the reverse
    if (Status st = out.probe({"frames.csv", "run.txt", "words.csv", "positions.csv", "topics.csv", "perplexity.csv",
                               "surprise.csv", "surprise_cells.csv", "topicmodel.csv", "summary.png", "overlay.mp4",
                               "overlay.avi"},
                              skip);
        !st.ok())
        return fail(st.message());
    if (Status st = probeMissionOutputs(o.model, o.out_bag, inputs, out.paths(), vision::inputWouldRead); !st.ok())
        return fail(st.message());
    if (Status st = words.open(o); !st.ok()) return fail(st.message());
    words.printNotes();
    if (Status st = engine.open(o, words, realtime); !st.ok()) return fail(st.message());
    RunSinks sinks(o, words, engine, realtime);
    if (Status st = sinks.open(o, words, engine, out); !st.ok()) return fail(st.message());
    if (!o.quiet) engine.describe(o, words, realtime);

    // frames -> words -> engine -> sinks
    Capture capture(words, engine, sinks.frameRing, o.max_frames);
    Progress progress(words.live ? "rost (Ctrl-C stops)" : "rost", engine.frames, o.quiet);
    if (!realtime) {
        playOffline(capture, *engine.engine, sinks, progress);
    } else if (Status st = playRealtime(capture, words, *engine.engine, sinks, progress); !st.ok()) {
        return fail(st.message());
    }
    sinks.drain();
    progress.finish();
    if (words.live) interrupts.reset();
    if (sinks.checkpoints && !sinks.collector.rows().empty())  // the state after the last observation (if any came)
        if (Status st = finishCheckpoints(*sinks.checkpoints); !st.ok()) return fail(st.message());
    if (!capture.readError().empty()) return fail(capture.readError());
    if (interrupted() && !words.live) return abandonedRun();
    if (const std::string why = runFailure(o, words, engine, capture, sinks.collector); !why.empty()) return fail(why);

    // End of stream: final sweeps and labels, then the files.
    sinks.collector.finish(o.model.settings.final_sweeps, words.live ? nullptr : &interruptFlag());
    if (interrupted() && !words.live) return abandonedRun();
    if (Status st = sinks.collector.closeStreams(); !st.ok()) return fail(st.message());
    sinks.frames.drainFrames();
    sinks.overlay.close();
    const double seconds = std::chrono::duration<double>(Clock::now() - started).count();
    const WordDrops drops = WordDrops::of(sinks.frames.ingestedWords(), sinks.collector);
    double busy = 0.0;
    for (const FrameRow& r : sinks.collector.rows()) busy += r.refine_ms * 1e-3;
    const RunReport report{o,        words,  engine, sinks.frames, sinks.collector.rows().size(), capture.dropped(),
                           realtime, seconds, drops, busy};
    Status st = writeResultFiles(out, sinks.collector, *engine.engine,
                                 {{"frames.csv", [&] { return sinks.frames.framesCsv(); }},
                                  {"run.txt", [&] { return report.text(); }}});
    if (st.ok() && o.summary)
        st = writeRunSummary(out, o, words, engine, sinks.frames, sinks.thumbs, sinks.collector.rows());
    if (st.ok() && interrupted() && !words.live) return abandonedRun();
    if (st.ok()) st = sinks.bag.finish(sinks.collector.rows());
    if (st.ok()) st = out.commit();
    if (!st.ok()) return fail(st.message());
    if (!o.quiet) std::fputs((drops.note(engine.ec.model) + out.earlierFilesNote()).c_str(), stderr);
    if (!o.quiet) {
        const std::size_t frames = sinks.frames.rows().size();
        std::fprintf(stderr, "rost: %s in %.1f s (%.1f frames/s); outputs in %s\n",
                     text::counted(static_cast<long long>(frames), "frame").c_str(), seconds,
                     static_cast<double>(frames) / std::max(1e-9, seconds), text::printable(o.out).c_str());
    }
    return kExitOk;
}

} // namespace rost::tool
