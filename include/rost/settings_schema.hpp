#pragma once

// The one settings schema. Every setting of rost is declared once, in
// ROST_SETTINGS below: its key, type, group, default, range, documentation,
// command-line names and the field it sets. From this list come
//   * the library's defaults (Config, StrategyConfig, Budget, EngineConfig,
//     ThreadSettings, vision::ExtractorConfig initialise their fields with
//     settingDefault<T>("key"), evaluated at compile time),
//   * the range checks of validate() (settingSpec("key").lo / .hi),
//   * the `key = value` configuration files and their error messages
//     (rost/config_file.hpp, rost/settings.hpp),
//   * the rost tool's options and `--help` text, and `rost config`,
//   * the experiment harness's parameters, Python keyword arguments and ROS
//     parameters (paramName(): dots and dashes become underscores).
// To add a setting: add one line here and the field it names (see
// docs/design.md, "to change X, touch Y").
//
// Columns of X(key, type, group, default, lo, hi, choices, cli, rostcli, flags, field, doc):
//   key      the name in configuration files and (with "--") on the command line
//   type     Integer, Real, Bool, Choice, or one of the budget kinds
//   group    Model (fixes a checkpoint's state), Refinement, Runtime, Words, Mission
//   default  the default in its text form, exactly as a configuration file writes it
//   lo, hi   the allowed range of a number (inclusive, unless flag LoOpen)
//   choices  the names a Choice takes, '|'-separated, in the order of its enum
//   cli      the tool's option names when they are not just "--key"
//   rostcli  rost-cli's flag names for it (topics.refine.t/txy), "=DEFAULT" after
//            them where rost-cli's default differs from the schema's ("" : none)
//   flags    Derived (the tool derives it from the input unless set; with Cores,
//            from the cores it may use), Library (the tool sets it itself: not a
//            tool option), LoOpen (lo excluded)
//   field    the member of rost::Settings it sets
//   doc      one line of documentation

#include <cstdint>
#include <span>
#include <string_view>
#include <type_traits>

