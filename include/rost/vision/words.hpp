#pragma once

// Visual words of a frame (paper section VII): ORB words quantised with a
// vocabulary, intensity words and hue words on a thumbnail grid, each word
// with the pixel position it was seen at, so it lands in a cell. The word
// ids of the extractors that run are offset into one vocabulary, in the
// order ORB, intensity, hue; with all three and a 5000-word ORB vocabulary
// that is V = 5000 + 256 + 180 = 5436, the paper's mixed vocabulary.

#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include <opencv2/core.hpp>

#include "rost/model.hpp"
#include "rost/status.hpp"
#include "rost/word_settings.hpp"
#include "rost/vision/vocabulary.hpp"

namespace cv {
class ORB;
}

namespace rost::vision {

struct ExtractorConfig {
    // ORB words: keypoints and descriptors by OpenCV's ORB, each descriptor
    // quantised to its nearest vocabulary word, positioned at its keypoint.
    bool orb = settingDefault<bool>("words.orb");
    int orb_features = settingDefault<int>("orb.features");  // keypoints per frame at most (strongest kept)
    float orb_scale_factor = 1.2f; // pyramid scale step
    int orb_levels = 8;            // pyramid levels
    int orb_fast_threshold = settingDefault<int>("orb.fast");  // FAST corner threshold
    Search search;                 // how descriptors find their word (vocabulary.hpp)

    // Intensity and hue words: the frame is shrunk (area average) so each
    // thumbnail pixel covers a thumb_cell x thumb_cell block; each thumbnail
    // pixel gives one intensity word (grey level 0..255) and, where colour is
    // defined, one hue word (OpenCV 8-bit hue 0..179), positioned at the
    // block's centre.
    bool intensity = settingDefault<bool>("words.intensity");
    bool hue = settingDefault<bool>("words.hue");
    int thumb_cell = settingDefault<int>("thumb.cell");  // pixels per thumbnail pixel
    // Hue is meaningless for grey or dark pixels: no hue word below these
    // (OpenCV 8-bit HSV saturation and value, 0..255).
    int hue_min_saturation = 32;
    int hue_min_value = 32;

    // Checks every field; the message names the field and the allowed range.
    [[nodiscard]] Status validate() const;
    // The extractors the word settings of the schema describe (the other
    // fields keep their defaults).
    static ExtractorConfig from(const WordSettings& w) noexcept;
};

// Which ids belong to which extractor.
struct WordLayout {
    uint32_t orb_offset = 0, orb_size = 0;
    uint32_t intensity_offset = 0, intensity_size = 0;
    uint32_t hue_offset = 0, hue_size = 0;
    [[nodiscard]] uint32_t size() const noexcept { return hue_offset + hue_size; }
    // "orb", "intensity", "hue" or "?" for an id.
    [[nodiscard]] const char* kindOf(uint32_t word) const noexcept;
};

// Words of one frame. Reused across frames: clear() keeps the capacity, so a
// steady stream of similar frames stops allocating in these vectors.
struct FrameWords {
    std::vector<uint32_t> words;
    std::vector<Position> positions;
    uint32_t orb = 0, intensity = 0, hue = 0;  // per-extractor counts of this frame
    [[nodiscard]] uint32_t size() const noexcept { return static_cast<uint32_t>(words.size()); }
    void clear() noexcept {
        words.clear();
        positions.clear();
        orb = intensity = hue = 0;
    }
};

class WordExtractor {
public:
    static constexpr uint32_t kIntensityWords = 256;
    static constexpr uint32_t kHueWords = 180;

    // `vocabulary` is needed when config.orb is set (shared: several
    // extractors, e.g. one per thread, may use one vocabulary), and refused
    // when it is not (unusedVocabulary).
    static std::unique_ptr<WordExtractor> create(const ExtractorConfig& config,
                                                 std::shared_ptr<const Vocabulary> vocabulary, Status& status);
    ~WordExtractor();
    WordExtractor(const WordExtractor&) = delete;
    WordExtractor& operator=(const WordExtractor&) = delete;

    const ExtractorConfig& config() const noexcept { return cfg_; }
    const WordLayout& layout() const noexcept { return layout_; }
    // The vocabulary size V a model needs for these words.
    uint32_t vocabularySize() const noexcept { return layout_.size(); }

    // Extracts the words of an 8-bit BGR (3 channels) or grey (1 channel)
    // frame into `out` (cleared first). Positions lie in [0, cols) x [0, rows).
    // Deterministic: the same image gives the same words in the same order
    // (ORB words first, strongest keypoint first; then intensity and hue
    // words in raster order of the thumbnail). Returns false for an empty or
    // unsupported image, or one too small (frameTooSmall()).
    bool extract(const cv::Mat& image, FrameWords& out);

    // The intensity and hue words alone, for a given thumbnail (used by extract; exposed for tests).
    void thumbnailWords(const cv::Mat& bgr, FrameWords& out);

private:
    WordExtractor(const ExtractorConfig& cfg, std::shared_ptr<const Vocabulary> vocabulary);

    ExtractorConfig cfg_;
    WordLayout layout_;
    std::shared_ptr<const Vocabulary> vocabulary_;
    cv::Ptr<cv::ORB> orb_;
    // Scratch reused across frames.
    cv::Mat bgr_, grey_, thumb_, thumbGrey_, hsv_, descriptors_;
    std::vector<cv::KeyPoint> keypoints_;
};

// Layout of the word ids for a configuration and an ORB vocabulary size.
WordLayout makeLayout(const ExtractorConfig& config, uint32_t orb_vocabulary_size) noexcept;

// The most words WordExtractor::extract gives a width x height frame under
// `config`: orb_features ORB words (extract keeps no more), one intensity
// word and at most one hue word per thumbnail pixel. The rost tool sizes an
// observation's capacity (max.words) with it, so no word is dropped.
// A vocabulary given with ORB words off would make no word: a setting that
// does nothing is a mistake to name. "WHAT: given, but words.orb is false:
// ..." when it is so, else ok. The mission checks a vocabulary's path with it
// before reading the file; WordExtractor::create checks a vocabulary.
Status unusedVocabulary(const ExtractorConfig& config, const std::string& what);

uint64_t maxWordsPerFrame(const ExtractorConfig& config, int width, int height) noexcept;

// The vocabulary shipped with rost (share/rost/default.rostvoc, compiled into
// the library). Loaded and checked on first use; its note says what footage
// it was trained on.
std::shared_ptr<const Vocabulary> defaultVocabulary(Status& status);

} // namespace rost::vision
