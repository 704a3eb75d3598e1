#include "rost/vision/frame_source.hpp"
#include "rost/vision/image_file.hpp"
#include "rost/vision/presentation_clock.hpp"
#include "rost/text_io.hpp"

#include <fnmatch.h>
#include <glob.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <limits>

#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#include <opencv2/videoio.hpp>

#include "camera_source.hpp"
#include "rost/mission.hpp"

namespace fs = std::filesystem;

namespace rost::vision {

namespace {

std::string lower(std::string s) {
    for (char& c : s) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
    return s;
}

// The regular files a glob pattern matches now, sorted: what a glob input
// reads, and what its outputs may not replace (inputWouldRead).
std::vector<std::string> globFiles(const std::string& pattern) {
    glob_t g{};
    std::vector<std::string> files;
    if (::glob(pattern.c_str(), 0, nullptr, &g) == 0)
        for (std::size_t i = 0; i < g.gl_pathc; ++i) {
            std::error_code ec;  // a link that leads nowhere (or to itself) is no frame: skipped, never thrown
            if (fs::is_regular_file(g.gl_pathv[i], ec)) files.emplace_back(g.gl_pathv[i]);
        }
    globfree(&g);
    std::sort(files.begin(), files.end());
    return files;
}

constexpr const char* kImageExtensions[] = {".png", ".jpg", ".jpeg", ".pgm", ".ppm", ".pnm", ".pbm",
                                            ".bmp", ".tif", ".tiff", ".webp"};

bool isImageFile(const fs::path& p) {
    const std::string e = lower(p.extension().string());
    return std::any_of(std::begin(kImageExtensions), std::end(kImageExtensions), [&](const char* x) { return e == x; });
}

// "png, jpg, ...": the extensions a directory's images are found by.
std::string imageExtensionsText() {
    std::string s;
    for (const char* x : kImageExtensions) (s += s.empty() ? "" : ", ") += x + 1;
    return s;
}

// Brings a decoded image to 8-bit BGR at the source's size: empty, or why
// it cannot (its pixel depth or channels named).
std::string normalise(const cv::Mat& in, int width, int height, cv::Mat& out) {
    if (in.empty()) return "no pixels";
    cv::Mat m = in;
    if (m.depth() != CV_8U) {
        // To 8 bits as viewers show them: 16-bit over its range, floating
        // point (TIFF, EXR) from [0, 1], signed from its range's middle. A
        // float image taken as 0-255 would be black.
        double scale = 1.0, shift = 0.0;
        switch (m.depth()) {
        case CV_16U: scale = 1.0 / 257.0; break;
        case CV_16S: scale = 1.0 / 257.0, shift = 32768.0 / 257.0; break;
        case CV_8S: shift = 128.0; break;
        case CV_32F:
        case CV_64F: scale = 255.0; break;
        default:  // 32-bit integers: no range a viewer agrees on
            return "32-bit integer pixels, which have no agreed range: convert it to 8 or 16 bits, or to floating "
                   "point in [0, 1]";
        }
        cv::Mat t;
        m.convertTo(t, CV_8U, scale, shift);
        m = t;
    }
    cv::Mat bgr;
    if (m.channels() == 3) bgr = m;
    else if (m.channels() == 1) cv::cvtColor(m, bgr, cv::COLOR_GRAY2BGR);
    else if (m.channels() == 4) cv::cvtColor(m, bgr, cv::COLOR_BGRA2BGR);
    else return std::to_string(m.channels()) + " channels (1, 3 or 4 are read)";
    if (bgr.cols == width && bgr.rows == height) {
        if (bgr.data == out.data) return {};
        bgr.copyTo(out);
    } else {
        const bool shrink = bgr.cols > width || bgr.rows > height;
        cv::resize(bgr, out, cv::Size(width, height), 0, 0, shrink ? cv::INTER_AREA : cv::INTER_LINEAR);
    }
    return {};
}

// Checks that a path exists, is a regular file and can be read; a missing or
// unreadable one is said as every reader of the library says it
// ("PATH: cannot open: No such file or directory", text_io's words).
Status checkReadable(const std::string& path) {
    std::error_code ec;
    const auto st = fs::status(path, ec);
    if (!fs::exists(st) && (!ec || ec == std::errc::no_such_file_or_directory))
        return Status::fromErrno(ENOENT, path + ": cannot open: " + std::strerror(ENOENT));
    if (ec) return Status::fromErrno(ec.value(), path + ": cannot open: " + ec.message());  // as open(2) says it
    if (!fs::is_regular_file(st) && !fs::is_directory(st)) return Status::error(path + ": not a regular file");
    if (::access(path.c_str(), R_OK) != 0) {
        const int err = errno;
        return Status::fromErrno(err, path + ": cannot open: " + std::strerror(err));
    }
    return {};
}

} // namespace

// rost/vision/frame_source.hpp: every source's frame size.
Status chooseSize(const SourceOptions& o, int w, int h, SourceInfo& info, std::vector<std::string>& notes) {
    if (o.width > 0 && o.height > 0) {
        info.width = o.width;
        info.height = o.height;
    } else if (o.width > 0) {  // keep the aspect ratio
        info.width = o.width;
        info.height = std::max(1, static_cast<int>(std::lround(static_cast<double>(h) * o.width / w)));
    } else if (o.height > 0) {
        info.height = o.height;
        info.width = std::max(1, static_cast<int>(std::lround(static_cast<double>(w) * o.height / h)));
    } else {
        const FrameSize m = modelFrameSize(w, h);
        info.width = m.width;
        info.height = m.height;
        if (m.width != w || m.height != h) notes.push_back(scaledNote(w, h, m));
    }
    if (const std::string why = frameTooSmall(info.width, info.height); !why.empty())
        return Status::error("width " + std::to_string(o.width) + ", height " + std::to_string(o.height) +
                             " asked for: " + why);
    return {};
}

namespace {

// Whether a video's container stores its frame count: QuickTime and MP4 (the
// sample tables) and AVI (its header). The others (Matroska and WebM, MPEG
// program and elementary streams, TS, Ogg, FLV) have none, and FFmpeg then
// estimates one from the duration and the rate, off either way: 1 for a
// 79-frame MPEG stream, twice the frames for a WebM whose audio outlasts its
// video. Told by the file's first bytes.
bool containerCountsFrames(const std::string& path) {
    char h[12] = {};
    std::ifstream f(path, std::ios::binary);
    if (!f.read(h, sizeof h)) return false;
    const auto at = [&](int offset, const char* tag) { return std::memcmp(h + offset, tag, 4) == 0; };
    if (at(0, "RIFF") && at(8, "AVI ")) return true;
    for (const char* box : {"ftyp", "moov", "mdat", "wide", "free", "skip", "pnot"})
        if (at(4, box)) return true;  // a QuickTime box: 4 bytes of size, then its type
    return false;
}

} // namespace

// Whether a container that counts its frames (containerCountsFrames) is
// whole: every top-level QuickTime box, or every RIFF chunk of an AVI, ends
// within the file. A file cut short (a copy stopped half way, a card pulled)
// has its last one run past the end. A whole file may still give fewer
// frames than its count: an edit list (a clip cut with `ffmpeg -ss ... -c
// copy` keeps the samples before its start) or an AVI's empty chunks for
// dropped frames.
// Edge cases, each tested on hand-made bytes (VisionContainer.*):
// * fewer than 8 bytes after the last whole box or chunk cannot start
//   another: zeros there are padding (whole), anything else a header cut off;
// * an AVI's last odd-sized chunk may lack its pad byte; a QuickTime box one
//   byte short is cut;
// * a size running past the end, however large (a 64-bit box size near 2^64
//   included), is a cut, never a wrap;
// * a walk that gives up (more than max_chunks) proves nothing: not whole.
bool containerIsWhole(const std::string& path, int max_chunks) {
    std::ifstream f(path, std::ios::binary);
    if (!f) return false;
    f.seekg(0, std::ios::end);
    const auto size = static_cast<uint64_t>(f.tellg());
    const auto bytesAt = [&](uint64_t at, unsigned char* b, std::size_t n) {
        f.clear();
        f.seekg(static_cast<std::streamoff>(at));
        return static_cast<bool>(f.read(reinterpret_cast<char*>(b), static_cast<std::streamsize>(n)));
    };
    unsigned char h[16];
    if (!bytesAt(0, h, 12)) return false;
    const bool riff = std::memcmp(h, "RIFF", 4) == 0;
    uint64_t at = 0;
    for (int chunks = 0; at < size; ++chunks) {
        if (chunks == max_chunks) return false;
        const uint64_t left = size - at;
        if (left < 8) {  // too short for a header: padding if zeros
            if (!bytesAt(at, h, static_cast<std::size_t>(left))) return false;
            return std::all_of(h, h + left, [](unsigned char c) { return c == 0; });
        }
        if (!bytesAt(at, h, 8)) return false;
        if (riff) {  // "RIFF" or "AVIX", a little-endian size, padded to even
            const uint64_t n = uint64_t{h[4]} | uint64_t{h[5]} << 8 | uint64_t{h[6]} << 16 | uint64_t{h[7]} << 24;
            const uint64_t length = 8 + n + (n & 1);
            if (length > left) return (n & 1) != 0 && length == left + 1;  // only the pad byte missing
            at += length;
        } else {  // a big-endian size (1: 64 bits follow; 0: to the end), then the type
            uint64_t n = uint64_t{h[0]} << 24 | uint64_t{h[1]} << 16 | uint64_t{h[2]} << 8 | uint64_t{h[3]};
            if (n == 0) return true;
            if (n == 1) {
                if (left < 16 || !bytesAt(at + 8, h + 8, 8)) return false;
                n = 0;
                for (int i = 8; i < 16; ++i) n = n << 8 | h[i];
                if (n < 16) return false;
            } else if (n < 8) {
                return false;
            }
            if (n > left) return false;
            at += n;
        }
    }
    return true;
}

namespace {

class ImageSequenceSource final : public FrameSource {
public:
    ImageSequenceSource(std::vector<std::string> files, std::string what) : files_(std::move(files)), what_(std::move(what)) {}

