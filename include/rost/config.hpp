#pragma once

#include <cstdint>
#include <string>

#include "rost/status.hpp"

namespace rost {

// What happens to the counts of a time step when the ring wraps and the step
// leaves the refinable window.
enum class EvictionPolicy : uint8_t {
    Keep,      // its word-topic counts stay in n_k^v: the model keeps what it learned
    Subtract,  // its counts are removed: the model describes the window only
};

// Every size and hyperparameter of a model. All memory is sized from this at
// construction and never grows afterwards.
struct Config {
    // Topic model (paper defaults: K = 16, alpha = 0.1, beta = 0.5).
    int K = 16;          // topics, 1..1024
    int V = 5436;        // vocabulary size, 1..16777216
    double alpha = 0.1;  // Dirichlet prior on a neighbourhood's topics, > 0
    double beta = 0.5;   // Dirichlet prior on a topic's words, > 0

    // Cells (paper: 64x64 px, one time step).
    int cell_space = 64;  // cell width and height in pixels
    int cell_time = 1;    // observations (time steps) per temporal cell
    int g_space = 1;      // spatial neighbourhood radius in cells (Manhattan: 1 = 4 neighbours)
    int g_time = 1;       // temporal neighbourhood radius in cells (1 = previous and next)

    // Frame geometry: positions must lie in [0, width) x [0, height).
    int frame_width = 640;
    int frame_height = 480;

    // Capacities.
    int ring_steps = 256;           // temporal cells kept refinable (T_max)
    int cell_capacity = 128;        // words a cell holds; extra words are subsampled
    int max_words_per_frame = 4096; // words one observation holds; extra are subsampled

    EvictionPolicy eviction = EvictionPolicy::Keep;
    uint64_t seed = 1;

    // Grid size derived from the frame geometry.
    [[nodiscard]] int gridWidth() const noexcept { return (frame_width + cell_space - 1) / cell_space; }
    [[nodiscard]] int gridHeight() const noexcept { return (frame_height + cell_space - 1) / cell_space; }
    [[nodiscard]] int cellsPerStep() const noexcept { return gridWidth() * gridHeight(); }

    // Checks every field; the message names the field, its value and the allowed range.
    [[nodiscard]] Status validate() const;
};

const char* toString(EvictionPolicy p) noexcept;
// Parses "keep" or "subtract".
Status parseEvictionPolicy(const std::string& text, EvictionPolicy& out);

} // namespace rost
