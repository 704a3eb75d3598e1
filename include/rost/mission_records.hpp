#pragma once

// A mission's results, as every face reports them: one row per observation
// (perplexity.csv, surprise.csv, surprise_cells.csv) and each observation's
// final labels as it leaves the window or at the end (topics.csv). The
// engine publishes its records into preallocated rings (no allocation, no
// lock on the refiner: Engine::publishResults); MissionRecords reads them on
// the caller's thread and applies the paper's rules once for every face:
//   * an observation's instantaneous perplexity is its step's, taken as the
//     next step opens (the last step's at the end of its budget, before any
//     final sweeps);
//   * its final perplexity and labels are its step's as it leaves the window,
//     or after the final sweeps for what is still in it.
// The rost tool (`run`, `refine`) and Python's rost.Mission/rost.vision.Mission
// read their results through it. Set-up and rows allocate; draining does not
// touch the refiner.

#include <cstdint>
#include <functional>
#include <limits>
#include <string>
#include <vector>

#include "rost/engine.hpp"
#include "rost/status.hpp"

namespace rost {

// One observation's results, right after its refinement budget (derived from
// the engine's published record: the dominant topic of each cell and the
// step's topic shares in the output numbering).
struct ObservationRecord {
    int64_t timestamp = 0;  // the caller's tag: a frame index, a file's time stamp
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
    std::vector<uint16_t> dominant;    // per cell: topic with the most labels, kNoTopic when empty
    std::vector<float> cell_surprise;  // per cell
    std::vector<float> topic_share;    // K
    static constexpr uint16_t kNoTopic = 0xFFFF;
};

// One observation's row.
struct MissionRow {
    int64_t timestamp = 0;
    uint64_t observation = 0;
    int64_t step = -1;
    uint32_t kept = 0;  // words in cells
    double surprise = std::numeric_limits<double>::quiet_NaN();
    double instantaneous = std::numeric_limits<double>::quiet_NaN();  // its step's, one step after arrival
    double final = std::numeric_limits<double>::quiet_NaN();          // its step's, at eviction or at the end
    double plugin = std::numeric_limits<double>::quiet_NaN();         // plug-in perplexity at the instantaneous instant
    int topics = 0;                                                    // open topics after its refinement
    uint64_t refinements = 0;
    double refine_ms = 0.0;
    std::vector<float> cell_surprise;  // per cell
    std::vector<float> topic_share;    // K: share of its step's labels per topic
};

// The first observation the model refused.
struct MissionRejection {
    bool any = false;
    int64_t timestamp = 0;
    AddError error = AddError::None;
    uint32_t index = 0;  // the word at fault
};

class MissionRecords {
public:
    // Turns on the engine's publication (set-up: before the engine starts):
    // `slots` records of results, and as many final labels plus one step's
    // observations (cell.time), so the records of a step that leaves the
    // window always fit when the caller drains after each observation.
    MissionRecords(Engine& engine, std::size_t slots);
    MissionRecords(const MissionRecords&) = delete;
    MissionRecords& operator=(const MissionRecords&) = delete;

    // What turning the publication on said (an allocation failure).
    const Status& status() const noexcept { return publishing_; }
    // A resumed mission: its first observation is number `n` (the
    // checkpoint's count); rows start there, and the observations before it
    // still in the window get their final labels too.
    void setFirstObservation(uint64_t n) noexcept { first_ = n; }
    // Sees each observation's record before its row is made (e.g. to draw the overlay).
    void setObservationSink(std::function<void(const ObservationRecord&)> sink) { on_observation_ = std::move(sink); }
    // Sees each observation's final labels, in observation order; `words`:
    // the record also holds its words and positions.
    void setFinalSink(std::function<void(const FinalLabels&)> sink, bool words) {
        on_final_ = std::move(sink);
        final_words_ = words;
    }

    // Moves every published record into rows and hands finals to the sink.
    void drain();
    // The end of the stream (engine stopped): the last step's instantaneous
    // perplexity, `sweeps` batch sweeps, then the final labels of everything
    // still in the window. `stop`, when given: the sweeps end early once it
    // reads true (an interrupted run, whose outputs are then discarded).
    void finish(int sweeps, const std::atomic<bool>* stop = nullptr);

    // Records the engine could not publish because the reader fell behind.
    uint64_t lost() const noexcept { return engine_.resultsLost(); }
    const MissionRejection& rejection() const noexcept { return rejection_; }
    // Over this mission's observations: words that entered cells, and words a
    // cell had no room for (cell.capacity).
    uint64_t wordsKept() const noexcept { return kept_; }
    uint64_t wordsDroppedCell() const noexcept { return dropped_cell_; }
    uint64_t finals() const noexcept { return finals_; }

    const std::vector<MissionRow>& rows() const noexcept { return rows_; }
    std::vector<MissionRow>& rows() noexcept { return rows_; }
    int cells() const noexcept { return cells_; }

    // The rows as the tool's CSV files (header, one line a row; `first`: the
    // name of the timestamp column).
    std::string perplexityCsv(const char* first = "frame") const;
    std::string surpriseCsv(const char* first = "frame") const;
    std::string cellSurpriseCsv(const char* first = "frame") const;

private:
    void fromPublished();
    void takeObservation(const ObservationRecord& o);
    void takeFinal(const FinalLabels& f);
    void fillFinal(const WindowObservation& w, const Model& m, double perplexity, const uint16_t* labels) noexcept;

    Engine& engine_;
    int K_, cells_;
    Status publishing_;
    PublishedResult published_;  // read from the engine, sized once
    ObservationRecord record_;   // made from it
    FinalLabels final_;          // sized once
    std::vector<MissionRow> rows_;
    std::function<void(const ObservationRecord&)> on_observation_;
    std::function<void(const FinalLabels&)> on_final_;
    bool final_words_ = false;
    MissionRejection rejection_;
    uint64_t finals_ = 0, first_ = 0, kept_ = 0, dropped_cell_ = 0;
};

} // namespace rost