    Status open(const SourceOptions& o) {
        // The first usable image fixes the size; those too small before it are skipped.
        cv::Mat first;
        for (;;) {
            if (next_ >= files_.size())
                return Status::error(what_ + ": no image large enough to extract words from (each side at least " +
                                     std::to_string(kMinFrameSide) + " pixels)");
            if (Status st = readImageFile(files_[next_], first, bytes_); !st.ok()) return st;
            if (!skipSmall(first)) break;
        }
        if (Status st = chooseSize(o, first.cols, first.rows, info_, notes_); !st.ok()) return st.prefixed(what_ + ": ");
        first_ = noted_ = cv::Size(first.cols, first.rows);
        info_.frames = static_cast<int64_t>(files_.size() - next_);
        info_.description = what_ + " (" + text::counted(static_cast<long long>(files_.size()), "image") + ", " + std::to_string(info_.width) +
                            "x" + std::to_string(info_.height) + ")";
        pending_ = first;
        return {};
    }

    ReadStatus read(Frame& out) override {
        cv::Mat img;
        do {
            if (next_ >= files_.size()) return ReadStatus::End;
            if (!pending_.empty()) {
                img = std::move(pending_), pending_ = cv::Mat();
            } else if (Status st = readImageFile(files_[next_], img, bytes_); !st.ok()) {
                error_ = st.message();
                return ReadStatus::Error;
            }
        } while (skipSmall(img));
        // An image of another size than the first is scaled to the frame: said once per size in a row.
        if (!img.empty() && img.size() != first_ && img.size() != noted_) {
            notes_.push_back(files_[next_] + ": " + std::to_string(img.cols) + "x" + std::to_string(img.rows) +
                             ", not the first image's " + std::to_string(first_.width) + "x" +
                             std::to_string(first_.height) + ": scaled to the " + std::to_string(info_.width) + "x" +
                             std::to_string(info_.height) + " frame");
            noted_ = img.size();
        }
        if (const std::string why = normalise(img, info_.width, info_.height, out.image); !why.empty()) {
            error_ = files_[next_] + ": cannot decode image: " + why;
            return ReadStatus::Error;
        }
        out.index = delivered_;  // in delivery order: skipped images leave no gap
        out.timestamp_us = kImagePeriodUs * delivered_++;
        ++next_;
        return ReadStatus::Ok;
    }

private:
    // An image too small to extract words from: a note naming it, and the next file.
    bool skipSmall(const cv::Mat& img) {
        const std::string why = frameTooSmall(img.cols, img.rows);
        if (why.empty()) return false;
        notes_.push_back(files_[next_] + ": " + why + "; skipped");
        ++next_;
        return true;
    }

