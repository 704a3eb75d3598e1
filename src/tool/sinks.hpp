#pragma once

// The result sinks of `rost run` (and `rost refine`): each reads on the
// writer thread, never on the refiner's. The Collector (collector.hpp)
// drains the engine's published results into rows, words.csv,
// positions.csv and topics.csv; the sinks here pair them with the captured
// frames (frames.csv, the overlay video, the summary's thumbnails) and
// write the end-of-run files (run.txt, summary.png, the CSV files).

#include <cstdint>
#include <string>
#include <vector>

#include <opencv2/core.hpp>
#include <opencv2/videoio.hpp>

#include "collector.hpp"
#include "outputs.hpp"
#include "results.hpp"
#include "stages.hpp"

namespace rost::tool {

// Blends each cell of `img` (cells of cellSpace pixels, gridW to a row, cut at
// the image's edges) 38 % toward its dominant topic's colour; a cell without
// words is left as it is. In place, without temporaries.
void tintCells(cv::Mat& img, const ObservationRecord& r, int cellSpace, int gridW);

// The overlay video: each ingested frame tinted with its cells' dominant topics.
class OverlaySink {
public:
    Status open(OutputDir& out, const vision::SourceInfo& info, const std::string& format);
    bool enabled() const { return video_.isOpened(); }
    void write(const FrameSlot& s, const ObservationRecord& r, int cellSpace, int gridW);
    void close() { video_.release(); }

private:
    cv::VideoWriter video_;
    cv::Mat canvas_;
    uint64_t frames_ = 0;
};

// Thumbnails for summary.png, in one pool allocated at set-up: per-frame
// allocations interleaved with the video encoder's buffers fragment the heap
// (measured: +0.36 MB of RSS per 640x480 frame). When the pool is full every
// other thumbnail is dropped and only every 2nd frame kept.
class ThumbnailSink {
public:
    void open(const vision::SourceInfo& info, int64_t frames);
    void take(const FrameSlot& s);
    // Up to n thumbnails: evenly spaced, with the surprise peaks swapped in.
    void pick(std::span<const FrameRow> rows, std::size_t n, std::vector<cv::Mat>& outThumbs,
              std::vector<int64_t>& outFrames) const;

private:
    cv::Mat slot(std::size_t i) const;
    void halve();
    bool on_ = false;
    int w_ = 160, h_ = 1;
    std::size_t cap_ = 0;
    cv::Mat pool_;
    std::vector<cv::Mat> thumbs_;  // views into the pool
    std::vector<int64_t> frames_;
    int every_ = 1;
};

// Per-frame line of frames.csv.
struct CaptureRow {
    int64_t frame = 0, timestamp_us = 0;
    uint32_t words = 0, orb = 0, intensity = 0, hue = 0, kept = 0;
    bool ingested = false;
};

// Pairs each observation record with its captured frame (frames before it
// whose observation never came were dropped at the queue) and hands the
// pair to frames.csv, the overlay and the thumbnails.
class FrameSink {
public:
    FrameSink(FrameRing& ring, OverlaySink& overlay, ThumbnailSink* thumbs, const EngineConfig& ec)
        : ring_(ring), overlay_(overlay), thumbs_(thumbs), ec_(ec) {}
    void onObservation(const ObservationRecord& r);
    void drainFrames();  // the end: frames left without an observation

    const std::vector<CaptureRow>& rows() const noexcept { return capture_; }
    uint64_t missing() const noexcept { return missing_; }
    uint64_t totalWords() const noexcept;
    uint64_t ingestedWords() const noexcept;  // words of the frames the engine took up
    double wordsPerFrame() const noexcept;
    std::string framesCsv() const;

private:
    void take(const FrameSlot& s, const ObservationRecord* r);
    FrameRing& ring_;
    OverlaySink& overlay_;
    ThumbnailSink* thumbs_;
    const EngineConfig& ec_;
    std::vector<CaptureRow> capture_;
    uint64_t missing_ = 0;
};

// run.txt: the command, the input, the settings and what the run did.
struct RunReport {
    const RunOptions& o;
    const WordsStage& w;
    const RunEngine& e;
    const FrameSink& frames;
    std::size_t ingested = 0;
    uint64_t writerSkipped = 0;
    bool realtime = false;
    double seconds = 0.0;
    WordDrops drops;
    double busy = 0.0;  // seconds the refiner spent on observations (take-up to publication)
    std::string text() const;

private:
    std::string settingsText() const;
};

// summary.png of a run.
Status writeRunSummary(OutputDir& out, const RunOptions& o, const WordsStage& w, const RunEngine& e,
                       const FrameSink& frames, const ThumbnailSink& thumbs, const std::vector<FrameRow>& rows);

} // namespace rost::tool
