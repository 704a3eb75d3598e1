#include "rost/config_file.hpp"

#include <algorithm>

#include "rost/settings.hpp"

// The engine's part of the settings (rost/settings.hpp), for the library and
// the checkpoints: the same keys, parser and messages, on an EngineConfig.

namespace rost {
namespace {

Settings around(const EngineConfig& cfg) {
    Settings s;
    s.engine = cfg;
    return s;
}

} // namespace

const std::vector<ConfigKey>& configKeys() {
    static const std::vector<ConfigKey> keys = [] {
        std::vector<ConfigKey> k;
        for (const SettingSpec& s : settingSpecs())
            if (isEngineSetting(s)) k.push_back({s.key.data(), s.group, s.doc.data()});
        return k;
    }();
    return keys;
}

Status setConfigValue(std::string_view key, std::string_view value, EngineConfig& cfg) {
    const SettingSpec* spec = findSetting(key);
    if (spec && !isEngineSetting(*spec))  // in any spelling: "orb_features" as "orb.features"
        return Status::error("key '" + std::string(key) + "' is not an engine setting");
    Settings s = around(cfg);
    if (Status st = setSetting(s, key, value); !st.ok()) return st;
    cfg = s.engine;
    return {};
}

std::string configValue(const EngineConfig& cfg, std::string_view key) {
    const SettingSpec* spec = findSetting(key);
    if (!spec || !isEngineSetting(*spec)) return {};
    return settingValue(around(cfg), spec->key);
}

Status parseConfigText(std::string_view text, std::string_view name, EngineConfig& cfg, std::vector<ConfigKeyLine>* set) {
    Settings s = around(cfg);
    if (Status st = parseSettingsText(text, name, s, set); !st.ok()) return st;
    cfg = s.engine;
    return {};
}

Status readConfigFile(const std::string& path, EngineConfig& cfg, std::vector<ConfigKeyLine>* set) {
    Settings s = around(cfg);
    if (Status st = readSettingsFile(path, s, set); !st.ok()) return st;
    cfg = s.engine;
    return {};
}

std::string formatConfig(const EngineConfig& cfg) {
    const Settings s = around(cfg);
    std::string out;
    for (const SettingSpec& spec : settingSpecs()) {
        if (!isEngineSetting(spec)) continue;
        const std::string v = settingValue(s, spec.key);
        if (v.empty()) continue;
        out += spec.key;
        out += " = ";
        out += v;
        out += '\n';
    }
    return out;
}

std::vector<std::string> configDifferences(const EngineConfig& a, const EngineConfig& b,
                                           std::initializer_list<ConfigGroup> groups, std::string_view aName,
                                           std::string_view bName) {
    const Settings sa = around(a), sb = around(b);
    std::vector<std::string> out;
    for (const SettingSpec& spec : settingSpecs()) {
        if (!isEngineSetting(spec) || std::find(groups.begin(), groups.end(), spec.group) == groups.end()) continue;
        const std::string va = settingValue(sa, spec.key), vb = settingValue(sb, spec.key);
        if (va == vb) continue;
        out.push_back(std::string(spec.key) + " = " + (va.empty() ? "(unset)" : va) + " in " + std::string(aName) +
                      ", " + (vb.empty() ? "(unset)" : vb) + " in " + std::string(bName));
    }
    return out;
}

} // namespace rost
