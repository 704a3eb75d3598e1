#pragma once

// Every setting of rost in one value, read and written by key. The keys,
// types, defaults, ranges and documentation are declared once, in
// rost/settings_schema.hpp; the configuration files (rost/config_file.hpp),
// the rost tool's options, `rost config`, the Python keywords and the ROS
// parameters are all made from that declaration through these functions.
// Set-up code: allocates.

#include <cstdint>
#include <string>
#include <string_view>
#include <vector>

#include "rost/engine.hpp"
#include "rost/settings_schema.hpp"
#include "rost/status.hpp"
#include "rost/word_settings.hpp"

namespace rost {

struct Settings {
    EngineConfig engine;
    WordSettings words;
    int final_sweeps = settingDefault<int>("final.sweeps");
    uint64_t checkpoint_every = settingDefault<uint64_t>("checkpoint.every");

    // The engine's checks, then the range of every other number; the message
    // names the key, its value and the allowed range.
    [[nodiscard]] Status validate() const;
};

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

// Every setting as a configuration file that parseSettingsText() reads back to
// `s`: each key with its documentation and range as a comment. Settings the
// rost tool derives from its input or sets itself, and budget keys not in
// force, are written commented out (with their value), so reading the text
// changes nothing for the tool.
std::string formatSettingsDocumented(const Settings& s);

} // namespace rost
