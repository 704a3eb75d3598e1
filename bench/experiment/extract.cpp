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

// --check-vocabulary: says whether the built-in vocabulary exists; the exit code.
int checkBuiltInVocabulary() {
    Status s;
    const auto v = vision::defaultVocabulary(s);
    if (!v) {
        std::printf("no built-in vocabulary: %s\n", s.message().c_str());
        return 1;
    }
    std::printf("built-in vocabulary: %u words; %s\n", v->size(), v->note().c_str());
    return 0;
}

// The ORB vocabulary: the file at `path`, or the built-in one if empty.
std::shared_ptr<const vision::Vocabulary> loadVocabulary(const std::string& path) {
    if (!path.empty()) {
        auto v = std::make_shared<vision::Vocabulary>();
        if (Status s = vision::Vocabulary::load(path, *v); !s.ok()) fail(s.message());
        return v;
    }
    Status st;
    auto v = vision::defaultVocabulary(st);
    if (!st.ok()) fail(st.message());
    return v;
}

// The words of every frame, as the word-stream CSVs, and their counts.
struct Extraction {
    std::string words, positions;  // words.csv and positions.csv
    int64_t frames = 0;
    uint64_t total = 0, orb = 0, intensity = 0, hue = 0;
    uint32_t minWords = UINT32_MAX, maxWords = 0;
    double seconds = 0.0;
};

// Extracts the words of at most `maxFrames` frames of `source` (0: all).
Extraction extractAll(vision::FrameSource& source, vision::WordExtractor& extractor, const std::string& input,
                      int64_t maxFrames) {
    Extraction x;
    vision::Frame frame;
    vision::FrameWords fw;
    const auto t0 = std::chrono::steady_clock::now();
    while (maxFrames == 0 || x.frames < maxFrames) {
        const vision::ReadStatus rs = source.read(frame);
        if (rs == vision::ReadStatus::End) break;
        if (rs == vision::ReadStatus::Error) fail(source.error());
        if (!extractor.extract(frame.image, fw)) fail(input + ": frame " + std::to_string(frame.index) + ": cannot extract words");
        appendCsvLine(x.words, x.frames, fw.words.data(), fw.words.size());
        appendPositionsLine(x.positions, x.frames, fw.positions.data(), fw.positions.size());
        x.total += fw.size();
        x.orb += fw.orb;
        x.intensity += fw.intensity;
        x.hue += fw.hue;
        x.minWords = std::min(x.minWords, fw.size());
        x.maxWords = std::max(x.maxWords, fw.size());
        ++x.frames;
    }
    if (x.frames == 0) fail(input + ": no frames");
    x.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    return x;
}

// What the cached stream is: OUT/dataset.txt.
void writeMeta(const std::string& out, const std::string& name, const std::string& input,
               const std::string& vocabularyPath, const vision::SourceInfo& info,
               const vision::WordExtractor& extractor, const vision::ExtractorConfig& ec,
               const vision::Vocabulary& vocabulary, const Extraction& x) {
    auto per = [&](uint64_t n) { return std::to_string(static_cast<double>(n) / static_cast<double>(x.frames)); };
    std::string note = vocabulary.note();
    std::replace(note.begin(), note.end(), '\n', ' ');
    if (Status s = experiment::writeDatasetMeta(
            out, {{"name", name},
                  {"source", input},
                  {"source_description", info.description},
                  {"width", std::to_string(info.width)},
                  {"height", std::to_string(info.height)},
                  {"V", std::to_string(extractor.vocabularySize())},
                  {"frames", std::to_string(x.frames)},
                  {"words", std::to_string(x.total)},
                  {"words_per_frame", per(x.total)},
                  {"words_per_frame_min", std::to_string(x.minWords)},
                  {"words_per_frame_max", std::to_string(x.maxWords)},
                  {"orb_per_frame", per(x.orb)},
                  {"intensity_per_frame", per(x.intensity)},
                  {"hue_per_frame", per(x.hue)},
                  {"extractor", "orb_features=" + std::to_string(ec.orb_features) +
                                    " thumb_cell=" + std::to_string(ec.thumb_cell) + " orb_vocabulary=" +
                                    std::to_string(vocabulary.size())},
                  {"vocabulary", vocabularyPath.empty() ? "built-in" : vocabularyPath},
                  {"vocabulary_note", note},
                  {"extract_seconds", std::to_string(x.seconds)}});
        !s.ok())
        fail(s.message());
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
    if (checkVocabulary) return checkBuiltInVocabulary();
    if (input.empty() || out.empty()) fail("--input and --out are required");
    if (name.empty()) name = out.substr(out.find_last_of('/') + 1);

    const std::shared_ptr<const vision::Vocabulary> vocabulary = loadVocabulary(vocabularyPath);
    Status st;
    const vision::ExtractorConfig ec;
    auto extractor = vision::WordExtractor::create(ec, vocabulary, st);
    if (!extractor) fail(st.message());
    auto source = vision::openFrameSource(input, vision::SourceOptions{}, st);
    if (!source) fail(st.message());
    const vision::SourceInfo& info = source->info();

    ::mkdir(out.c_str(), 0755);
    const Extraction x = extractAll(*source, *extractor, input, maxFrames);
    if (Status s = writeFileAtomic(out + "/words.csv", x.words); !s.ok()) fail(s.message());
    if (Status s = writeFileAtomic(out + "/positions.csv", x.positions); !s.ok()) fail(s.message());
    writeMeta(out, name, input, vocabularyPath, info, *extractor, ec, *vocabulary, x);
    const double frames = static_cast<double>(x.frames);
    std::printf("%s: %lld frames %dx%d, %.0f words/frame (ORB %.0f, intensity %.0f, hue %.0f), V = %u, %.1f s\n",
                name.c_str(), static_cast<long long>(x.frames), info.width, info.height,
                static_cast<double>(x.total) / frames, static_cast<double>(x.orb) / frames,
                static_cast<double>(x.intensity) / frames, static_cast<double>(x.hue) / frames,
                extractor->vocabularySize(), x.seconds);
    return 0;
}