// clang-format off
#define ROST_SETTINGS(X) \
    X("K", Integer, Model, "16", 1, 1024, "", "-K,--topics", "-K,--ntopics=100", 0, engine.model.K, \
      "topics (paper: 16)") \
    X("V", Integer, Model, "5436", 1, 16777216, "", "-V,--vocabulary-size", "-V,--vocabsize", Derived, engine.model.V, \
      "vocabulary size; word ids are 0..V-1 (the tool: the extractors' vocabulary, or the largest word id + 1, unless set)") \
    X("alpha", Real, Model, "0.1", 0, 1e6, "", "", "-a,--alpha", LoOpen, engine.model.alpha, \
      "Dirichlet prior on a neighbourhood's topic mix (paper: 0.1)") \
    X("beta", Real, Model, "0.5", 1e-30, 1e6, "", "", "-b,--beta=1.0", 0, engine.model.beta, \
      "Dirichlet prior on a topic's words (paper: 0.5); the sampler's tables are single precision, hence the range's floor") \
    X("topics.grow", Bool, Model, "false", 0, 0, "", "", "--grow.topics.size", 0, engine.model.grow, \
      "let topics grow: K is then the cap; split and merge moves between sweeps open and close topics as the data asks (rost-cli: --grow.topics.size)") \
    X("gamma", Real, Model, "0.1", 0, 1e6, "", "", "--gamma=1e-5", LoOpen, engine.model.gamma, \
      "with topics.grow: the starting value of the topics' concentration, learned from the data at every move; any value from 1e-7 to 0.1 gives the same topics") \
    X("topicmodel.fixed", Bool, Model, "false", 0, 0, "", "", "", 0, engine.model.fixed, \
      "keep the topic-word counts as given (--in.topicmodel, set_topic_model): refinement changes only the labels (rostpy: update_model=False)") \
    X("cell.space", Integer, Model, "64", 1, 65536, "", "", "--cell.space=32", 0, engine.model.cell_space, \
      "cell width and height in pixels (paper: 64)") \
    X("cell.time", Integer, Model, "1", 1, 1024, "", "", "--cell.time", 0, engine.model.cell_time, \
      "observations (frames) per temporal cell") \
    X("g.space", Integer, Model, "1", 0, 16, "", "", "--g.space", 0, engine.model.g_space, \
      "spatial neighbourhood radius in cells (Manhattan; 1: the 4 neighbours)") \
    X("g.time", Integer, Model, "1", 0, 64, "", "", "--g.time", 0, engine.model.g_time, \
      "temporal neighbourhood radius in cells (1: previous and next)") \
    X("frame.width", Integer, Model, "640", 1, 65536, "", "", "", Derived, engine.model.frame_width, \
      "frame width in pixels; positions lie in [0, width) (the tool: from the input)") \
    X("frame.height", Integer, Model, "480", 1, 65536, "", "", "", Derived, engine.model.frame_height, \
      "frame height in pixels; positions lie in [0, height) (the tool: from the input)") \
    X("ring.steps", Integer, Model, "256", 1, 67108864, "", "", "", Derived, engine.model.ring_steps, \
      "time steps kept refinable (the tool: the whole input and a step more when its length is known, up to 2048)") \
    X("cell.capacity", Integer, Model, "256", 1, 1048576, "", "", "", 0, engine.model.cell_capacity, \
      "words a cell holds; more are uniformly subsampled") \
    X("max.words", Integer, Model, "4096", 1, 4194304, "", "", "", Derived, engine.model.max_words_per_frame, \
      "words an observation holds; more are uniformly subsampled (the tool: as many as the extractors can give a frame of the input's size, or a word stream's longest observation, unless set)") \
    X("eviction", Choice, Model, "keep", 0, 0, "keep|subtract", "", "", 0, engine.model.eviction, \
      "what a time step leaving the window does to the topic model: keep its counts or subtract them") \
    X("seed", Integer, Model, "1", 0, 18446744073709551615.0, "", "", "--seed", 0, engine.model.seed, \
      "random seed; the same seed, input and count budget give the same outputs") \
    X("sampler", Choice, Refinement, "uni+now", 0, 0, "now|uniform|agep|exp|uni+now|agep+now|uni+exp|agep+exp", "", "", 0, \
      engine.strategy.kind, \
      "which time step to refine next, P(t|T): now, uniform, agep (age-proportional), exp (exponential) or a mixture") \
    X("eta", Real, Refinement, "0.5", 0, 1, "", "", "", 0, engine.strategy.eta, \
      "mixing weight of the local part (now, exp) of a mixture sampler") \
    X("q", Real, Refinement, "0.5", 0, 1, "", "", "", LoOpen, engine.strategy.q, \
      "parameter of the exponential sampler") \
    X("budget.refines", BudgetSteps, Refinement, "40", 0, 1099511627776.0, "", "", "", 0, engine.budget, \
      "count budget: time steps refined per observation (reproducible; one budget key at most)") \
    X("budget.tokens", BudgetTokens, Refinement, "", 0, 1099511627776.0, "", "", "", 0, engine.budget, \
      "count budget instead: tokens refined per observation (reproducible)") \
    X("budget.ms", BudgetMs, Refinement, "", 0, 3600000, "", "", "--online.mint=50", LoOpen, engine.budget, \
      "time budget instead: milliseconds of refinement per observation (the paper's T_R; not reproducible)") \
    X("refine.window", Integer, Refinement, "256", 1, 65536, "", "", "--refine.window", 0, engine.model.refine_window, \
      "cell refinements per parallel window (W): 1 is the exact serial Gibbs sampler; results never depend on threads") \
    X("final.sweeps", Integer, Refinement, "0", 0, 1000000, "", "", "-n,--iter=100", 0, final_sweeps, \
      "batch Gibbs sweeps over the window at the end of the stream") \
    X("threads", Integer, Runtime, "1", 1, 1024, "", "", "--threads", Derived | Cores, engine.model.threads, \
      "refinement threads; the tool's default is the cores it may use (minus one for capture with --realtime)") \
    X("queue.slots", Integer, Runtime, "8", 1, 65536, "", "--queue.slots,--queue", "", 0, engine.queue_slots, \
      "observations the capture-to-refiner queue holds") \
    X("drop", Choice, Runtime, "oldest", 0, 0, "newest|oldest", "", "", 0, engine.drop, \
      "when the queue is full, drop the newest observation or the oldest queued one") \
    X("thread.fifo", Bool, Runtime, "false", 0, 0, "", "--thread.fifo,--fifo", "", 0, engine.thread.fifo, \
      "ask for SCHED_FIFO priority for the refiner (falls back with a note)") \
    X("thread.priority", Integer, Runtime, "80", 1, 99, "", "", "", 0, engine.thread.priority, \
      "SCHED_FIFO priority of the refiner") \
    X("thread.cpu", Integer, Runtime, "-1", -1, 1023, "", "--thread.cpu,--cpu", "", 0, engine.thread.cpu, \
      "pin the refiner to this CPU (-1: no pinning)") \
    X("thread.lock-memory", Bool, Runtime, "false", 0, 0, "", "", "", 0, engine.thread.lock_memory, \
      "lock the process's memory (mlockall) when the engine starts") \
    X("ppx.instantaneous", Bool, Runtime, "true", 0, 0, "", "", "", Library, engine.flags.instantaneous_perplexity, \
      "compute each time step's instantaneous perplexity before the next step is added") \
    X("ppx.snapshot", Bool, Runtime, "true", 0, 0, "", "", "", Library, engine.flags.snapshot_perplexity, \
      "compute the newest step's perplexity for each snapshot") \
    X("snapshot.labels", Bool, Runtime, "true", 0, 0, "", "", "", Library, engine.flags.snapshot_labels, \
      "publish the newest observation's labels and cell histograms in snapshots") \
    X("stop-on-arrival", Bool, Runtime, "false", 0, 0, "", "", "", Library, engine.flags.stop_on_arrival, \
      "time budget: stop refining as soon as a newer observation is queued (paper Algorithm 2)") \
    X("image.queue", Integer, Runtime, "4", 1, 1024, "", "", "", Library, image_queue, \
      "rost_node: images waiting for its words thread; a full queue drops its oldest") \
    X("checkpoint.every", Integer, Mission, "100", 1, 1099511627776.0, "", "", "", 0, checkpoint_every, \
      "observations between two checkpoints (with --checkpoint)") \
    X("words.orb", Bool, Words, "true", 0, 0, "", "--words.orb,!--no-orb", "", 0, words.orb, \
      "ORB words: each keypoint's descriptor quantised to its nearest vocabulary word") \
    X("words.intensity", Bool, Words, "true", 0, 0, "", "--words.intensity,!--no-intensity", "", 0, words.intensity, \
      "intensity words: the grey level of each thumbnail pixel") \
    X("words.hue", Bool, Words, "true", 0, 0, "", "--words.hue,!--no-hue", "", 0, words.hue, \
      "hue words: the hue of each coloured thumbnail pixel") \
    X("orb.features", Integer, Words, "1000", 1, 100000, "", "", "", 0, words.orb_features, \
      "ORB keypoints per frame at most (the strongest are kept)") \
    X("orb.fast", Integer, Words, "20", 1, 255, "", "", "", 0, words.orb_fast_threshold, \
      "ORB's FAST corner threshold") \
    X("orb.search", Choice, Words, "tree", 0, 0, "linear|tree", "", "", 0, words.orb_search, \
      "how a descriptor finds its word: linear (exact) or tree (coarse-to-fine, approximate)") \
    X("orb.probes", Integer, Words, "16", 1, 1024, "", "", "", 0, words.orb_probes, \
      "coarse buckets the tree search visits (more: closer to exact, slower)") \
    X("thumb.cell", Integer, Words, "16", 1, 256, "", "", "", 0, words.thumb_cell, \
      "pixels per thumbnail pixel of the intensity and hue words (one word each per block)")
