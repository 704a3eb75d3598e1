// Settings as the text of a configuration file: `key = value` lines read
// (errors name the file, the line and the key) and written with their
// documentation (`rost config`). The bindings and the check: settings.cpp.

#include <algorithm>
#include <map>
#include <string>
#include <vector>

#include "rost/settings.hpp"
#include "rost/text_io.hpp"
#include "settings_text.hpp"

namespace rost {

using settings_detail::quoted;
using settings_detail::trim;
using settings_detail::unknownKey;

namespace {

// Checks the line-by-line grammar and sets each key on `s`; `seen` gets the
// keys with their lines.
struct ParseState {
    std::map<std::string, int, std::less<>> seen;  // key -> line
    std::string budgetKey;
};

Status parseLine(std::string_view line, int lineNo, std::string_view name, Settings& s, ParseState& ps) {
    auto where = [&] { return text::where(name, lineNo); };
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

Status parseSettingsText(std::string_view content, std::string_view name, Settings& s, std::vector<ConfigKeyLine>* set) {
    Settings tmp = s;
    ParseState ps;
    // Every line: blank lines and comments are the grammar's to skip ('#'
    // starts a comment anywhere on a line).
    text::LineReader lines(text::withoutByteOrderMark(content), name, text::kEveryLine);
    text::Line l;
    while (lines.next(l)) {
        std::string_view line = l.text;
        if (line.find('\0') != std::string_view::npos)
            return Status::error(text::where(name, l.number) + "NUL byte in the text");
        // A comment runs from '#' to the end of the line (no value contains '#').
        if (const std::size_t hash = line.find('#'); hash != std::string_view::npos) line = line.substr(0, hash);
        line = trim(line);
        if (!line.empty())
            if (Status st = parseLine(line, l.number, name, tmp, ps); !st.ok()) return st;
    }
    if (auto p = checkSettings(tmp)) {
        // Point at the line that set the offending key, when the text set it.
        const std::string what = "invalid configuration: " + p->describe(p->spec->key);
        if (auto it = ps.seen.find(p->spec->key); it != ps.seen.end())
            return Status::error(text::where(name, it->second) + "key '" + it->first + "': " + what);
        return Status::error(std::string(name) + ": " + what);
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
    std::string content;
    if (Status st = text::readFile(path, content); !st.ok()) return st;
    return parseSettingsText(content, path, s, set);
}

std::string formatSettingsDocumented(const Settings& s, std::span<const std::string> given) {
    std::string out =
        "# rost settings: every setting with its value, as `rost run --config FILE` reads them.\n"
        "# Lines starting with '#' are comments. The settings given when this was printed are\n"
        "# set; every other is commented out with its value (uncomment a line to set it; the rost\n"
        "# tool derives V, ring.steps, max.words and the frame size from its input unless set).\n";
    int group = -1;
    for (const SettingSpec& sp : settingSpecs()) {
        if (static_cast<int>(sp.group) != group) {
            group = static_cast<int>(sp.group);
            out += "\n# ---- " + std::string(settingGroupNames(sp.group).title) + "\n";
        }
        std::string value = settingValue(s, sp.key);
        out += "# " + std::string(sp.doc) + "; " + settingRange(sp);
        if (sp.has(setting_flags::Library)) out += " (the library and the ROS node; the rost tool sets it itself)";
        out += "\n";
        const bool isGiven = std::find(given.begin(), given.end(), sp.key) != given.end();
        const bool commented = value.empty() || !isGiven || sp.has(setting_flags::Library);
        if (value.empty()) value = std::string(sp.def.empty() ? "" : sp.def);
        out += (commented ? "# " : "") + std::string(sp.key) + " =" + (value.empty() ? "" : " " + value) + "\n";
    }
    return out;
}

} // namespace rost
