#include "dataset.hpp"

#include <algorithm>
#include <charconv>
#include <string_view>

namespace rost::experiment {

namespace {

std::string trim(std::string_view s) {
    std::size_t a = 0, b = s.size();
    while (a < b && (s[a] == ' ' || s[a] == '\t' || s[a] == '\r')) ++a;
    while (b > a && (s[b - 1] == ' ' || s[b - 1] == '\t' || s[b - 1] == '\r')) --b;
    return std::string(s.substr(a, b - a));
}

Status parseMeta(const std::string& path, const std::string& text, std::map<std::string, std::string>& out) {
    std::size_t pos = 0;
    int line = 0;
    while (pos <= text.size()) {
        std::size_t end = text.find('\n', pos);
        if (end == std::string::npos) end = text.size();
        const std::string l = trim(std::string_view(text).substr(pos, end - pos));
        ++line;
        pos = end + 1;
        if (l.empty() || l[0] == '#') continue;
        const std::size_t eq = l.find('=');
        if (eq == std::string::npos || eq == 0)
            return Status::error(path + ":" + std::to_string(line) + ":1: expected key=value, found '" + l + "'");
        out[trim(std::string_view(l).substr(0, eq))] = trim(std::string_view(l).substr(eq + 1));
    }
    return {};
}

Status intField(const std::string& path, const std::map<std::string, std::string>& meta, const char* key,
                int64_t lo, int64_t hi, int64_t& v) {
    const auto it = meta.find(key);
    if (it == meta.end()) return Status::error(path + ": missing field '" + key + "'");
    const std::string& s = it->second;
    const auto [p, ec] = std::from_chars(s.data(), s.data() + s.size(), v);
    if (ec != std::errc() || p != s.data() + s.size() || v < lo || v > hi)
        return Status::error(path + ": field '" + key + "' = '" + s + "' is not an integer in [" +
                             std::to_string(lo) + ", " + std::to_string(hi) + "]");
    return {};
}

} // namespace

Status loadDataset(const std::string& dir, int64_t max_frames, Dataset& out) {
    out = Dataset{};
    out.dir = dir;
    const std::string metaPath = dir + "/dataset.txt";
    std::string text;
    if (Status s = readFile(metaPath, text); !s.ok()) return s;
    if (Status s = parseMeta(metaPath, text, out.meta); !s.ok()) return s;
    int64_t w = 0, h = 0, V = 0;
    if (Status s = intField(metaPath, out.meta, "width", 1, 1 << 15, w); !s.ok()) return s;
    if (Status s = intField(metaPath, out.meta, "height", 1, 1 << 15, h); !s.ok()) return s;
    if (Status s = intField(metaPath, out.meta, "V", 1, 1 << 24, V); !s.ok()) return s;
    out.width = static_cast<int>(w);
    out.height = static_cast<int>(h);
    out.V = static_cast<uint32_t>(V);
    const auto name = out.meta.find("name");
    out.name = name != out.meta.end() ? name->second : dir.substr(dir.find_last_of('/') + 1);

    WordStreamLimits limits;
    limits.vocabulary = out.V;
    limits.width = out.width;
    limits.height = out.height;
    WordStream ws;
    if (Status s = readWordStream(dir + "/words.csv", dir + "/positions.csv", limits, ws); !s.ok()) return s;
    if (!ws.has_positions) return Status::error(dir + "/positions.csv: no positions (the experiment needs them)");
    if (ws.observations.empty()) return Status::error(dir + "/words.csv: no observations");
    out.frames = std::move(ws.observations);
    if (max_frames > 0 && static_cast<int64_t>(out.frames.size()) > max_frames)
        out.frames.resize(static_cast<std::size_t>(max_frames));
    for (const auto& f : out.frames) {
        out.words += f.words.size();
        out.max_words_frame = std::max<uint32_t>(out.max_words_frame, static_cast<uint32_t>(f.words.size()));
    }
    return {};
}

Status writeDatasetMeta(const std::string& dir, const std::vector<std::pair<std::string, std::string>>& kv) {
    std::string text = "# rost experiment dataset: a word stream cached from footage (bench/experiment/README.md)\n";
    for (const auto& [k, v] : kv) text += k + "=" + v + "\n";
    return writeFileAtomic(dir + "/dataset.txt", text);
}

Config modelConfig(const Dataset& d, const ModelParams& p, uint64_t seed) {
    Config c;  // only the model parameters come from p; the rest is sized from the data
    c.K = p.K;
    c.V = static_cast<int>(d.V);
    c.alpha = p.alpha;
    c.beta = p.beta;
    c.cell_space = p.cell_space;
    c.cell_time = 1;
    c.g_space = p.g_space;
    c.g_time = p.g_time;
    c.frame_width = d.width;
    c.frame_height = d.height;
    c.ring_steps = static_cast<int>(std::max<int64_t>(1, d.steps()));
    c.max_words_per_frame = static_cast<int>(std::max<uint32_t>(1, d.max_words_frame));
    // Largest cell occupancy over the stream, so no word is subsampled away.
    const int gw = c.gridWidth();
    std::vector<uint32_t> count(static_cast<std::size_t>(c.cellsPerStep()));
    uint32_t most = 1;
    for (const auto& f : d.frames) {
        std::fill(count.begin(), count.end(), 0u);
        for (const Position& pos : f.positions) {
            const std::size_t cell = static_cast<std::size_t>(pos.y / p.cell_space) * static_cast<std::size_t>(gw) +
                                     static_cast<std::size_t>(pos.x / p.cell_space);
            most = std::max(most, ++count[cell]);
        }
    }
    c.cell_capacity = static_cast<int>(most);
    c.eviction = EvictionPolicy::Keep;
    c.seed = seed;
    return c;
}

} // namespace rost::experiment
