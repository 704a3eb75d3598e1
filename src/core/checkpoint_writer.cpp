// Periodic checkpoints of a running engine (rost/checkpoint.hpp,
// CheckpointWriter): the refiner copies its state into a preallocated file
// image, a writer thread seals and writes it atomically (docs/trust.md).

#include <chrono>
#include <filesystem>
#include <mutex>
#include <string>
#include <thread>

#include "checkpoint_image.hpp"
#include "rost/checkpoint.hpp"
#include "rost/text_io.hpp"

namespace rost {

using text::writeFileAtomic;

CheckpointWriter::CheckpointWriter(Engine& engine, std::string path) : engine_(engine), path_(std::move(path)) {}

std::unique_ptr<CheckpointWriter> CheckpointWriter::create(Engine& engine, std::string path, Status& status) {
    if (path.empty()) {
        status = Status::error("checkpoint: empty file name");
        return nullptr;
    }
    if (engine.running()) {
        status = Status::error(path + ": create the checkpoint writer before the engine starts");
        return nullptr;
    }
    std::unique_ptr<CheckpointWriter> w(new CheckpointWriter(engine, std::move(path)));
    try {
        status = detail::buildCheckpointImage(engine, w->image_, w->sections_);
        if (!status.ok()) return nullptr;
        // Temporaries (".<name>.tmpXXXXXX") killed writes left beside the file written (a link's target).
        namespace fs = std::filesystem;
        std::string written;
        if (status = text::linkTarget(w->path_, written); !status.ok()) return nullptr;
        const fs::path target(written);
        const fs::path dir = target.has_parent_path() ? target.parent_path() : fs::path(".");
        std::error_code ec;  // never thrown: a loop of links on the way is an error like any other
        if (!fs::is_directory(dir, ec)) {
            status = Status::error(StatusKind::NotFound, w->path_ + ": directory " + dir.string() + " does not exist");
            return nullptr;
        }
        std::string stale(1, '.');  // appended, not "." + name: GCC 12's -Wrestrict misreads that here
        (stale += target.filename().string()) += ".tmp";
        for (const auto& e : fs::directory_iterator(dir, ec)) {
            const std::string f = e.path().filename().string();
            if (f.size() == stale.size() + 6 && f.compare(0, stale.size(), stale) == 0) fs::remove(e.path(), ec);
        }
        // The first, full copy happens here, at set-up: captures on the
        // refining thread then copy only what changed.
        if (!detail::fillCheckpointImage(engine, w->image_.data(), w->sections_, true)) {
            status = Status::error(w->path_ + ": the engine's state does not match its layout");
            return nullptr;
        }
        w->full_.store(false, std::memory_order_relaxed);
        w->thread_ = std::thread([p = w.get()] { p->writerMain(); });
    } catch (const std::exception& e) {
        status = Status::error(w->path_ + ": cannot set up checkpoints: " + e.what());
        return nullptr;
    }
    status = {};
    return w;
}

CheckpointWriter::~CheckpointWriter() {
    if (!thread_.joinable()) return;
    for (;;) {
        uint32_t s = kIdle;
        if (state_.compare_exchange_weak(s, kStopping, std::memory_order_acq_rel)) break;
        if (s != kIdle) state_.wait(s, std::memory_order_acquire);
    }
    state_.notify_all();
    thread_.join();
}

bool CheckpointWriter::capture() noexcept {
    if (engine_.running() && !engine_.onRefinerThread()) {  // a torn image: refused, counted as failed
        failed_.fetch_add(1, std::memory_order_relaxed);
        return false;
    }
    uint32_t s = kIdle;
    if (!state_.compare_exchange_strong(s, kFilling, std::memory_order_acquire, std::memory_order_relaxed)) {
        skipped_.fetch_add(1, std::memory_order_relaxed);
        return false;
    }
    const auto t0 = std::chrono::steady_clock::now();
    const bool ok = detail::fillCheckpointImage(engine_, image_.data(), sections_, full_.exchange(false, std::memory_order_relaxed));
    const int64_t ns = (std::chrono::steady_clock::now() - t0).count();
    last_capture_ns_.store(ns, std::memory_order_relaxed);
    if (ns > max_capture_ns_.load(std::memory_order_relaxed)) max_capture_ns_.store(ns, std::memory_order_relaxed);
    if (!ok) {  // not reached: the state's size is fixed by the configuration
        failed_.fetch_add(1, std::memory_order_relaxed);
        state_.store(kIdle, std::memory_order_release);
        state_.notify_all();  // a flush() waiting on kFilling sees it end
        return false;
    }
    captured_.fetch_add(1, std::memory_order_relaxed);
    state_.store(kPending, std::memory_order_release);
    state_.notify_all();
    return true;
}

bool CheckpointWriter::captureEvery(uint64_t every, const ObservationResult& r) noexcept {
    if (every == 0 || r.step < 0 || (r.observation + 1) % every != 0) return false;
    return capture();
}

void CheckpointWriter::writerMain() {
    for (;;) {
        uint32_t s = state_.load(std::memory_order_acquire);
        while (s == kIdle || s == kFilling) {
            state_.wait(s, std::memory_order_acquire);
            s = state_.load(std::memory_order_acquire);
        }
        if (s == kStopping) return;
        // kPending: the image is ours until we set kIdle.
        const auto t0 = std::chrono::steady_clock::now();
        detail::sealCheckpointImage(image_, sections_);
        Status st = writeFileAtomic(path_, std::string_view(reinterpret_cast<const char*>(image_.data()), image_.size()));
        const int64_t ns = (std::chrono::steady_clock::now() - t0).count();
        last_write_ns_.store(ns, std::memory_order_relaxed);
        if (ns > max_write_ns_.load(std::memory_order_relaxed)) max_write_ns_.store(ns, std::memory_order_relaxed);
        {
            std::lock_guard<std::mutex> lock(error_mutex_);
            last_error_ = st.ok() ? std::string() : st.message();
        }
        (st.ok() ? written_ : failed_).fetch_add(1, std::memory_order_relaxed);
        state_.store(kIdle, std::memory_order_release);
        state_.notify_all();
    }
}

Status CheckpointWriter::flush() {
    for (;;) {
        const uint32_t s = state_.load(std::memory_order_acquire);
        if (s == kIdle || s == kStopping) break;
        state_.wait(s, std::memory_order_acquire);
    }
    std::lock_guard<std::mutex> lock(error_mutex_);
    return last_error_.empty() ? Status{} : Status::error(last_error_);
}

Status CheckpointWriter::finish() {
    if (engine_.running())
        return Status::error("checkpoint: finish() called while the engine is running (stop it first): " + path_);
    (void)flush();  // a periodic save still in progress: superseded by this one
    if (!capture()) return Status::error("checkpoint: the engine's state could not be captured: " + path_);
    return flush();
}

void CheckpointWriter::invalidate() noexcept { full_.store(true, std::memory_order_relaxed); }

CheckpointWriter::Stats CheckpointWriter::stats() const noexcept {
    Stats s;
    s.captured = captured_.load(std::memory_order_relaxed);
    s.skipped = skipped_.load(std::memory_order_relaxed);
    s.written = written_.load(std::memory_order_relaxed);
    s.failed = failed_.load(std::memory_order_relaxed);
    s.last_capture_ns = last_capture_ns_.load(std::memory_order_relaxed);
    s.max_capture_ns = max_capture_ns_.load(std::memory_order_relaxed);
    s.last_write_ns = last_write_ns_.load(std::memory_order_relaxed);
    s.max_write_ns = max_write_ns_.load(std::memory_order_relaxed);
    return s;
}

} // namespace rost
