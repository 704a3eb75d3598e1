// Writes the binary seed inputs of the checkpoint and vocabulary fuzz
// targets into fuzz/corpus/<target>/ (scripts/fuzz.sh --seeds). Each seed
// starts with the targets' mode byte: 0 = as is, 1 = checksums recomputed.

#include <cstdio>
#include <fstream>
#include <string>
#include <vector>

#include "rost/checkpoint.hpp"
#include "rost/random.hpp"
#include "rost/vision/vocabulary.hpp"

namespace {

void write(const std::string& path, uint8_t mode, const std::vector<uint8_t>& bytes) {
    std::ofstream f(path, std::ios::binary);
    f.put(static_cast<char>(mode));
    f.write(reinterpret_cast<const char*>(bytes.data()), static_cast<std::streamsize>(bytes.size()));
}

rost::EngineConfig tiny(int variant) {
    rost::EngineConfig e;
    rost::Config& c = e.model;
    c.K = 3 + variant;
    c.V = 20;
    c.frame_width = 32;
    c.frame_height = 32;
    c.cell_space = 16;  // 2 x 2 cells
    c.ring_steps = 3;
    c.cell_time = variant == 2 ? 2 : 1;
    c.cell_capacity = 6;
    c.max_words_per_frame = 12;
    c.eviction = variant == 1 ? rost::EvictionPolicy::Subtract : rost::EvictionPolicy::Keep;
    c.seed = 5 + static_cast<uint64_t>(variant);
    e.budget = rost::Budget::steps(2);
    e.queue_slots = 2;
    return e;
}

} // namespace

int main(int argc, char** argv) {
    if (argc != 2) {
        std::fprintf(stderr, "usage: make_fuzz_seeds FUZZ_CORPUS_DIR\n");
        return 2;
    }
    const std::string dir = argv[1];
    for (int variant = 0; variant < 3; ++variant) {
        rost::Engine e(tiny(variant));
        rost::Rng r(static_cast<uint64_t>(variant) + 1);
        const int frames[] = {0, 2, 7};
        for (int f = 0; f < frames[variant]; ++f) {
            std::vector<uint32_t> w(1 + r.below(14));
            std::vector<rost::Position> p(w.size());
            for (std::size_t i = 0; i < w.size(); ++i) {
                w[i] = r.below(20);
                p[i] = {static_cast<int32_t>(r.below(32)), static_cast<int32_t>(r.below(32))};
            }
            e.processNow({f, w, p});
        }
        std::vector<uint8_t> bytes;
        if (!rost::encodeCheckpoint(e, bytes).ok()) return 1;
        write(dir + "/checkpoint/seed" + std::to_string(variant) + ".ckpt", static_cast<uint8_t>(variant & 1), bytes);
    }
    for (int variant = 0; variant < 3; ++variant) {
        rost::Rng r(100 + static_cast<uint64_t>(variant));
        std::vector<rost::vision::Descriptor> words(static_cast<std::size_t>(1 + variant * 20));
        for (auto& d : words)
            for (auto& x : d.w) x = (uint64_t{r.next()} << 32) | r.next();
        rost::vision::Vocabulary v(words, variant == 1 ? "seed vocabulary" : "");
        write(dir + "/vocabulary/seed" + std::to_string(variant) + ".rostvoc", static_cast<uint8_t>(variant & 1),
              v.serialize());
    }
    return 0;
}
