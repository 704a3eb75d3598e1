#include "rost/checkpoint.hpp"

#include <algorithm>
#include <array>
#include <bit>
#include <chrono>
#include <cmath>
#include <cstddef>
#include <cstring>
#include <filesystem>
#include <limits>
#include <new>

#include "rost/config_file.hpp"
#include "kernel_tables.hpp"
#include "rost/state_layout.hpp"
#include "rost/text_io.hpp"

namespace rost {

using text::readFile, text::writeFileAtomic;

namespace {

// ---- fixed-width little-endian encoding ----------------------------------------------

constexpr char kMagic[8] = {'R', 'O', 'S', 'T', 'C', 'K', 'P', 'T'};
constexpr std::size_t kFileHeader = 32;
constexpr std::size_t kSectionHeader = 56;
constexpr std::size_t kNameBytes = 32;
constexpr uint32_t kMaxSections = 256;
constexpr uint32_t kConfigSectionVersion = 0;  // the "config" section's text format (formatConfig)
constexpr bool kLittleEndian = std::endian::native == std::endian::little;

void putU32(uint8_t* p, uint32_t v) noexcept {
    for (int i = 0; i < 4; ++i) p[i] = static_cast<uint8_t>(v >> (8 * i));
}
void putU64(uint8_t* p, uint64_t v) noexcept {
    for (int i = 0; i < 8; ++i) p[i] = static_cast<uint8_t>(v >> (8 * i));
}
uint32_t getU32(const uint8_t* p) noexcept {
    uint32_t v = 0;
    for (int i = 0; i < 4; ++i) v |= uint32_t{p[i]} << (8 * i);
    return v;
}
uint64_t getU64(const uint8_t* p) noexcept {
    uint64_t v = 0;
    for (int i = 0; i < 8; ++i) v |= uint64_t{p[i]} << (8 * i);
    return v;
}

// Copies `bytes` of `width`-byte host elements to little-endian (or back:
// the swap is its own inverse). A plain copy on little-endian hosts.
void copyLittleEndian(uint8_t* dst, const uint8_t* src, std::size_t bytes, uint32_t width) noexcept {
    if (kLittleEndian || width == 1) {
        if (bytes) std::memcpy(dst, src, bytes);
        return;
    }
    for (std::size_t i = 0; i + width <= bytes; i += width)
        for (uint32_t j = 0; j < width; ++j) dst[i + j] = src[i + width - 1 - j];
}

// Element `i` of a little-endian payload as T (an integer or float type).
template <typename T>
T element(const uint8_t* payload, std::size_t i) noexcept {
    using U = std::conditional_t<sizeof(T) == 1, uint8_t,
                                 std::conditional_t<sizeof(T) == 2, uint16_t,
                                                    std::conditional_t<sizeof(T) == 4, uint32_t, uint64_t>>>;
    const uint8_t* p = payload + i * sizeof(T);
    U u = 0;
    for (std::size_t b = 0; b < sizeof(T); ++b) u = static_cast<U>(u | static_cast<U>(U{p[b]} << (8 * b)));
    return std::bit_cast<T>(u);
}

// The engine's state as one layout (Engine::describeState): the sections
// after "config", each with its name, version, element width and size.
Status engineLayout(Engine& engine, StateLayout& layout) {
    layout.clear();
    engine.describeState(layout);
    if (layout.overflowed())
        return Status::error("checkpoint: the engine's state has more than " + std::to_string(StateLayout::kMaxSections) +
                             " sections");
    for (const StateSection& s : layout.sections()) {
        const bool widthOk = s.width == 1 || s.width == 2 || s.width == 4 || s.width == 8;
        if (s.name.empty() || s.name.size() >= kNameBytes || s.name == "config" || !widthOk || s.bytes % s.width != 0 ||
            s.size != SectionSize::Fixed || layout.find(s.name) != &s)
            return Status::error("checkpoint: state section '" + std::string(s.name) +
                                 "' cannot be stored (a unique name of 1..31 characters, a width of 1, 2, 4 or 8 "
                                 "bytes, a size fixed by the configuration)");
    }
    return {};
}

// Writes a section header (checksums are left for sealImage).
void putSectionHeader(uint8_t* h, std::string_view name, uint32_t version, uint32_t width, std::size_t bytes) noexcept {
    std::memcpy(h, name.data(), name.size());
    putU32(h + 32, width);
    putU32(h + 36, version);
    putU64(h + 40, bytes);
}

// The config section: the engine's settings as config-file text, without
// `threads` (the machine's, not the state's: a mission may resume on another
// board) and without `refine.window` when it is 1, which is what a
// checkpoint without the key means (written before refinement in windows
// existed: the serial sampler).
std::string checkpointConfigText(const EngineConfig& cfg) {
    const std::string all = formatConfig(cfg);  // a "key = value\n" line per setting
    const std::string defaults = "\n" + formatConfig(EngineConfig{});
    const auto isDefault = [&defaults](std::string_view line) {
        std::string key(1, '\n');  // appended: GCC 12 warns falsely on "\n" + string (-Wrestrict)
        key.append(line);
        key += '\n';
        return defaults.find(key) != std::string::npos;
    };
    std::string out;
    text::LineReader lines(all, {}, text::kEveryLine);
    for (text::Line l; lines.next(l);) {
        // Left out: what does not change the state, and the defaults of settings
        // newer than format 1 (so such checkpoints stay as they were). A gamma
        // other than its default stays even without growth: a resume that
        // repeats the command line's --gamma must find it.
        const std::string_view line = l.text;
        const bool newer = line == "topicmodel.fixed = false" ||
                           (!cfg.model.grow && (line == "topics.grow = false" || (line.starts_with("gamma = ") && isDefault(line))));
        if (!newer && !line.starts_with("threads = ") && line != "refine.window = 1") (out += line) += '\n';
    }
    return out;
}

// Lays out a file image: header, the config section (filled), then a
// section per state section (headers filled, payloads left for fillImage).
Status buildImage(Engine& engine, std::vector<uint8_t>& image, std::vector<detail::CheckpointSlot>& slots) {
    StateLayout layout;
    if (Status st = engineLayout(engine, layout); !st.ok()) return st;
    const std::string config = checkpointConfigText(engine.config());
    auto slotAt = [](std::size_t at, std::size_t bytes, uint32_t width) {
        return detail::CheckpointSlot{at, at + kSectionHeader, bytes, width};
    };
    slots.clear();
    slots.push_back(slotAt(kFileHeader, config.size(), 1));
    for (const StateSection& s : layout.sections())
        slots.push_back(slotAt(slots.back().payload + slots.back().bytes, s.bytes, s.width));
    const std::size_t size = slots.back().payload + slots.back().bytes;
    image.assign(size, 0);
    std::memcpy(image.data(), kMagic, sizeof kMagic);
    putU32(image.data() + 8, kCheckpointVersion);
    putU32(image.data() + 12, static_cast<uint32_t>(slots.size()));
    putU64(image.data() + 16, size);
    putSectionHeader(image.data() + slots[0].header, "config", kConfigSectionVersion, 1, config.size());
    for (std::size_t i = 0; i < layout.size(); ++i)
        putSectionHeader(image.data() + slots[i + 1].header, layout[i].name, layout[i].version, layout[i].width,
                         layout[i].bytes);
    std::memcpy(image.data() + slots[0].payload, config.data(), config.size());
    return {};
}

// One section of a file image beside its state section in the engine.
struct Pair {
    const uint8_t* src = nullptr;  // the engine's memory (stable while we copy)
    uint8_t* dst = nullptr;        // the payload in the image
    uint32_t width = 1;
    template <typename T>
    T state(std::size_t i) const noexcept {  // element i of the engine's state
        T v;
        std::memcpy(&v, src + i * sizeof(T), sizeof(T));
        return v;
    }
    template <typename T>
    T image(std::size_t i) const noexcept {  // element i as the image holds it
        return element<T>(dst, i);
    }
    // Elements [from, to): copied from the state, or zeroed.
    void copy(std::size_t from, std::size_t to) const noexcept {
        if (to > from) copyLittleEndian(dst + from * width, src + from * width, (to - from) * width, width);
    }
    void zero(std::size_t from, std::size_t to) const noexcept {
        if (to > from) std::memset(dst + from * width, 0, (to - from) * width);
    }
};

// The ring's sections are copied sparsely (Filler::fillRing); every other section whole.
constexpr std::string_view kRingSections[] = {
    "ring.slot_step", "ring.cell_n",    "ring.cell_words", "ring.cell_z", "ring.n_ck",         "ring.cell_surprise",
    "ring.in_word",   "ring.in_pos",    "ring.in_slot",    "ring.in_n",   "ring.obs_surprise",
};
enum Ring : std::size_t {
    kSlotStep, kCellN, kCellWords, kCellZ, kNck, kCellSurprise, kInWord, kInPos, kInSlot, kInN, kObsSurprise, kRingCount
};
static_assert(std::size(kRingSections) == kRingCount);

// Copies the engine's state into the payloads of an image laid out by
// buildImage. Runs on the refining thread: no allocation, no lock.
//
// The copy is proportional to what the ring holds, not to its capacity:
// only the words a cell holds (cell_n of them) and the inputs an
// observation kept (in_n) are copied, and what lies beyond them in the
// image is zero. This is also the canonical encoding: the bytes of a
// checkpoint depend on the engine's state alone, not on stale memory.
// Incremental: a ring slot whose time step was complete when the image was
// last filled and is still in the same slot has the same words, positions,
// input slots and surprises now; only its labels and topic counts, which
// refinement changes, are copied again. A fresh (zero) image copies all.
struct Filler {
    const Config& cfg;
    Pair ring[kRingCount];
    Pair frames;
    uint64_t imageFrames = 0;  // counters.frames as the image held it before this fill
    bool fresh = false;