    std::vector<std::string> files_;
    std::string what_;
    std::size_t next_ = 0;
    int64_t delivered_ = 0;
    cv::Mat pending_;
    cv::Size first_, noted_;  // the first image's size; the last other size noted
    std::string bytes_;       // each file's bytes, read into the same buffer
};

class VideoSource final : public FrameSource {
public:
    explicit VideoSource(std::string path) : path_(std::move(path)) {}

    Status open(const SourceOptions& o) {
        max_frames_name_ = o.max_frames_name;
        // FFmpeg only: it reads every common container, and OpenCV's other
        // backends (GStreamer, image-sequence patterns) would each try a file
        // FFmpeg refused and fill stderr with their complaints.
        if (!cap_.open(path_, cv::CAP_FFMPEG) || !cap_.isOpened()) {
            // A recording cut before its index (a QuickTime file keeps it at the end) cannot be opened at all.
            if (containerCountsFrames(path_) && !containerIsWhole(path_))
                return Status::error(path_ + ": cannot decode video: truncated or damaged (its container's boxes run "
                                             "past the end of the file)");
            return Status::error(path_ + ": cannot decode video (OpenCV cannot open it)");
        }
        if (!cap_.read(pending_) || pending_.empty())
            return Status::error(path_ + ": cannot decode video (no frame could be decoded)");
        pending_ms_ = cap_.get(cv::CAP_PROP_POS_MSEC);
        if (const std::string why = frameTooSmall(pending_.cols, pending_.rows); !why.empty())
            return Status::error(path_ + ": " + why + " (every frame of a video has its size)");
        if (Status st = chooseSize(o, pending_.cols, pending_.rows, info_, notes_); !st.ok()) return st.prefixed(path_ + ": ");
        info_.fps = cap_.get(cv::CAP_PROP_FPS);
        if (!(info_.fps > 0.0 && info_.fps < 1000.0)) info_.fps = 0.0;
        clock_ = PresentationClock(info_.fps);
        const double n = cap_.get(cv::CAP_PROP_FRAME_COUNT);
        // An estimate is no count: the length unknown, as a camera's (planning
        // and progress not misled), and kept to say where decoding fell short of it.
        const int64_t count = n >= 1.0 ? static_cast<int64_t>(n) : -1;
        if (containerCountsFrames(path_)) info_.frames = count;
        else info_.frames = -1, estimate_ = count;
        char fps[32];
        std::snprintf(fps, sizeof fps, "%.3g fps", info_.fps);
        info_.description = "video " + path_ + " (" + std::to_string(pending_.cols) + "x" +
                            std::to_string(pending_.rows) + ", " + fps +
                            (info_.frames > 0 ? ", " + text::counted(info_.frames, "frame") : std::string()) + ")";
        return {};
    }