// clang-format on

namespace rost {

enum class SettingType : uint8_t { Integer, Real, Bool, Choice, BudgetSteps, BudgetTokens, BudgetMs };

// What a setting configures.
enum class SettingGroup : uint8_t {
    Model,       // sizes and hyperparameters: they define a checkpoint's state
    Refinement,  // strategy and budget: how refinement proceeds (may change on resume)
    Runtime,     // queue, drop policy, threads, engine flags: how this process runs
    Mission,     // checkpoints
    Words,       // visual word extraction (rost::vision)
};

// Each group's name (Python's `describe()`, lower case) and its title (the
// tool's --help sections, `rost config`'s sections): the one table of them.
struct SettingGroupNames {
    std::string_view name, title;
};
inline constexpr SettingGroupNames kSettingGroupNames[] = {
    {"model", "Model"},
    {"refinement", "Refinement (paper section VI)"},
    {"runtime", "Realtime"},
    {"mission", "Missions (docs/trust.md)"},
    {"words", "Words"},
};
constexpr const SettingGroupNames& settingGroupNames(SettingGroup g) {
    return kSettingGroupNames[static_cast<int>(g)];
}

namespace setting_flags {
inline constexpr unsigned Derived = 1u;  // the tool derives it from the input unless it is set
inline constexpr unsigned Library = 2u;  // the library's and the node's; the tool sets it itself
inline constexpr unsigned LoOpen = 4u;   // the lower bound is excluded
inline constexpr unsigned Cores = 8u;    // with Derived: from the machine's cores, not the input
} // namespace setting_flags

struct SettingSpec {
    std::string_view key;
    SettingType type;
    SettingGroup group;
    std::string_view def;  // default, text form ("" for a budget kind that is not the default)
    double lo, hi;         // range of a number
    std::string_view choices;
    std::string_view cli;  // option names ("" : "--key")
    std::string_view rostcli;  // rost-cli's flag names[=its default] ("" : not a rost-cli flag)
    unsigned flags;
    std::string_view doc;

