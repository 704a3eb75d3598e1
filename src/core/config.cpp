#include "rost/config.hpp"

#include <cmath>
#include <sstream>

namespace rost {
namespace {

template <typename T>
Status rangeError(const char* field, T value, const char* range) {
    std::ostringstream os;
    os << "invalid configuration: " << field << " = " << value << ", allowed " << range;
    return Status::error(os.str());
}

Status checkInt(const char* field, long long value, long long lo, long long hi) {
    if (value < lo || value > hi) {
        std::ostringstream range;
        range << "[" << lo << ", " << hi << "]";
        return rangeError(field, value, range.str().c_str());
    }
    return {};
}

Status checkPositive(const char* field, double value, double hi) {
    if (!std::isfinite(value) || value <= 0.0 || value > hi) {
        std::ostringstream range;
        range << "(0, " << hi << "]";
        return rangeError(field, value, range.str().c_str());
    }
    return {};
}

} // namespace

Status Config::validate() const {
    // The ranges are the settings schema's (rost/settings_schema.hpp).
#define ROST_CHECK_INT(key, field) checkInt(key, field, static_cast<long long>(settingSpec(key).lo), \
                                            static_cast<long long>(settingSpec(key).hi))
#define ROST_CHECK_POSITIVE(key, field) checkPositive(key, field, settingSpec(key).hi)
    const Status checks[] = {
        ROST_CHECK_INT("K", K),
        ROST_CHECK_INT("V", V),
        ROST_CHECK_POSITIVE("alpha", alpha),
        ROST_CHECK_POSITIVE("beta", beta),
        ROST_CHECK_POSITIVE("gamma", gamma),
        ROST_CHECK_INT("cell.space", cell_space),
        ROST_CHECK_INT("cell.time", cell_time),
        ROST_CHECK_INT("g.space", g_space),
        ROST_CHECK_INT("g.time", g_time),
        ROST_CHECK_INT("frame.width", frame_width),
        ROST_CHECK_INT("frame.height", frame_height),
        ROST_CHECK_INT("ring.steps", ring_steps),
        ROST_CHECK_INT("cell.capacity", cell_capacity),
        ROST_CHECK_INT("max.words", max_words_per_frame),
        ROST_CHECK_INT("refine.window", refine_window),
        ROST_CHECK_INT("threads", threads),
    };
#undef ROST_CHECK_INT
#undef ROST_CHECK_POSITIVE
    for (const Status& s : checks)
        if (!s.ok()) return s;
    if (g_time >= ring_steps && ring_steps > 1)
        return rangeError("g.time", g_time, "smaller than ring.steps");
    // The grid in 64 bits first: cellsPerStep() multiplies ints, which a
    // 65536 x 65536 frame of 1-pixel cells would overflow.
    const int64_t cells = static_cast<int64_t>(gridWidth()) * gridHeight();
    if (cells > (int64_t{1} << 20))
        return Status::error("invalid configuration: frame.width x frame.height / cell.space^2 = " +
                             std::to_string(cells) + " cells per step, allowed at most 1048576; raise cell.space");
    const double words = static_cast<double>(ring_steps) * static_cast<double>(cells) * cell_capacity;
    const double bytes = words * 8.0;
    if (bytes > 64.0 * 1024 * 1024 * 1024)
        // Every setting the size comes from, each as "key = value".
        return Status::error("invalid configuration: the ring would need more than 64 GiB: ring.steps = " +
                             std::to_string(ring_steps) + " steps of " + std::to_string(cells) +
                             " cells (the cells of a step: frame.width = " + std::to_string(frame_width) +
                             " and frame.height = " + std::to_string(frame_height) + " over cell.space = " +
                             std::to_string(cell_space) + ") of cell.capacity = " + std::to_string(cell_capacity) +
                             " words, " + std::to_string(static_cast<long long>(words)) +
                             " words in all; lower ring.steps or cell.capacity, or raise cell.space");
    // Each observation's kept inputs (word, position, cell slot: 12 bytes).
    const double inputs = static_cast<double>(ring_steps) * cell_time * max_words_per_frame;
    if (inputs * 12.0 > 64.0 * 1024 * 1024 * 1024)
        return Status::error("invalid configuration: ring of " + std::to_string(static_cast<long long>(inputs)) +
                             " observation inputs needs more than 64 GiB; lower ring.steps, cell.time or max.words");
    return {};
}

const char* toString(EvictionPolicy p) noexcept {
    return p == EvictionPolicy::Keep ? "keep" : "subtract";
}

Status parseEvictionPolicy(const std::string& text, EvictionPolicy& out) {
    if (text == "keep") {
        out = EvictionPolicy::Keep;
        return {};
    }
    if (text == "subtract") {
        out = EvictionPolicy::Subtract;
        return {};
    }
    return Status::error("invalid eviction policy '" + text + "', allowed keep|subtract");
}

} // namespace rost
