#pragma once

// The results sink of `rost run` and `rost refine`: the engine publishes
// each observation's results and each leaving observation's final labels
// into its own preallocated rings (Engine::publishResults; no allocation,
// no lock on the refiner); this sink reads them on the writer thread
// (Engine::readResult, readFinal), derives what the outputs need (dominant
// topic per cell, topic shares) and makes per-frame rows and CSV text. It
// installs no hook: writing outputs never runs on the refiner thread.

#include <cstdint>
#include <cstdio>
#include <functional>
#include <memory>
#include <string>
#include <vector>

#include "outputs.hpp"
#include "rost/engine.hpp"

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
    uint32_t dropped_cell = 0;  // words beyond a cell's capacity
    double surprise = 0.0;
    int64_t previous_step = -1;
    double previous_perplexity = 0.0;
    double previous_plugin = 0.0;
    int active_topics = 0;
    uint64_t refinements = 0;
    int64_t elapsed_ns = 0;
    std::vector<uint16_t> dominant;      // per cell: topic with the most labels, kNoTopic when empty
    std::vector<float> cell_surprise;    // per cell
    std::vector<float> topic_share;      // K
    static constexpr uint16_t kNoTopic = 0xFFFF;
};

class Collector {
public:
    // Turns on the engine's publication, `slots` records per ring (set-up:
    // before the engine starts). A failure is reported by streamTo().
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

    // Records the engine could not publish because the writer fell behind (realtime only).
    uint64_t lost() const noexcept { return engine_.resultsLost(); }
    // First observation the model rejected, if any ("" when none).
    const std::string& rejection() const noexcept { return rejection_; }
    // Over the observations of this run: words that entered cells, and words
    // a cell had no room for (cell.capacity).
    uint64_t wordsKept() const noexcept { return kept_; }
    uint64_t wordsDroppedCell() const noexcept { return dropped_cell_; }

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
    void fromPublished();  // published_ -> record_
    void takeObservation(const ObservationRecord& o);
    // final_ for observation w, with its measurements (Model::finalMeasurements).
    void fillFinal(const WindowObservation& w, const Model& m, double perplexity, const uint16_t* labels) noexcept;
    void takeFinal(const FinalLabels& f);

    Engine& engine_;
    int K_, cells_;
    Status publishing_;
    PublishedResult published_;  // read from the engine, sized once
    ObservationRecord record_;   // made from it
    FinalLabels final_;          // sized once
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
    uint64_t kept_ = 0, dropped_cell_ = 0;
};

} // namespace rost::tool
