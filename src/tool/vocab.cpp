// `rost vocab INPUT... --out FILE`: trains an ORB vocabulary from footage by
// k-majority clustering (vocabulary.hpp) and saves it in the versioned file
// format.

#include <chrono>
#include <cstdio>

#include <opencv2/features2d.hpp>
#include <opencv2/imgproc.hpp>

#include "progress.hpp"
#include "rost/mission.hpp"
#include "rost/random.hpp"
#include "rost/text_io.hpp"
#include "rost/word_stream.hpp"
#include "tool.hpp"

namespace rost::tool {

namespace {

// The options, and the output before the training (minutes on a long video):
// one that would replace an input (a video, a frame of an image directory)
// or is unwritable fails at once.
Status checkVocabOptions(const VocabOptions& o) {
    if (o.out.empty()) return Status::error("--out: no vocabulary file given");
    if (o.words < 1 || o.words > vision::Vocabulary::kMaxWords)
        return Status::error("--words " + std::to_string(o.words) + " outside 1..1000000");
    if (o.features < 1) return Status::error("--features must be at least 1");
    if (o.every < 1) return Status::error("--every must be at least 1");
    if (o.max_descriptors < o.words) return Status::error("--max-descriptors must be at least --words");
    if (o.iterations < 1) return Status::error("--iterations " + std::to_string(o.iterations) + ": must be at least 1");
    // As run's and refine's --threads (the schema's range): a million threads is not a request to honour.
    if (o.threads < 1 || o.threads > 1024)
        return Status::error("--threads " + std::to_string(o.threads) + " outside 1..1024");
    MissionOptions inputs;
    inputs.inputs = o.inputs;
    inputs.would_read = vision::inputWouldRead;
    if (Status st = checkMissionOutputOverlap(inputs, "--out", o.out); !st.ok()) return st;
    if (Status st = probeOutputFile(o.out); !st.ok()) return st.prefixed("--out: ");
    return {};
}

} // namespace

int vocabCommand(const VocabOptions& o) {
    using vision::Descriptor;
    const auto started = std::chrono::steady_clock::now();
    if (Status st = checkVocabOptions(o); !st.ok()) return fail(st.message());

    vision::ExtractorConfig ex;  // same ORB settings as the extractor's defaults
    cv::Ptr<cv::ORB> orb = cv::ORB::create(o.features, ex.orb_scale_factor, ex.orb_levels, 31, 0, 2,
                                           cv::ORB::HARRIS_SCORE, 31, ex.orb_fast_threshold);
    // Descriptors of every used frame; beyond max_descriptors a seeded
    // reservoir sample keeps a uniform subset.
    std::vector<Descriptor> data;
    data.reserve(static_cast<std::size_t>(std::min<int64_t>(o.max_descriptors, 1 << 22)));
    Rng rng(o.seed ^ 0x766F6361ull);
    uint64_t seen = 0;
    int64_t framesUsed = 0;
    std::string inputsNote;
    vision::SourceOptions so;
    so.width = o.width;
    for (const auto& in : o.inputs) {
        Status st;
        auto src = vision::openFrameSource(in, so, st);
        if (!src) return fail(st.message());
        inputsNote += (inputsNote.empty() ? "" : "; ") + src->info().description;
        Progress progress("rost vocab: " + in, src->info().frames, o.quiet);
        vision::Frame f;
        cv::Mat grey, desc;
        std::vector<cv::KeyPoint> kps;
        int64_t read = 0;
        for (;;) {
            if (o.max_frames > 0 && read >= o.max_frames) break;  // before reading: the next may be a damaged one
            const vision::ReadStatus rs = src->read(f);
            if (rs == vision::ReadStatus::End) break;
            if (rs == vision::ReadStatus::Error) return fail(src->error());
            progress.update(++read);
            if ((read - 1) % o.every != 0) continue;
            ++framesUsed;
            cv::cvtColor(f.image, grey, cv::COLOR_BGR2GRAY);
            orb->detectAndCompute(grey, cv::noArray(), kps, desc);
            for (int r = 0; r < desc.rows; ++r) {
                const Descriptor d = Descriptor::fromBytes(desc.ptr<uint8_t>(r));
                ++seen;
                if (data.size() < static_cast<std::size_t>(o.max_descriptors)) {
                    data.push_back(d);
                } else {
                    const uint64_t j = static_cast<uint64_t>(rng.uniformDouble() * static_cast<double>(seen));
                    if (j < data.size()) data[j] = d;
                }
            }
        }
    }
    if (!o.quiet)
        std::fprintf(stderr, "rost vocab: %llu descriptors from %lld frames, training %u words on %zu of them\n",
                     static_cast<unsigned long long>(seen), static_cast<long long>(framesUsed), o.words, data.size());

    vision::KMajorityOptions km;
    km.words = o.words;
    km.max_iterations = o.iterations;
    km.seed = o.seed;
    km.threads = o.threads;
    vision::KMajorityReport rep;
    std::vector<Descriptor> centres;
    const bool verbose = !o.quiet && stderrIsTerminal();
    Status st = vision::trainKMajority(data, km, centres, &rep, [&](int it, uint64_t changed) {
        if (verbose) std::fprintf(stderr, "\rrost vocab: iteration %d, %llu assignments changed\033[K", it,
                                  static_cast<unsigned long long>(changed));
    });
    if (verbose) std::fputs("\r\033[K", stderr);
    if (!st.ok()) return fail(st.message());

    char note[512];
    std::snprintf(note, sizeof note,
                  "k-majority, %u words, seed %llu, %d iterations (%llu changed in the last), mean distance %.2f bits, "
                  "%zu of %llu ORB descriptors (%d per frame) from %s (every %d)\n",
                  o.words, static_cast<unsigned long long>(o.seed), rep.iterations,
                  static_cast<unsigned long long>(rep.changed_last), rep.mean_distance, data.size(),
                  static_cast<unsigned long long>(seen), o.features,
                  text::counted(static_cast<long long>(framesUsed), "frame").c_str(), o.every);
    const std::string fullNote = std::string(note) + "inputs: " + inputsNote + "\ncommand: " + o.command_line + "\n";
    vision::Vocabulary v(std::move(centres), fullNote.substr(0, vision::Vocabulary::kMaxNoteBytes));
    st = v.save(o.out);
    if (!st.ok()) return fail(st.message());
    if (!o.quiet) {
        const double s = std::chrono::duration<double>(std::chrono::steady_clock::now() - started).count();
        std::fprintf(stderr, "rost vocab: %s: %u words, %d iterations, mean distance %.2f bits, %.1f s\n",
                     text::printable(o.out).c_str(), v.size(), rep.iterations, rep.mean_distance, s);
    }
    return kExitOk;
}

int camerasCommand() {
    if (!vision::haveLibcamera()) return fail("cameras: this build of rost has no libcamera support");
    const auto cams = vision::listCameras();
    if (cams.empty()) return fail("cameras: no camera found (libcamera sees no camera)");
    for (const auto& c : cams) std::printf("camera:%s\n", c.c_str());
    return kExitOk;
}

} // namespace rost::tool
