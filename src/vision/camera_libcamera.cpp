// The libcamera frame source. Every libcamera call of the project is in this
// file; API differences between libcamera releases are guarded on
// LIBCAMERA_VERSION_MAJOR / MINOR (Debian 12 ships 0.0.3).
//
// Threads and hand-off:
//   libcamera's thread  --requestCompleted--> onRequestCompleted(): pushes the
//                        Request* into a lock-free single-producer ring and
//                        wakes the capture thread; nothing else.
//   capture thread      (whoever calls read(): the tool's producer thread)
//                        takes the newest completed request, requeues older
//                        ones at once (stale frames are skipped and counted),
//                        converts the mapped buffer to BGR, requeues it
//                        with Request::ReuseBuffers.
// Buffers are mapped once at set-up and unmapped at the end; requests are
// created once and reused. In steady state read() allocates nothing.

#include <sys/mman.h>
#include <unistd.h>

#include <array>
#include <atomic>
#include <cstring>
#include <map>

#include <libcamera/libcamera.h>
#include <libcamera/version.h>

#include <opencv2/imgproc.hpp>

#include "camera_source.hpp"
#include "rost/vision/pixel_format.hpp"
#include "spsc_ring.hpp"

namespace rost::vision {

namespace {

constexpr std::size_t kCacheLine = 64;
constexpr unsigned kMaxBuffers = 16;

// libcamera logs INFO and WARN lines to stderr by default; the tool wants one
// line per problem. Its logger reads LIBCAMERA_LOG_LEVELS once, when it is
// created (on first use), and applies it to categories created later too,
// which logSetLevel() does not; so the variable is set, unless the user set
// it. ROST_LIBCAMERA_LOG=1 keeps libcamera's own logging.
void quietLogging() {
    if (const char* v = std::getenv("ROST_LIBCAMERA_LOG"); v && *v == '1') return;
    ::setenv("LIBCAMERA_LOG_LEVELS", "*:ERROR", 0);
}

std::string cameraName(const libcamera::Camera& cam) {
    std::string s = cam.id();
    const auto model = cam.properties().get(libcamera::properties::Model);
    if (model) s += " (" + *model + ")";
    return s;
}

std::vector<std::string> describeCameras(const libcamera::CameraManager& cm) {
    std::vector<std::string> out;
    const auto cams = cm.cameras();
    for (std::size_t i = 0; i < cams.size(); ++i) out.push_back(std::to_string(i) + ": " + cameraName(*cams[i]));
    return out;
}

std::string seeList(const std::vector<std::string>& cams) {
    if (cams.empty()) return "libcamera sees no camera";
    std::string s = "libcamera sees " + std::to_string(cams.size()) + (cams.size() == 1 ? " camera: " : " cameras: ");
    for (std::size_t i = 0; i < cams.size(); ++i) s += (i ? "; " : "") + cams[i];
    return s;
}

class LibcameraSource final : public FrameSource {
public:
    LibcameraSource() = default;
    ~LibcameraSource() override { shutdown(); }