    constexpr bool has(unsigned f) const noexcept { return (flags & f) != 0; }
    constexpr bool isBudget() const noexcept {
        return type == SettingType::BudgetSteps || type == SettingType::BudgetTokens || type == SettingType::BudgetMs;
    }
};

namespace detail {
using enum SettingType;
using enum SettingGroup;
using namespace setting_flags;
#define ROST_SETTING_SPEC(key, type, group, def, lo, hi, choices, cli, rostcli, flags, field, doc) \
    SettingSpec{key, type, group, def, static_cast<double>(lo), static_cast<double>(hi), choices, cli, rostcli, flags, doc},
inline constexpr SettingSpec kSettingSpecs[] = {ROST_SETTINGS(ROST_SETTING_SPEC)};
#undef ROST_SETTING_SPEC

constexpr const SettingSpec& specOf(std::string_view key) {
    for (const SettingSpec& s : kSettingSpecs)
        if (s.key == key) return s;
    throw "no such setting in ROST_SETTINGS";  // a compile error where it is evaluated
}

// Decimal text ("16", "-1", "0.1", "1e6") to a number: the integer part and
// fraction are exact integers, so the one division rounds correctly, as
// std::from_chars does (a test checks every default against it).
constexpr double parseDecimal(std::string_view s) {
    bool neg = false;
    std::size_t i = 0;
    if (i < s.size() && s[i] == '-') neg = true, ++i;
    double mant = 0.0;
    int frac = 0;
    bool dot = false;
    for (; i < s.size() && s[i] != 'e'; ++i) {
        if (s[i] == '.') {
            dot = true;
            continue;
        }
        if (s[i] < '0' || s[i] > '9') throw "bad default";
        mant = mant * 10.0 + (s[i] - '0');
        if (dot) ++frac;
    }
    int exp = 0;
    if (i < s.size()) {
        for (++i; i < s.size(); ++i) exp = exp * 10 + (s[i] - '0');
    }
    exp -= frac;
    double scale = 1.0;
    for (int k = 0; k < (exp < 0 ? -exp : exp); ++k) scale *= 10.0;
    const double v = exp < 0 ? mant / scale : mant * scale;
    return neg ? -v : v;
}

constexpr int choiceIndex(const SettingSpec& s) {
    int index = 0;
    std::size_t at = 0;
    while (at <= s.choices.size()) {
        std::size_t end = s.choices.find('|', at);
        if (end == std::string_view::npos) end = s.choices.size();
        if (s.choices.substr(at, end - at) == s.def) return index;
        ++index;
        at = end + 1;
    }
    throw "default is not one of the choices";
}
} // namespace detail

// Every setting, in the order configuration files list them.
inline std::span<const SettingSpec> settingSpecs() noexcept { return detail::kSettingSpecs; }

// The declaration of `key`, at compile time (an unknown key does not compile).
consteval const SettingSpec& settingSpec(std::string_view key) { return detail::specOf(key); }

// The default of `key` as the field's type, at compile time: numbers and
// booleans from their text, a Choice as the enum value at its index.
template <class T>
consteval T settingDefault(std::string_view key) {
    const SettingSpec& s = detail::specOf(key);
    if constexpr (std::is_same_v<T, bool>) {
        return s.def == "true";
    } else if constexpr (std::is_enum_v<T>) {
        return static_cast<T>(detail::choiceIndex(s));
    } else {
        return static_cast<T>(detail::parseDecimal(s.def));
    }
}

} // namespace rost
