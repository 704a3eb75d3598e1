#include "rost/config_file.hpp"

#include <algorithm>
#include <charconv>
#include <cmath>
#include <cstdint>
#include <limits>
#include <map>

#include "rost/word_stream.hpp"

namespace rost {
namespace {

// ---- value codecs ---------------------------------------------------------------

template <typename T>
bool parseInteger(std::string_view s, T& out) {
    T v{};
    const auto [ptr, ec] = std::from_chars(s.data(), s.data() + s.size(), v);
    if (ec != std::errc() || ptr != s.data() + s.size()) return false;
    out = v;
    return true;
}

bool parseDouble(std::string_view s, double& out) {
    double v = 0.0;
    const auto [ptr, ec] = std::from_chars(s.data(), s.data() + s.size(), v);
    if (ec != std::errc() || ptr != s.data() + s.size() || !std::isfinite(v)) return false;
    out = v;
    return true;
}

bool parseBool(std::string_view s, bool& out) {
    if (s == "true" || s == "yes" || s == "on" || s == "1") {
        out = true;
        return true;
    }
    if (s == "false" || s == "no" || s == "off" || s == "0") {
        out = false;
        return true;
    }
    return false;
}

template <typename T>
std::string formatInteger(T v) {
    char buf[32];
    const auto r = std::to_chars(buf, buf + sizeof buf, v);
    return std::string(buf, r.ptr);
}

// Shortest text that parses back to the same double.
std::string formatDouble(double v) {
    char buf[64];
    const auto r = std::to_chars(buf, buf + sizeof buf, v);
    return std::string(buf, r.ptr);
}

std::string quoted(std::string_view s) {
    constexpr std::size_t kMax = 40;
    std::string out = "'";
    out += s.substr(0, kMax);
    if (s.size() > kMax) out += "...";
    out += "'";
    return out;
}

// ---- the key table --------------------------------------------------------------

// A setter returns an empty string on success, otherwise what was expected.
using Getter = std::string (*)(const EngineConfig&);
using Setter = std::string (*)(std::string_view, EngineConfig&);

struct Entry {
    ConfigKey key;
    Getter get;
    Setter set;
};

template <typename T>
std::string setIntField(std::string_view s, T& field) {
    long long v = 0;
    if (!parseInteger(s, v)) return "expected an integer";
    if (v < static_cast<long long>(std::numeric_limits<T>::min()) ||
        v > static_cast<long long>(std::numeric_limits<T>::max()))
        return "integer out of range";
    field = static_cast<T>(v);
    return {};
}

std::string setU64Field(std::string_view s, uint64_t& field) {
    uint64_t v = 0;
    if (!parseInteger(s, v)) return "expected a non-negative integer";
    field = v;
    return {};
}

std::string setDoubleField(std::string_view s, double& field) {
    if (!parseDouble(s, field)) return "expected a finite number";
    return {};
}

std::string setBoolField(std::string_view s, bool& field) {
    if (!parseBool(s, field)) return "expected true or false";
    return {};
}

#define ROST_INT_KEY(NAME, GROUP, HELP, FIELD)                                                       \
    Entry {                                                                                          \
        {NAME, GROUP, HELP}, [](const EngineConfig& c) { return formatInteger(c.FIELD); },           \
            [](std::string_view s, EngineConfig& c) { return setIntField(s, c.FIELD); }              \
    }
#define ROST_DOUBLE_KEY(NAME, GROUP, HELP, FIELD)                                                    \
    Entry {                                                                                          \
        {NAME, GROUP, HELP}, [](const EngineConfig& c) { return formatDouble(c.FIELD); },            \
            [](std::string_view s, EngineConfig& c) { return setDoubleField(s, c.FIELD); }           \
    }
#define ROST_BOOL_KEY(NAME, GROUP, HELP, FIELD)                                                      \
    Entry {                                                                                          \
        {NAME, GROUP, HELP}, [](const EngineConfig& c) { return std::string(c.FIELD ? "true" : "false"); }, \
            [](std::string_view s, EngineConfig& c) { return setBoolField(s, c.FIELD); }             \
    }

const std::vector<Entry>& entries() {
    using G = ConfigGroup;
    static const std::vector<Entry> table = {
        ROST_INT_KEY("K", G::Model, "topics", model.K),
        ROST_INT_KEY("V", G::Model, "vocabulary size", model.V),
        ROST_DOUBLE_KEY("alpha", G::Model, "Dirichlet prior on a neighbourhood's topics", model.alpha),
        ROST_DOUBLE_KEY("beta", G::Model, "Dirichlet prior on a topic's words", model.beta),
        ROST_INT_KEY("cell.space", G::Model, "cell width and height in pixels", model.cell_space),
        ROST_INT_KEY("cell.time", G::Model, "observations per temporal cell", model.cell_time),
        ROST_INT_KEY("g.space", G::Model, "spatial neighbourhood radius in cells", model.g_space),
        ROST_INT_KEY("g.time", G::Model, "temporal neighbourhood radius in cells", model.g_time),
        ROST_INT_KEY("frame.width", G::Model, "frame width in pixels", model.frame_width),
        ROST_INT_KEY("frame.height", G::Model, "frame height in pixels", model.frame_height),
        ROST_INT_KEY("ring.steps", G::Model, "temporal cells kept refinable", model.ring_steps),
        ROST_INT_KEY("cell.capacity", G::Model, "words a cell holds", model.cell_capacity),
        ROST_INT_KEY("max.words", G::Model, "words one observation holds", model.max_words_per_frame),
        Entry{{"eviction", G::Model, "keep|subtract: what an evicted step leaves in the topic model"},
              [](const EngineConfig& c) { return std::string(toString(c.model.eviction)); },
              [](std::string_view s, EngineConfig& c) -> std::string {
                  if (!parseEvictionPolicy(std::string(s), c.model.eviction).ok()) return "expected keep or subtract";
                  return {};
              }},
        Entry{{"seed", G::Model, "random seed"}, [](const EngineConfig& c) { return formatInteger(c.model.seed); },
              [](std::string_view s, EngineConfig& c) { return setU64Field(s, c.model.seed); }},
        Entry{{"sampler", G::Refinement, "refinement strategy P(t|T)"},
              [](const EngineConfig& c) { return std::string(toString(c.strategy.kind)); },
              [](std::string_view s, EngineConfig& c) -> std::string {
                  if (!parseStrategy(std::string(s), c.strategy.kind).ok())
                      return "expected one of now, uniform, agep, exp, uni+now, agep+now, uni+exp, agep+exp";
                  return {};
              }},
        ROST_DOUBLE_KEY("eta", G::Refinement, "weight of the local part of a mixed strategy", strategy.eta),
        ROST_DOUBLE_KEY("q", G::Refinement, "geometric parameter of the exponential strategies", strategy.q),
        Entry{{"budget.refines", G::Refinement, "time-step refinements per observation (count budget)"},
              [](const EngineConfig& c) {
                  return c.budget.kind == BudgetKind::Steps ? formatInteger(c.budget.count) : std::string();
              },
              [](std::string_view s, EngineConfig& c) {
                  c.budget.kind = BudgetKind::Steps;
                  return setU64Field(s, c.budget.count);
              }},
        Entry{{"budget.tokens", G::Refinement, "token refinements per observation (count budget)"},
              [](const EngineConfig& c) {
                  return c.budget.kind == BudgetKind::Tokens ? formatInteger(c.budget.count) : std::string();
              },
              [](std::string_view s, EngineConfig& c) {
                  c.budget.kind = BudgetKind::Tokens;
                  return setU64Field(s, c.budget.count);
              }},
        Entry{{"budget.ms", G::Refinement, "milliseconds of refinement per observation (time budget)"},
              [](const EngineConfig& c) {
                  return c.budget.kind == BudgetKind::Time ? formatDouble(c.budget.ms) : std::string();
              },
              [](std::string_view s, EngineConfig& c) {
                  c.budget.kind = BudgetKind::Time;
                  return setDoubleField(s, c.budget.ms);
              }},
        ROST_INT_KEY("queue.slots", G::Runtime, "observations the queue holds", queue_slots),
        Entry{{"drop", G::Runtime, "newest|oldest: what a full queue drops"},
              [](const EngineConfig& c) { return std::string(toString(c.drop)); },
              [](std::string_view s, EngineConfig& c) -> std::string {
                  if (!parseDropPolicy(std::string(s), c.drop).ok()) return "expected newest or oldest";
                  return {};
              }},
        ROST_BOOL_KEY("thread.fifo", G::Runtime, "run the refiner with SCHED_FIFO", thread.fifo),
        ROST_INT_KEY("thread.priority", G::Runtime, "SCHED_FIFO priority", thread.priority),
        ROST_INT_KEY("thread.cpu", G::Runtime, "CPU to pin the refiner to (-1: none)", thread.cpu),
        ROST_BOOL_KEY("thread.lock-memory", G::Runtime, "mlockall at start", thread.lock_memory),
        ROST_BOOL_KEY("ppx.instantaneous", G::Runtime, "instantaneous perplexity of each step",
                      flags.instantaneous_perplexity),
        ROST_BOOL_KEY("ppx.snapshot", G::Runtime, "perplexity of the newest step in snapshots",
                      flags.snapshot_perplexity),
        ROST_BOOL_KEY("snapshot.labels", G::Runtime, "labels and histograms in snapshots", flags.snapshot_labels),
        ROST_BOOL_KEY("stop-on-arrival", G::Runtime, "time budget: stop refining when a newer observation waits",
                      flags.stop_on_arrival),
    };
    return table;
}

#undef ROST_INT_KEY
#undef ROST_DOUBLE_KEY
#undef ROST_BOOL_KEY

const Entry* find(std::string_view key) {
    for (const Entry& e : entries())
        if (key == e.key.name) return &e;
    return nullptr;
}

std::size_t editDistance(std::string_view a, std::string_view b) {
    std::vector<std::size_t> row(b.size() + 1);
    for (std::size_t j = 0; j <= b.size(); ++j) row[j] = j;
    for (std::size_t i = 1; i <= a.size(); ++i) {
        std::size_t diag = row[0];
        row[0] = i;
        for (std::size_t j = 1; j <= b.size(); ++j) {
            const std::size_t up = row[j];
            row[j] = std::min({row[j] + 1, row[j - 1] + 1, diag + (a[i - 1] == b[j - 1] ? 0 : 1)});
            diag = up;
        }
    }
    return row[b.size()];
}

std::string unknownKey(std::string_view key) {
    std::string msg = "unknown key " + quoted(key);
    const Entry* best = nullptr;
    std::size_t bestD = 3;
    if (key.size() <= 64)
        for (const Entry& e : entries()) {
            const std::size_t d = editDistance(key, e.key.name);
            if (d < bestD) {
                bestD = d;
                best = &e;
            }
        }
    if (best) msg += std::string(" (did you mean '") + best->key.name + "'?)";
    return msg;
}

bool isBudgetKey(std::string_view k) { return k == "budget.refines" || k == "budget.tokens" || k == "budget.ms"; }

std::string_view trim(std::string_view s) {
    std::size_t b = 0, e = s.size();
    while (b < e && (s[b] == ' ' || s[b] == '\t' || s[b] == '\r')) ++b;
    while (e > b && (s[e - 1] == ' ' || s[e - 1] == '\t' || s[e - 1] == '\r')) --e;
    return s.substr(b, e - b);
}

// The key a validation message is about: "K = 0, allowed ..." names K; the
// engine's messages use a few other spellings.
bool messageNames(const std::string& msg, std::string_view key) {
    auto names = [&](std::string_view field) {
        const std::string pat = std::string(field) + " = ";
        for (std::size_t at = msg.find(pat); at != std::string::npos; at = msg.find(pat, at + 1)) {
            const char before = at == 0 ? ' ' : msg[at - 1];
            if (before == ' ' || before == '.') return true;
        }
        return false;
    };
    if (names(key)) return true;
    if (key == "queue.slots") return names("queue_slots");
    if (isBudgetKey(key)) return names("budget.count");
    return false;
}

} // namespace

const std::vector<ConfigKey>& configKeys() {
    static const std::vector<ConfigKey> keys = [] {
        std::vector<ConfigKey> k;
        for (const Entry& e : entries()) k.push_back(e.key);
        return k;
    }();
    return keys;
}

Status setConfigValue(std::string_view key, std::string_view value, EngineConfig& cfg) {
    const Entry* e = find(key);
    if (!e) return Status::error(unknownKey(key));
    EngineConfig tmp = cfg;
    const std::string why = e->set(value, tmp);
    if (!why.empty()) return Status::error("key '" + std::string(key) + "': " + why + ", found " + quoted(value));
    cfg = tmp;
    return {};
}

std::string configValue(const EngineConfig& cfg, std::string_view key) {
    const Entry* e = find(key);
    return e ? e->get(cfg) : std::string();
}

Status parseConfigText(std::string_view text, std::string_view name, EngineConfig& cfg,
                       std::vector<ConfigKeyLine>* set) {
    EngineConfig tmp = cfg;
    std::map<std::string, int, std::less<>> seen;  // key -> line
    std::string budgetKey;
    int lineNo = 0;
    std::size_t pos = 0;
    auto where = [&](int line) { return std::string(name) + ":" + std::to_string(line) + ": "; };
    while (pos <= text.size()) {
        std::size_t end = text.find('\n', pos);
        if (end == std::string_view::npos) end = text.size();
        std::string_view line = text.substr(pos, end - pos);
        pos = end + 1;
        ++lineNo;
        if (line.find('\0') != std::string_view::npos) return Status::error(where(lineNo) + "NUL byte in the text");
        // A comment runs from '#' to the end of the line (no value contains '#').
        if (const std::size_t hash = line.find('#'); hash != std::string_view::npos) line = line.substr(0, hash);
        line = trim(line);
        if (line.empty()) {
            if (end == text.size()) break;
            continue;
        }
        const std::size_t eq = line.find('=');
        if (eq == std::string_view::npos)
            return Status::error(where(lineNo) + "expected 'key = value', found " + quoted(line));
        const std::string_view key = trim(line.substr(0, eq));
        const std::string_view value = trim(line.substr(eq + 1));
        if (key.empty()) return Status::error(where(lineNo) + "missing key before '='");
        const Entry* e = find(key);
        if (!e) return Status::error(where(lineNo) + unknownKey(key));
        if (auto it = seen.find(key); it != seen.end())
            return Status::error(where(lineNo) + "key '" + std::string(key) + "' set again (first set on line " +
                                 std::to_string(it->second) + ")");
        if (isBudgetKey(key)) {
            if (!budgetKey.empty())
                return Status::error(where(lineNo) + "key '" + std::string(key) + "': a budget was already set by '" +
                                     budgetKey + "' on line " + std::to_string(seen[budgetKey]) +
                                     " (give one of budget.refines, budget.tokens, budget.ms)");
            budgetKey = std::string(key);
        }
        if (value.empty()) return Status::error(where(lineNo) + "key '" + std::string(key) + "': missing value");
        const std::string why = e->set(value, tmp);
        if (!why.empty())
            return Status::error(where(lineNo) + "key '" + std::string(key) + "': " + why + ", found " + quoted(value));
        seen.emplace(std::string(key), lineNo);
        if (end == text.size()) break;
    }
    if (Status st = tmp.validate(); !st.ok()) {
        // Point at the line that set the offending key, when the file set it.
        for (const auto& [key, line] : seen)
            if (messageNames(st.message(), key))
                return Status::error(where(line) + "key '" + key + "': " + st.message());
        return Status::error(std::string(name) + ": " + st.message());
    }
    cfg = tmp;
    if (set) {
        set->clear();
        for (const auto& [key, line] : seen) set->push_back({key, line});
        std::sort(set->begin(), set->end(), [](const ConfigKeyLine& a, const ConfigKeyLine& b) { return a.line < b.line; });
    }
    return {};
}

Status readConfigFile(const std::string& path, EngineConfig& cfg, std::vector<ConfigKeyLine>* set) {
    std::string text;
    if (Status st = readFile(path, text); !st.ok()) return st;
    return parseConfigText(text, path, cfg, set);
}

std::string formatConfig(const EngineConfig& cfg) {
    std::string out;
    for (const Entry& e : entries()) {
        const std::string v = e.get(cfg);
        if (v.empty()) continue;
        out += e.key.name;
        out += " = ";
        out += v;
        out += '\n';
    }
    return out;
}

std::vector<std::string> configDifferences(const EngineConfig& a, const EngineConfig& b,
                                           std::initializer_list<ConfigGroup> groups, std::string_view aName,
                                           std::string_view bName) {
    std::vector<std::string> out;
    for (const Entry& e : entries()) {
        if (std::find(groups.begin(), groups.end(), e.key.group) == groups.end()) continue;
        const std::string va = e.get(a), vb = e.get(b);
        if (va == vb) continue;
        out.push_back(std::string(e.key.name) + " = " + (va.empty() ? "(unset)" : va) + " in " + std::string(aName) +
                      ", " + (vb.empty() ? "(unset)" : vb) + " in " + std::string(bName));
    }
    return out;
}

} // namespace rost