    Status open(int index, const SourceOptions& o) {
        quietLogging();
        cm_ = std::make_unique<libcamera::CameraManager>();
        if (int rc = cm_->start(); rc < 0)
            return Status::error("camera:" + std::to_string(index) + ": no camera found (libcamera camera manager "
                                 "failed to start: " + std::strerror(-rc) + ")");
        managerStarted_ = true;
        const auto cams = cm_->cameras();
        if (index < 0 || static_cast<std::size_t>(index) >= cams.size())
            return Status::error("camera:" + std::to_string(index) + ": no camera found (" +
                                 seeList(describeCameras(*cm_)) + ")");
        camera_ = cams[static_cast<std::size_t>(index)];
        const std::string what = "camera:" + std::to_string(index) + " " + cameraName(*camera_);
        if (camera_->acquire() < 0) return Status::error(what + ": busy (another program holds it)");
        acquired_ = true;

        // One stream for video, in a pixel format this library converts.
        std::vector<libcamera::StreamRole> roles{libcamera::StreamRole::VideoRecording};
#if LIBCAMERA_VERSION_MAJOR == 0 && LIBCAMERA_VERSION_MINOR < 1
        config_ = camera_->generateConfiguration(roles);  // takes a StreamRoles vector
#else
        config_ = camera_->generateConfiguration(libcamera::Span<const libcamera::StreamRole>(roles));
#endif
        if (!config_ || config_->empty()) return Status::error(what + ": cannot generate a video configuration");
        libcamera::StreamConfiguration& sc = config_->at(0);
        const std::vector<libcamera::PixelFormat> offered = sc.formats().pixelformats();
        auto offers = [&](PixelFormat f) {
            for (const auto& p : offered)
                if (p.fourcc() == toFourcc(f) && p.modifier() == 0) return true;
            return false;
        };
        PixelFormat chosen = PixelFormat::Unknown;
        if (!o.camera_format.empty()) {
            chosen = parsePixelFormat(o.camera_format);
            if (chosen == PixelFormat::Unknown || !offers(chosen))
                return Status::error(what + ": pixel format " + o.camera_format + " is not offered or not supported");
        } else {
            for (PixelFormat f : supportedPixelFormats())
                if (offers(f)) {
                    chosen = f;
                    break;
                }
        }
        if (chosen == PixelFormat::Unknown) {
            std::string list;
            for (const auto& p : offered) list += (list.empty() ? "" : ", ") + p.toString();
            return Status::error(what + ": offers no pixel format rost converts (offers: " + list + ")");
        }
        sc.pixelFormat = libcamera::PixelFormat(toFourcc(chosen));
        sc.size = libcamera::Size(static_cast<unsigned>(o.camera_width), static_cast<unsigned>(o.camera_height));
        sc.bufferCount = static_cast<unsigned>(std::clamp(o.camera_buffers, 2, static_cast<int>(kMaxBuffers)));
        if (config_->validate() == libcamera::CameraConfiguration::Invalid)
            return Status::error(what + ": configuration " + sc.toString() + " is invalid");
        format_ = fromFourcc(sc.pixelFormat.fourcc());
        if (format_ == PixelFormat::Unknown || sc.pixelFormat.modifier() != 0)
            return Status::error(what + ": the camera adjusted the pixel format to " + sc.pixelFormat.toString() +
                                 ", which rost does not convert");
        if (camera_->configure(config_.get()) < 0)
            return Status::error(what + ": cannot configure " + sc.toString());
        stream_ = sc.stream();
        width_ = static_cast<int>(sc.size.width);
        height_ = static_cast<int>(sc.size.height);
        stride_ = sc.stride;

        // Buffers: allocated, mapped and wrapped in requests once.
        allocator_ = std::make_unique<libcamera::FrameBufferAllocator>(camera_);
        if (allocator_->allocate(stream_) < 0) return Status::error(what + ": cannot allocate capture buffers");
        const auto& buffers = allocator_->buffers(stream_);
        if (buffers.empty() || buffers.size() > kMaxBuffers)
            return Status::error(what + ": got " + std::to_string(buffers.size()) + " buffers, expected 1.." +
                                 std::to_string(kMaxBuffers));
        views_.resize(buffers.size());
        for (std::size_t b = 0; b < buffers.size(); ++b) {
            Status st = mapBuffer(*buffers[b], views_[b]);
            if (!st.ok()) return Status::error(what + ": " + st.message());
            std::unique_ptr<libcamera::Request> req = camera_->createRequest(b);
            if (!req || req->addBuffer(stream_, buffers[b].get()) < 0)
                return Status::error(what + ": cannot create capture request " + std::to_string(b));
            requests_.push_back(std::move(req));
        }

        // Sized once: the converted frame and the repack scratch.
        bgr_.create(height_, width_, CV_8UC3);
        if (Status st = chooseSize(o, width_, height_, info_, notes_); !st.ok()) return st.prefixed(what + ": ");
        info_.fps = 0.0;
        info_.frames = -1;
        info_.live = true;
        info_.description = what + " (" + std::to_string(width_) + "x" + std::to_string(height_) + " " +
                            toString(format_) + ", " + std::to_string(buffers.size()) + " buffers)";

        // Connect before start, then queue every request.
        camera_->requestCompleted.connect(this, &LibcameraSource::onRequestCompleted);
        connected_ = true;
        if (camera_->start() < 0) return Status::error(what + ": cannot start capture");
        started_ = true;
        for (auto& r : requests_)
            if (camera_->queueRequest(r.get()) < 0) return Status::error(what + ": cannot queue a capture request");
        return {};
    }

