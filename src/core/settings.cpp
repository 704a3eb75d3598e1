#include "rost/settings.hpp"

#include <algorithm>
#include <charconv>
#include <cmath>
#include <limits>
#include <map>
#include <sstream>
#include <type_traits>

#include "rost/word_stream.hpp"

namespace rost {
namespace {

// ---- text forms of values ----------------------------------------------------

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

std::string quoted(std::string_view s) {
    constexpr std::size_t kMax = 40;
    std::string out = "'";
    out += s.substr(0, kMax);
    if (s.size() > kMax) out += "...";
    out += "'";
    return out;
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
            if (!parseInteger(s, v)) return "expected a non-negative integer";
            f = v;
        } else {
            long long v = 0;
            if (!parseInteger(s, v)) return "expected an integer";
            if (v < static_cast<long long>(std::numeric_limits<F>::min()) ||
                v > static_cast<long long>(std::numeric_limits<F>::max()))
                return "integer out of range";
            f = static_cast<F>(v);
        }
        return {};
    }
    template <class F>
    static double number(const F& f) { return static_cast<double>(f); }
};

template <>
struct Codec<SettingType::Real> {
    static std::string get(const SettingSpec&, double f) { return formatDouble(f); }
    static std::string set(const SettingSpec&, std::string_view s, double& f) {
        return parseDouble(s, f) ? std::string() : "expected a finite number";
    }
    static double number(double f) { return f; }
};

template <>
struct Codec<SettingType::Bool> {
    static std::string get(const SettingSpec&, bool f) { return f ? "true" : "false"; }
    static std::string set(const SettingSpec&, std::string_view s, bool& f) {
        return parseBool(s, f) ? std::string() : "expected true or false";
    }
    static double number(bool) { return std::nan(""); }
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
    static double number(const E&) { return std::nan(""); }
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
            if (!parseInteger(s, n)) return "expected a non-negative integer";
            b = Budget{K, n, 0.0};
        }
        return {};
    }
    static double number(const Budget& b) {
        if (b.kind != K) return std::nan("");
        return K == BudgetKind::Time ? b.ms : static_cast<double>(b.count);
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
    bool engine;  // a field of EngineConfig
    std::string (*get)(const SettingSpec&, const Settings&);
    std::string (*set)(const SettingSpec&, std::string_view, Settings&);
    double (*number)(const Settings&);  // NaN: not a number or not in force
};

constexpr std::size_t specIndex(std::string_view key) {
    for (std::size_t i = 0; i < std::size(detail::kSettingSpecs); ++i)
        if (detail::kSettingSpecs[i].key == key) return i;
    return std::size(detail::kSettingSpecs);
}

#define ROST_SETTING_BINDING(key, type, group, def, lo, hi, choices, cli, flags, field, doc)               \
    Binding{detail::kSettingSpecs[specIndex(key)], std::string_view(#field).starts_with("engine."),          \
            [](const SettingSpec& sp, const Settings& s) { return Codec<SettingType::type>::get(sp, s.field); }, \
            [](const SettingSpec& sp, std::string_view v, Settings& s) {                                     \
                return Codec<SettingType::type>::set(sp, v, s.field);                                        \
            },                                                                                               \
            [](const Settings& s) { return Codec<SettingType::type>::number(s.field); }},
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

// "unknown key 'alfa' (did you mean 'alpha'?)"; a parameter name ("cell_space")
// is pointed to its key.
std::string unknownKey(std::string_view name) {
    std::string msg = "unknown key " + quoted(name);
    const SettingSpec* best = findSetting(name);
    std::size_t bestD = 3;
    if (!best && name.size() <= 64)
        for (const SettingSpec& c : settingSpecs())
            if (const std::size_t d = editDistance(name, c.key); d < bestD) bestD = d, best = &c;
    if (best) msg += " (did you mean '" + std::string(best->key) + "'?)";
    return msg;
}

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
    if (key.starts_with("budget.")) return names("budget.count");
    return false;
}

std::string formatBound(const SettingSpec& s, double v) {
    if (s.type == SettingType::Integer || s.type == SettingType::BudgetSteps || s.type == SettingType::BudgetTokens) {
        if (v >= 1.8e19) return "2^64-1";
        return formatInteger(static_cast<long long>(v));
    }
    std::ostringstream os;
    os << v;
    return os.str();
}

// Checks the line-by-line grammar and sets each key on `s`; `seen` gets the
// keys with their lines.
struct ParseState {
    std::map<std::string, int, std::less<>> seen;  // key -> line
    std::string budgetKey;
};

