#pragma once

// The results sink of `rost run` and `rost refine`: the library's
// MissionRecords (rost/mission_records.hpp: rows, the instantaneous and
// final perplexities, final labels, read from the engine's publication on the
// writer thread) plus the tool's streamed files. It installs no hook:
// writing outputs never runs on the refiner thread.

#include <cstdint>
#include <cstdio>
#include <functional>
#include <string>
#include <vector>

#include "outputs.hpp"
#include "rost/engine.hpp"
#include "rost/mission_records.hpp"

namespace rost::tool {

class Collector {
public:
    // Turns on the engine's publication, `slots` records per ring (set-up:
    // before the engine starts). A failure is reported by streamTo().
    Collector(Engine& engine, std::size_t slots);
    ~Collector();
    Collector(const Collector&) = delete;
    Collector& operator=(const Collector&) = delete;

    // Sees each observation record first (e.g. to draw the overlay).
    void setObservationSink(std::function<void(const ObservationRecord&)> sink) {
        records_.setObservationSink(std::move(sink));
    }
    // Writer side: moves every published record into rows and CSV text.
    void drain() { records_.drain(); }
    // End of stream (engine stopped): MissionRecords::finish.
    void finish(int sweeps, const std::atomic<bool>* stop = nullptr) { records_.finish(sweeps, stop); }
    // A resumed run: its first observation is number `n` (the checkpoint's
    // count); rows are made from there on, and observations before it that
    // leave the window still get their final labels in topics.csv.
    void setFirstObservation(uint64_t n) noexcept { records_.setFirstObservation(n); }

    uint64_t lost() const noexcept { return records_.lost(); }
    // First observation the model rejected, if any ("" when none).
    std::string rejection() const;
    uint64_t wordsKept() const noexcept { return records_.wordsKept(); }
    uint64_t wordsDroppedCell() const noexcept { return records_.wordsDroppedCell(); }

    const std::vector<MissionRow>& rows() const noexcept { return records_.rows(); }
    // Streams words.csv and positions.csv (when `words`) and topics.csv into
    // `out`'s staging directory as observations leave the window, so their
    // text never accumulates in memory (earlier ROST formats: timestamp,values...).
    Status streamTo(OutputDir& out, bool words);
    // Flushes and closes those files; reports a failed write (disk full, ...).
    Status closeStreams();
    std::string perplexityCsv() const { return records_.perplexityCsv(); }
    std::string surpriseCsv() const { return records_.surpriseCsv(); }
    std::string cellSurpriseCsv() const { return records_.cellSurpriseCsv(); }

private:
    void takeFinal(const FinalLabels& f);

    MissionRecords records_;
    struct Stream {
        std::FILE* file = nullptr;
        std::string path;   // where it is written (staged)
        std::string shown;  // what errors call it: the file in --out
        int error = 0;      // errno of its first failed write
    };
    Stream words_, positions_, topics_;
    std::string line_;  // reused for each line
};

} // namespace rost::tool
