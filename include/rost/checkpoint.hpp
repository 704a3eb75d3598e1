#pragma once

// Checkpoints: the whole state of an Engine (topic model, ring contents and
// labels, counters, RNG state, window bookkeeping, configuration) in one
// versioned binary file with checksums, written atomically, so a vehicle
// that loses power carries on where the last checkpoint left it. Under a
// count budget a resumed run continues bit for bit as if it had never
// stopped. See docs/trust.md.
//
// File format, version 1. Every integer is little-endian and fixed-width,
// every float IEEE-754 binary32/binary64 little-endian, whatever the host:
//
//   offset  size  field
//        0     8  magic "ROSTCKPT"
//        8     4  format version (1)
//       12     4  number of sections S (1 .. 256)
//       16     8  file size in bytes
//       24     4  reserved, 0
//       28     4  CRC-32C of bytes 0..27
//       32        S sections, back to back, each:
//                   +0   32  name, ASCII, NUL-padded
//                   +32   4  element width in bytes (1, 2, 4 or 8)
//                   +36   4  section version (0 for every section of format 1)
//                   +40   8  payload bytes P (a multiple of the width)
//                   +48   4  CRC-32C of the payload
//                   +52   4  CRC-32C of bytes +0..+51 of this section header
//                   +56   P  payload: P / width elements
//
// The file ends right after the last payload. Section 0 is "config": the
// EngineConfig as rost/config_file.hpp text (formatConfig), so a file made
// with another configuration is named key by key. Then come the sections
// of Engine::describeState (the Model's, then the engine's own; see
// rost/state_layout.hpp), in their order, each with the name, version,
// element width and size the layout gives for this configuration. This file
// only walks that layout; a section whose version differs from this
// build's is refused, naming both versions.
//
// Why CRC-32C (Castagnoli): it is what storage stacks use to catch the same
// faults (ext4 and btrfs metadata, iSCSI, SCTP), it detects every burst
// error up to 32 bits and every error of up to 3 bits in sections far
// larger than ours, and x86 (SSE4.2) and ARMv8 have instructions for it. It
// guards against torn writes, media corruption and truncation, not against
// an adversary: the loader checks every value's range and every count
// besides, so a file with valid checksums and hostile contents is refused
// too, never loaded into a state that could crash the engine.

#include <atomic>
#include <cstddef>
#include <cstdint>
#include <memory>
#include <mutex>
#include <span>
#include <string>
#include <string_view>
#include <thread>
#include <vector>

#include "rost/engine.hpp"
#include "rost/status.hpp"

namespace rost {

inline constexpr uint32_t kCheckpointVersion = 1;

// CRC-32C (Castagnoli, reflected polynomial 0x82F63B78), as iSCSI and ext4
// compute it: crc32c("123456789") == 0xE3069283. Chain by passing the
// previous result as `crc`.
uint32_t crc32c(std::span<const uint8_t> bytes, uint32_t crc = 0) noexcept;

// What a checkpoint says about itself (readCheckpointInfo / loadCheckpoint).
struct CheckpointInfo {
    uint32_t version = 0;
    uint64_t bytes = 0;           // file size
    EngineConfig config;          // the configuration it was made with
    uint64_t observations = 0;    // observations in the model (ingested)
    int64_t steps = 0;            // time steps (Model::steps())
    // Producer sequence number of the first observation not in the
    // checkpoint: a resumed stream starts there (observations queued but
    // not yet taken up when it was made are not in it).
    uint64_t next_sequence = 0;
    int64_t last_timestamp = 0;   // time stamp of the last observation ingested (when observations > 0)
    // Empty when every section whose size the configuration fixes and which
    // grows with it (n_kv, the ring's tables) is there with that size; else
    // which is not. A reader refuses such a file before building an engine
    // of the size its configuration claims (resumeEngine, planMission).
    std::string sizes_problem;
};

struct CheckpointLoadOptions {
    // The sampler, eta, q and budget may differ from the file's: the state
    // does not depend on them, but the resumed run then continues under the
    // new ones (not bit for bit). The model keys (K, V, alpha, ..., seed)
    // must always match; the runtime keys (queue, threads, flags) never need to.
    bool allow_refinement_change = false;
};

// ---- one-shot save and load (set-up code: allocates) -------------------------

// The checkpoint of `engine` as bytes. The engine must not be running (or
// the caller is the refining thread). Errors only for a state section this
// build does not know.
Status encodeCheckpoint(Engine& engine, std::vector<uint8_t>& out);
// encodeCheckpoint, then written atomically (temporary file in the same
// directory, fsync, rename, directory fsync): a crash leaves the previous
// file or the new one, never a torn one. Every error names `path`.
Status saveCheckpoint(Engine& engine, const std::string& path);

// Checks the header, every checksum and the configuration section, without
// an engine. `name` is used in messages.
Status inspectCheckpoint(std::span<const uint8_t> bytes, std::string_view name, CheckpointInfo& info);
Status readCheckpointInfo(const std::string& path, CheckpointInfo& info);

// Validates everything (header, checksums, configuration against the
// engine's, every section's name and size, every value's range, every count
// against the labels) before touching the engine; on error the engine is
// unchanged and the message names the file, the section and the byte
// offset. The engine must not be running and must have nothing queued.
Status loadCheckpoint(std::span<const uint8_t> bytes, std::string_view name, Engine& engine,
                      const CheckpointLoadOptions& options = {}, CheckpointInfo* info = nullptr);
Status loadCheckpoint(const std::string& path, Engine& engine, const CheckpointLoadOptions& options = {},
                      CheckpointInfo* info = nullptr);

// Builds an engine with the checkpoint's configuration and loads it: the
// tool's --resume. nullptr and `status` set on error. The bytes overload
// takes a file already read (a FIFO can be read once only), named `name`.
std::unique_ptr<Engine> resumeEngine(const std::string& path, Status& status, CheckpointInfo* info = nullptr);
std::unique_ptr<Engine> resumeEngine(std::span<const uint8_t> bytes, std::string_view name, Status& status,
                                     CheckpointInfo* info = nullptr);

namespace detail {
// Where one section sits in a file image.
struct CheckpointSlot {
    std::size_t header = 0;   // offset of the section header
    std::size_t payload = 0;  // offset of the payload
    std::size_t bytes = 0;
    uint32_t width = 1;
};
} // namespace detail

// ---- periodic checkpoints from the refiner's side ------------------------------

// Saves checkpoints of a running engine without stalling its refiner for
// more than a copy of what changed: capture() (on the refining thread, in
// the observation hook) copies the state into a preallocated file image and
// wakes a writer thread, which computes the checksums and writes the file
// atomically. The copy is proportional to the words the ring holds, not to
// its capacity, and skips the words, positions and surprises of ring steps
// already captured (they never change; only their labels and counts are
// copied again). If the previous image is still being written, capture()
// skips (and counts it) instead of waiting. The refiner's stall is measured
// by stats() and stated in bench/RESULTS.md.
//
// Wiring (the tool's --checkpoint FILE --checkpoint.every N):
//   auto writer = CheckpointWriter::create(engine, path, status);
//   engine.captureCheckpoints(writer.get(), N);   // the refiner calls captureEvery(N, r)
//   // (or, from an observation hook: writer->captureEvery(N, r))
//   engine.start(); ...; engine.stop();
//   Status st = writer->finish();   // the final state, written
class CheckpointWriter {
public:
    // Sizes the image for `engine` and copies its whole state into it
    // (set-up: before start(), after any loadCheckpoint), removes temporary
    // files a killed writer left beside `path`, starts the writer thread.
    static std::unique_ptr<CheckpointWriter> create(Engine& engine, std::string path, Status& status);
    ~CheckpointWriter();  // finishes a write in progress, then stops the thread