Status parseLine(std::string_view line, int lineNo, std::string_view name, Settings& s, ParseState& ps) {
    auto where = [&] { return std::string(name) + ":" + std::to_string(lineNo) + ": "; };
    const std::size_t eq = line.find('=');
    if (eq == std::string_view::npos) return Status::error(where() + "expected 'key = value', found " + quoted(line));
    const std::string_view key = trim(line.substr(0, eq));
    const std::string_view value = trim(line.substr(eq + 1));
    if (key.empty()) return Status::error(where() + "missing key before '='");
    const SettingSpec* spec = findSetting(key);
    if (!spec || spec->key != key) return Status::error(where() + unknownKey(key));
    if (auto it = ps.seen.find(key); it != ps.seen.end())
        return Status::error(where() + "key '" + std::string(key) + "' set again (first set on line " +
                             std::to_string(it->second) + ")");
    if (spec->isBudget()) {
        if (!ps.budgetKey.empty())
            return Status::error(where() + "key '" + std::string(key) + "': a budget was already set by '" +
                                 ps.budgetKey + "' on line " + std::to_string(ps.seen[ps.budgetKey]) +
                                 " (give one of budget.refines, budget.tokens, budget.ms)");
        ps.budgetKey = std::string(key);
    }
    if (value.empty()) return Status::error(where() + "key '" + std::string(key) + "': missing value");
    if (Status st = setSetting(s, key, value); !st.ok()) return Status::error(where() + st.message());
    ps.seen.emplace(std::string(key), lineNo);
    return {};
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
    return b && b->engine;
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

Status setSetting(Settings& s, std::string_view name, std::string_view value) {
    const SettingSpec* spec = findSetting(name);
    if (!spec) return Status::error(unknownKey(name));
    Settings tmp = s;
    const std::string why = bindingOf(*spec)->set(*spec, value, tmp);
    if (!why.empty())
        return Status::error("key '" + std::string(spec->key) + "': " + why + ", found " + quoted(value));
    s = tmp;
    return {};
}

std::string settingValue(const Settings& s, std::string_view name) {
    const SettingSpec* spec = findSetting(name);
    return spec ? bindingOf(*spec)->get(*spec, s) : std::string();
}

Status Settings::validate() const {
    if (Status st = engine.validate(); !st.ok()) return st;
    // The rest: each number within its declared range (the engine's own
    // checks above name its fields in their words).
    for (const Binding& b : kBindings) {
        if (b.engine) continue;
        const double v = b.number(*this);
        if (std::isnan(v)) continue;
        const bool low = b.spec.has(setting_flags::LoOpen) ? !(v > b.spec.lo) : !(v >= b.spec.lo);
        if (low || !(v <= b.spec.hi))
            return Status::error("invalid configuration: " + std::string(b.spec.key) + " = " + b.get(b.spec, *this) +
                                 ", allowed " + settingRange(b.spec));
    }
    return {};
}

Status parseSettingsText(std::string_view text, std::string_view name, Settings& s, std::vector<ConfigKeyLine>* set) {
    Settings tmp = s;
    ParseState ps;
    int lineNo = 0;
    std::size_t pos = 0;
    while (pos <= text.size()) {
        std::size_t end = text.find('\n', pos);
        if (end == std::string_view::npos) end = text.size();
        std::string_view line = text.substr(pos, end - pos);
        pos = end + 1;
        ++lineNo;
        if (line.find('\0') != std::string_view::npos)
            return Status::error(std::string(name) + ":" + std::to_string(lineNo) + ": NUL byte in the text");
        // A comment runs from '#' to the end of the line (no value contains '#').
        if (const std::size_t hash = line.find('#'); hash != std::string_view::npos) line = line.substr(0, hash);
        line = trim(line);
        if (!line.empty())
            if (Status st = parseLine(line, lineNo, name, tmp, ps); !st.ok()) return st;
        if (end == text.size()) break;
    }
    if (Status st = tmp.validate(); !st.ok()) {
        // Point at the line that set the offending key, when the text set it.
        for (const auto& [key, line] : ps.seen)
            if (messageNames(st.message(), key))
                return Status::error(std::string(name) + ":" + std::to_string(line) + ": key '" + key + "': " +
                                     st.message());
        return Status::error(std::string(name) + ": " + st.message());
    }
    s = tmp;
    if (set) {
        set->clear();
        for (const auto& [key, line] : ps.seen) set->push_back({key, line});
        std::sort(set->begin(), set->end(), [](const ConfigKeyLine& a, const ConfigKeyLine& b) { return a.line < b.line; });
    }
    return {};
}

Status readSettingsFile(const std::string& path, Settings& s, std::vector<ConfigKeyLine>* set) {
    std::string text;
    if (Status st = readFile(path, text); !st.ok()) return st;
    return parseSettingsText(text, path, s, set);
}

std::string formatSettingsDocumented(const Settings& s) {
    static const char* const kGroups[] = {"Model", "Refinement", "Runtime", "Mission", "Words"};
    std::string out =
        "# rost settings: every setting with its value, as `rost run --config FILE` reads them.\n"
        "# Lines starting with '#' are comments. Settings the rost tool derives from its input or\n"
        "# sets itself, and the budget keys not in force, are written commented out.\n";
    int group = -1;
    for (const Binding& b : kBindings) {
        const SettingSpec& sp = b.spec;
        if (static_cast<int>(sp.group) != group) {
            group = static_cast<int>(sp.group);
            out += "\n# ---- " + std::string(kGroups[group]) + "\n";
        }
        std::string value = b.get(sp, s);
        out += "# " + std::string(sp.doc) + "; " + settingRange(sp);
        if (sp.has(setting_flags::Library)) out += " (the library and the ROS node; the rost tool sets it itself)";
        out += "\n";
        const bool commented = value.empty() || sp.has(setting_flags::Derived) || sp.has(setting_flags::Library);
        if (value.empty()) value = std::string(sp.def.empty() ? "" : sp.def);
        out += (commented ? "# " : "") + std::string(sp.key) + " =" + (value.empty() ? "" : " " + value) + "\n";
    }
    return out;
}

} // namespace rost