    void fillRing() const noexcept {
        const auto slots = static_cast<std::size_t>(cfg.ring_steps);
        const auto ct = static_cast<std::size_t>(cfg.cell_time);
        // What the image held when it was last filled (a fresh image: nothing).
        uint64_t prevFrames = fresh ? 0 : imageFrames;
        if (frames.state<uint64_t>(0) < prevFrames) prevFrames = 0;  // not the same history
        for (std::size_t slot = 0; slot < slots; ++slot) {
            const auto step = ring[kSlotStep].state<int64_t>(slot);
            const bool same = step >= 0 && ring[kSlotStep].image<int64_t>(slot) == step &&
                              static_cast<uint64_t>(step + 1) * ct <= prevFrames;
            ring[kSlotStep].copy(slot, slot + 1);
            fillCells(slot, same);
            if (!same) fillInputs(slot);
        }
    }
    // The cells of one ring slot; `same`: its words are already in the image.
    void fillCells(std::size_t slot, bool same) const noexcept {
        const auto cells = static_cast<std::size_t>(cfg.cellsPerStep());
        const auto cap = static_cast<std::size_t>(cfg.cell_capacity);
        const auto Kp = static_cast<std::size_t>(kernel::paddedK(cfg.K));
        for (std::size_t c = 0; c < cells; ++c) {
            const std::size_t ci = slot * cells + c;
            const auto n = ring[kCellN].state<uint32_t>(ci);
            if (same) {
                // Words unchanged; labels and counts refined since.
                if (n > 0) {
                    ring[kCellZ].copy(ci * cap, ci * cap + n);
                    ring[kNck].copy(ci * Kp, (ci + 1) * Kp);
                }
                continue;
            }
            const auto before = ring[kCellN].image<uint32_t>(ci);
            ring[kCellN].copy(ci, ci + 1);
            ring[kCellWords].copy(ci * cap, ci * cap + n);
            ring[kCellZ].copy(ci * cap, ci * cap + n);
            ring[kCellWords].zero(ci * cap + n, ci * cap + before);
            ring[kCellZ].zero(ci * cap + n, ci * cap + before);
            ring[kNck].copy(ci * Kp, (ci + 1) * Kp);
            ring[kCellSurprise].copy(ci, ci + 1);
        }
    }
    // The kept inputs of the observations of one ring slot.
    void fillInputs(std::size_t slot) const noexcept {
        const auto ct = static_cast<std::size_t>(cfg.cell_time);
        const auto maxw = static_cast<std::size_t>(cfg.max_words_per_frame);
        for (std::size_t o = slot * ct; o < (slot + 1) * ct; ++o) {
            const auto n = ring[kInN].state<uint32_t>(o);
            const auto before = ring[kInN].image<uint32_t>(o);
            ring[kInN].copy(o, o + 1);
            ring[kObsSurprise].copy(o, o + 1);
            for (std::size_t s : {kInWord, kInPos, kInSlot}) {
                ring[s].copy(o * maxw, o * maxw + n);
                ring[s].zero(o * maxw + n, o * maxw + before);
            }
        }
    }
};

// Walks the engine's layout beside the image's sections (slot i + 1 holds
// layout section i): sections outside the ring are copied whole, the ring
// sparsely. False when the state no longer matches the image's layout.
bool fillImage(Engine& engine, uint8_t* image, const std::vector<detail::CheckpointSlot>& slots, bool fresh) noexcept {
    StateLayout layout;
    engine.describeState(layout);
    if (layout.overflowed() || slots.size() != layout.size() + 1) return false;
    Filler f{engine.config().model, {}, {}, 0, fresh};
    std::size_t bound = 0;
    for (std::size_t i = 0; i < layout.size(); ++i) {
        const StateSection& s = layout[i];
        const detail::CheckpointSlot& slot = slots[i + 1];
        if (slot.bytes != s.bytes || slot.width != s.width) return false;
        const Pair pair{static_cast<const uint8_t*>(s.data), image + slot.payload, s.width};
        if (s.name == "counters.frames" && s.bytes == sizeof(uint64_t)) {
            f.frames = pair;
            f.imageFrames = pair.image<uint64_t>(0);
        }
        const auto* ring = std::find(std::begin(kRingSections), std::end(kRingSections), s.name);
        if (ring != std::end(kRingSections)) {
            f.ring[ring - std::begin(kRingSections)] = pair;
            ++bound;
        } else {
            pair.copy(0, s.bytes / s.width);
        }
    }
    if (bound != kRingCount || !f.frames.src) return false;
    f.fillRing();
    return true;
}

// Computes every checksum of a filled image.
void sealImage(std::vector<uint8_t>& image, const std::vector<detail::CheckpointSlot>& slots) noexcept {
    for (const auto& s : slots) {
        uint8_t* h = image.data() + s.header;
        putU32(h + 48, crc32c({image.data() + s.payload, s.bytes}));
        putU32(h + 52, crc32c({h, 52}));
    }
    putU32(image.data() + 28, crc32c({image.data(), 28}));
}

// ---- parsing ------------------------------------------------------------------------

struct ParsedSection {
    std::string name;
    uint32_t width = 1;
    uint32_t version = 0;
    std::size_t header = 0;
    std::size_t payload = 0;
    std::size_t bytes = 0;
};

struct Parsed {
    uint32_t version = 0;
    std::size_t size = 0;
    std::vector<ParsedSection> sections;
    EngineConfig config;
};

std::string prefix(std::string_view name) { return std::string(name) + ": "; }

std::string range(std::size_t a, std::size_t b) {
    return "bytes " + std::to_string(a) + ".." + std::to_string(b == 0 ? 0 : b - 1);
}

std::string hex32(uint32_t v) {
    static const char* d = "0123456789abcdef";
    std::string s = "0x";
    for (int i = 7; i >= 0; --i) s += d[(v >> (4 * i)) & 0xFu];
    return s;
}

// A section header's name: 1..31 printable ASCII characters, NUL-padded.
Status parseSectionName(const uint8_t* h, const std::string& where, std::string& name) {
    std::size_t len = 0;
    while (len < kNameBytes && h[len] != 0) ++len;
    if (len == 0 || len == kNameBytes) return Status::error(where + ": name is empty or not NUL-terminated");
    for (std::size_t j = 0; j < len; ++j)
        if (h[j] < 0x21 || h[j] > 0x7e) return Status::error(where + ": name is not printable ASCII");
    for (std::size_t j = len; j < kNameBytes; ++j)
        if (h[j] != 0) return Status::error(where + ": name padding is not zero");
    name.assign(reinterpret_cast<const char*>(h), len);
    return {};
}

Status parseConfigSection(const uint8_t* b, std::string_view name, Parsed& out);

Status parseImage(std::span<const uint8_t> bytes, std::string_view name, Parsed& out) {
    const std::string P = prefix(name);
    const std::size_t n = bytes.size();
    const uint8_t* b = bytes.data();
    if (n < sizeof kMagic) {
        if (n == 0) return Status::error(P + "empty file, not a rost checkpoint");
        return Status::error(P + "not a rost checkpoint (only " + std::to_string(n) + " bytes)");
    }
    if (std::memcmp(b, kMagic, sizeof kMagic) != 0) {
        if (std::memcmp(b, "ROSTVOC", 7) == 0)
            return Status::error(P + "this is a rost vocabulary file, not a checkpoint");
        return Status::error(P + "not a rost checkpoint (no \"ROSTCKPT\" magic at byte 0)");
    }
    if (n < kFileHeader)
        return Status::error(P + "truncated: " + std::to_string(n) + " bytes, the file header alone is " +
                             std::to_string(kFileHeader));
    const uint32_t headerCrc = getU32(b + 28);
    const uint32_t version = getU32(b + 8);
    if (crc32c({b, 28}) != headerCrc)
        return Status::error(P + "file header (" + range(0, kFileHeader) + ") is corrupt: checksum mismatch");
    if (version != kCheckpointVersion)
        return Status::error(P + "checkpoint format version " + std::to_string(version) +
                             " is not supported (this build reads version " + std::to_string(kCheckpointVersion) +
                             ")");
    const uint32_t count = getU32(b + 12);
    const uint64_t declared = getU64(b + 16);
    if (getU32(b + 24) != 0) return Status::error(P + "file header: reserved field at byte 24 is not 0");
    if (count == 0 || count > kMaxSections)
        return Status::error(P + "file header: " + std::to_string(count) + " sections (expected 1.." +
                             std::to_string(kMaxSections) + ")");
    out.version = version;
    out.sections.clear();
    std::size_t at = kFileHeader;
    std::string previous = "the file header";
    for (uint32_t i = 0; i < count; ++i) {
        if (n - at < kSectionHeader)
            return Status::error(P + "truncated: the file ends at byte " + std::to_string(n) + ", inside the header of section " +
                                 std::to_string(i) + " (" + range(at, at + kSectionHeader) + ", after " + previous +
                                 "); the header says the file has " + std::to_string(declared) + " bytes");
        const uint8_t* h = b + at;
        if (crc32c({h, 52}) != getU32(h + 52))
            return Status::error(P + "header of section " + std::to_string(i) + " (" + range(at, at + kSectionHeader) +
                                 ", after " + previous + ") is corrupt: checksum mismatch");
        ParsedSection s;
        if (Status st = parseSectionName(h, P + "section " + std::to_string(i) + " at byte " + std::to_string(at), s.name);
            !st.ok())
            return st;
        s.width = getU32(h + 32);
        const uint64_t payloadBytes = getU64(h + 40);
        const std::string S = P + "section '" + s.name + "' (header at byte " + std::to_string(at) + "): ";
        if (s.width != 1 && s.width != 2 && s.width != 4 && s.width != 8)
            return Status::error(S + "element width " + std::to_string(s.width) + " (expected 1, 2, 4 or 8)");
        s.version = getU32(h + 36);
        if (payloadBytes % s.width != 0)
            return Status::error(S + std::to_string(payloadBytes) + " bytes is not a whole number of " +
                                 std::to_string(s.width) + "-byte elements");
        s.header = at;
        s.payload = at + kSectionHeader;
        if (payloadBytes > n - s.payload)
            return Status::error(P + "truncated: the file ends at byte " + std::to_string(n) + ", inside section '" +
                                 s.name + "' (payload " + range(s.payload, s.payload + payloadBytes) +
                                 "); the header says the file has " + std::to_string(declared) + " bytes");
        s.bytes = static_cast<std::size_t>(payloadBytes);
        const uint32_t crc = crc32c({b + s.payload, s.bytes});
        if (crc != getU32(h + 48))
            return Status::error(P + "section '" + s.name + "' (payload " + range(s.payload, s.payload + s.bytes) +
                                 ") is corrupt: checksum " + hex32(crc) + ", stored " + hex32(getU32(h + 48)));
        at = s.payload + s.bytes;
        previous = "section '" + s.name + "'";
        out.sections.push_back(std::move(s));
    }
    if (at != declared)
        return Status::error(P + "the sections end at byte " + std::to_string(at) + " but the header says the file has " +
                             std::to_string(declared) + " bytes");
    if (at != n)
        return Status::error(P + std::to_string(n - at) + " unexpected bytes after the last section (from byte " +
                             std::to_string(at) + ")");
    out.size = n;
    return parseConfigSection(b, name, out);
}

// Section 0: the configuration as config-file text.
Status parseConfigSection(const uint8_t* b, std::string_view name, Parsed& out) {
    const std::string P = prefix(name);
    const ParsedSection& c = out.sections[0];
    if (c.name != "config")
        return Status::error(P + "section 0 is '" + c.name + "', expected 'config'");
    if (c.version != kConfigSectionVersion)
        return Status::error(P + "section 'config' is version " + std::to_string(c.version) + ", this build reads version " +
                             std::to_string(kConfigSectionVersion));
    const std::string_view text(reinterpret_cast<const char*>(b + c.payload), c.bytes);
    EngineConfig cfg;
    cfg.model.refine_window = 1;  // absent: the serial sampler (checkpointConfigText)
    if (Status st = parseConfigText(text, std::string(name) + " [config section at byte " + std::to_string(c.payload) + "]", cfg);
        !st.ok())
        return st;
    out.config = cfg;
    return {};
}

const ParsedSection* findSection(const Parsed& p, std::string_view name) {
    for (const auto& s : p.sections)
        if (s.name == name) return &s;
    return nullptr;
}

// The sections whose sizes the configuration fixes and which grow with it
// (the vocabulary, the ring's cells, steps and words): each must be in the
// file with that size, so a small file cannot make a reader build an engine
// of gigabytes only to refuse the file. Empty when they all are; else which
// section is not.
std::string sizesProblem(const Parsed& p) {
    const Config& c = p.config.model;
    const auto times = [](std::initializer_list<uint64_t> xs) {  // saturating: no wrap to a match
        uint64_t r = 1;
        for (const uint64_t x : xs)
            if (__builtin_mul_overflow(r, x, &r)) return std::numeric_limits<uint64_t>::max();
        return r;
    };
    const uint64_t V = static_cast<uint64_t>(std::max(c.V, 0)), Kp = static_cast<uint64_t>(kernel::paddedK(c.K));
    const uint64_t ring = static_cast<uint64_t>(std::max(c.ring_steps, 0));
    const uint64_t cells = static_cast<uint64_t>(std::max(c.cellsPerStep(), 0));
    const uint64_t cap = static_cast<uint64_t>(std::max(c.cell_capacity, 0));
    const uint64_t ct = static_cast<uint64_t>(std::max(c.cell_time, 0));
    const uint64_t maxw = static_cast<uint64_t>(std::max(c.max_words_per_frame, 0));
    const std::pair<const char*, uint64_t> expect[] = {
        {"n_kv", times({V, Kp, 4})},
        {"ring.slot_step", times({ring, 8})},
        {"ring.cell_n", times({ring, cells, 4})},
        {"ring.cell_words", times({ring, cells, cap, 4})},
        {"ring.cell_z", times({ring, cells, cap, 2})},
        {"ring.n_ck", times({ring, cells, Kp, 4})},
        {"ring.cell_surprise", times({ring, cells, 4})},
        {"ring.in_word", times({ring, ct, maxw, 4})},
        {"ring.in_pos", times({ring, ct, maxw, 4})},
        {"ring.in_slot", times({ring, ct, maxw, 4})},
        {"ring.in_n", times({ring, ct, 4})},
        {"ring.obs_surprise", times({ring, ct, 4})},
    };
    for (const auto& [name, bytes] : expect)
        if (const ParsedSection* s = findSection(p, name); !s || s->bytes != bytes)
            return std::string("section '") + name + "' " +
                   (s ? "has " + std::to_string(s->bytes) + " bytes" : std::string("is missing")) +
                   ", the configuration in the file implies " + std::to_string(bytes);
    return {};
}

void fillInfo(const Parsed& p, std::span<const uint8_t> bytes, CheckpointInfo& info) {
    info = CheckpointInfo{};
    info.version = p.version;
    info.bytes = p.size;
    info.config = p.config;
    info.sizes_problem = sizesProblem(p);
    const uint8_t* b = bytes.data();
    if (const auto* s = findSection(p, "counters.frames"); s && s->bytes == 8) info.observations = getU64(b + s->payload);
    if (const auto* s = findSection(p, "counters.steps"); s && s->bytes == 8)
        info.steps = static_cast<int64_t>(getU64(b + s->payload));
    if (const auto* s = findSection(p, "engine.counters"); s && s->bytes == sizeof(EngineStateCounters))
        info.next_sequence = getU64(b + s->payload + offsetof(EngineStateCounters, next_sequence));
    if (const auto* s = findSection(p, "engine.window.timestamp"); s && info.observations > 0) {
        const std::size_t cap = std::max<std::size_t>(
            1, static_cast<std::size_t>(p.config.model.ring_steps) * static_cast<std::size_t>(p.config.model.cell_time));
        const std::size_t at = static_cast<std::size_t>((info.observations - 1) % cap) * 8;
        if (at + 8 <= s->bytes) info.last_timestamp = static_cast<int64_t>(getU64(b + s->payload + at));
    }
}

// ---- semantic validation ---------------------------------------------------------------

// Every value a Model or Engine could index with, divide by or count must be
// in range, so a file with valid checksums but hostile contents is refused.
// The model's sections are the store's to judge (Model::checkRestoredState,
// then checkInvariants, on a scratch model); the engine's cost estimates here.

// A problem in section `section`, element `index`, named with its byte in the file.
Status sectionProblem(const Parsed& p, std::string_view name, const std::string& section, std::size_t index,
                      const std::string& what) {
    const ParsedSection* s = findSection(p, section);
    const std::size_t byte = s ? s->payload + index * s->width : 0;
    return Status::error(prefix(name) + "section '" + section + "', element " + std::to_string(index) + " (byte " +
                         std::to_string(byte) + "): " + what);
}

// The time-budget predictors: finite, non-negative cost estimates.
Status checkPredictors(const Parsed& p, std::span<const uint8_t> bytes, std::string_view name) {
    const ParsedSection* pred = findSection(p, "engine.predictors");
    for (std::size_t i = 0; pred && i < pred->bytes / 8; ++i) {
        const double v = element<double>(bytes.data() + pred->payload, i);
        if (!(v >= 0.0 && v < 1e12)) {
            std::string what = "cost estimate ";
            text::appendNumber(what, v);  // shortest: "-1", "1e+300", "nan"
            return sectionProblem(p, name, pred->name, i, what + " ns is out of range [0, 1e12)");
        }
    }
    return {};
}

// Copies the file's sections into the state sections of the same names.
// The caller has checked that every section is there with the right size.
void restoreLayout(const StateLayout& layout, const Parsed& p, const uint8_t* bytes) noexcept {
    for (const StateSection& s : layout.sections()) {
        const ParsedSection* f = findSection(p, s.name);
        if (!f || f->bytes != s.bytes) continue;  // not reached: layouts were compared before
        copyLittleEndian(static_cast<uint8_t*>(s.data), bytes + f->payload, s.bytes, f->width);
    }
}

} // namespace

// The image's three steps for the writer (checkpoint_writer.cpp; checkpoint_image.hpp).
namespace detail {
Status buildCheckpointImage(Engine& engine, std::vector<uint8_t>& image, std::vector<CheckpointSlot>& slots) {
    return buildImage(engine, image, slots);
}
bool fillCheckpointImage(Engine& engine, uint8_t* image, const std::vector<CheckpointSlot>& slots, bool fresh) noexcept {
    return fillImage(engine, image, slots, fresh);
}
void sealCheckpointImage(std::vector<uint8_t>& image, const std::vector<CheckpointSlot>& slots) noexcept {
    sealImage(image, slots);
}
} // namespace detail

// ---- public API -----------------------------------------------------------------------

Status encodeCheckpoint(Engine& engine, std::vector<uint8_t>& out) {
    // Another thread's copy of a running engine's state would be torn (a
    // file that does not load): refused, as loading into a running engine is.
    if (engine.running() && !engine.onRefinerThread())
        return Status::error("checkpoint: cannot save a running engine from outside its refiner thread (stop it "
                             "first, or save in an observation hook)");
    std::vector<detail::CheckpointSlot> slots;
    if (Status st = buildImage(engine, out, slots); !st.ok()) return st;
    if (!fillImage(engine, out.data(), slots, true)) return Status::error("checkpoint: the engine's state changed size");
    sealImage(out, slots);
    return {};
}

Status saveCheckpoint(Engine& engine, const std::string& path) {
    std::vector<uint8_t> image;
    if (Status st = encodeCheckpoint(engine, image); !st.ok()) return st.prefixed(path + ": ");
    return writeFileAtomic(path, std::string_view(reinterpret_cast<const char*>(image.data()), image.size()));
}

Status inspectCheckpoint(std::span<const uint8_t> bytes, std::string_view name, CheckpointInfo& info) {
    Parsed p;
    if (Status st = parseImage(bytes, name, p); !st.ok()) return st;
    fillInfo(p, bytes, info);
    return {};
}

Status readCheckpointInfo(const std::string& path, CheckpointInfo& info) {
    std::string data;
    if (Status st = readFile(path, data); !st.ok()) return st;
    return inspectCheckpoint({reinterpret_cast<const uint8_t*>(data.data()), data.size()}, path, info);
}

namespace {

// The configuration: the model keys define what the state means.
Status checkConfig(const Parsed& p, const EngineConfig& mine, const CheckpointLoadOptions& options,
                   const std::string& P) {
    std::vector<std::string> diffs = configDifferences(p.config, mine, {ConfigGroup::Model}, "the checkpoint", "this run");
    if (!options.allow_refinement_change) {
        auto more = configDifferences(p.config, mine, {ConfigGroup::Refinement}, "the checkpoint", "this run");
        diffs.insert(diffs.end(), more.begin(), more.end());
    }
    if (diffs.empty()) return {};
    std::string msg = P + "checkpoint was made with a different configuration: ";
    for (std::size_t i = 0; i < diffs.size(); ++i) msg += (i ? "; " : "") + diffs[i];
    return Status::error(msg);
}

// Every section of the layout by name, version and size, in order.
Status checkSections(const Parsed& p, const StateLayout& layout, const std::string& P) {
    if (p.sections.size() != layout.size() + 1)
        return Status::error(P + std::to_string(p.sections.size()) + " sections, this build expects " +
                             std::to_string(layout.size() + 1) + " for this configuration");
    for (std::size_t i = 0; i < layout.size(); ++i) {
        const ParsedSection& s = p.sections[i + 1];
        const StateSection& e = layout[i];
        if (s.name != e.name || s.bytes != e.bytes || s.width != e.width)
            return Status::error(P + "section " + std::to_string(i + 1) + " (header at byte " + std::to_string(s.header) +
                                 ") is '" + s.name + "' of " + std::to_string(s.bytes) + " bytes, expected '" +
                                 std::string(e.name) + "' of " + std::to_string(e.bytes) + " bytes");
        if (s.version != e.version)
            return Status::error(P + "section '" + s.name + "' (header at byte " + std::to_string(s.header) +
                                 ") is version " + std::to_string(s.version) + ", this build reads version " +
                                 std::to_string(e.version));
    }
    return {};
}

// The file's model sections in a scratch model: every value in range
// (Model::checkRestoredState; then the engine's predictors), then the
// counts against the labels.
Status checkOnScratchModel(const Parsed& p, std::span<const uint8_t> bytes, const Config& cfg, std::string_view name) {
    const std::string P = prefix(name);
    try {
        Model scratch(cfg);
        StateLayout layout;
        scratch.describeState(layout);
        restoreLayout(layout, p, bytes.data());
        StateProblem problem;
        if (!scratch.checkRestoredState(problem))
            return sectionProblem(p, name, problem.section, problem.element, problem.what);
        if (Status st = checkPredictors(p, bytes, name); !st.ok()) return st;
        scratch.stateRestored();
        std::string why;
        if (!scratch.checkInvariants(&why)) return Status::error(P + "the model state is inconsistent: " + why);
    } catch (const std::bad_alloc&) {
        return Status::error(StatusKind::OutOfMemory, P + "not enough memory to validate the checkpoint");
    }
    return {};
}

} // namespace

Status loadCheckpoint(std::span<const uint8_t> bytes, std::string_view name, Engine& engine,
                      const CheckpointLoadOptions& options, CheckpointInfo* info) {
    const std::string P = prefix(name);
    if (engine.running()) return Status::error(P + "cannot load a checkpoint into a running engine (stop it first)");
    if (engine.queued() != 0)
        return Status::error(P + "cannot load a checkpoint while " +
                             text::counted(static_cast<long long>(engine.queued()), "observation") +
                             (engine.queued() == 1 ? " is queued" : " are queued"));
    Parsed p;
    if (Status st = parseImage(bytes, name, p); !st.ok()) return st;
    if (Status st = checkConfig(p, engine.config(), options, P); !st.ok()) return st;
    StateLayout layout;
    if (Status st = engineLayout(engine, layout); !st.ok()) return st;
    if (Status st = checkSections(p, layout, P); !st.ok()) return st;
    // Every value in range, then every count against the labels.
    if (Status st = checkOnScratchModel(p, bytes, engine.config().model, name); !st.ok()) return st;

    // Everything checked: now the engine.
    restoreLayout(layout, p, bytes.data());
    if (Status st = engine.applyState(); !st.ok()) return Status::error(P + st.message());
    if (info) fillInfo(p, bytes, *info);
    return {};
}

Status loadCheckpoint(const std::string& path, Engine& engine, const CheckpointLoadOptions& options,
                      CheckpointInfo* info) {
    std::string data;
    if (Status st = readFile(path, data); !st.ok()) return st;
    return loadCheckpoint({reinterpret_cast<const uint8_t*>(data.data()), data.size()}, path, engine, options, info);
}

std::unique_ptr<Engine> resumeEngine(const std::string& path, Status& status, CheckpointInfo* info) {
    std::string data;
    status = readFile(path, data);
    if (!status.ok()) return nullptr;
    return resumeEngine({reinterpret_cast<const uint8_t*>(data.data()), data.size()}, path, status, info);
}

std::unique_ptr<Engine> resumeEngine(std::span<const uint8_t> bytes, std::string_view name, Status& status,
                                     CheckpointInfo* info) {
    Parsed p;
    if (status = parseImage(bytes, name, p); !status.ok()) return nullptr;
    // Before building an engine of the size the file claims (sizesProblem).
    if (const std::string why = sizesProblem(p); !why.empty()) {
        status = Status::error(prefix(name) + why);
        return nullptr;
    }
    std::unique_ptr<Engine> engine = Engine::create(p.config, status);
    if (!engine) status = status.prefixed(prefix(name));
    else status = loadCheckpoint(bytes, name, *engine, {}, info);
    return status.ok() ? std::move(engine) : nullptr;
}

} // namespace rost