    CheckpointWriter(const CheckpointWriter&) = delete;
    CheckpointWriter& operator=(const CheckpointWriter&) = delete;

    // Copies the engine's state into the image and hands it to the writer
    // thread. Call on the refining thread (observation hook) or while the
    // engine is not running. False when skipped because the previous image
    // is still being written (a periodic capture: the next one is due
    // soon), or when called from another thread while the engine runs
    // (counted in stats().failed). No allocation, no lock; at most a futex wake.
    bool capture() noexcept;
    // capture() after every `every`-th observation taken up (r.observation + 1
    // a multiple of `every`); false when no capture was due or it was skipped.
    bool captureEvery(uint64_t every, const ObservationResult& r) noexcept;
    // The image is refreshed incrementally (ring slots whose step was complete
    // at the last capture keep their words); after replacing the engine's
    // state behind the writer's back (loadCheckpoint into the same engine),
    // call this so the next capture copies everything (a longer stall).
    void invalidate() noexcept;

    // Waits until no image is pending; the status of the last write.
    Status flush();
    // The engine's state now, written (set-up code, the engine stopped: the
    // end of a mission): waits out a write in progress (a periodic image
    // captured earlier), captures, and waits for this write; its status.
    // A capture() right after stop() may be skipped while an earlier image
    // is still being written, leaving an older state in the file.
    Status finish();

    struct Stats {
        uint64_t captured = 0;         // images copied
        uint64_t skipped = 0;          // captures skipped: the writer was busy
        uint64_t written = 0;          // files written
        uint64_t failed = 0;           // writes that failed (see flush()), and captures refused (capture())
        int64_t last_capture_ns = 0;   // refiner stall of the last capture
        int64_t max_capture_ns = 0;    // largest refiner stall
        int64_t last_write_ns = 0;     // writer thread: checksums + write + fsync + rename
        int64_t max_write_ns = 0;
    };
    Stats stats() const noexcept;
    std::size_t imageBytes() const noexcept { return image_.size(); }
    const std::string& path() const noexcept { return path_; }

private:
    CheckpointWriter(Engine& engine, std::string path);
    void writerMain();
    void fill() noexcept;

    enum : uint32_t { kIdle = 0, kFilling = 1, kPending = 2, kStopping = 3 };

    Engine& engine_;
    std::string path_;
    std::vector<uint8_t> image_;
    std::vector<detail::CheckpointSlot> sections_;
    std::size_t cursor_ = 0;  // section being filled (refining thread only)

    alignas(kCacheLine) std::atomic<uint32_t> state_{kIdle};
    std::atomic<bool> full_{true};  // the next capture copies everything
    alignas(kCacheLine) std::atomic<uint64_t> captured_{0};
    std::atomic<uint64_t> skipped_{0};
    std::atomic<int64_t> last_capture_ns_{0};
    std::atomic<int64_t> max_capture_ns_{0};
    alignas(kCacheLine) std::atomic<uint64_t> written_{0};
    std::atomic<uint64_t> failed_{0};
    std::atomic<int64_t> last_write_ns_{0};
    std::atomic<int64_t> max_write_ns_{0};
    mutable std::mutex error_mutex_;  // writer thread and flush() only, never the refiner
    std::string last_error_;
    std::thread thread_;
};

} // namespace rost