    ReadStatus read(Frame& out) override {
        cv::Mat img;
        double ms = pending_ms_;
        if (!pending_.empty()) img = std::move(pending_), pending_ = cv::Mat();
        else if (!cap_.read(raw_) || raw_.empty()) return endOrCut();
        else img = raw_, ms = cap_.get(cv::CAP_PROP_POS_MSEC);
        if (const std::string why = normalise(img, info_.width, info_.height, out.image); !why.empty()) {
            error_ = path_ + ": cannot decode frame " + std::to_string(next_) + ": " + why;
            return ReadStatus::Error;
        }
        out.index = next_;
        out.timestamp_us = clock_.next(ms);
        ++next_;
        return ReadStatus::Ok;
    }

private:

    // The decoder gave no more frames. Short of the count the container
    // gives (beyond the slack of a count estimated from the duration), the
    // file was cut or damaged: an error naming where, not an end that would
    // pass a part of the video off as the whole.
    // A container without a count: a note where its estimate said more.
    ReadStatus endOrCut() {
        const int64_t n = info_.frames > 0 ? info_.frames : estimate_;
        if (n <= 0 || next_ + std::max<int64_t>(2, n / 100) >= n) return ReadStatus::End;
        if (info_.frames <= 0) {
            notes_.push_back(path_ + ": " + std::to_string(next_) + " frames decoded where its duration suggested " +
                             std::to_string(n) + ": the video may be cut short or damaged (its container gives no "
                             "frame count)");
            return ReadStatus::End;
        }
        if (containerIsWhole(path_)) {  // not cut: frames counted and never shown
            notes_.push_back(path_ + ": " + std::to_string(next_) + " of the " + std::to_string(n) +
                             " frames its container counts were decoded; the file is whole (an edit list, or "
                             "frames the recorder dropped, are counted and not shown)");
            return ReadStatus::End;
        }
        error_ = path_ + ": only " + std::to_string(next_) + " of the " + std::to_string(n) +
                 " frames its container gives could be decoded: truncated or damaged (" + max_frames_name_ + " " +
                 std::to_string(next_) + " models those)";
        return ReadStatus::Error;
    }