    ReadStatus read(Frame& out) override {
        for (;;) {
            // The signal before the ring: a completion after this load changes it, so the wait returns.
            const uint32_t seen = signal_.load(std::memory_order_acquire);
            if (completed_.front() == nullptr) {
                if (stop_.load(std::memory_order_acquire)) return ReadStatus::End;
                signal_.wait(seen, std::memory_order_acquire);
                continue;
            }
            // Newest completed request wins; older ones go straight back to the camera.
            libcamera::Request* newest = nullptr;
            while (libcamera::Request** slot = completed_.front()) {
                libcamera::Request* r = *slot;
                completed_.pop();
                if (newest) {
                    requeue(newest);
                    ++skipped_;
                }
                newest = r;
            }
            if (newest->status() != libcamera::Request::RequestComplete) {
                requeue(newest);
                continue;
            }
            const libcamera::FrameBuffer* fb = newest->buffers().begin()->second;
            const std::size_t b = static_cast<std::size_t>(newest->cookie());
            const bool ok = b < views_.size() && convertToBgr(views_[b], bgr_, scratch_);
            const uint64_t ts = fb->metadata().timestamp;
            requeue(newest);
            if (!ok) {
                error_ = info_.description + ": cannot convert a " + toString(format_) + " frame";
                return ReadStatus::Error;
            }
            if (frames_ == 0) t0_ns_ = ts;
            if (width_ == info_.width && height_ == info_.height) bgr_.copyTo(out.image);
            else cv::resize(bgr_, out.image, cv::Size(info_.width, info_.height), 0, 0, cv::INTER_AREA);
            out.index = frames_++;
            out.timestamp_us = static_cast<int64_t>((ts - t0_ns_) / 1000);
            return ReadStatus::Ok;
        }
    }

    void interrupt() noexcept override {
        stop_.store(true, std::memory_order_release);
        signal_.fetch_add(1, std::memory_order_release);
        signal_.notify_all();
    }

private:
    // Runs on libcamera's thread: hand the request over and return.
    void onRequestCompleted(libcamera::Request* r) {
        if (r->status() == libcamera::Request::RequestCancelled) return;
        // Never full: at most kMaxBuffers requests exist.
        libcamera::Request** slot = completed_.beginPush();
        if (slot == nullptr) return;
        *slot = r;
        completed_.commitPush();
        signal_.fetch_add(1, std::memory_order_release);
        signal_.notify_one();
    }

    void requeue(libcamera::Request* r) noexcept {
        if (stop_.load(std::memory_order_acquire)) return;
        r->reuse(libcamera::Request::ReuseBuffers);
        camera_->queueRequest(r);
    }

