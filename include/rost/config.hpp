#pragma once

#include <cstdint>
#include <string>

#include "rost/settings_schema.hpp"
#include "rost/status.hpp"

namespace rost {

// What happens to the counts of a time step when the ring wraps and the step
// leaves the refinable window.
enum class EvictionPolicy : uint8_t {
    Keep,      // its word-topic counts stay in n_k^v: the model keeps what it learned
    Subtract,  // its counts are removed: the model describes the window only
};

// With growth, the prior mass of a word opening a topic alone (its words
// uniform, so weight kGrowthFreshMass / V): negligible beside any open
// topic's, so a word opens one only when no topic is open; topics open by
// the split moves (docs/design.md, "Growth from the data").
inline constexpr double kGrowthFreshMass = 1e-20;

// Every size and hyperparameter of a model. All memory is sized from this at
// construction and never grows afterwards. Defaults, ranges and documentation
// are the settings schema's (rost/settings_schema.hpp), by key.
struct Config {
    // Topic model (paper defaults: K = 16, alpha = 0.1, beta = 0.5).
    int K = settingDefault<int>("K");                // topics
    int V = settingDefault<int>("V");                // vocabulary size
    double alpha = settingDefault<double>("alpha");  // Dirichlet prior on a neighbourhood's topics
    double beta = settingDefault<double>("beta");    // Dirichlet prior on a topic's words
    // Topic growth (docs/design.md, "Topics that grow" and "Growth from the
    // data"): K is the cap; topics open by split moves between sweeps and
    // close by merges or when they lose their last word. gamma is the
    // starting value of the concentration the moves learn from the data.
    bool grow = settingDefault<bool>("topics.grow");
    double gamma = settingDefault<double>("gamma");
    // A fixed topic model (docs/design.md, "A fixed topic model"): n_k^v and
    // n_k hold only the counts given before the first observation
    // (Model::addTopicCounts); refinement draws labels against them and
    // changes only the cells' counts. Labels a mission in a given (merged)
    // topic set. Not with grow.
    bool fixed = settingDefault<bool>("topicmodel.fixed");

    // Cells (paper: 64x64 px, one time step).
    int cell_space = settingDefault<int>("cell.space");  // cell width and height in pixels
    int cell_time = settingDefault<int>("cell.time");    // observations (time steps) per temporal cell
    int g_space = settingDefault<int>("g.space");        // spatial neighbourhood radius (Manhattan: 1 = 4 neighbours)
    int g_time = settingDefault<int>("g.time");          // temporal neighbourhood radius (1 = previous and next)

    // Frame geometry: positions must lie in [0, width) x [0, height).
    int frame_width = settingDefault<int>("frame.width");
    int frame_height = settingDefault<int>("frame.height");

    // Capacities.
    int ring_steps = settingDefault<int>("ring.steps");             // temporal cells kept refinable (T_max)
    int cell_capacity = settingDefault<int>("cell.capacity");       // words a cell holds; extra are subsampled
    int max_words_per_frame = settingDefault<int>("max.words");     // words one observation holds; extra are subsampled

    // Refinement in windows of W cell refinements, coloured into rounds of
    // cells that share no neighbourhood and refined by `threads` threads
    // (docs/design.md, "Refinement on every core"). W = 1 is the exact
    // serial sampler; the result never depends on the number of threads.
    int refine_window = settingDefault<int>("refine.window");
    int threads = settingDefault<int>("threads");

    EvictionPolicy eviction = settingDefault<EvictionPolicy>("eviction");
    uint64_t seed = settingDefault<uint64_t>("seed");

    // Grid size derived from the frame geometry.
    [[nodiscard]] int gridWidth() const noexcept { return (frame_width + cell_space - 1) / cell_space; }
    [[nodiscard]] int gridHeight() const noexcept { return (frame_height + cell_space - 1) / cell_space; }
    [[nodiscard]] int cellsPerStep() const noexcept { return gridWidth() * gridHeight(); }

    // Checks every field; the message names the field, its value and the allowed range.
    [[nodiscard]] Status validate() const;
    // The settings the model's tables grow with, for a message: "K = 16, V =
    // 5436, ring.steps = 256, 80 cells a step (frame 640x480, cell.space =
    // 64), cell.capacity = 256, max.words = 4096".
    [[nodiscard]] std::string tablesText() const;
};

const char* toString(EvictionPolicy p) noexcept;
// Parses "keep" or "subtract".
Status parseEvictionPolicy(const std::string& text, EvictionPolicy& out);

} // namespace rost
