#pragma once

// Where frames come from, behind one small interface: a video file, an image
// sequence (a directory or a glob), several of those joined end to end, or a
// live camera through libcamera (when built with it). Every source hands out
// 8-bit BGR frames of one fixed size, which is what a Model's frame geometry
// needs.

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <memory>
#include <string>
#include <utility>
#include <vector>

#include <opencv2/core.hpp>

#include "rost/status.hpp"

namespace rost::vision {

// Images carry no time: a sequence of them is timed, and played under
// `rost run --realtime`, at 10 a second.
inline constexpr int64_t kImagePeriodUs = 100000;

// The time between two frames at a source's nominal rate (SourceInfo::fps),
// in whole microseconds and at least 1; kImagePeriodUs where the rate is
// unknown (0: image sequences, a container that gives none) or below one
// frame in 10^6 s.
inline int64_t nominalPeriodUs(double fps) noexcept {
    return fps >= 1e-6 ? std::max<int64_t>(1, std::llround(1e6 / fps)) : kImagePeriodUs;
}

struct Frame {
    cv::Mat image;               // 8-bit BGR, SourceInfo::width x height
    int64_t index = 0;           // 0, 1, 2, ... in delivery order
    int64_t timestamp_us = 0;    // from the stream start: a video frame's presentation time, sensor
                                 // time, or (images, which have none) kImagePeriodUs apart
};

struct SourceInfo {
    std::string description;  // e.g. "video diver.mov (640x480, 25 fps, 351 frames)"
    int width = 0;
    int height = 0;
    double fps = 0.0;         // nominal frame rate; 0 when unknown (image sequences)
    int64_t frames = -1;      // frames in the source if known (may be an estimate for video), else -1
    bool live = false;        // a camera: frames arrive in real time and cannot be re-read
};

enum class ReadStatus : uint8_t {
    Ok,     // `out` holds the next frame
    End,    // no more frames
    Error,  // a frame could not be read; FrameSource::error() says which and why
};

class FrameSource {
public:
    virtual ~FrameSource() = default;
    FrameSource(const FrameSource&) = delete;
    FrameSource& operator=(const FrameSource&) = delete;

