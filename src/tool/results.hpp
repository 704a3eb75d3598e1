#pragma once

// What `rost run` and `rost refine` both write at the end: the CSV files,
// the note on dropped words, run.txt's line on growing topics. No OpenCV
// I/O here: `rost refine` is built without it (docs/tool.md, "Two programs").

#include <cstdint>
#include <functional>
#include <initializer_list>
#include <string>

#include "collector.hpp"
#include "outputs.hpp"
#include "rost/engine.hpp"

namespace rost::tool {

// Words of the observations taken up that the model had no room for:
// beyond an observation's capacity (max.words: uniformly subsampled when
// pushed) or a cell's (cell.capacity: uniformly subsampled when added).
struct WordDrops {
    uint64_t offered = 0;      // words of the observations taken up
    uint64_t observation = 0;  // beyond max.words
    uint64_t cell = 0;         // beyond cell.capacity
    uint64_t dropped() const noexcept { return observation + cell; }
    // `offered` words, of which the collector's observations kept and dropped at cells what they did.
    static WordDrops of(uint64_t offered, const Collector& c) noexcept;
    // run.txt's line ("words dropped: none ..." when none).
    std::string line(const Config& c) const;
    // The note on stderr (once, at the end), "" when nothing was dropped.
    std::string note(const Config& c) const;
};

// The CSV files every command writes at the end (perplexity, surprise,
// per-cell surprise, the topic model), and `extra` ones.
struct OutputFile {
    const char* name;
    std::function<std::string()> body;  // made when written, one at a time
};
Status writeResultFiles(OutputDir& out, const Collector& c, const Engine& engine, std::initializer_list<OutputFile> extra);

// run.txt's line on growing topics (empty without growth).
std::string topicsLine(const Model& m);

} // namespace rost::tool
