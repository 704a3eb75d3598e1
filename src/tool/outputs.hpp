#pragma once

// What `rost run` and `rost refine` write, and how: every file is written
// into a hidden staging directory inside the output directory and renamed
// into place only when the whole run succeeded, so an interrupted or failed
// run never leaves files that look complete.

#include <cstdint>
#include <initializer_list>
#include <span>
#include <string_view>
#include <string>
#include <utility>
#include <vector>

#include <opencv2/core.hpp>

#include "aligned_buffer.hpp"

#include "rost/mission_records.hpp"
#include "rost/model.hpp"
#include "rost/status.hpp"

namespace rost::tool {

class OutputDir {
public:
    OutputDir() = default;
    ~OutputDir();  // removes the staging directory unless commit() succeeded
    OutputDir(const OutputDir&) = delete;
    OutputDir& operator=(const OutputDir&) = delete;

    // Creates `dir` if needed and a fresh staging directory inside it. A run
    // that does not commit leaves nothing: staging and the directories made
    // here are removed (those that hold anything else are kept).
    Status open(const std::string& dir);
    // Path of a file in the staging directory.
    std::string staged(const std::string& name) const { return staging_ + "/" + name; }
    std::string final(const std::string& name) const { return dir_ + "/" + name; }
    // Before any work: the files this command may move into place there
    // (`names`), those this run will (all but `skip`: no summary.png under
    // --no-summary) none taken by a directory (the move would fail after the work).
    Status probe(std::initializer_list<std::string_view> names, const std::vector<std::string_view>& skip = {});
    // Writes a whole file into staging.
    Status write(const std::string& name, const std::string& content);
    // Renames every staged file into the output directory; removes staging.
    Status commit();
    // After commit(): a note naming the files of probe()'s names there that
    // this run did not write (an earlier run's summary.png beside a
    // --no-summary run's files), which could pass for this run's; "" when
    // none. They are kept: whose they are is not known here.
    std::string earlierFilesNote() const;
    // Removes the staging directory and everything in it.
    void abandon() noexcept;
    const std::string& dir() const noexcept { return dir_; }
    // Where the files this run writes go: final(name) for probe()'s names but its `skip`.
    std::vector<std::string> paths() const;
    const std::vector<std::string>& files() const noexcept { return files_; }
    void track(const std::string& name) { files_.push_back(name); }

private:
    std::string dir_, staging_;
    std::vector<std::string> files_;
    std::vector<std::string> names_;    // probe()'s: every file this command may write
    std::vector<std::string> writes_;   // of them, those this run writes
    std::vector<std::string> created_;  // directories open() made, outermost first
    bool committed_ = false;
};

// Per-frame results the tool collects (one row per ingested observation;
// `timestamp` is the input frame index).
using FrameRow = MissionRow;

// Colour of topic k (BGR), a fixed palette of well-separated hues.
cv::Scalar topicColour(int k);

// An 8-bit BGR image whose pixels, from 2 MiB up, lie in a mapping of
// their own asked for huge pages (AlignedBuffer): summary.png's canvas is
// drawn once and written, and its 3 MB, from malloc, were faulted in a 4 KiB
// page at a time, 15 ms of the summary's 33 ms on the project's VM
// (bench/RESULTS.md, "Item 1, twelfth session"). Movable, not copyable;
// `image` views `pixels`, so a copy of `image` (a cv::Mat header) is valid
// only while its Picture lives: clone() it to keep the pixels longer.
struct Picture {
    AlignedBuffer<unsigned char> pixels;
    cv::Mat image;
};
Picture makePicture(int rows, int cols);

// Draws summary.png: perplexity and surprise over the frames, the topic mix
// over time, and a strip of thumbnails (may be empty).
struct SummaryInput {
    std::string title;
    std::string subtitle;
    int K = 0;
    std::span<const FrameRow> rows;
    // Thumbnails of some frames and their frame indices.
    std::span<const cv::Mat> thumbs;
    std::span<const int64_t> thumb_frames;
    // A resumed run: the first rows meet a trained model, not an empty one.
    bool resumed = false;
};
Picture drawSummary(const SummaryInput& in);

// summary.png's time axis, first and last: the rows' first and last time
// stamps, made at least 1 wide and wide enough for a double to tell its
// tenths apart (stamps in nanoseconds, a single row).
std::pair<double, double> timeAxis(std::span<const FrameRow> rows);

// summary.png's time ticks on an axis from x0 to x1, `width` pixels wide:
// where they stand and what they read. Stamps much larger than their span
// (nanoseconds since 1970 from a bag) are read from `origin`, the first
// tick ("+2e+09", not 19 digits each), and the picture names the origin;
// fewer ticks are drawn where their labels would touch.
struct TimeTicks {
    double origin = 0.0;  // what the labels count from: 0, or the first tick
    std::vector<double> at;
    std::vector<std::string> labels;
};
TimeTicks timeTicks(double x0, double x1, int width);
// The width in pixels of a tick label as summary.png draws it.
int tickLabelWidth(const std::string& label);
// Whether the labels of `t` on the axis from x0 to x1, `width` pixels wide,
// read: each at most nine characters (and a sign), and every two
// neighbours at least 12 pixels apart.
bool tickLabelsRead(const TimeTicks& t, double x0, double x1, int width);

// Rows where the surprise jumps to at least twice the median of the 10 rows
// before it (after the first frames), strongest jump first, at least
// `separation` rows apart: where the scene changed.
std::vector<std::size_t> surprisePeaks(std::span<const FrameRow> rows, std::size_t count, std::size_t separation);

} // namespace rost::tool
