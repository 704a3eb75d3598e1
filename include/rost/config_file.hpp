#pragma once

// Configuration files: one `key = value` per line, keys named like the rost
// tool's options, so a file and a command line say the same thing. The keys
// are the settings schema's (rost/settings_schema.hpp); rost/settings.hpp
// reads and writes all of them, this header the engine's part (EngineConfig):
//
//   # diver survey, small board
//   K = 16
//   alpha = 0.1
//   cell.space = 64
//   sampler = uni+now
//   eta = 0.5
//   budget.refines = 4
//
// Blank lines and lines whose first non-blank character is '#' are skipped;
// a '#' after a value starts a comment. Whitespace around keys and values is
// ignored. A key may appear once. Unknown keys, malformed values and values
// out of range are errors naming the file, the line and the key. The same
// text, written by formatConfig(), is the configuration section of a
// checkpoint (rost/checkpoint.hpp). Set-up code: allocates.
//
// Keys: every setting of rost/settings_schema.hpp (`rost config` prints
// them all, documented); at most one budget key per file. Booleans are
// true|false|yes|no|on|off|1|0.

#include <cstdint>
#include <initializer_list>
#include <string>
#include <string_view>
#include <vector>

#include "rost/engine.hpp"
#include "rost/settings.hpp"
#include "rost/status.hpp"

namespace rost {

// What a key configures (rost/settings_schema.hpp).
using ConfigGroup = SettingGroup;

struct ConfigKey {
    const char* name;
    ConfigGroup group;
    const char* help;
};
// Every key of EngineConfig, in the order formatConfig() writes them.
const std::vector<ConfigKey>& configKeys();

// Applies the keys of `text` to `cfg` (keys not in the text keep their
// values, so defaults or a command line can be layered), then validates the
// result. Errors: "rost.conf:7: key 'alpha': expected a number, found 'x'",
// "rost.conf:3: unknown key 'alfa' (did you mean 'alpha'?)". On error `cfg`
// is unchanged.
// `set`, when given, receives the keys the text set with their line numbers
// (a command line layers its explicit options over exactly these).
Status parseConfigText(std::string_view text, std::string_view name, EngineConfig& cfg,
                       std::vector<ConfigKeyLine>* set = nullptr);

// Reads and parses a file; the error names the path.
Status readConfigFile(const std::string& path, EngineConfig& cfg, std::vector<ConfigKeyLine>* set = nullptr);

// Sets one key from its text form (a command-line override). A key is
// matched in either spelling (the file's "orb.features", Python's
// "orb_features"). Errors name the key.
Status setConfigValue(std::string_view key, std::string_view value, EngineConfig& cfg);
// The text form of one key's value, the key in any spelling as above; empty
// for an unknown key.
std::string configValue(const EngineConfig& cfg, std::string_view key);

// Every key, one `key = value` per line, in configKeys() order. Numbers are
// written so they parse back exactly (parseConfigText(formatConfig(c)) == c).
std::string formatConfig(const EngineConfig& cfg);

// Keys of the given groups whose values differ, as "K = 16 in <aName>, 32 in <bName>".
std::vector<std::string> configDifferences(const EngineConfig& a, const EngineConfig& b,
                                           std::initializer_list<ConfigGroup> groups, std::string_view aName,
                                           std::string_view bName);

} // namespace rost