    std::string path_;
    std::string max_frames_name_;
    cv::VideoCapture cap_;
    cv::Mat pending_, raw_;
    int64_t next_ = 0;
    int64_t estimate_ = -1;  // FFmpeg's estimate of the frames, where the container gives no count
    double pending_ms_ = 0;  // the first frame's presentation time (read by open())
    PresentationClock clock_;  // the frames' times (set with the rate by open())
};

// Several sources one after the other at the first one's size.
class ConcatSource final : public FrameSource {
public:
    explicit ConcatSource(std::vector<std::unique_ptr<FrameSource>> parts) : parts_(std::move(parts)) {
        info_ = parts_[0]->info();
        int64_t frames = 0;
        info_.description.clear();
        for (const auto& p : parts_) {
            if (!info_.description.empty()) info_.description += " + ";
            info_.description += p->info().description;
            frames = (frames < 0 || p->info().frames < 0) ? -1 : frames + p->info().frames;
            info_.live = info_.live || p->info().live;
        }
        info_.frames = frames;
    }

    ReadStatus read(Frame& out) override {
        while (cur_ < parts_.size()) {
            const ReadStatus s = parts_[cur_]->read(tmp_);
            if (s == ReadStatus::Ok) {
                if (const std::string why = normalise(tmp_.image, info_.width, info_.height, out.image);
                    !why.empty()) {
                    error_ = "cannot convert a frame of " + parts_[cur_]->info().description + ": " + why;
                    return ReadStatus::Error;
                }
                out.index = next_++;
                out.timestamp_us = offset_us_ + tmp_.timestamp_us;
                if (out.index > 0) step_us_ = out.timestamp_us - last_us_;
                last_us_ = out.timestamp_us;
                return ReadStatus::Ok;
            }
            if (s == ReadStatus::Error) {
                error_ = parts_[cur_]->error();
                return s;
            }
            // The next part starts a step after this one's last frame (the last step between two
            // frames; a first part of one frame: its nominal period).
            if (next_ > 0) offset_us_ = last_us_ + (step_us_ > 0 ? step_us_ : nominalPeriodUs(parts_[cur_]->info().fps));
            ++cur_;
        }
        return ReadStatus::End;
    }

