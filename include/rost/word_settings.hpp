#pragma once

// The visual-word settings (keys words.*, orb.*, thumb.cell of the settings
// schema), without OpenCV: rost::vision::ExtractorConfig is made from them.

#include <cstdint>

#include "rost/settings_schema.hpp"

namespace rost {

// How an ORB descriptor finds its word (rost::vision::Vocabulary::quantize).
enum class SearchMethod : uint8_t {
    Linear,  // exact: every word, a popcount per word
    Tree,    // coarse-to-fine: only the words of the `probes` nearest coarse buckets
};

// Visual word extraction (rost::vision::ExtractorConfig is made from these).
struct WordSettings {
    bool orb = settingDefault<bool>("words.orb");
    bool intensity = settingDefault<bool>("words.intensity");
    bool hue = settingDefault<bool>("words.hue");
    int orb_features = settingDefault<int>("orb.features");
    int orb_fast_threshold = settingDefault<int>("orb.fast");
    SearchMethod orb_search = settingDefault<SearchMethod>("orb.search");
    uint32_t orb_probes = settingDefault<uint32_t>("orb.probes");
    int thumb_cell = settingDefault<int>("thumb.cell");
};

} // namespace rost
