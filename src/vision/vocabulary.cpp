#include "rost/vision/vocabulary.hpp"

#include <algorithm>
#include <atomic>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <limits>
#include <thread>

#include <zlib.h>

#include "rost/random.hpp"
#include "rost/text_io.hpp"
#include "rost/settings.hpp"

#if defined(__ARM_NEON)
#include <arm_neon.h>
#endif

// x86-64's baseline has no popcount instruction; without one a 256-bit
// distance costs ~4x more. Let the loader pick a POPCNT clone where the CPU
// has it (every x86-64 since 2008). AArch64 and ARMv7 NEON have a byte
// popcount (cnt / vcnt) that the compiler uses for __builtin_popcountll.
// Not under ThreadSanitizer: the clones' ifunc resolver runs while the
// dynamic loader relocates, before the sanitizer's runtime is up, and its
// instrumentation crashes the process.
#if defined(__x86_64__) && !defined(__POPCNT__) && defined(__GNUC__) && defined(__linux__) && \
    !defined(__SANITIZE_THREAD__)
#define ROST_POPCOUNT_CLONES __attribute__((target_clones("popcnt", "default")))
#else
#define ROST_POPCOUNT_CLONES
#endif

namespace rost::vision {

namespace {

constexpr char kMagic[8] = {'R', 'O', 'S', 'T', 'V', 'O', 'C', '\0'};
constexpr std::size_t kHeaderBytes = 32;

#if defined(__ARM_NEON)
// NEON: a byte popcount over 16 bytes per instruction. The scalar
// __builtin_popcountll costs four instructions per 64 bits on AArch64
// (fmov, cnt, addv, fmov) and more on ARMv7, so whole vectors are counted.
inline int distanceInline(const Descriptor& a, const Descriptor& b) noexcept {
    const auto* pa = reinterpret_cast<const uint8_t*>(a.w.data());
    const auto* pb = reinterpret_cast<const uint8_t*>(b.w.data());
    const uint8x16_t c = vaddq_u8(vcntq_u8(veorq_u8(vld1q_u8(pa), vld1q_u8(pb))),
                                  vcntq_u8(veorq_u8(vld1q_u8(pa + 16), vld1q_u8(pb + 16))));
#if defined(__aarch64__)
    return static_cast<int>(vaddlvq_u8(c));
#else
    const uint64x2_t s = vpaddlq_u32(vpaddlq_u16(vpaddlq_u8(c)));
    return static_cast<int>(vgetq_lane_u64(s, 0) + vgetq_lane_u64(s, 1));
#endif
}
#else
inline int distanceInline(const Descriptor& a, const Descriptor& b) noexcept {
    return __builtin_popcountll(a.w[0] ^ b.w[0]) + __builtin_popcountll(a.w[1] ^ b.w[1]) +
           __builtin_popcountll(a.w[2] ^ b.w[2]) + __builtin_popcountll(a.w[3] ^ b.w[3]);
}
#endif

// Nearest of words[0..n) to d, keeping (best, bestId) when no word is strictly
// closer or equally close with a lower id. ids == nullptr means id = index.
ROST_POPCOUNT_CLONES
void scan(const Descriptor* words, const uint32_t* ids, uint32_t n, const Descriptor& query, int& best,
          uint32_t& bestId) noexcept {
    // Locals, so the query stays in registers and nothing is stored per word.
    const Descriptor q = query;
    int b = best;
    uint32_t bi = bestId;
    if (ids) {
        for (uint32_t i = 0; i < n; ++i) {
            const int dist = distanceInline(words[i], q);
            if (dist < b || (dist == b && ids[i] < bi)) b = dist, bi = ids[i];
        }
    } else {
        for (uint32_t i = 0; i < n; ++i) {
            const int dist = distanceInline(words[i], q);
            if (dist < b) b = dist, bi = i;  // ids ascend: an equal distance never wins
        }
    }
    best = b;
    bestId = bi;
}

ROST_POPCOUNT_CLONES
void distancesTo(const Descriptor* centres, uint32_t n, const Descriptor& d, int* out) noexcept {
    for (uint32_t i = 0; i < n; ++i) out[i] = distanceInline(centres[i], d);
}

void putU32(std::vector<uint8_t>& b, std::size_t at, uint32_t v) {
    for (int i = 0; i < 4; ++i) b[at + i] = static_cast<uint8_t>(v >> (8 * i));
}
uint32_t getU32(const uint8_t* p) {
    return static_cast<uint32_t>(p[0]) | static_cast<uint32_t>(p[1]) << 8 | static_cast<uint32_t>(p[2]) << 16 |
           static_cast<uint32_t>(p[3]) << 24;
}

} // namespace

Descriptor Descriptor::fromBytes(const uint8_t* bytes) noexcept {
    Descriptor d;
    std::memcpy(d.w.data(), bytes, kBytes);
    return d;
}

void Descriptor::toBytes(uint8_t* bytes) const noexcept { std::memcpy(bytes, w.data(), kBytes); }

int hammingDistance(const Descriptor& a, const Descriptor& b) noexcept { return distanceInline(a, b); }

// The names are the schema's (the `orb.search` row's choices, in enum order).
const char* toString(SearchMethod m) noexcept { return choiceName(settingSpec("orb.search"), static_cast<std::size_t>(m)); }

Status parseSearchMethod(const std::string& text, SearchMethod& out) {
    const int i = choiceIndexOf(settingSpec("orb.search"), text);
    if (i < 0)
        return Status::error("invalid search method '" + text + "', allowed " + std::string(settingSpec("orb.search").choices));
    out = static_cast<SearchMethod>(i);
    return {};
}

uint32_t crc32(std::span<const uint8_t> bytes, uint32_t crc) noexcept {
    // zlib's CRC-32 (IEEE 802.3), continuing from `crc`; its length is a uInt,
    // so larger inputs go in chunks.
    uLong c = crc;
    const uint8_t* p = bytes.data();
    std::size_t left = bytes.size();
    while (left > 0) {
        const uInt n = static_cast<uInt>(std::min<std::size_t>(left, std::numeric_limits<uInt>::max()));
        c = ::crc32(c, p, n);
        p += n;
        left -= n;
    }
    return static_cast<uint32_t>(c);
}

// ---- vocabulary -----------------------------------------------------------------

Vocabulary::Vocabulary(std::vector<Descriptor> words, std::string note)
    : words_(std::move(words)), note_(std::move(note)) {
    buildIndex();
}

void Vocabulary::buildIndex() {
    coarse_.clear();
    bucket_begin_.clear();
    bucket_words_.clear();
    bucket_ids_.clear();
    bucket_radius_.clear();
    const auto W = static_cast<uint32_t>(words_.size());
    if (W < 256) return;  // a linear scan is as fast
    // About sqrt(W) coarse centres balances the two levels' work; they are a
    // k-majority clustering of the words themselves (fixed seed: the index
    // depends only on the vocabulary).
    std::vector<Descriptor> distinct = words_;
    std::sort(distinct.begin(), distinct.end(), [](const Descriptor& a, const Descriptor& b) { return a.w < b.w; });
    distinct.erase(std::unique(distinct.begin(), distinct.end()), distinct.end());
    auto C = static_cast<uint32_t>(std::max(2.0, std::round(std::sqrt(static_cast<double>(W)))));
    C = std::min<uint32_t>(C, static_cast<uint32_t>(distinct.size()));
    KMajorityOptions o;
    o.words = C;
    o.max_iterations = 10;
    o.seed = 0x5EED;
    o.threads = 1;
    if (!trainKMajority(distinct, o, coarse_).ok()) {
        coarse_.clear();
        return;
    }
    std::vector<uint32_t> owner(W);
    std::vector<int> dist(W);
    std::vector<uint32_t> count(C, 0);
    for (uint32_t i = 0; i < W; ++i) {
        int best = std::numeric_limits<int>::max();
        uint32_t id = 0;
        scan(coarse_.data(), nullptr, C, words_[i], best, id);
        owner[i] = id;
        dist[i] = best;
        ++count[id];
    }
    bucket_begin_.assign(C + 1, 0);
    for (uint32_t c = 0; c < C; ++c) bucket_begin_[c + 1] = bucket_begin_[c] + count[c];
    bucket_words_.resize(W);
    bucket_ids_.resize(W);
    bucket_radius_.assign(C, 0);
    std::vector<uint32_t> fill(bucket_begin_.begin(), bucket_begin_.end() - 1);
    for (uint32_t i = 0; i < W; ++i) {
        const uint32_t at = fill[owner[i]]++;
        bucket_words_[at] = words_[i];
        bucket_ids_[at] = i;
        bucket_radius_[owner[i]] = std::max<uint16_t>(bucket_radius_[owner[i]], static_cast<uint16_t>(dist[i]));
    }
}

uint32_t Vocabulary::linear(const Descriptor& d, int& best) const noexcept {
    best = std::numeric_limits<int>::max();
    uint32_t id = 0;
    scan(words_.data(), nullptr, size(), d, best, id);
    return id;
}

uint32_t Vocabulary::tree(const Descriptor& d, uint32_t probes, int& best, uint32_t* visited) const noexcept {
    const auto C = static_cast<uint32_t>(coarse_.size());
    if (C == 0) {
        if (visited) *visited = size();
        return linear(d, best);
    }
    // Coarse level: distance to every centre; buckets in order of distance
    // (counting sort on 0..256: stable, so ties go to the lower bucket).
    constexpr uint32_t kMaxCoarse = 1024;
    int dc[kMaxCoarse];
    uint16_t order[kMaxCoarse];
    const uint32_t n = std::min(C, kMaxCoarse);
    distancesTo(coarse_.data(), n, d, dc);
    uint16_t hist[258] = {};
    for (uint32_t c = 0; c < n; ++c) ++hist[dc[c] + 1];
    for (int i = 1; i < 258; ++i) hist[i] = static_cast<uint16_t>(hist[i] + hist[i - 1]);
    for (uint32_t c = 0; c < n; ++c) order[hist[dc[c]]++] = static_cast<uint16_t>(c);

    best = std::numeric_limits<int>::max();
    uint32_t id = 0, seen = n;
    const uint32_t visit = std::min(std::max(probes, 1u), n);
    for (uint32_t i = 0; i < visit; ++i) {
        const uint32_t c = order[i];
        // Every word w of bucket c has d(q, w) >= d(q, c) - radius(c): a bucket
        // that cannot hold a closer word is skipped (this keeps probes >= C exact).
        if (dc[c] - static_cast<int>(bucket_radius_[c]) > best) continue;
        const uint32_t b = bucket_begin_[c], e = bucket_begin_[c + 1];
        scan(bucket_words_.data() + b, bucket_ids_.data() + b, e - b, d, best, id);
        seen += e - b;
    }
    if (visited) *visited = seen;
    return id;
}

uint32_t Vocabulary::quantize(const Descriptor& d, const Search& s) const noexcept {
    int best = 0;
    return quantize(d, best, s);
}

uint32_t Vocabulary::quantize(const Descriptor& d, int& distance, const Search& s) const noexcept {
    return s.method == SearchMethod::Linear ? linear(d, distance) : tree(d, s.probes, distance, nullptr);
}

uint32_t Vocabulary::distancesComputed(const Descriptor& d, const Search& s) const noexcept {
    if (s.method == SearchMethod::Linear) return size();
    int best = 0;
    uint32_t visited = 0;
    (void)tree(d, s.probes, best, &visited);
    return visited;
}

void Vocabulary::quantizeRows(const uint8_t* rows, std::size_t stride, std::size_t count, uint32_t* out,
                              const Search& s) const noexcept {
    for (std::size_t i = 0; i < count; ++i) out[i] = quantize(Descriptor::fromBytes(rows + i * stride), s);
}

// ---- file format ------------------------------------------------------------------

std::vector<uint8_t> Vocabulary::serialize() const {
    const std::size_t payload = note_.size() + words_.size() * Descriptor::kBytes;
    std::vector<uint8_t> b(kHeaderBytes + payload, 0);
    std::memcpy(b.data(), kMagic, sizeof kMagic);
    putU32(b, 8, kFormatVersion);
    putU32(b, 12, size());
    putU32(b, 16, static_cast<uint32_t>(Descriptor::kBytes));
    putU32(b, 20, static_cast<uint32_t>(note_.size()));
    std::memcpy(b.data() + kHeaderBytes, note_.data(), note_.size());
    uint8_t* p = b.data() + kHeaderBytes + note_.size();
    for (const Descriptor& d : words_) {
        d.toBytes(p);
        p += Descriptor::kBytes;
    }
    putU32(b, 24, crc32({b.data() + kHeaderBytes, payload}));
    return b;
}

Status Vocabulary::save(const std::string& path) const {
    if (empty()) return Status::error("vocabulary " + path + ": nothing to save (no words)");
    if (note_.size() > kMaxNoteBytes) return Status::error("vocabulary " + path + ": note longer than 65536 bytes");
    const std::vector<uint8_t> bytes = serialize();
    // Through a temporary file renamed into place; a device or a FIFO is written in place.
    const Status st =
        text::writeFileAtomic(path, std::string_view(reinterpret_cast<const char*>(bytes.data()), bytes.size()));
    if (!st.ok()) return st.prefixed("vocabulary ");
    return {};
}

Status Vocabulary::load(const std::string& path, Vocabulary& out) {
    std::string bytes;  // the library's reader: its errors say what failed and where (StatusKind)
    if (Status st = text::readFile(path, bytes); !st.ok()) return st.prefixed("vocabulary ");
    return parse(std::span(reinterpret_cast<const uint8_t*>(bytes.data()), bytes.size()), path, out);
}

Status Vocabulary::parse(std::span<const uint8_t> b, const std::string& name, Vocabulary& out) {
    auto fail = [&](const std::string& why) { return Status::error("vocabulary " + name + ": " + why); };
    if (b.size() < sizeof kMagic || std::memcmp(b.data(), kMagic, sizeof kMagic) != 0)
        return fail("not a rost vocabulary (magic \"ROSTVOC\" missing at byte 0)");
    if (b.size() < kHeaderBytes)
        return fail("truncated header (" + std::to_string(b.size()) + " of " + std::to_string(kHeaderBytes) + " bytes)");
    const uint32_t version = getU32(b.data() + 8);
    const uint32_t W = getU32(b.data() + 12);
    const uint32_t D = getU32(b.data() + 16);
    const uint32_t N = getU32(b.data() + 20);
    const uint32_t crc = getU32(b.data() + 24);
    if (version != kFormatVersion)
        return fail("format version " + std::to_string(version) + " is not supported (this build reads version " +
                    std::to_string(kFormatVersion) + ")");
    if (D != Descriptor::kBytes)
        return fail("descriptor size " + std::to_string(D) + " bytes at byte 16, expected " +
                    std::to_string(Descriptor::kBytes));
    if (W == 0 || W > kMaxWords)
        return fail("word count " + std::to_string(W) + " at byte 12 outside 1.." + std::to_string(kMaxWords));
    if (N > kMaxNoteBytes) return fail("note length " + std::to_string(N) + " at byte 20 exceeds 65536");
    const std::size_t expect = kHeaderBytes + N + static_cast<std::size_t>(W) * D;
    if (b.size() < expect)
        return fail("truncated: " + std::to_string(b.size()) + " bytes, the header promises " + std::to_string(expect));
    if (b.size() > expect)
        return fail(std::to_string(b.size() - expect) + " unexpected bytes after the last word (at byte " +
                    std::to_string(expect) + ")");
    const uint32_t actual = crc32(b.subspan(kHeaderBytes));
    if (actual != crc) {
        char buf[96];
        std::snprintf(buf, sizeof buf, "checksum mismatch (stored %08x, computed %08x): the file is corrupt", crc,
                      actual);
        return fail(buf);
    }
    std::vector<Descriptor> words(W);
    const uint8_t* p = b.data() + kHeaderBytes + N;
    for (uint32_t i = 0; i < W; ++i) words[i] = Descriptor::fromBytes(p + static_cast<std::size_t>(i) * D);
    out = Vocabulary(std::move(words), std::string(reinterpret_cast<const char*>(b.data() + kHeaderBytes), N));
    return {};
}

// ---- k-majority -------------------------------------------------------------------

namespace {

// Initial centres by k-means++ seeding (Arthur & Vassilvitskii 2007): the
// first uniformly, each next one with probability proportional to its
// squared distance to the nearest centre so far. Centres spread over the
// clusters, so k-majority rarely starts with two in one cluster and none
// in another. A duplicate of a centre has weight 0, so centres are distinct;
// fewer than K come back when the data has fewer distinct descriptors.
void seedCentres(std::span<const Descriptor> data, uint32_t K, Rng& rng, std::vector<Descriptor>& centres) {
    const std::size_t N = data.size();
    centres.clear();
    centres.reserve(K);
    std::vector<uint32_t> weight(N);
    centres.push_back(data[rng.below(static_cast<uint32_t>(std::min<std::size_t>(N, UINT32_MAX)))]);
    uint64_t total = 0;
    for (std::size_t i = 0; i < N; ++i) {
        const auto d = static_cast<uint32_t>(hammingDistance(data[i], centres[0]));
        weight[i] = d * d;
        total += weight[i];
    }
    while (centres.size() < K && total > 0) {
        const auto r = static_cast<uint64_t>(rng.uniformDouble() * static_cast<double>(total));
        std::size_t pick = 0;
        for (uint64_t acc = 0; pick < N; ++pick) {
            acc += weight[pick];
            if (acc > r && weight[pick] > 0) break;
        }
        if (pick == N) pick = N - 1;
        while (weight[pick] == 0) --pick;  // rounding at the top end: the last positive weight
        const Descriptor c = data[pick];
        centres.push_back(c);
        total = 0;
        for (std::size_t i = 0; i < N; ++i) {
            const auto d = static_cast<uint32_t>(hammingDistance(data[i], c));
            weight[i] = std::min(weight[i], d * d);
            total += weight[i];
        }
    }
}

// Assignment step: each descriptor to its nearest centre (ties to the lowest
// index), with its distance. In parallel over `threads` contiguous chunks;
// each descriptor is independent, so the result is the same for any thread
// count. Returns how many assignments changed.
uint64_t assignToNearest(std::span<const Descriptor> data, const std::vector<Descriptor>& centres, int threads,
                         std::vector<uint32_t>& assign, std::vector<uint16_t>& dist) {
    const std::size_t N = data.size();
    const auto K = static_cast<uint32_t>(centres.size());
    std::atomic<uint64_t> changed{0};
    auto work = [&](std::size_t b, std::size_t e) {
        uint64_t ch = 0;
        for (std::size_t i = b; i < e; ++i) {
            int best = std::numeric_limits<int>::max();
            uint32_t id = 0;
            scan(centres.data(), nullptr, K, data[i], best, id);
            if (id != assign[i]) ++ch;
            assign[i] = id;
            dist[i] = static_cast<uint16_t>(best);
        }
        changed += ch;
    };
    std::vector<std::thread> pool;
    const std::size_t chunk = (N + threads - 1) / threads;
    for (int t = 1; t < threads; ++t) {
        const std::size_t b = std::min(N, t * chunk), e = std::min(N, (t + 1) * chunk);
        if (b < e) pool.emplace_back(work, b, e);
    }
    work(0, std::min(N, chunk));
    for (auto& th : pool) th.join();
    return changed.load();
}

// Counts each cluster's members, then gives every empty cluster the
// descriptor farthest from its centre (stable order by distance; never the
// last member of another cluster). Returns how many clusters were reseeded.
uint32_t reseedEmptyClusters(std::vector<uint32_t>& assign, std::vector<uint16_t>& dist,
                             std::vector<uint32_t>& members) {
    const std::size_t N = assign.size();
    const auto K = static_cast<uint32_t>(members.size());
    std::fill(members.begin(), members.end(), 0u);
    for (std::size_t i = 0; i < N; ++i) ++members[assign[i]];
    std::vector<uint32_t> empties;
    for (uint32_t k = 0; k < K; ++k)
        if (members[k] == 0) empties.push_back(k);
    if (empties.empty()) return 0;
    std::vector<uint32_t> far(N);
    for (std::size_t i = 0; i < N; ++i) far[i] = static_cast<uint32_t>(i);
    std::stable_sort(far.begin(), far.end(), [&](uint32_t a, uint32_t b) { return dist[a] > dist[b]; });
    uint32_t reseeded = 0;
    std::size_t next = 0;
    for (uint32_t k : empties) {
        while (next < N && members[assign[far[next]]] <= 1) ++next;  // do not empty another cluster
        if (next == N) break;
        const uint32_t i = far[next++];
        --members[assign[i]];
        assign[i] = k;
        dist[i] = 0;
        members[k] = 1;
        ++reseeded;
    }
    return reseeded;
}

// Update step: each non-empty centre's bits become the majority of its
// members' bits (ties keep the old bit). `bits` is K x 256 scratch.
void voteCentres(std::span<const Descriptor> data, const std::vector<uint32_t>& assign,
                 const std::vector<uint32_t>& members, std::vector<uint32_t>& bits, std::vector<Descriptor>& centres) {
    const std::size_t N = data.size();
    const auto K = static_cast<uint32_t>(centres.size());
    std::fill(bits.begin(), bits.end(), 0u);
    for (std::size_t i = 0; i < N; ++i) {
        uint32_t* c = bits.data() + static_cast<std::size_t>(assign[i]) * 256;
        for (int w = 0; w < 4; ++w) {
            uint64_t x = data[i].w[w];
            while (x) {
                ++c[w * 64 + __builtin_ctzll(x)];
                x &= x - 1;
            }
        }
    }
    for (uint32_t k = 0; k < K; ++k) {
        if (members[k] == 0) continue;
        const uint32_t* c = bits.data() + static_cast<std::size_t>(k) * 256;
        Descriptor nd = centres[k];
        for (int b = 0; b < 256; ++b) {
            const uint64_t mask = 1ull << (b & 63);
            if (2 * c[b] > members[k]) nd.w[b >> 6] |= mask;
            else if (2 * c[b] < members[k]) nd.w[b >> 6] &= ~mask;
        }
        centres[k] = nd;
    }
}

} // namespace

Status trainKMajority(std::span<const Descriptor> data, const KMajorityOptions& o, std::vector<Descriptor>& centres,
                      KMajorityReport* report, const std::function<void(int, uint64_t)>& progress) {
    const std::size_t N = data.size();
    const uint32_t K = o.words;
    if (K == 0) return Status::error("k-majority: the vocabulary size must be at least 1");
    if (N < K)
        return Status::error("k-majority: " + std::to_string(N) + " descriptors cannot make " + std::to_string(K) +
                             " words; use more footage or fewer words");
    if (o.max_iterations < 1) return Status::error("k-majority: max_iterations must be at least 1");

    Rng rng(o.seed);
    seedCentres(data, K, rng, centres);
    if (centres.size() < K)
        return Status::error("k-majority: only " + std::to_string(centres.size()) + " distinct descriptors, " +
                             std::to_string(K) + " words asked for");

    std::vector<uint32_t> assign(N, UINT32_MAX);
    std::vector<uint16_t> dist(N, 0);
    std::vector<uint32_t> bits(static_cast<std::size_t>(K) * 256);
    std::vector<uint32_t> members(K);
    const int threads = std::max(1, o.threads);
    KMajorityReport rep;
    for (int it = 0; it < o.max_iterations; ++it) {
        rep.iterations = it + 1;
        rep.changed_last = assignToNearest(data, centres, threads, assign, dist);
        if (progress) progress(it + 1, rep.changed_last);
        if (rep.changed_last == 0) break;
        rep.reseeded += reseedEmptyClusters(assign, dist, members);
        voteCentres(data, assign, members, bits, centres);
    }
    double sum = 0.0;
    for (std::size_t i = 0; i < N; ++i) sum += hammingDistance(data[i], centres[assign[i]]);
    rep.mean_distance = sum / static_cast<double>(N);
    if (report) *report = rep;
    return {};
}

} // namespace rost::vision
