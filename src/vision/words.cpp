#include "rost/vision/words.hpp"

#include <algorithm>

#include <opencv2/features2d.hpp>
#include <opencv2/imgproc.hpp>

#include "rost/settings.hpp"
#include "rost/vision/frame_source.hpp"

namespace rost::vision {

Status ExtractorConfig::validate() const {
    // The settings of the schema by its one range check (rost/settings.hpp);
    // the fields the schema does not hold by their own ranges here.
    auto schema = [](const SettingSpec& spec, double v) {
        const auto p = checkSettingRange(spec, v);
        return p ? Status::error("invalid configuration: " + p->describe(spec.key)) : Status();
    };
    auto bad = [](const char* field, double v, const char* range) {
        return Status::error(std::string("extractor setting ") + field + " = " + std::to_string(v) + " outside " +
                             range);
    };
    if (!orb && !intensity && !hue) return Status::error("extractor settings: no extractor enabled (orb, intensity, hue)");
    if (orb) {
        if (Status st = schema(settingSpec("orb.features"), orb_features); !st.ok()) return st;
        if (!(orb_scale_factor > 1.0f && orb_scale_factor <= 4.0f))
            return bad("orb_scale_factor", orb_scale_factor, "(1, 4]");
        if (orb_levels < 1 || orb_levels > 32) return bad("orb_levels", orb_levels, "1..32");
        if (Status st = schema(settingSpec("orb.fast"), orb_fast_threshold); !st.ok()) return st;
        if (Status st = schema(settingSpec("orb.probes"), search.probes); !st.ok()) return st;
    }
    if (intensity || hue)
        if (Status st = schema(settingSpec("thumb.cell"), thumb_cell); !st.ok()) return st;
    if (hue) {
        if (hue_min_saturation < 0 || hue_min_saturation > 255)
            return bad("hue_min_saturation", hue_min_saturation, "0..255");
        if (hue_min_value < 0 || hue_min_value > 255) return bad("hue_min_value", hue_min_value, "0..255");
    }
    return {};
}

ExtractorConfig ExtractorConfig::from(const WordSettings& w) noexcept {
    ExtractorConfig c;
    c.orb = w.orb;
    c.intensity = w.intensity;
    c.hue = w.hue;
    c.orb_features = w.orb_features;
    c.orb_fast_threshold = w.orb_fast_threshold;
    c.search.method = w.orb_search;
    c.search.probes = w.orb_probes;
    c.thumb_cell = w.thumb_cell;
    return c;
}

const char* WordLayout::kindOf(uint32_t w) const noexcept {
    if (w >= orb_offset && w < orb_offset + orb_size) return "orb";
    if (w >= intensity_offset && w < intensity_offset + intensity_size) return "intensity";
    if (w >= hue_offset && w < hue_offset + hue_size) return "hue";
    return "?";
}

WordLayout makeLayout(const ExtractorConfig& c, uint32_t orbSize) noexcept {
    WordLayout l;
    l.orb_offset = 0;
    l.orb_size = c.orb ? orbSize : 0;
    l.intensity_offset = l.orb_offset + l.orb_size;
    l.intensity_size = c.intensity ? WordExtractor::kIntensityWords : 0;
    l.hue_offset = l.intensity_offset + l.intensity_size;
    l.hue_size = c.hue ? WordExtractor::kHueWords : 0;
    return l;
}

WordExtractor::WordExtractor(const ExtractorConfig& cfg, std::shared_ptr<const Vocabulary> vocabulary)
    : cfg_(cfg), vocabulary_(std::move(vocabulary)) {
    layout_ = makeLayout(cfg_, vocabulary_ ? vocabulary_->size() : 0);
    if (cfg_.orb)
        orb_ = cv::ORB::create(cfg_.orb_features, cfg_.orb_scale_factor, cfg_.orb_levels, 31, 0, 2,
                               cv::ORB::HARRIS_SCORE, 31, cfg_.orb_fast_threshold);
}

WordExtractor::~WordExtractor() = default;

std::unique_ptr<WordExtractor> WordExtractor::create(const ExtractorConfig& config,
                                                     std::shared_ptr<const Vocabulary> vocabulary, Status& status) {
    status = config.validate();
    if (!status.ok()) return nullptr;
    if (config.orb && (!vocabulary || vocabulary->empty())) {
        status = Status::error("ORB words need a vocabulary (none given)");
        return nullptr;
    }
    if (vocabulary && (status = unusedVocabulary(config, "vocabulary"), !status.ok())) return nullptr;
    return std::unique_ptr<WordExtractor>(new WordExtractor(config, config.orb ? std::move(vocabulary) : nullptr));
}

namespace {
// Thumbnail size of a frame: one pixel per thumb_cell x thumb_cell block (at least 1 x 1).
int thumbSize(int frameSize, int cell) noexcept { return std::max(1, frameSize / cell); }
} // namespace

Status unusedVocabulary(const ExtractorConfig& config, const std::string& what) {
    if (config.orb) return Status();
    return Status::error(what + ": given, but words.orb is false: no word would come from it");
}

uint64_t maxWordsPerFrame(const ExtractorConfig& c, int width, int height) noexcept {
    const uint64_t thumb = c.thumb_cell > 0 && width > 0 && height > 0
                               ? static_cast<uint64_t>(thumbSize(width, c.thumb_cell)) *
                                     static_cast<uint64_t>(thumbSize(height, c.thumb_cell))
                               : 0;
    return (c.orb ? static_cast<uint64_t>(std::max(0, c.orb_features)) : 0) + (c.intensity ? thumb : 0) +
           (c.hue ? thumb : 0);
}

void WordExtractor::thumbnailWords(const cv::Mat& bgr, FrameWords& out) {
    if (!cfg_.intensity && !cfg_.hue) return;
    const int s = cfg_.thumb_cell;
    const int tw = thumbSize(bgr.cols, s), th = thumbSize(bgr.rows, s);
    // Area averaging: each thumbnail pixel is the mean of its block, so the
    // words describe the block rather than one aliased pixel.
    // Scratch members only hold our own results; a caller's image is only
    // ever referred to through local references, never written.
    if (s != 1) cv::resize(bgr, thumb_, cv::Size(tw, th), 0, 0, cv::INTER_AREA);
    const cv::Mat& thumb = s == 1 ? bgr : thumb_;
    // Block centres in the full frame (the grid covers cols x rows scaled by
    // cols / tw, so it spans the whole frame even when s does not divide it).
    const double sx = static_cast<double>(bgr.cols) / tw, sy = static_cast<double>(bgr.rows) / th;
    auto centre = [&](int x, int y) {
        Position p;
        p.x = std::min(bgr.cols - 1, static_cast<int32_t>((x + 0.5) * sx));
        p.y = std::min(bgr.rows - 1, static_cast<int32_t>((y + 0.5) * sy));
        return p;
    };
    if (cfg_.intensity) {
        cv::cvtColor(thumb, thumbGrey_, cv::COLOR_BGR2GRAY);
        for (int y = 0; y < th; ++y) {
            const uint8_t* row = thumbGrey_.ptr<uint8_t>(y);
            for (int x = 0; x < tw; ++x) {
                out.words.push_back(layout_.intensity_offset + row[x]);
                out.positions.push_back(centre(x, y));
                ++out.intensity;
            }
        }
    }
    if (cfg_.hue) {
        cv::cvtColor(thumb, hsv_, cv::COLOR_BGR2HSV);
        for (int y = 0; y < th; ++y) {
            const cv::Vec3b* row = hsv_.ptr<cv::Vec3b>(y);
            for (int x = 0; x < tw; ++x) {
                if (row[x][1] < cfg_.hue_min_saturation || row[x][2] < cfg_.hue_min_value) continue;
                out.words.push_back(layout_.hue_offset + std::min<uint32_t>(row[x][0], kHueWords - 1));
                out.positions.push_back(centre(x, y));
                ++out.hue;
            }
        }
    }
}

bool WordExtractor::extract(const cv::Mat& image, FrameWords& out) {
    out.clear();
    if (image.empty() || image.depth() != CV_8U) return false;
    if (image.cols < kMinFrameSide || image.rows < kMinFrameSide) return false;  // ORB would fail on it
    // bgr_ only ever holds our own conversions (never shares the caller's image).
    if (image.channels() == 1) cv::cvtColor(image, bgr_, cv::COLOR_GRAY2BGR);
    else if (image.channels() == 4) cv::cvtColor(image, bgr_, cv::COLOR_BGRA2BGR);
    else if (image.channels() != 3) return false;
    const cv::Mat& bgr = image.channels() == 3 ? image : bgr_;

    if (cfg_.orb) {
        if (image.channels() != 1) cv::cvtColor(bgr, grey_, cv::COLOR_BGR2GRAY);
        const cv::Mat& grey = image.channels() == 1 ? image : grey_;
        keypoints_.clear();
        orb_->detectAndCompute(grey, cv::noArray(), keypoints_, descriptors_);
        if (!keypoints_.empty() && (descriptors_.cols != static_cast<int>(Descriptor::kBytes) ||
                                    descriptors_.type() != CV_8U))
            return false;
        // OpenCV's ORB keeps keypoints tied with the last one it retains, so
        // it may give a few more than asked: keep orb_features (the bound
        // maxWordsPerFrame promises).
        const std::size_t n = std::min(keypoints_.size(), static_cast<std::size_t>(cfg_.orb_features));
        const std::size_t base = out.words.size();
        out.words.resize(base + n);
        vocabulary_->quantizeRows(descriptors_.data, descriptors_.step[0], n, out.words.data() + base, cfg_.search);
        out.positions.reserve(base + n);
        for (std::size_t i = 0; i < n; ++i) {
            out.words[base + i] += layout_.orb_offset;
            Position p;
            p.x = std::clamp(static_cast<int32_t>(keypoints_[i].pt.x), 0, image.cols - 1);
            p.y = std::clamp(static_cast<int32_t>(keypoints_[i].pt.y), 0, image.rows - 1);
            out.positions.push_back(p);
        }
        out.orb = static_cast<uint32_t>(n);
    }
    thumbnailWords(bgr, out);
    return true;
}

} // namespace rost::vision