    Status mapBuffer(const libcamera::FrameBuffer& fb, ImageView& view) {
        // Each dma-buf once, as a whole (planes may share one).
        std::map<int, std::size_t> extent;
        for (const auto& p : fb.planes()) {
            const int fd = p.fd.get();
            extent[fd] = std::max(extent[fd], static_cast<std::size_t>(p.offset) + p.length);
        }
        std::map<int, const uint8_t*> base;
        for (const auto& [fd, len] : extent) {
            void* addr = ::mmap(nullptr, len, PROT_READ, MAP_SHARED, fd, 0);
            if (addr == MAP_FAILED) return Status::error(std::string("cannot map a capture buffer: ") + std::strerror(errno));
            maps_.push_back({addr, len});
            base[fd] = static_cast<const uint8_t*>(addr);
        }
        view = ImageView{};
        view.format = format_;
        view.width = width_;
        view.height = height_;
        const auto& planes = fb.planes();
        const int n = planeCount(format_);
        if (static_cast<int>(planes.size()) == 1 && n > 1) {
            // All planes in one buffer, back to back.
            const auto& p = *planes.begin();
            return describeContiguous(format_, width_, height_, stride_, base[p.fd.get()] + p.offset, p.length, view);
        }
        if (static_cast<int>(planes.size()) != n)
            return Status::error(std::string(toString(format_)) + " buffer has " + std::to_string(planes.size()) +
                                 " planes, expected " + std::to_string(n));
        int i = 0;
        for (const auto& p : planes) {
            const std::size_t ps = i == 0 ? stride_ : (format_ == PixelFormat::YUV420 ? stride_ / 2 : stride_);
            view.planes[static_cast<std::size_t>(i)] = {base[p.fd.get()] + p.offset, ps, p.length};
            ++i;
        }
        return {};
    }

    void shutdown() {
        stop_.store(true, std::memory_order_release);
        if (started_) camera_->stop();  // cancels pending requests (their completions are ignored)
        started_ = false;
        if (connected_) camera_->requestCompleted.disconnect(this, &LibcameraSource::onRequestCompleted);
        connected_ = false;
        requests_.clear();
        for (const auto& m : maps_) ::munmap(m.addr, m.len);
        maps_.clear();
        if (allocator_ && stream_) allocator_->free(stream_);
        allocator_.reset();
        if (acquired_) camera_->release();
        acquired_ = false;
        config_.reset();
        camera_.reset();
        if (managerStarted_) cm_->stop();
        managerStarted_ = false;
        cm_.reset();
    }

    std::unique_ptr<libcamera::CameraManager> cm_;
    std::shared_ptr<libcamera::Camera> camera_;
    std::unique_ptr<libcamera::CameraConfiguration> config_;
    std::unique_ptr<libcamera::FrameBufferAllocator> allocator_;
    std::vector<std::unique_ptr<libcamera::Request>> requests_;
    libcamera::Stream* stream_ = nullptr;
    struct Mapping {
        void* addr;
        std::size_t len;
    };
    std::vector<Mapping> maps_;
    std::vector<ImageView> views_;  // per buffer (= request cookie)
    PixelFormat format_ = PixelFormat::Unknown;
    int width_ = 0, height_ = 0;
    std::size_t stride_ = 0;
    bool managerStarted_ = false, acquired_ = false, connected_ = false, started_ = false;

    cv::Mat bgr_, scratch_;
    int64_t frames_ = 0;
    uint64_t t0_ns_ = 0;
    uint64_t skipped_ = 0;  // completed frames requeued unread because a newer one was waiting

    // Completed requests: libcamera's thread produces, the capture thread consumes.
    SpscRing<libcamera::Request*> completed_{kMaxBuffers};
    alignas(kCacheLine) std::atomic<uint32_t> signal_{0};
    std::atomic<bool> stop_{false};
};

} // namespace

std::unique_ptr<FrameSource> openCamera(int index, const SourceOptions& options, Status& status) {
    auto src = std::make_unique<LibcameraSource>();
    status = src->open(index, options);
    if (!status.ok()) return nullptr;
    return src;
}

std::vector<std::string> listCameras() {
    quietLogging();
    libcamera::CameraManager cm;
    if (cm.start() < 0) return {};
    std::vector<std::string> out = describeCameras(cm);
    cm.stop();
    return out;
}

bool haveLibcamera() noexcept { return true; }

} // namespace rost::vision
