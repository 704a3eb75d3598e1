#pragma once

// A video's frame times from its decoder's presentation times (VideoSource's
// Frame::timestamp_us): the times as given, so a variable-frame-rate video
// keeps its frames' own; always increasing, whatever the decoder gives.

#include <cmath>
#include <cstdint>

#include "rost/vision/frame_source.hpp"

namespace rost::vision {

class PresentationClock {
public:
    // `fps`: the source's nominal rate (0: unknown), the step after a first
    // frame whose next has no time of its own.
    explicit PresentationClock(double fps = 0.0) noexcept : period_(nominalPeriodUs(fps)) {}

    // The next frame's time stamp in microseconds, from the decoder's time
    // `ms` in milliseconds from the stream's start. A time that does not
    // follow the last (a clock that went back: transport streams joined with
    // cat), none (NaN, beyond 10^12 us), or 0 after the first frame (OpenCV's
    // "no time" for the frames the decoder holds back to the end) is taken as
    // the last step after the last frame, and the frames after it keep their
    // own steps from there: a clock that went back costs one frame's true
    // step, not every later frame's. A negative first time is the stream's 0.
    int64_t next(double ms) noexcept {
        const double us = ms * 1000.0;
        const bool given = std::isfinite(us) && std::fabs(us) < 1e12 && (frames_ == 0 || us != 0.0);
        const int64_t g = given ? std::llround(us) : 0;
        int64_t t = 0;
        if (frames_ == 0) {
            offset_ = g < 0 ? -g : 0;
            t = g + offset_;
        } else if (given && g + offset_ > last_) {
            t = g + offset_;
        } else {
            t = last_ + (step_ > 0 ? step_ : period_);
            if (given) offset_ = t - g;
        }
        if (frames_++ > 0) step_ = t - last_;
        last_ = t;
        return t;
    }

private:
    int64_t period_;
    int64_t frames_ = 0;
    int64_t last_ = 0;    // the last frame's time stamp
    int64_t step_ = 0;    // and its step from the one before
    int64_t offset_ = 0;  // added to the decoder's times since its clock last went back
};

} // namespace rost::vision
