#pragma once

// A vocabulary of binary (ORB) visual words: K centres in 256-bit Hamming
// space, the quantiser that maps a descriptor to its nearest centre, the
// k-majority trainer that makes one, and its versioned file format.
//
// This header needs only the standard library (no OpenCV), so a vocabulary
// can be loaded and used wherever descriptors come from.
//
// File format (all integers little-endian), version 1:
//
//   offset  size  field
//        0     8  magic "ROSTVOC\0"
//        8     4  version (1)
//       12     4  number of words W (1 .. 1,000,000)
//       16     4  bytes per descriptor D (32 = 256 bits, ORB)
//       20     4  length N of the UTF-8 note (0 .. 65,536)
//       24     4  CRC-32 (IEEE 802.3: zlib's crc32) of everything after the header
//       28     4  reserved, 0
//       32     N  note: free text saying how the vocabulary was made
//     32+N   W*D  the words' descriptors, word 0 first, bytes as the extractor produced them
//
// The file ends exactly after the last descriptor. Word ids are the order in
// the file, so a vocabulary's ids never change once it is written.

#include <array>
#include <cstddef>
#include <cstdint>
#include <functional>
#include <span>
#include <string>
#include <vector>

#include "rost/status.hpp"
#include "rost/word_settings.hpp"

namespace rost::vision {

// One 256-bit binary descriptor (an ORB descriptor's 32 bytes). Hamming
// distance is independent of how the bytes are grouped into words, so the
// bytes are copied as they are; the file and memory layouts agree on every
// architecture. Deliberately not over-aligned: GCC for 32-bit ARM does not
// realign the stack for alignas(32) locals, yet would emit aligned NEON
// loads for them (a bus error on armhf).
struct Descriptor {
    static constexpr std::size_t kBytes = 32;
    std::array<uint64_t, 4> w{};

    static Descriptor fromBytes(const uint8_t* bytes) noexcept;
    void toBytes(uint8_t* bytes) const noexcept;
    bool operator==(const Descriptor&) const = default;
};

// Hamming distance of two descriptors (0..256).
int hammingDistance(const Descriptor& a, const Descriptor& b) noexcept;

// How quantize() finds a descriptor's word (rost/word_settings.hpp): Linear
// is exact; Tree computes distances to ~sqrt(W) coarse centres, then only to
// the words of the `probes` nearest coarse buckets, approximate unless
// probes >= coarseCentres() (bench/bench_vision.cpp measures how often it
// agrees with Linear).
using rost::SearchMethod;
const char* toString(SearchMethod m) noexcept;
// Parses "linear" or "tree".
Status parseSearchMethod(const std::string& text, SearchMethod& out);

struct Search {
    SearchMethod method = settingDefault<SearchMethod>("orb.search");
    // Coarse buckets visited by Tree. 16 of the ~71 buckets of a 5000-word
    // vocabulary agree with the exact word for ~98% of ORB descriptors of real
    // footage, at about a quarter of the distance computations (bench_vision).
    uint32_t probes = settingDefault<uint32_t>("orb.probes");
};

class Vocabulary {
public:
    static constexpr uint32_t kFormatVersion = 1;
    static constexpr uint32_t kMaxWords = 1000000;
    static constexpr uint32_t kMaxNoteBytes = 65536;

    Vocabulary() = default;
    // Takes the words (ids in order) and a note on their provenance; builds the index.
    explicit Vocabulary(std::vector<Descriptor> words, std::string note = {});

    [[nodiscard]] uint32_t size() const noexcept { return static_cast<uint32_t>(words_.size()); }
    [[nodiscard]] bool empty() const noexcept { return words_.empty(); }
    [[nodiscard]] const Descriptor& word(uint32_t id) const noexcept { return words_[id]; }
    [[nodiscard]] std::span<const Descriptor> words() const noexcept { return words_; }
    [[nodiscard]] const std::string& note() const noexcept { return note_; }

