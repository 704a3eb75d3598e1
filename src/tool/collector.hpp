#pragma once

// Collects what an engine run produces, for `rost run` and `rost refine`:
// the engine's hooks (on the refiner thread under --realtime) copy each
// observation's results and each leaving observation's final labels into
// preallocated records of two single-producer rings; the writer thread
// drains them into per-frame rows and CSV text. The hooks neither allocate
// nor lock.

#include <cstdint>
#include <cstdio>
#include <functional>
#include <memory>
#include <string>
#include <vector>

#include "outputs.hpp"
#include "rost/engine.hpp"
#include "spsc_ring.hpp"

namespace rost::tool {

// One observation's results, right after its refinement budget.
struct ObservationRecord {
    int64_t frame = 0;  // the observation's timestamp: input frame index
    uint64_t observation = 0;
    int64_t step = -1;
    bool rejected = false;
    AddError error = AddError::None;
    uint32_t error_index = 0;
    uint32_t kept = 0;
    double surprise = 0.0;
    int64_t previous_step = -1;
    double previous_perplexity = 0.0;
    uint64_t refinements = 0;
    int64_t elapsed_ns = 0;
    std::vector<uint16_t> dominant;      // per cell: topic with the most labels, kNoTopic when empty
    std::vector<float> cell_surprise;    // per cell
    std::vector<float> topic_share;      // K
    static constexpr uint16_t kNoTopic = 0xFFFF;
};

// An observation leaving the window (or still in it at the end): its final labels.
struct FinalRecord {
    uint64_t observation = 0;
    int64_t frame = 0;
    int64_t step = 0;
    double perplexity = 0.0;  // of its step, now
    uint32_t n = 0;
    std::vector<uint32_t> words;
    std::vector<Position> positions;
    std::vector<uint16_t> labels;
};

class Collector {
public:
    // Installs the engine's hooks. `slots` records per ring.
    Collector(Engine& engine, std::size_t slots);
    ~Collector();
    Collector(const Collector&) = delete;
    Collector& operator=(const Collector&) = delete;

    // Writer side: moves every published record into rows and CSV text.
    // `onObservation` sees each observation record first (e.g. to draw the overlay).
    void drain(const std::function<void(const ObservationRecord&)>& onObservation = {});
    // End of stream (engine stopped): the last step's instantaneous
    // perplexity, `sweeps` batch sweeps, then the final labels of everything
    // still in the window.
    void finish(int sweeps);

    // A resumed run: its first observation is number `n` (the checkpoint's
    // count); rows are made from there on, and observations before it that
    // leave the window still get their final labels in topics.csv.
    void setFirstObservation(uint64_t n) noexcept { first_ = n; }

    // Records a hook could not store because the writer fell behind (realtime only).
    uint64_t lost() const noexcept { return lost_.load(std::memory_order_relaxed); }
    // First observation the model rejected, if any ("" when none).
    const std::string& rejection() const noexcept { return rejection_; }

    const std::vector<FrameRow>& rows() const noexcept { return rows_; }
    std::vector<FrameRow>& rows() noexcept { return rows_; }
    // Streams words.csv and positions.csv (when `words`) and topics.csv into
    // `out`'s staging directory as observations leave the window, so their
    // text never accumulates in memory (earlier ROST formats: timestamp,values...).
    Status streamTo(OutputDir& out, bool words);
    // Flushes and closes those files; reports a failed write (disk full, ...).
    Status closeStreams();
    std::string perplexityCsv() const;
    std::string surpriseCsv() const;
    std::string cellSurpriseCsv() const;

private:
    void onObservationHook(const ObservationResult& r, const Model& m) noexcept;
    void onEvictionHook(const WindowObservation& w, const Model& m) noexcept;
    void fillFinal(FinalRecord& f, const WindowObservation& w, const Model& m) noexcept;
    void takeFinal(const FinalRecord& f);

    Engine& engine_;
    int K_, cells_;
    std::size_t maxw_;
    SpscRing<ObservationRecord> obs_;
    SpscRing<FinalRecord> final_;
    std::atomic<uint64_t> lost_{0};
    std::vector<FrameRow> rows_;
    struct Stream {
        std::FILE* file = nullptr;
        std::string path;
    };
    Stream words_, positions_, topics_;
    std::string line_;  // reused for each line
    bool writeFailed_ = false;
    std::string rejection_;
    uint64_t finals_ = 0;
    uint64_t first_ = 0;
};

} // namespace rost::tool