    [[nodiscard]] const SourceInfo& info() const noexcept { return info_; }
    // The next frame. `out.image` is reused when it has the right size.
    virtual ReadStatus read(Frame& out) = 0;
    // Asks a blocking read() on another thread to return End soon (live sources).
    virtual void interrupt() noexcept {}
    // Why the last read() returned Error: one line naming the file or device.
    [[nodiscard]] const std::string& error() const noexcept { return error_; }
    // What the source did that its caller should tell a user, one line each,
    // taken (cleared) by this call: an image skipped as too small to extract
    // words from (frameTooSmall()), frames scaled to the model's size.
    // Set-up and file reading only (a camera's frames have the size asked for).
    virtual std::vector<std::string> takeNotes() { return std::exchange(notes_, {}); }

protected:
    FrameSource() = default;
    SourceInfo info_;
    std::string error_;
    std::vector<std::string> notes_;
};

// The one rule on frame sizes, the same in every face (the rost tool, the
// ROS node, Python; docs/vision.md, "Frame sizes"):
// * a frame with a side under kMinFrameSide pixels is too small to extract
//   words from (ORB's pyramid shrinks it to nothing; a thumbnail cell is 16
//   pixels by default). It is refused: the tool and the node skip it with a
//   message naming it and its size and never size a model from it; Python's
//   WordExtractor raises ValueError;
// * the size a model is made for, when the caller sets none, is the first
//   usable frame's, scaled down (aspect ratio kept) so that its longer side
//   is at most kMaxModelSide: a 4000x3000 first frame would otherwise fix a
//   ring of 1.4 GB of cells. The frames are then resized, and a note says so.
// Header-only: the ROS parts (C++17) use it too.
inline constexpr int kMinFrameSide = 16;
inline constexpr int kMaxModelSide = 1920;

// "" for a frame words can be extracted from; else why not:
// "a 1x300 frame is too small to extract words from (each side at least 16 pixels)".
inline std::string frameTooSmall(int width, int height) {
    if (width >= kMinFrameSide && height >= kMinFrameSide) return {};
    return "a " + std::to_string(width) + "x" + std::to_string(height) +
           " frame is too small to extract words from (each side at least " + std::to_string(kMinFrameSide) +
           " pixels)";
}

struct FrameSize {
    int width = 0, height = 0;
};
// "frames of 4000x3000 are scaled to 1920x1440 (...)": the note a source gives.
inline std::string scaledNote(int width, int height, FrameSize model) {
    return "frames of " + std::to_string(width) + "x" + std::to_string(height) + " are scaled to " +
           std::to_string(model.width) + "x" + std::to_string(model.height) + " (at most " +
           std::to_string(kMaxModelSide) + " pixels on the longer side unless a size is given)";
}
inline FrameSize modelFrameSize(int width, int height) noexcept {
    const int longer = width > height ? width : height;
    if (longer <= kMaxModelSide) return {width, height};
    const double scale = static_cast<double>(kMaxModelSide) / longer;
    const auto side = [&](int s) {
        const int v = static_cast<int>(s * scale + 0.5);
        return v < 1 ? 1 : v;
    };
    return {side(width), side(height)};
}

struct SourceOptions {
    // Output frame size; 0 keeps the (first) input's size, one of the two
    // alone keeps its aspect ratio. Frames of another size are resized (area
    // average when shrinking).
    int width = 0;
    int height = 0;
    // Camera settings (camera:N only).
    int camera_width = 640;
    int camera_height = 480;
    int camera_buffers = 4;     // buffers cycling between the camera and the capture thread
    std::string camera_format;  // preferred pixel format name ("NV12", "RGB888", ...); empty: first supported
    // How the caller's face spells the option that limits the frames read,
    // named in a cut video's error ("--max-frames 102 models those"):
    // MissionNames::max_frames.
    std::string max_frames_name = "--max-frames";
};

// Opens INPUT, one of:
//   camera:N          the N-th camera libcamera lists (N from 0)
//   a directory       its image files (png, jpg, jpeg, pbm, pgm, ppm, pnm, bmp, tif, tiff, webp), sorted by name
//   a glob pattern    (contains *, ? or [) the matching files, sorted by name
//   any other file    a video OpenCV can decode (or a single image)
// On failure returns nullptr and a one-line status naming the input and the
// cause: no such file, not readable, empty directory, no match, cannot
// decode, no camera found (with the cameras it can see).
std::unique_ptr<FrameSource> openFrameSource(const std::string& input, const SourceOptions& options, Status& status);

// Opens several inputs played one after the other, all at the first one's
// size (or the size in options). Frame indices continue across inputs.
std::unique_ptr<FrameSource> openFrameSources(const std::vector<std::string>& inputs, const SourceOptions& options,
                                              Status& status);

// The size of a source's frames, whose first (or native) size is w x h: the
// options' (one alone keeps the aspect ratio), else w x h within
// kMaxModelSide (a note in `notes` when scaled). A size asked for that words
// cannot be extracted from is refused. Every source sizes its frames so (files,
// cameras, rost_node's image topic).
Status chooseSize(const SourceOptions& o, int w, int h, SourceInfo& info, std::vector<std::string>& notes);

// Whether a video file whose container counts its frames (QuickTime, MP4,
// AVI) is whole: every top-level box or RIFF chunk ends within the file.
// A video source that decodes fewer frames than counted tells a whole file
// (an edit list, dropped frames: a note) from a cut one (an error) by it.
// The walk stops after `max_chunks` chunks and then says false.
inline constexpr int kMaxContainerChunks = 1000000;
bool containerIsWhole(const std::string& path, int max_chunks = kMaxContainerChunks);

// True when INPUT names a camera ("camera:N").
bool isCameraInput(const std::string& input) noexcept;

// True when INPUT is a glob(3) pattern of image files: '*', '?' or '[' in it,
// and no file or directory of that very name ("dive [x3f].mov" is the video).
bool isGlobInput(const std::string& input) noexcept;

// Whether the input `input` would read the file `path` besides being it (a
// mission's outputs may not: MissionOptions::would_read): one of an image
// directory's frames (an image file directly in it), a file an input glob
// matches now or would match once written (its pattern, as glob(3) reads it:
// no leading dot matched by a wildcard). Relative paths are the current
// directory's.
bool inputWouldRead(const std::string& input, const std::string& path);

// Cameras libcamera can see, one line each ("0: <id> (<model>)"); empty
// when none or when built without libcamera.
std::vector<std::string> listCameras();
// Whether this build has the libcamera source.
bool haveLibcamera() noexcept;

} // namespace rost::vision
