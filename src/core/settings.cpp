#include "rost/settings.hpp"

#include <algorithm>
#include <charconv>
#include <cmath>
#include <limits>
#include <optional>
#include <type_traits>

#include "kernel_tables.hpp"
#include "rost/word_stream.hpp"
#include "settings_text.hpp"

namespace rost {
// Shared with settings_text.cpp (the configuration files' text): settings_text.hpp.
namespace settings_detail {

std::string quoted(std::string_view s) {
    constexpr std::size_t kMax = 40;
    std::string out = "'";
    out += text::printable(s, kMax);
    if (s.size() > kMax) out += "...";
    out += "'";
    return out;
}

std::string_view trim(std::string_view s) {
    std::size_t b = 0, e = s.size();
    while (b < e && (s[b] == ' ' || s[b] == '\t' || s[b] == '\r')) ++b;
    while (e > b && (s[e - 1] == ' ' || s[e - 1] == '\t' || s[e - 1] == '\r')) --e;
    return s.substr(b, e - b);
}

} // namespace settings_detail
using settings_detail::quoted;
using settings_detail::trim;

namespace {

// ---- text forms of values ----------------------------------------------------

// Why `s` is not an integer of type T: "" when it is (then in `out`); a
// number too large for T is "integer out of range", which setSettingText
// words as the setting's range, rather than "expected ...".
template <typename T>
std::string integerProblem(std::string_view s, T& out, const char* expected) {
    T v{};
    const auto [ptr, ec] = std::from_chars(s.data(), s.data() + s.size(), v);
    if (ec == std::errc::result_out_of_range && ptr == s.data() + s.size())
        return "integer out of range";
    if (ec != std::errc() || ptr != s.data() + s.size()) return expected;
    out = v;
    return {};
}

bool parseDouble(std::string_view s, double& out) {
    double v = 0.0;
    const auto [ptr, ec] = std::from_chars(s.data(), s.data() + s.size(), v);
    if (ec != std::errc() || ptr != s.data() + s.size() || !std::isfinite(v)) return false;
    out = v;
    return true;
}

bool parseBool(std::string_view s, bool& out) {
    if (s == "true" || s == "yes" || s == "on" || s == "1") return out = true, true;
    if (s == "false" || s == "no" || s == "off" || s == "0") return out = false, true;
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


std::vector<std::string_view> choiceNames(std::string_view choices) {
    std::vector<std::string_view> out;
    std::size_t at = 0;
    while (at <= choices.size()) {
        std::size_t end = choices.find('|', at);
        if (end == std::string_view::npos) end = choices.size();
        out.push_back(choices.substr(at, end - at));
        at = end + 1;
    }
    return out;
}

// "expected keep or subtract", "expected one of now, uniform, ...".
std::string expectedChoice(std::string_view choices) {
    const auto names = choiceNames(choices);
    std::string out = names.size() == 2 ? "expected " : "expected one of ";
    for (std::size_t i = 0; i < names.size(); ++i) {
        if (i) out += names.size() == 2 ? " or " : ", ";
        out += names[i];
    }
    return out;
}

// ---- one codec per setting type: the field <-> text ------------------------------
// A setter returns an empty string on success, otherwise what was expected.

template <SettingType T>
struct Codec;

template <>
struct Codec<SettingType::Integer> {
    template <class F>
    static std::string get(const SettingSpec&, const F& f) { return formatInteger(f); }
    template <class F>
    static std::string set(const SettingSpec&, std::string_view s, F& f) {
        if constexpr (std::is_same_v<F, uint64_t>) {
            uint64_t v = 0;
            if (std::string why = integerProblem(s, v, "expected a non-negative integer"); !why.empty()) return why;
            f = v;
        } else {
            long long v = 0;
            if (std::string why = integerProblem(s, v, "expected an integer"); !why.empty()) return why;
            if (v < static_cast<long long>(std::numeric_limits<F>::min()) ||
                v > static_cast<long long>(std::numeric_limits<F>::max()))
                return "integer out of range";
            f = static_cast<F>(v);
        }
        return {};
    }
    template <class F>
    static bool number(const F& f, double& out) { return out = static_cast<double>(f), true; }
};

template <>
struct Codec<SettingType::Real> {
    static std::string get(const SettingSpec&, double f) { return formatDouble(f); }
    static std::string set(const SettingSpec&, std::string_view s, double& f) {
        return parseDouble(s, f) ? std::string() : "expected a finite number";
    }
    static bool number(double f, double& out) { return out = f, true; }
};

template <>
struct Codec<SettingType::Bool> {
    static std::string get(const SettingSpec&, bool f) { return f ? "true" : "false"; }
    static std::string set(const SettingSpec&, std::string_view s, bool& f) {
        return parseBool(s, f) ? std::string() : "expected true or false";
    }
    static bool number(bool, double&) { return false; }
};

template <>
struct Codec<SettingType::Choice> {
    template <class E>
    static std::string get(const SettingSpec& spec, const E& f) {
        const auto names = choiceNames(spec.choices);
        const auto i = static_cast<std::size_t>(f);
        return i < names.size() ? std::string(names[i]) : std::string("?");
    }
    template <class E>
    static std::string set(const SettingSpec& spec, std::string_view s, E& f) {
        const auto names = choiceNames(spec.choices);
        for (std::size_t i = 0; i < names.size(); ++i)
            if (names[i] == s) return f = static_cast<E>(i), std::string();
        return expectedChoice(spec.choices);
    }
    template <class E>
    static bool number(const E& f, double& out) { return out = static_cast<double>(f), true; }  // the choice's index
};

// The three budget keys share one Budget: the key sets its kind.
template <BudgetKind K>
struct BudgetCodec {
    static std::string get(const SettingSpec&, const Budget& b) {
        if (b.kind != K) return {};
        return K == BudgetKind::Time ? formatDouble(b.ms) : formatInteger(b.count);
    }
    static std::string set(const SettingSpec&, std::string_view s, Budget& b) {
        if constexpr (K == BudgetKind::Time) {
            double ms = 0.0;
            if (!parseDouble(s, ms)) return "expected a finite number";
            b = Budget::time(ms);
        } else {
            uint64_t n = 0;
            if (std::string why = integerProblem(s, n, "expected a non-negative integer"); !why.empty()) return why;
            b = Budget{K, n, 0.0};
        }
        return {};
    }
    static bool number(const Budget& b, double& out) {
        if (b.kind != K) return false;  // not the budget in force
        out = K == BudgetKind::Time ? b.ms : static_cast<double>(b.count);
        return true;
    }
};
template <>
struct Codec<SettingType::BudgetSteps> : BudgetCodec<BudgetKind::Steps> {};
template <>
struct Codec<SettingType::BudgetTokens> : BudgetCodec<BudgetKind::Tokens> {};
template <>
struct Codec<SettingType::BudgetMs> : BudgetCodec<BudgetKind::Time> {};

// ---- the binding of each key to its field, made from the schema ------------------

struct Binding {
    const SettingSpec& spec;
    std::string_view field;  // "engine.model.K": the part of Settings it lies in
    std::string (*get)(const SettingSpec&, const Settings&);
    std::string (*set)(const SettingSpec&, std::string_view, Settings&);
    bool (*number)(const Settings&, double&);  // false: a Bool, or a budget not in force
    bool engine() const noexcept { return field.starts_with("engine."); }
};

constexpr std::size_t specIndex(std::string_view key) {
    for (std::size_t i = 0; i < std::size(detail::kSettingSpecs); ++i)
        if (detail::kSettingSpecs[i].key == key) return i;
    return std::size(detail::kSettingSpecs);
}

#define ROST_SETTING_BINDING(key, type, group, def, lo, hi, choices, cli, rostcli, flags, field, doc)               \
    Binding{detail::kSettingSpecs[specIndex(key)], std::string_view(#field),                                 \
            [](const SettingSpec& sp, const Settings& s) { return Codec<SettingType::type>::get(sp, s.field); }, \
            [](const SettingSpec& sp, std::string_view v, Settings& s) {                                     \
                return Codec<SettingType::type>::set(sp, v, s.field);                                        \
            },                                                                                               \
            [](const Settings& s, double& out) { return Codec<SettingType::type>::number(s.field, out); }},
const Binding kBindings[] = {ROST_SETTINGS(ROST_SETTING_BINDING)};
#undef ROST_SETTING_BINDING

const Binding* bindingOf(const SettingSpec& spec) {
    for (const Binding& b : kBindings)
        if (&b.spec == &spec) return &b;
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



std::string formatBound(const SettingSpec& s, double v) {
    if (s.type == SettingType::Integer || s.type == SettingType::BudgetSteps || s.type == SettingType::BudgetTokens) {
        if (v >= 1.8e19) return "2^64-1";
        return formatInteger(static_cast<long long>(v));
    }
    if (v == std::floor(v) && std::abs(v) < 1e15) return formatInteger(static_cast<long long>(v));  // "1000000"
    return formatDouble(v);  // shortest round trip: "0.5"
}

// A number against the schema's range (a Choice: its index among the names).
std::optional<SettingProblem> rangeProblem(const SettingSpec& sp, double v, std::string text) {
    bool bad;
    if (sp.type == SettingType::Choice) {
        bad = !(v >= 0 && v < static_cast<double>(choiceNames(sp.choices).size()));
        if (bad) text = formatInteger(static_cast<long long>(v));
    } else {
        const bool low = sp.has(setting_flags::LoOpen) ? !(v > sp.lo) : !(v >= sp.lo);
        bad = low || !(v <= sp.hi);  // NaN fails both
    }
    if (!bad) return std::nullopt;
    return SettingProblem{&sp, SettingProblem::Kind::Range, std::move(text), settingRange(sp), {}, {}};
}

// The bindings whose field starts with `part` ("" : all), in schema order.
std::optional<SettingProblem> checkPart(const Settings& s, std::string_view part) {
    for (const Binding& b : kBindings) {
        if (!b.field.starts_with(part)) continue;
        double v = 0.0;
        if (!b.number(s, v)) continue;
        if (auto p = rangeProblem(b.spec, v, b.get(b.spec, s))) return p;
    }
    return std::nullopt;
}

const SettingSpec& specNamed(std::string_view key) { return *findSetting(key); }

// The model's combinations, each blamed on one setting, the others involved named.
std::optional<SettingProblem> modelCombinations(const Config& c) {
    using K = SettingProblem::Kind;
    const auto& spec = [](std::string_view key) { return &specNamed(key); };
    const auto n = [](auto v) { return formatInteger(static_cast<long long>(v)); };
    if (c.fixed && c.grow)
        return SettingProblem{spec("topics.grow"), K::Range, "true", "false with {topicmodel.fixed} = true",
                              {spec("topicmodel.fixed")}, "a fixed topic model opens no topics (K is the given model's rows)"};
    // A ring of one step has no temporal neighbours; it keeps g.time's
    // default of 1, but no more (a larger one would still set the rounds'
    // colours, and change the draws, for neighbours that never exist).
    if (c.g_time > std::max(c.ring_steps - 1, 1))
        return SettingProblem{spec("g.time"), K::Range, n(c.g_time), "[0, " + n(std::max(c.ring_steps - 1, 1)) + "]",
                              {spec("ring.steps")},
                              c.ring_steps > 1 ? "below {ring.steps} = " + n(c.ring_steps)
                                               : "a ring of {ring.steps} = 1 has no temporal neighbours"};
    // The grid in 64 bits first: cellsPerStep() multiplies ints, which a
    // 65536 x 65536 frame of 1-pixel cells would overflow.
    constexpr int64_t kMaxCells = int64_t{1} << 20;
    auto cellsAt = [&](int64_t space) {
        return ((c.frame_width + space - 1) / space) * ((c.frame_height + space - 1) / space);
    };
    const int64_t cells = cellsAt(c.cell_space);
    const std::vector<const SettingSpec*> frame = {spec("frame.width"), spec("frame.height")};
    const std::string frameText = "{frame.width} = " + n(c.frame_width) + " by {frame.height} = " + n(c.frame_height);
    if (cells > kMaxCells) {
        int64_t least = c.cell_space + 1;
        while (cellsAt(least) > kMaxCells) ++least;
        return SettingProblem{spec("cell.space"), K::Range, n(c.cell_space), "at least " + n(least) + " for " + frameText,
                              frame, n(cells) + " cells a step, at most 1048576"};
    }
    constexpr double kMaxBytes = 64.0 * 1024 * 1024 * 1024;
    const double stepBytes = static_cast<double>(cells) * c.cell_capacity * 8.0;  // a cell's words and labels
    if (static_cast<double>(c.ring_steps) * stepBytes > kMaxBytes)
        return SettingProblem{spec("ring.steps"), K::Range, n(c.ring_steps),
                              "at most " + n(kMaxBytes / stepBytes) + " for " + n(cells) + " cells a step (" + frameText +
                                  " in cells of {cell.space} = " + n(c.cell_space) + ") of {cell.capacity} = " +
                                  n(c.cell_capacity) + " words",
                              {spec("frame.width"), spec("frame.height"), spec("cell.space"), spec("cell.capacity")},
                              "the ring would need more than 64 GiB; lower {ring.steps} or {cell.capacity}, or raise "
                              "{cell.space}"};
    // The cells' topic counts (4 bytes a topic, K padded to the kernel's
    // blocks as they are stored), which outgrow the words when K is above
    // twice cell.capacity.
    const double countBytes = static_cast<double>(cells) * kernel::paddedK(c.K) * 4.0;
    if (static_cast<double>(c.ring_steps) * countBytes > kMaxBytes)
        return SettingProblem{spec("ring.steps"), K::Range, n(c.ring_steps),
                              "at most " + n(kMaxBytes / countBytes) + " for " + n(cells) + " cells a step (" + frameText +
                                  " in cells of {cell.space} = " + n(c.cell_space) + ") of {K} = " + n(c.K) + " topics",
                              {spec("frame.width"), spec("frame.height"), spec("cell.space"), spec("K")},
                              "the cells' topic counts would need more than 64 GiB; lower {ring.steps} or {K}, or raise "
                              "{cell.space}"};
    // Each observation's kept inputs (word, position, cell slot: 12 bytes).
    const double obsBytes = static_cast<double>(c.cell_time) * c.max_words_per_frame * 12.0;
    if (static_cast<double>(c.ring_steps) * obsBytes > kMaxBytes)
        return SettingProblem{spec("ring.steps"), K::Range, n(c.ring_steps),
                              "at most " + n(kMaxBytes / obsBytes) + " with {cell.time} = " + n(c.cell_time) +
                                  " and {max.words} = " + n(c.max_words_per_frame),
                              {spec("cell.time"), spec("max.words")},
                              "the observations' inputs would need more than 64 GiB; lower {ring.steps}, {cell.time} or "
                              "{max.words}"};
    // And the three together, each within the bound alone.
    const double allBytes = stepBytes + countBytes + obsBytes;
    if (static_cast<double>(c.ring_steps) * allBytes > kMaxBytes)
        return SettingProblem{spec("ring.steps"), K::Range, n(c.ring_steps),
                              "at most " + n(kMaxBytes / allBytes) + " for " + n(cells) + " cells a step (" + frameText +
                                  " in cells of {cell.space} = " + n(c.cell_space) + ") of {cell.capacity} = " +
                                  n(c.cell_capacity) + " words and {K} = " + n(c.K) + " topics, and {cell.time} = " +
                                  n(c.cell_time) + " observations of {max.words} = " + n(c.max_words_per_frame),
                              {spec("frame.width"), spec("frame.height"), spec("cell.space"), spec("cell.capacity"),
                               spec("K"), spec("cell.time"), spec("max.words")},
                              "the ring's words, topic counts and observations together would need more than 64 GiB"};
    return std::nullopt;
}
} // namespace

const SettingSpec* findSetting(std::string_view name) noexcept {
    for (const SettingSpec& s : settingSpecs())
        if (s.key == name) return &s;
    for (const SettingSpec& s : settingSpecs()) {
        if (s.key.size() != name.size()) continue;
        bool same = true;
        for (std::size_t i = 0; same && i < name.size(); ++i) {
            const char k = s.key[i] == '.' || s.key[i] == '-' ? '_' : s.key[i];
            same = k == name[i];
        }
        if (same) return &s;
    }
    return nullptr;
}

std::string paramName(const SettingSpec& spec) {
    std::string out(spec.key);
    std::replace_if(out.begin(), out.end(), [](char c) { return c == '.' || c == '-'; }, '_');
    return out;
}

bool isEngineSetting(const SettingSpec& spec) noexcept {
    const Binding* b = bindingOf(spec);
    return b && b->engine();
}

std::string settingRange(const SettingSpec& s) {
    switch (s.type) {
    case SettingType::Bool: return "true|false";
    case SettingType::Choice: return std::string(s.choices);
    default:
    {
        std::string out(1, s.has(setting_flags::LoOpen) ? '(' : '[');
        out += formatBound(s, s.lo);
        out += ", ";
        out += formatBound(s, s.hi);
        out += ']';
        return out;
    }
    }
}

namespace {
// Every Choice setting's names, NUL-terminated, built once without the heap.
struct ChoiceTable {
    static constexpr std::size_t kMaxNames = 16;
    char text[1024] = {};
    const char* names[std::size(detail::kSettingSpecs)][kMaxNames] = {};
    std::size_t count[std::size(detail::kSettingSpecs)] = {};
    ChoiceTable() noexcept {
        std::size_t at = 0;
        for (std::size_t i = 0; i < std::size(detail::kSettingSpecs); ++i) {
            const std::string_view c = detail::kSettingSpecs[i].choices;
            if (detail::kSettingSpecs[i].type != SettingType::Choice || c.size() + 1 > sizeof text - at) continue;
            std::copy(c.begin(), c.end(), text + at);
            names[i][count[i]++] = text + at;
            for (std::size_t k = 0; k < c.size(); ++k)
                if (text[at + k] == '|' && count[i] < kMaxNames) text[at + k] = '\0', names[i][count[i]++] = text + at + k + 1;
            at += c.size() + 1;
        }
    }
};
const ChoiceTable& choiceTable() noexcept {
    static const ChoiceTable table;
    return table;
}
} // namespace

const char* choiceName(const SettingSpec& spec, std::size_t index) noexcept {
    const std::size_t i = static_cast<std::size_t>(&spec - detail::kSettingSpecs);
    if (i >= std::size(detail::kSettingSpecs) || index >= choiceTable().count[i]) return "?";
    return choiceTable().names[i][index];
}

int choiceIndexOf(const SettingSpec& spec, std::string_view name) noexcept {
    const std::size_t i = static_cast<std::size_t>(&spec - detail::kSettingSpecs);
    if (i >= std::size(detail::kSettingSpecs)) return -1;
    for (std::size_t k = 0; k < choiceTable().count[i]; ++k)
        if (name == choiceTable().names[i][k]) return static_cast<int>(k);
    return -1;
}

std::string choiceExpected(const SettingSpec& spec) { return expectedChoice(spec.choices); }

std::string SettingProblem::compose(std::string name, const std::function<std::string(const SettingSpec&)>& spell) const {
    // "{key}" -> the face's name of that setting.
    auto spelled = [&](const std::string& text) {
        std::string out;
        for (std::size_t at = 0; at < text.size();) {
            const std::size_t open = text.find('{', at), close = open == std::string::npos ? open : text.find('}', open);
            const SettingSpec* named =
                close == std::string::npos ? nullptr : findSetting(std::string_view(text).substr(open + 1, close - open - 1));
            if (!named) {
                const std::size_t to = open == std::string::npos ? text.size() : open + 1;
                out.append(text, at, to - at);
                at = to;
                continue;
            }
            out.append(text, at, open - at);
            out += spell(*named);
            at = close + 1;
        }
        return out;
    };
    if (kind == Kind::Type) return name + ": expected " + spelled(allowed) + ", found " + quoted(value);
    std::string out = name + " = " + value + ", allowed " + spelled(allowed);
    if (!note.empty()) out += "; " + spelled(note);
    return out;
}

std::string SettingProblem::describe(std::string_view name) const {
    return compose(std::string(name), [&](const SettingSpec& s) {
        return &s == spec ? std::string(name) : std::string(s.key);
    });
}

const SettingSpec* closestSetting(std::string_view name) noexcept {
    if (const SettingSpec* s = findSetting(name)) return s;
    const SettingSpec* best = nullptr;
    std::size_t bestD = 3;
    if (name.size() <= 64)
        for (const SettingSpec& c : settingSpecs()) {
            // Against the key and the parameter name: "alfa", "cell_spac".
            std::size_t d = editDistance(name, c.key);
            std::string param(c.key);
            std::replace_if(param.begin(), param.end(), [](char ch) { return ch == '.' || ch == '-'; }, '_');
            d = std::min(d, editDistance(name, param));
            if (d < bestD) bestD = d, best = &c;
        }
    return best;
}

namespace settings_detail {
// "unknown key 'alfa' (did you mean 'alpha'?)"; a parameter name ("cell_space")
// is pointed to its key.
std::string unknownKey(std::string_view name) {
    std::string msg = "unknown key " + quoted(name);
    if (const SettingSpec* best = closestSetting(name)) msg += " (did you mean '" + std::string(best->key) + "'?)";
    return msg;
}
} // namespace settings_detail
using settings_detail::unknownKey;

std::optional<SettingProblem> setSettingText(Settings& s, const SettingSpec& spec, std::string_view value) {
    Settings tmp = s;
    std::string why = bindingOf(spec)->set(spec, value, tmp);
    if (!why.empty()) {
        if (why.rfind("expected ", 0) != 0)  // an integer beyond the field's type: the schema's range
            return SettingProblem{&spec, SettingProblem::Kind::Range, std::string(value), settingRange(spec), {}, {}};
        why.erase(0, 9);
        return SettingProblem{&spec, SettingProblem::Kind::Type, std::string(value), std::move(why), {}, {}};
    }
    s = tmp;
    return std::nullopt;
}

Status setSetting(Settings& s, std::string_view name, std::string_view value) {
    const SettingSpec* spec = findSetting(name);
    if (!spec) return Status::error(unknownKey(name));
    if (auto p = setSettingText(s, *spec, value)) return Status::error(p->describe("key '" + std::string(spec->key) + "'"));
    return {};
}

std::string settingValue(const Settings& s, std::string_view name) {
    const SettingSpec* spec = findSetting(name);
    return spec ? bindingOf(*spec)->get(*spec, s) : std::string();
}

std::optional<SettingProblem> checkSettings(const Settings& s) {
    if (auto p = checkPart(s, "")) return p;
    return modelCombinations(s.engine.model);
}

std::optional<SettingProblem> checkSettingRanges(const Settings& s) { return checkPart(s, ""); }

std::optional<SettingProblem> checkModelSettings(const Config& c) {
    Settings s;
    s.engine.model = c;
    if (auto p = checkPart(s, "engine.model.")) return p;
    return modelCombinations(c);
}

std::optional<SettingProblem> checkStrategySettings(const StrategyConfig& c) {
    Settings s;
    s.engine.strategy = c;
    return checkPart(s, "engine.strategy.");
}

std::optional<SettingProblem> checkEngineSettings(const EngineConfig& c) {
    Settings s;
    s.engine = c;
    if (auto p = checkPart(s, "engine.")) return p;
    return modelCombinations(c.model);
}

std::optional<SettingProblem> checkSettingRange(const SettingSpec& spec, double value) {
    return rangeProblem(spec, value, spec.type == SettingType::Real || spec.type == SettingType::BudgetMs
                                         ? formatDouble(value)
                                         : formatInteger(static_cast<long long>(value)));
}

Status Settings::validate() const {
    if (auto p = checkSettings(*this)) return Status::error("invalid configuration: " + p->describe(p->spec->key));
    return {};
}

} // namespace rost
