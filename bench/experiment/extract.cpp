// rost_experiment_extract: visual words of a piece of footage, extracted
// once and cached for the experiment (bench/experiment/README.md).
//
//   rost_experiment_extract --input data/.../diver.mov --name diver --out data/experiment/diver
//
// Writes OUT/words.csv, OUT/positions.csv (timestamp = frame index) and
// OUT/dataset.txt, each atomically. The extractor is the library's default
// (rost/vision/words.hpp): ORB words on the built-in vocabulary (or
// --vocabulary FILE), intensity and hue words on a 16 px thumbnail grid.

#include <CLI/CLI.hpp>

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <string>
#include <sys/stat.h>

#include "dataset.hpp"
#include "rost/vision/frame_source.hpp"
#include "rost/vision/words.hpp"
#include "rost/word_stream.hpp"

using namespace rost;

namespace {

[[noreturn]] void fail(const std::string& what) {
    std::fprintf(stderr, "rost_experiment_extract: %s\n", what.c_str());
    std::exit(1);
}

} // namespace

int main(int argc, char** argv) {
    std::string input, out, name, vocabularyPath;
    int64_t maxFrames = 0;
    CLI::App app{"rost_experiment_extract: cache the visual words of footage for rost_experiment"};
    app.add_option("--input", input, "video file, image directory or glob");
    app.add_option("--out", out, "output directory (created)");
    app.add_option("--name", name, "dataset name (default: the output directory's name)");
    app.add_option("--frames", maxFrames, "extract at most N frames (0: all)")->capture_default_str();
    app.add_option("--vocabulary", vocabularyPath, "ORB vocabulary file (default: the built-in one)");
    bool checkVocabulary = false;
    app.add_flag("--check-vocabulary", checkVocabulary,
                 "only check that the built-in vocabulary exists (exit 0) or not (exit 1), then exit");
    CLI11_PARSE(app, argc, argv);
    if (checkVocabulary) {
        Status s;
        const auto v = vision::defaultVocabulary(s);
        if (!v) {
            std::printf("no built-in vocabulary: %s\n", s.message().c_str());
            return 1;
        }
        std::printf("built-in vocabulary: %u words; %s\n", v->size(), v->note().c_str());
        return 0;
    }
    if (input.empty() || out.empty()) fail("--input and --out are required");
    if (name.empty()) name = out.substr(out.find_last_of('/') + 1);

    Status st;
    std::shared_ptr<const vision::Vocabulary> vocabulary;
    if (!vocabularyPath.empty()) {
        auto v = std::make_shared<vision::Vocabulary>();
        if (Status s = vision::Vocabulary::load(vocabularyPath, *v); !s.ok()) fail(s.message());
        vocabulary = std::move(v);
    } else {
        vocabulary = vision::defaultVocabulary(st);
        if (!st.ok()) fail(st.message());
    }
    const vision::ExtractorConfig ec;
    auto extractor = vision::WordExtractor::create(ec, vocabulary, st);
    if (!extractor) fail(st.message());
    auto source = vision::openFrameSource(input, vision::SourceOptions{}, st);
    if (!source) fail(st.message());
    const vision::SourceInfo& info = source->info();

    ::mkdir(out.c_str(), 0755);
    std::string words, positions;
    vision::Frame frame;
    vision::FrameWords fw;
    int64_t frames = 0;
    uint64_t total = 0, orb = 0, intensity = 0, hue = 0;
    uint32_t minWords = UINT32_MAX, maxWords = 0;
    const auto t0 = std::chrono::steady_clock::now();
    while (maxFrames == 0 || frames < maxFrames) {
        const vision::ReadStatus rs = source->read(frame);
        if (rs == vision::ReadStatus::End) break;
        if (rs == vision::ReadStatus::Error) fail(source->error());
        if (!extractor->extract(frame.image, fw)) fail(input + ": frame " + std::to_string(frame.index) + ": cannot extract words");
        appendCsvLine(words, frames, fw.words.data(), fw.words.size());
        appendPositionsLine(positions, frames, fw.positions.data(), fw.positions.size());
        total += fw.size();
        orb += fw.orb;
        intensity += fw.intensity;
        hue += fw.hue;
        minWords = std::min(minWords, fw.size());
        maxWords = std::max(maxWords, fw.size());
        ++frames;
    }
    if (frames == 0) fail(input + ": no frames");
    const double secs = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    if (Status s = writeFileAtomic(out + "/words.csv", words); !s.ok()) fail(s.message());
    if (Status s = writeFileAtomic(out + "/positions.csv", positions); !s.ok()) fail(s.message());
    auto per = [&](uint64_t n) { return std::to_string(static_cast<double>(n) / static_cast<double>(frames)); };
    std::string note = vocabulary->note();
    std::replace(note.begin(), note.end(), '\n', ' ');
    if (Status s = experiment::writeDatasetMeta(
            out, {{"name", name},
                  {"source", input},
                  {"source_description", info.description},
                  {"width", std::to_string(info.width)},
                  {"height", std::to_string(info.height)},
                  {"V", std::to_string(extractor->vocabularySize())},
                  {"frames", std::to_string(frames)},
                  {"words", std::to_string(total)},
                  {"words_per_frame", per(total)},
                  {"words_per_frame_min", std::to_string(minWords)},
                  {"words_per_frame_max", std::to_string(maxWords)},
                  {"orb_per_frame", per(orb)},
                  {"intensity_per_frame", per(intensity)},
                  {"hue_per_frame", per(hue)},
                  {"extractor", "orb_features=" + std::to_string(ec.orb_features) +
                                    " thumb_cell=" + std::to_string(ec.thumb_cell) + " orb_vocabulary=" +
                                    std::to_string(vocabulary->size())},
                  {"vocabulary", vocabularyPath.empty() ? "built-in" : vocabularyPath},
                  {"vocabulary_note", note},
                  {"extract_seconds", std::to_string(secs)}});
        !s.ok())
        fail(s.message());
    std::printf("%s: %lld frames %dx%d, %.0f words/frame (ORB %.0f, intensity %.0f, hue %.0f), V = %u, %.1f s\n",
                name.c_str(), static_cast<long long>(frames), info.width, info.height,
                static_cast<double>(total) / static_cast<double>(frames),
                static_cast<double>(orb) / static_cast<double>(frames),
                static_cast<double>(intensity) / static_cast<double>(frames),
                static_cast<double>(hue) / static_cast<double>(frames), extractor->vocabularySize(), secs);
    return 0;
}
