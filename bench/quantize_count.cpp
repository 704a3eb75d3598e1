// Descriptor quantisation as a plain program (standard library only, no
// OpenCV, no Google Benchmark), so it cross-builds for ARM and runs under
// qemu with bench/qemu_insn_count.c to count instructions per descriptor:
//
//   quantize_count VOCABULARY DESCRIPTORS linear|tree [PROBES] [COUNT]
//
// DESCRIPTORS is a file of raw 32-byte ORB descriptors (bench_vision
// --dump-descriptors FILE writes one from diver.mov). COUNT descriptors are
// quantised (cycling through the file); COUNT = 0 measures the set-up alone,
// so (instructions(COUNT) - instructions(0)) / COUNT is the cost of one.
// Prints a checksum of the word ids so the work cannot be optimised away.

#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <string>
#include <vector>

#include "rost/vision/vocabulary.hpp"

int main(int argc, char** argv) {
    using namespace rost::vision;
    if (argc < 4) {
        std::fprintf(stderr, "usage: quantize_count VOCABULARY DESCRIPTORS linear|tree [PROBES] [COUNT]\n");
        return 2;
    }
    Vocabulary v;
    if (auto st = Vocabulary::load(argv[1], v); !st.ok()) {
        std::fprintf(stderr, "quantize_count: %s\n", st.message().c_str());
        return 2;
    }
    std::ifstream f(argv[2], std::ios::binary);
    std::vector<uint8_t> raw((std::istreambuf_iterator<char>(f)), std::istreambuf_iterator<char>());
    std::vector<Descriptor> d;
    for (std::size_t i = 0; i + Descriptor::kBytes <= raw.size(); i += Descriptor::kBytes)
        d.push_back(Descriptor::fromBytes(raw.data() + i));
    if (d.empty()) {
        std::fprintf(stderr, "quantize_count: %s holds no descriptors\n", argv[2]);
        return 2;
    }
    Search s;
    s.method = std::string(argv[3]) == "linear" ? SearchMethod::Linear : SearchMethod::Tree;
    if (argc > 4) s.probes = static_cast<uint32_t>(std::strtoul(argv[4], nullptr, 10));
    const long count = argc > 5 ? std::strtol(argv[5], nullptr, 10) : static_cast<long>(d.size());
    uint64_t sum = 0;
    for (long i = 0; i < count; ++i) sum += v.quantize(d[static_cast<std::size_t>(i) % d.size()], s);
    std::printf("%s probes %u: %ld descriptors, checksum %llu\n", toString(s.method), s.probes, count,
                static_cast<unsigned long long>(sum));
    return 0;
}
