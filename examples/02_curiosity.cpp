// Curiosity: what a vehicle would steer by. Frames from a video file or a
// camera become words, the engine refines them on its own thread, and a
// callback on that thread turns each frame's surprise into a steering cue:
// when the newest frame surprises the model much more than recent frames
// did, head for the cell that surprised it most.
//
//   02_curiosity [INPUT] [MAX_FRAMES]
//
// INPUT is a video, an image directory or camera:N (default: diver.mov from
// data/, see scripts/fetch-footage.sh); MAX_FRAMES defaults to 120.

#include <atomic>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <string>

#include "rost/engine.hpp"
#include "rost/vision/frame_source.hpp"
#include "rost/vision/words.hpp"

namespace {

// A steering cue, packed into one 64-bit word so the refiner thread can hand
// it to the control loop with a single atomic store (no lock, no allocation).
struct Cue {
    int32_t frame = -1;
    int16_t heading = 0;   // -1000 (hard left) .. 1000 (hard right)
    uint16_t ratio10 = 0;  // surprise / recent surprise, x10
};
uint64_t pack(Cue c) {
    return static_cast<uint32_t>(c.frame) | static_cast<uint64_t>(static_cast<uint16_t>(c.heading)) << 32 |
           static_cast<uint64_t>(c.ratio10) << 48;
}
Cue unpack(uint64_t v) {
    return {static_cast<int32_t>(v & 0xFFFFFFFFu), static_cast<int16_t>((v >> 32) & 0xFFFF),
            static_cast<uint16_t>(v >> 48)};
}

} // namespace

int main(int argc, char** argv) {
    const std::string input =
        argc > 1 ? argv[1] : ROST_SOURCE_DIR "/data/pd-extendedview/usr/share/doc/pd-extendedview/media/diver.mov";
    const long maxFrames = argc > 2 ? std::strtol(argv[2], nullptr, 10) : 120;

    // Frames and words.
    rost::Status st;
    auto source = rost::vision::openFrameSource(input, {}, st);
    if (!source) {
        std::fprintf(stderr, "02_curiosity: %s\n", st.message().c_str());
        return 2;
    }
    auto extractor = rost::vision::WordExtractor::create({}, rost::vision::defaultVocabulary(st), st);
    if (!extractor) {
        std::fprintf(stderr, "02_curiosity: %s\n", st.message().c_str());
        return 2;
    }
    const rost::vision::SourceInfo& info = source->info();

    // The engine: paper defaults, 20 time-step refinements per frame.
    rost::EngineConfig cfg;
    cfg.model.V = static_cast<int>(extractor->vocabularySize());
    cfg.model.frame_width = info.width;
    cfg.model.frame_height = info.height;
    cfg.budget = rost::Budget::steps(20);
    auto engine = rost::Engine::create(cfg, st);
    if (!engine) {
        std::fprintf(stderr, "02_curiosity: %s\n", st.message().c_str());
        return 2;
    }

    // The callback, on the refiner thread after each frame's refinement.
    // Recent surprise is an exponential average over earlier frames; a frame
    // at least 30% more surprising is a cue to turn toward its most
    // surprising cell (a hard cut to another scene gives 5x to 10x).
    std::atomic<uint64_t> mailbox{pack({})};
    double recent = 0.0;
    const int gridW = cfg.model.gridWidth();
    engine->setObservationHook([&](const rost::ObservationResult& r, const rost::Model& m) {
        if (!r.add.ok()) return;
        const auto cells = m.cellSurprise(r.step);
        int hottest = 0;
        for (int c = 1; c < static_cast<int>(cells.size()); ++c)
            if (cells[static_cast<std::size_t>(c)] > cells[static_cast<std::size_t>(hottest)]) hottest = c;
        const double ratio = recent > 0.0 ? r.surprise / recent : 1.0;
        recent = recent > 0.0 ? 0.8 * recent + 0.2 * r.surprise : r.surprise;
        const double column = (hottest % gridW + 0.5) / gridW;  // 0 = left edge, 1 = right edge
        Cue cue;
        cue.frame = static_cast<int32_t>(r.timestamp);
        cue.heading = static_cast<int16_t>(std::lround((2.0 * column - 1.0) * 1000.0));
        cue.ratio10 = static_cast<uint16_t>(std::min(65535.0, ratio * 10.0));
        mailbox.store(pack(cue), std::memory_order_release);
    });
    st = engine->start();
    if (!st.ok()) {
        std::fprintf(stderr, "02_curiosity: %s\n", st.message().c_str());
        return 2;
    }

    // The capture loop (a vehicle's camera thread): frame -> words -> tryPush.
    // It also plays the control loop here, reading the newest cue.
    std::printf("%s\n", info.description.c_str());
    rost::vision::Frame frame;
    rost::vision::FrameWords words;
    int32_t lastCue = -1;
    auto react = [&] {
        const Cue c = unpack(mailbox.load(std::memory_order_acquire));
        if (c.frame == lastCue || c.frame < 10) return;  // the first frames surprise an empty model
        lastCue = c.frame;
        if (c.ratio10 >= 13)
            std::printf("frame %4d: curious (surprise %.1fx the recent level): turn %s %d%%\n", c.frame,
                        c.ratio10 / 10.0, c.heading < 0 ? "left" : "right", std::abs(c.heading) / 10);
    };
    long n = 0;
    while (n < maxFrames && source->read(frame) == rost::vision::ReadStatus::Ok) {
        extractor->extract(frame.image, words);
        // Under the default DropPolicy::DropOldest a full queue drops its
        // oldest frame and takes this one (tryPush is then true): the
        // counters say a frame was dropped.
        const uint64_t droppedBefore = engine->counters().dropped();
        const bool taken = engine->tryPush({frame.index, words.words, words.positions});
        if (!taken || engine->counters().dropped() > droppedBefore)
            std::printf("frame %4lld: %s dropped, the refiner is behind\n", static_cast<long long>(frame.index),
                        taken ? "an older frame" : "this frame");
        react();
        ++n;
    }
    engine->stop(rost::Engine::StopMode::Drain);
    react();
    const rost::EngineCounters c = engine->counters();
    std::printf("%ld frames, %llu refined, %llu dropped\n", n, static_cast<unsigned long long>(c.ingested),
                static_cast<unsigned long long>(c.dropped()));
    return 0;
}
