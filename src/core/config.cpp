#include "rost/config.hpp"

#include "rost/settings.hpp"
#include "rost/text_io.hpp"

namespace rost {
std::string Config::tablesText() const {
    return "K = " + std::to_string(K) + ", V = " + std::to_string(V) + ", ring.steps = " + std::to_string(ring_steps) +
           ", " + text::counted(cellsPerStep(), "cell") + " a step (frame " + std::to_string(frame_width) + "x" +
           std::to_string(frame_height) + ", cell.space = " + std::to_string(cell_space) +
           "), cell.capacity = " + std::to_string(cell_capacity) + ", max.words = " + std::to_string(max_words_per_frame) +
           // Each refiner thread past the first keeps its own copy of the word-topic counts (K x V).
           (threads > 1 ? ", threads = " + std::to_string(threads) + " (each a copy of the K x V counts)" : "");
}

Status Config::validate() const {
    // The ranges are the settings schema's, checked by one generic check (rost/settings.hpp).
    if (auto p = checkModelSettings(*this)) return Status::error("invalid configuration: " + p->describe(p->spec->key));
    return {};
}

// The names are the schema's (the `eviction` row's choices, in enum order).
const char* toString(EvictionPolicy p) noexcept { return choiceName(settingSpec("eviction"), static_cast<std::size_t>(p)); }

Status parseEvictionPolicy(const std::string& text, EvictionPolicy& out) {
    const int i = choiceIndexOf(settingSpec("eviction"), text);
    if (i < 0)
        return Status::error("unknown eviction policy '" + text + "' (" + choiceExpected(settingSpec("eviction")) + ")");
    out = static_cast<EvictionPolicy>(i);
    return {};
}

} // namespace rost