    void interrupt() noexcept override {
        for (auto& p : parts_) p->interrupt();
    }
    std::vector<std::string> takeNotes() override {
        std::vector<std::string> out = std::exchange(notes_, {});
        for (auto& p : parts_)
            for (std::string& n : p->takeNotes()) out.push_back(std::move(n));
        return out;
    }

private:
    std::vector<std::unique_ptr<FrameSource>> parts_;
    std::size_t cur_ = 0;
    Frame tmp_;
    int64_t next_ = 0, offset_us_ = 0, last_us_ = 0, step_us_ = 0;
};

std::unique_ptr<FrameSource> openFiles(std::vector<std::string> files, const std::string& what,
                                       const SourceOptions& o, Status& status) {
    auto src = std::make_unique<ImageSequenceSource>(std::move(files), what);
    status = src->open(o);
    if (!status.ok()) return nullptr;
    return src;
}

} // namespace

bool inputWouldRead(const std::string& input, const std::string& path) {
    if (isCameraInput(input)) return false;
    std::error_code ec;
    if (isGlobInput(input)) {
        for (const std::string& f : globFiles(input))  // the files it reads now, under another spelling
            if (sameFile(f, path)) return true;
        const std::string pattern = fs::absolute(input, ec).lexically_normal().string();
        const std::string file = fs::absolute(path, ec).lexically_normal().string();
        return !ec && ::fnmatch(pattern.c_str(), file.c_str(), FNM_PATHNAME | FNM_PERIOD) == 0;
    }
    if (!fs::is_directory(input, ec)) return false;
    const fs::path file(path);  // a frame: an image file directly in the directory
    return isImageFile(file) && sameFile(file.has_parent_path() ? file.parent_path().string() : ".", input);
}

bool isCameraInput(const std::string& input) noexcept { return input.rfind("camera:", 0) == 0; }

bool isGlobInput(const std::string& input) noexcept {
    if (input.find_first_of("*?[") == std::string::npos) return false;
    std::error_code ec;  // a file or directory of that very name is itself ("dive [x3f].mov", as downloaders name them)
    return !fs::exists(input, ec);
}

std::unique_ptr<FrameSource> openFrameSource(const std::string& input, const SourceOptions& o, Status& status) {
    status = {};
    if (input.empty()) {
        status = Status::error("input: empty name");
        return nullptr;
    }
    if (isCameraInput(input)) {
        const std::string n = input.substr(7);
        char* end = nullptr;
        errno = 0;
        const long idx = std::strtol(n.c_str(), &end, 10);
        // Digits only, and an int: camera:4294967296 must not wrap to camera:0.
        if (n.empty() || n[0] < '0' || n[0] > '9' || *end != '\0' || errno || idx > std::numeric_limits<int>::max()) {
            status = Status::error(input + ": expected camera:N with N a camera number from 0");
            return nullptr;
        }
        return openCamera(static_cast<int>(idx), o, status);
    }
    if (isGlobInput(input)) {
        std::vector<std::string> files = globFiles(input);
        if (files.empty()) {
            status = Status::error(input + ": no files match");
            return nullptr;
        }
        for (const auto& f : files)
            if (::access(f.c_str(), R_OK) != 0) {
                const int err = errno;
                status = Status::fromErrno(err, f + ": cannot open: " + std::strerror(err));
                return nullptr;
            }
        return openFiles(std::move(files), "images " + input, o, status);
    }
    status = checkReadable(input);
    if (!status.ok()) return nullptr;
    std::error_code ec;
    if (fs::is_directory(input, ec)) {
        std::vector<std::string> files;
        for (const auto& e : fs::directory_iterator(input, ec)) {
            std::error_code entry;  // a link that leads nowhere (or to itself) is no frame: skipped, never thrown
            if (e.is_regular_file(entry) && isImageFile(e.path())) files.push_back(e.path().string());
        }
        if (ec) {
            status = Status::error(input + ": cannot list directory: " + ec.message());
            return nullptr;
        }
        if (files.empty()) {
            status = Status::error(input + ": directory holds no images (" + imageExtensionsText() + ")");
            return nullptr;
        }
        std::sort(files.begin(), files.end());
        return openFiles(std::move(files), "images in " + input, o, status);
    }
    if (isImageFile(input)) return openFiles({input}, "image " + input, o, status);
    auto src = std::make_unique<VideoSource>(input);
    status = src->open(o);
    if (!status.ok()) return nullptr;
    return src;
}

std::unique_ptr<FrameSource> openFrameSources(const std::vector<std::string>& inputs, const SourceOptions& o,
                                              Status& status) {
    if (inputs.empty()) {
        status = Status::error("no input given");
        return nullptr;
    }
    if (inputs.size() == 1) return openFrameSource(inputs[0], o, status);
    std::vector<std::unique_ptr<FrameSource>> parts;
    SourceOptions first = o;
    for (const auto& in : inputs) {
        auto s = openFrameSource(in, first, status);
        if (!s) return nullptr;
        if (parts.empty() && first.width <= 0) {
            first.width = s->info().width;
            first.height = s->info().height;
        }
        parts.push_back(std::move(s));
    }
    return std::make_unique<ConcatSource>(std::move(parts));
}

} // namespace rost::vision
