#pragma once

// Where frames come from, behind one small interface: a video file, an image
// sequence (a directory or a glob), several of those joined end to end, or a
// live camera through libcamera (when built with it). Every source hands out
// 8-bit BGR frames of one fixed size, which is what a Model's frame geometry
// needs.

#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include <opencv2/core.hpp>

#include "rost/status.hpp"

namespace rost::vision {

struct Frame {
    cv::Mat image;               // 8-bit BGR, SourceInfo::width x height
    int64_t index = 0;           // 0, 1, 2, ... in delivery order
    int64_t timestamp_us = 0;    // from the stream start: file time (index / fps) or sensor time
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

protected:
    FrameSource() = default;
    SourceInfo info_;
    std::string error_;
};

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
};

// Opens INPUT, one of:
//   camera:N          the N-th camera libcamera lists (N from 0)
//   a directory       its image files (png, jpg, jpeg, pgm, ppm, pnm, bmp, tif, tiff, webp), sorted by name
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

// True when INPUT names a camera ("camera:N").
bool isCameraInput(const std::string& input) noexcept;

// Cameras libcamera can see, one line each ("0: <id> (<model>)"); empty
// when none or when built without libcamera.
std::vector<std::string> listCameras();
// Whether this build has the libcamera source.
bool haveLibcamera() noexcept;

} // namespace rost::vision
