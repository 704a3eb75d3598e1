#include "results.hpp"

#include <cstdio>

#include "rost/topic_model_csv.hpp"

namespace rost::tool {

// ---- dropped words ---------------------------------------------------------------

WordDrops WordDrops::of(uint64_t offered, const Collector& c) noexcept {
    WordDrops d;
    d.offered = offered;
    d.cell = c.wordsDroppedCell();
    const uint64_t inModel = c.wordsKept() + d.cell;
    d.observation = offered > inModel ? offered - inModel : 0;
    return d;
}

namespace {
std::string dropDetail(const WordDrops& d, const Config& c) {
    std::string s;
    if (d.observation) s += std::to_string(d.observation) + " beyond max.words = " + std::to_string(c.max_words_per_frame);
    if (d.cell) {
        if (!s.empty()) s += ", ";
        s += std::to_string(d.cell) + " beyond cell.capacity = " + std::to_string(c.cell_capacity);
    }
    return s;
}
std::string percent(uint64_t part, uint64_t whole) {
    char buf[32];
    std::snprintf(buf, sizeof buf, "%.3g %%", whole ? 100.0 * static_cast<double>(part) / static_cast<double>(whole) : 0.0);
    return buf;
}
} // namespace

std::string WordDrops::line(const Config& c) const {
    if (dropped() == 0)
        return "words dropped: none of " + std::to_string(offered) + " (max.words = " +
               std::to_string(c.max_words_per_frame) + ", cell.capacity = " + std::to_string(c.cell_capacity) + ")\n";
    return "words dropped: " + std::to_string(dropped()) + " of " + std::to_string(offered) + " (" +
           percent(dropped(), offered) + "): " + dropDetail(*this, c) + "; uniformly subsampled\n";
}

std::string WordDrops::note(const Config& c) const {
    if (dropped() == 0) return {};
    std::string s = "rost: note: " + percent(dropped(), offered) + " of the words were dropped (" +
                    std::to_string(dropped()) + " of " + std::to_string(offered) + ": " + dropDetail(*this, c) +
                    "; uniformly subsampled); ";
    s += observation ? "a larger --max.words" : "";
    s += observation && cell ? " and " : "";
    s += cell ? "a larger --cell.capacity" : "";
    s += " keeps them\n";
    return s;
}

std::string topicsLine(const Model& m) {
    if (!m.config().grow) return {};
    std::string s = "topics: " + std::to_string(m.activeTopics()) + " open of at most K = " + std::to_string(m.K()) +
                    " (topics.grow, gamma = ";
    char g[32];
    std::snprintf(g, sizeof g, "%g", m.config().gamma);
    s += g;
    s += " at the start";
    if (m.learnedGamma() > 0.0) {
        std::snprintf(g, sizeof g, "%.3g", m.learnedGamma());
        (s += ", learned ") += g;
    }
    s += "; " + std::to_string(m.growthMovesAccepted()) + " split and merge moves accepted by this run)";
    if (m.topicCapReached()) s += "; the cap was reached: no new topic could open (raise -K)";
    return s + "\n";
}

Status writeResultFiles(OutputDir& out, const Collector& c, const Engine& engine, std::initializer_list<OutputFile> extra) {
    const OutputFile files[] = {
        {"perplexity.csv", [&] { return c.perplexityCsv(); }},
        {"surprise.csv", [&] { return c.surpriseCsv(); }},
        {"surprise_cells.csv", [&] { return c.cellSurpriseCsv(); }},
        {"topicmodel.csv", [&] { return formatTopicModelCsv(engine.model()); }},
    };
    for (const auto& f : files)
        if (Status st = out.write(f.name, f.body()); !st.ok()) return st;
    for (const auto& f : extra)
        if (Status st = out.write(f.name, f.body()); !st.ok()) return st;
    return {};
}

} // namespace rost::tool
