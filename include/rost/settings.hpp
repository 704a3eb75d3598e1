#pragma once

// Every setting of rost in one value, read and written by key. The keys,
// types, defaults, ranges and documentation are declared once, in
// rost/settings_schema.hpp; the configuration files (rost/config_file.hpp),
// the rost tool's options, `rost config`, the Python keywords and the ROS
// parameters are all made from that declaration through these functions.
// Set-up code: allocates.

#include <cstdint>
#include <functional>
#include <optional>
#include <span>
#include <string>
#include <string_view>
#include <type_traits>
#include <vector>

#include "rost/engine.hpp"
#include "rost/settings_schema.hpp"
#include "rost/status.hpp"
#include "rost/word_settings.hpp"

namespace rost {

// A value a setting may not take, as data: which setting, the value, what
// it may be. Every check of a setting's value (its type, its range or
// choices from the schema, and the few combinations between settings)
// gives one, and each face names the setting in its own spelling when it
// prints it: `--eta` (the rost tool), `eta` (Python), `~eta` (the ROS
// node), a rost-cli command's own flag, `key 'eta'` (a configuration file).
struct SettingProblem {
    enum class Kind : uint8_t {
        Type,   // the text is not a value of the setting's type: "expected a finite number"
        Range,  // a value of the type, outside what the setting allows
    };
    const SettingSpec* spec = nullptr;  // the setting (never null in a problem returned here)
    Kind kind = Kind::Range;
    std::string value;    // the value as text ("2", "0.5", "fast")
    std::string allowed;  // Type: what the text should be; Range: "[0, 1]", "(0, 1000000]", "keep|subtract", ...
    // For a combination: the other settings it involves and how to fix it.
    // `allowed` and `note` name them as "{key}", which describe() spells.
    std::vector<const SettingSpec*> involved;
    std::string note;  // "raise {cell.space}"; may be empty

    // The problem in one line, each setting spelled by `spell` (the face's
    // spelling of a setting):
    // Range: "NAME = VALUE, allowed ALLOWED[; NOTE]";
    // Type:  "NAME: expected ALLOWED, found 'VALUE'".
    template <class Spell>
        requires std::is_invocable_v<const Spell&, const SettingSpec&>
    std::string describe(const Spell& spell) const {
        return compose(std::string(spell(*spec)), [&](const SettingSpec& s) { return std::string(spell(s)); });
    }
    // With the setting named `name` and the others by their keys.
    std::string describe(std::string_view name) const;

private:
    std::string compose(std::string name, const std::function<std::string(const SettingSpec&)>& spell) const;
};

struct Settings {
    EngineConfig engine;
    WordSettings words;
    int final_sweeps = settingDefault<int>("final.sweeps");
    uint64_t checkpoint_every = settingDefault<uint64_t>("checkpoint.every");
    int image_queue = settingDefault<int>("image.queue");

    // The engine's checks, then the range of every other number; the message
    // names the key, its value and the allowed range.
    // (The message is checkSettings()'s problem with the key as its name,
    // after "invalid configuration: ".)
    [[nodiscard]] Status validate() const;
};

// The first setting of `s` whose value is not allowed: every number's range
// and every choice, as the schema declares them, in the schema's order; then
// the combinations (g.time below ring.steps, the cells of a step, the ring's
// memory), each blamed on the setting to change. nullopt when all are allowed.
std::optional<SettingProblem> checkSettings(const Settings& s);
// Every number's range and every choice only, not the combinations: for a
// face that checks its command line before the input has given the values
// that come from it (the frame size, ring.steps, max.words, V), and whose
// mission checks the combinations once they are known (rost/mission.hpp).
std::optional<SettingProblem> checkSettingRanges(const Settings& s);
// The same for one part, as its own validate() uses it: the model's fields
// and combinations; the strategy's fields; everything of an EngineConfig.
std::optional<SettingProblem> checkModelSettings(const Config& c);
std::optional<SettingProblem> checkStrategySettings(const StrategyConfig& c);
std::optional<SettingProblem> checkEngineSettings(const EngineConfig& c);
// One number against `spec`'s declared range (for a struct that holds a
// setting outside rost::Settings, as vision::ExtractorConfig does).
std::optional<SettingProblem> checkSettingRange(const SettingSpec& spec, double value);

// Sets `spec` on `s` from text; a Type problem (and `s` unchanged) when the
// text is not a value of the setting's type. Ranges are checkSettings()'s.
std::optional<SettingProblem> setSettingText(Settings& s, const SettingSpec& spec, std::string_view value);
// The setting an unknown name most likely meant ("alfa" -> alpha, a
// parameter name to its key), for a face's "did you mean"; nullptr if none.
const SettingSpec* closestSetting(std::string_view name) noexcept;

// A Choice setting's names, in its enum's order, from its schema row (the one
// table of them: the library's toString()/parse functions of StrategyKind,
// EvictionPolicy, DropPolicy and SearchMethod read it).
// choiceName(settingSpec("sampler"), 4) is "uni+now"; "?" out of range. No allocation.
const char* choiceName(const SettingSpec& spec, std::size_t index) noexcept;
// The index of `name` among the names; -1 when none.
int choiceIndexOf(const SettingSpec& spec, std::string_view name) noexcept;
// "expected one of now, uniform, ..." or "expected keep or subtract".
std::string choiceExpected(const SettingSpec& spec);

// The setting a name means: its key ("cell.space") or its parameter name
// ("cell_space"); nullptr when there is none.
const SettingSpec* findSetting(std::string_view name) noexcept;
// The key with dots and dashes as underscores: Python keywords, ROS parameters.
std::string paramName(const SettingSpec& spec);
// Whether the setting is a field of EngineConfig (the part a checkpoint holds).
bool isEngineSetting(const SettingSpec& spec) noexcept;
// "[1, 1024]", "(0, 1]", "now|uniform|...", "true|false": what a value may be.
std::string settingRange(const SettingSpec& spec);

// Sets one setting from its text form, by key or parameter name. Errors name
// the key: "key 'alpha': expected a finite number, found 'x'",
// "unknown key 'alfa' (did you mean 'alpha'?)". The value's type is checked
// here; ranges and combinations by validate(). On error `s` is unchanged.
Status setSetting(Settings& s, std::string_view name, std::string_view value);
// One setting's value in text form (parses back exactly); "" for an unknown
// key and for a budget key that is not the budget in force.
std::string settingValue(const Settings& s, std::string_view name);

// `key = value` text (rost/config_file.hpp describes the syntax) applied to
// `s`: keys not in the text keep their values. Errors name `name`, the line
// and the key. `set`, when given, receives the keys set with their lines.
struct ConfigKeyLine {
    std::string key;
    int line = 0;
};
Status parseSettingsText(std::string_view text, std::string_view name, Settings& s,
                         std::vector<ConfigKeyLine>* set = nullptr);
Status readSettingsFile(const std::string& path, Settings& s, std::vector<ConfigKeyLine>* set = nullptr);

// Every setting as a configuration file: each key with its documentation and
// range as a comment, then its line. The keys in `given` (what the user set,
// on the command line or in a settings file) are written as settings; every
// other key, and the keys the rost tool sets itself (Library) or a budget
// key not in force, commented out with its value, to be uncommented. So
// parseSettingsText() reads the text back to `s` with the same keys given:
// a file printed without options sets nothing (it fixes no model key for a
// --resume), one printed with `-V 100` sets V.
std::string formatSettingsDocumented(const Settings& s, std::span<const std::string> given);

} // namespace rost