    // Id of the word nearest to d in Hamming distance among the words the
    // search visits, ties to the lowest id. Deterministic, allocation-free and
    // thread-safe (const). Precondition: !empty().
    [[nodiscard]] uint32_t quantize(const Descriptor& d, const Search& s = {}) const noexcept;
    // The word and its distance.
    [[nodiscard]] uint32_t quantize(const Descriptor& d, int& distance, const Search& s) const noexcept;
    // Quantises `count` descriptors stored as rows of `stride` bytes (an OpenCV
    // descriptor matrix: rows x 32 bytes) into out[0..count).
    void quantizeRows(const uint8_t* rows, std::size_t stride, std::size_t count, uint32_t* out,
                      const Search& s = {}) const noexcept;

    // Index statistics: coarse centres (0 for vocabularies under 256 words,
    // which Tree scans linearly), and how many distances one query computes.
    [[nodiscard]] uint32_t coarseCentres() const noexcept { return static_cast<uint32_t>(coarse_.size()); }
    [[nodiscard]] uint32_t distancesComputed(const Descriptor& d, const Search& s) const noexcept;

    // ---- files ----------------------------------------------------------
    // Writes the file format above, through a temporary file renamed into place.
    [[nodiscard]] Status save(const std::string& path) const;
    // Reads a file. Errors name the file and what is wrong (not a vocabulary,
    // wrong version, truncated, checksum mismatch, ...).
    [[nodiscard]] static Status load(const std::string& path, Vocabulary& out);
    // Parses the file format from memory; `name` is used in error messages.
    [[nodiscard]] static Status parse(std::span<const uint8_t> bytes, const std::string& name, Vocabulary& out);
    // The file format as bytes.
    [[nodiscard]] std::vector<uint8_t> serialize() const;

private:
    void buildIndex();
    uint32_t linear(const Descriptor& d, int& best) const noexcept;
    uint32_t tree(const Descriptor& d, uint32_t probes, int& best, uint32_t* visited) const noexcept;

    std::vector<Descriptor> words_;
    std::string note_;

    // Coarse-to-fine index: words grouped by their nearest coarse centre; a
    // bucket's radius is its words' largest distance to the centre.
    std::vector<Descriptor> coarse_;
    std::vector<uint32_t> bucket_begin_;  // coarse + 1
    std::vector<Descriptor> bucket_words_;
    std::vector<uint32_t> bucket_ids_;
    std::vector<uint16_t> bucket_radius_;
};

// CRC-32 (IEEE, reflected, polynomial 0xEDB88320): zlib's crc32, continuing from `crc`.
uint32_t crc32(std::span<const uint8_t> bytes, uint32_t crc = 0) noexcept;

// ---- training ---------------------------------------------------------------

// Training's defaults, the same in every face (`rost vocab`, Python's
// Vocabulary.train): those the shipped vocabulary was made with.
inline constexpr int kTrainingFeatures = 500;  // ORB keypoints per frame collected for training

struct KMajorityOptions {
    uint32_t words = 5000;      // vocabulary size
    int max_iterations = 40;    // stop earlier when no assignment changes
    uint64_t seed = 1;          // initial centres and re-seeding of empty clusters
    int threads = 2;            // assignment step in parallel; the result does not depend on it
};

struct KMajorityReport {
    int iterations = 0;
    uint64_t changed_last = 0;   // assignments changed in the last iteration
    double mean_distance = 0.0;  // mean Hamming distance of a descriptor to its centre
    uint32_t reseeded = 0;       // empty clusters given a new centre
};

// k-majority clustering (k-means in Hamming space): assign each descriptor to
// its nearest centre, then set each centre bit to the majority of its
// members' bits (ties keep the old bit), until nothing changes. Initial
// centres by k-means++ seeding with the seed (distinct descriptors, spread
// by squared Hamming distance); a cluster that empties takes the descriptor
// farthest from its centre. Deterministic for a
// given seed and input, whatever the thread count. Needs at least `words`
// distinct descriptors.
[[nodiscard]] Status trainKMajority(std::span<const Descriptor> data, const KMajorityOptions& options,
                                    std::vector<Descriptor>& centres, KMajorityReport* report = nullptr,
                                    const std::function<void(int iteration, uint64_t changed)>& progress = {});

} // namespace rost::vision
