// The one settings schema (rost/settings_schema.hpp): every default of the
// library is the schema's, every key round-trips through its text form and a
// configuration file, every range is enforced with a message naming the key,
// and parameter names (Python, ROS) find their keys.

#include <gtest/gtest.h>

#include <algorithm>
#include <charconv>
#include <cmath>
#include <cstdint>
#include <set>
#include <vector>
#include <string>

#include "rost/config_file.hpp"
#include "rost/settings.hpp"

namespace rost {
namespace {

TEST(Settings, KeysAreUniqueDocumentedAndTheirParameterNamesToo) {
    std::set<std::string> keys, params;
    for (const SettingSpec& s : settingSpecs()) {
        EXPECT_TRUE(keys.insert(std::string(s.key)).second) << s.key;
        EXPECT_TRUE(params.insert(paramName(s)).second) << s.key;
        EXPECT_GT(s.doc.size(), 10u) << s.key;
        EXPECT_EQ(findSetting(s.key), &s);
        EXPECT_EQ(findSetting(paramName(s)), &s) << paramName(s);
        EXPECT_EQ(paramName(s).find_first_of(".-"), std::string::npos);
    }
    EXPECT_EQ(paramName(*findSetting("cell.space")), "cell_space");
    EXPECT_EQ(paramName(*findSetting("thread.lock-memory")), "thread_lock_memory");
    EXPECT_EQ(findSetting("cell_spac"), nullptr);
}

// The library's defaults (the fields' initialisers) are the schema's: a
// default-constructed Settings writes every key as the schema declares it.
TEST(Settings, TheLibrarysDefaultsAreTheSchemas) {
    const Settings s;
    for (const SettingSpec& spec : settingSpecs())
        EXPECT_EQ(settingValue(s, spec.key), spec.def) << spec.key;
    // The sub-structs a user may make alone start from the same values.
    EXPECT_EQ(Config{}.cell_capacity, 256);
    EXPECT_EQ(StrategyConfig{}.kind, s.engine.strategy.kind);
    EXPECT_EQ(Budget{}.count, 40u);
    EXPECT_EQ(ThreadSettings{}.priority, 80);
    EXPECT_TRUE(s.validate().ok());
}

// The defaults the paper and the docs state, pinned by value (not read back
// from the schema they are generated from, so changing one fails here):
// paper section VII's K 16, alpha 0.1, beta 0.5, 64-pixel cells, 1-cell
// neighbourhoods in space and time; the docs' sampler uni+now with eta 0.5
// and 40 refines an observation, the serial-equivalent window of 256, keep
// eviction, seed 1.
TEST(Settings, ThePapersAndTheDocsDefaultsByValue) {
    const Settings s;
    const Config& c = s.engine.model;
    EXPECT_EQ(c.K, 16);
    EXPECT_EQ(c.alpha, 0.1);
    EXPECT_EQ(c.beta, 0.5);
    EXPECT_EQ(c.cell_space, 64);
    EXPECT_EQ(c.cell_time, 1);
    EXPECT_EQ(c.g_space, 1);
    EXPECT_EQ(c.g_time, 1);
    EXPECT_EQ(c.cell_capacity, 256);
    EXPECT_EQ(c.seed, 1u);
    EXPECT_FALSE(c.grow);
    EXPECT_EQ(c.gamma, 0.1);
    EXPECT_EQ(c.eviction, EvictionPolicy::Keep);
    EXPECT_EQ(c.refine_window, 256);
    EXPECT_EQ(s.engine.strategy.kind, StrategyKind::UniformNow);
    EXPECT_EQ(s.engine.strategy.eta, 0.5);
    EXPECT_EQ(s.engine.strategy.q, 0.5);
    EXPECT_EQ(s.engine.budget.kind, BudgetKind::Steps);
    EXPECT_EQ(s.engine.budget.count, 40u);
    EXPECT_EQ(s.engine.queue_slots, 8);
    EXPECT_EQ(s.final_sweeps, 0);
}

// settingDefault<double> parses at compile time: it must give the double
// std::from_chars gives for the same text.
TEST(Settings, CompileTimeDefaultsAreTheCorrectlyRoundedValues) {
    for (const SettingSpec& spec : settingSpecs()) {
        if (spec.type != SettingType::Real || spec.def.empty()) continue;
        double v = 0.0;
        std::from_chars(spec.def.data(), spec.def.data() + spec.def.size(), v);
        EXPECT_EQ(settingValue(Settings{}, spec.key), spec.def);
        double back = 0.0;
        const std::string text = settingValue(Settings{}, spec.key);
        std::from_chars(text.data(), text.data() + text.size(), back);
        EXPECT_EQ(back, v) << spec.key;
    }
    static_assert(settingDefault<double>("alpha") == 0.1);
    static_assert(settingDefault<int>("thread.cpu") == -1);
    static_assert(settingDefault<StrategyKind>("sampler") == StrategyKind::UniformNow);
    static_assert(settingDefault<SearchMethod>("orb.search") == SearchMethod::Tree);
}

// Every number outside its declared range is refused, by validate() or by
// the type, with a message that names the key.
TEST(Settings, EveryRangeIsEnforcedNamingTheKey) {
    int checked = 0;
    for (const SettingSpec& spec : settingSpecs()) {
        if (spec.type == SettingType::Bool || spec.type == SettingType::Choice) continue;
        const bool integer = spec.type != SettingType::Real && spec.type != SettingType::BudgetMs;
        const double below = spec.has(setting_flags::LoOpen) ? spec.lo : spec.lo - (integer ? 1 : 1e-9);
        const double above = spec.hi + (integer ? 1 : spec.hi * 1e-9 + 1e-9);
        for (double bad : {below, above}) {
            if (integer && (bad < -9.2e18 || bad > 1.8e19)) continue;  // not writable as the field's integer
            Settings s;
            char text[64];
            const auto r = integer ? std::to_chars(text, text + 64, static_cast<long long>(bad))
                                   : std::to_chars(text, text + 64, bad);
            const std::string value(text, r.ptr);
            if (spec.lo >= 0 && bad < 0 && integer && spec.key == "seed") continue;
            const Status set = setSetting(s, spec.key, value);
            const Status valid = set.ok() ? s.validate() : set;
            ASSERT_FALSE(valid.ok()) << spec.key << " = " << value;
            const std::string& m = valid.message();
            const bool named = m.find(std::string(spec.key)) != std::string::npos ||
                               (spec.key == "queue.slots" && m.find("queue_slots") != std::string::npos) ||
                               (spec.isBudget() && m.find("budget.") != std::string::npos);
            EXPECT_TRUE(named) << spec.key << ": " << m;
            ++checked;
        }
    }
    EXPECT_GT(checked, 40);
}

// Every numeric setting takes both ends of its range (lo unless the range
// is open there): set alone, the value passes Settings::validate and, for
// the model's, Config::validate; where it conflicts with another setting's
// default, the problem is that combination (it names the other setting),
// never the value's own range.
TEST(Settings, EveryNumericSettingAcceptsBothEndsOfItsRange) {
    int checked = 0;
    for (const SettingSpec& spec : settingSpecs()) {
        if (spec.type == SettingType::Bool || spec.type == SettingType::Choice) continue;
        const bool integer = spec.type != SettingType::Real && spec.type != SettingType::BudgetMs;
        std::vector<double> ends{spec.hi};
        if (!spec.has(setting_flags::LoOpen)) ends.push_back(spec.lo);
        for (double end : ends) {
            char text[64];
            std::to_chars_result r{};
            if (!integer) r = std::to_chars(text, text + 64, end);
            else if (end >= 9.2e18) r = std::to_chars(text, text + 64, UINT64_MAX);  // the seed's 2^64 - 1
            else r = std::to_chars(text, text + 64, static_cast<long long>(end));
            const std::string value(text, r.ptr);
            Settings s;
            ASSERT_TRUE(setSetting(s, spec.key, value).ok()) << spec.key << " = " << value;
            if (auto p = checkSettings(s)) {
                EXPECT_FALSE(p->spec == &spec && p->involved.empty())
                    << spec.key << " = " << value << " refused by its own range: " << p->describe(p->spec->key);
            } else {
                EXPECT_TRUE(s.validate().ok()) << spec.key << " = " << value << ": " << s.validate().message();
                if (spec.group == SettingGroup::Model && isEngineSetting(spec)) {
                    EXPECT_TRUE(s.engine.model.validate().ok()) << spec.key << " = " << value << ": "
                                                                << s.engine.model.validate().message();
                }
                ++checked;
            }
        }
    }
    EXPECT_GT(checked, 50);
}

TEST(Settings, EveryKeyRoundTripsThroughTheDocumentedFile) {
    Settings s;
    ASSERT_TRUE(setSetting(s, "K", "32").ok());
    ASSERT_TRUE(setSetting(s, "orb_features", "700").ok());  // a parameter name
    ASSERT_TRUE(setSetting(s, "words.hue", "false").ok());
    ASSERT_TRUE(setSetting(s, "budget.ms", "12.5").ok());
    ASSERT_TRUE(setSetting(s, "sampler", "agep+exp").ok());
    ASSERT_TRUE(setSetting(s, "final.sweeps", "3").ok());
    ASSERT_TRUE(setSetting(s, "V", "100").ok());  // derived from the input unless given, as here
    ASSERT_TRUE(setSetting(s, "ppx.snapshot", "false").ok());  // the tool's own (Library)
    const std::vector<std::string> given = {"K", "orb.features", "words.hue", "budget.ms", "sampler",
                                            "final.sweeps", "V", "ppx.snapshot"};
    const std::string text = formatSettingsDocumented(s, given);
    Settings back;
    std::vector<ConfigKeyLine> set;
    const Status st = parseSettingsText(text, "config", back, &set);
    ASSERT_TRUE(st.ok()) << st.message();
    for (const SettingSpec& spec : settingSpecs()) {
        if (spec.has(setting_flags::Library)) continue;
        EXPECT_EQ(settingValue(back, spec.key), settingValue(s, spec.key)) << spec.key;
    }
    // What was given is set again, and only that: the text read back gives the same keys.
    std::vector<std::string> setKeys;
    for (const ConfigKeyLine& k : set) setKeys.push_back(k.key);
    std::sort(setKeys.begin(), setKeys.end());
    std::vector<std::string> expected = {"K", "V", "budget.ms", "final.sweeps", "orb.features", "sampler", "words.hue"};
    EXPECT_EQ(setKeys, expected);
    EXPECT_NE(text.find("\nV = 100\n"), std::string::npos);
    EXPECT_NE(text.find("# topics (paper: 16); [1, 1024]\nK = 32\n"), std::string::npos);
    EXPECT_NE(text.find("\nbudget.ms = 12.5\n"), std::string::npos);
    // The rest is there commented out, with its value: the tool's own even when given,
    // a budget key not in force, every key not given.
    EXPECT_NE(text.find("\n# ppx.snapshot = false\n"), std::string::npos);
    EXPECT_NE(text.find("\n# budget.refines = 40\n"), std::string::npos);  // not in force: budget.ms is
    EXPECT_NE(text.find("\n# alpha = 0.1\n"), std::string::npos);
    // Printed with nothing given, it sets nothing.
    ASSERT_TRUE(parseSettingsText(formatSettingsDocumented(Settings{}, {}), "config", back, &set).ok());
    EXPECT_TRUE(set.empty());
}

TEST(Settings, ErrorsNameTheKeyAndWhatWasExpected) {
    Settings s;
    EXPECT_EQ(setSetting(s, "orb.search", "fast").message(), "key 'orb.search': expected linear or tree, found 'fast'");
    EXPECT_EQ(setSetting(s, "orb.featurs", "1").message(), "unknown key 'orb.featurs' (did you mean 'orb.features'?)");
    EXPECT_EQ(setSetting(s, "checkpoint.every", "-2").message(),
              "key 'checkpoint.every': expected a non-negative integer, found '-2'");
    EXPECT_EQ(parseSettingsText("cell_space = 32\n", "f", s).message(),
              "f:1: unknown key 'cell_space' (did you mean 'cell.space'?)");
    EXPECT_EQ(parseSettingsText("thumb.cell = 0\n", "f", s).message(),
              "f:1: key 'thumb.cell': invalid configuration: thumb.cell = 0, allowed [1, 256]");
    // A combination whose blamed key the text does not set: the file is still named.
    EXPECT_EQ(parseSettingsText("max.words = 4000000\ncell.time = 1000\n", "rost.conf", s).message(),
              "rost.conf: invalid configuration: ring.steps = 256, allowed at most 1 with cell.time = 1000 and "
              "max.words = 4000000; the observations' inputs would need more than 64 GiB; lower ring.steps, "
              "cell.time or max.words");
    // A UTF-8 byte order mark before the first key is read past, as in every text file.
    Settings bom;
    ASSERT_TRUE(parseSettingsText("\xEF\xBB\xBFK = 12\n", "rost.conf", bom).ok());
    EXPECT_EQ(bom.engine.model.K, 12);
    EXPECT_EQ(settingRange(*findSetting("q")), "(0, 1]");
    EXPECT_EQ(settingRange(*findSetting("drop")), "newest|oldest");
}

// What a message quotes is cut at 40 characters, "..." saying so; an
// unknown key's guess is the nearest key within two edits, the first in the
// schema's order on a tie.
TEST(Settings, QuotedTextIsCutAtFortyCharactersAndATiedGuessIsTheSchemasFirstKey) {
    Settings s;
    const std::string forty(40, 'x');
    EXPECT_EQ(setSetting(s, "orb.search", forty).message(),
              "key 'orb.search': expected linear or tree, found '" + forty + "'");
    EXPECT_EQ(setSetting(s, "orb.search", forty + "y").message(),
              "key 'orb.search': expected linear or tree, found '" + forty + "...'");
    EXPECT_EQ(setSetting(s, forty + "y", "1").message(), "unknown key '" + forty + "...'");
    // "Q" is one edit from both "K" and "q": the schema lists K first.
    const auto at = [](std::string_view key) {
        const auto& specs = settingSpecs();
        return std::find_if(specs.begin(), specs.end(), [&](const SettingSpec& x) { return x.key == key; }) - specs.begin();
    };
    ASSERT_LT(at("K"), at("q"));
    EXPECT_EQ(setSetting(s, "Q", "1").message(), "unknown key 'Q' (did you mean 'K'?)");
}

// An integer beyond its field's type is out of the key's range, below as
// above: never wrapped into the type (-4294967288 would wrap to 8 in a
// 32-bit field, a K in range).
TEST(Settings, AnIntegerBeyondItsFieldsTypeIsOutOfRangeBelowAsAbove) {
    Settings s;
    EXPECT_EQ(setSetting(s, "K", "-4294967288").message(), "key 'K' = -4294967288, allowed [1, 1024]");
    EXPECT_EQ(setSetting(s, "K", "4294967304").message(), "key 'K' = 4294967304, allowed [1, 1024]");
    EXPECT_EQ(s.engine.model.K, Settings{}.engine.model.K) << "nothing set";
}

// The engine's part (rost/config_file.hpp) writes exactly the engine's keys,
// in schema order: the configuration section of a checkpoint.
TEST(Settings, TheEnginesPartIsTheCheckpointsConfigurationText) {
    std::string expected;
    for (const SettingSpec& spec : settingSpecs())
        if (isEngineSetting(spec) && !settingValue(Settings{}, spec.key).empty())
            expected += std::string(spec.key) + " = " + settingValue(Settings{}, spec.key) + "\n";
    EXPECT_EQ(formatConfig(EngineConfig{}), expected);
    EXPECT_FALSE(isEngineSetting(*findSetting("orb.features")));
    EXPECT_FALSE(isEngineSetting(*findSetting("final.sweeps")));
    EngineConfig c;
    EXPECT_EQ(setConfigValue("orb.features", "5", c).message(), "key 'orb.features' is not an engine setting");
}

} // namespace
} // namespace rost

namespace rost {
// The schema's choices are the one table of names: the library's toString()
// and parse functions of each Choice enum read it, index for index.
TEST(Settings, ChoiceNamesComeFromTheSchemasRow) {
    const SettingSpec& sampler = *findSetting("sampler");
    const char* expected[] = {"now", "uniform", "agep", "exp", "uni+now", "agep+now", "uni+exp", "agep+exp"};
    for (std::size_t i = 0; i < std::size(expected); ++i) {
        EXPECT_STREQ(choiceName(sampler, i), expected[i]);
        EXPECT_STREQ(toString(static_cast<StrategyKind>(i)), expected[i]);
        EXPECT_EQ(choiceIndexOf(sampler, expected[i]), static_cast<int>(i));
        StrategyKind k{};
        ASSERT_TRUE(parseStrategy(expected[i], k).ok());
        EXPECT_EQ(static_cast<std::size_t>(k), i);
    }
    EXPECT_STREQ(choiceName(sampler, 8), "?");
    EXPECT_EQ(choiceIndexOf(sampler, "uni"), -1);
    StrategyKind k{};
    EXPECT_EQ(parseStrategy("unifrom", k).message(),
              "unknown strategy 'unifrom' (expected one of now, uniform, agep, exp, uni+now, agep+now, uni+exp, agep+exp)");
    EXPECT_STREQ(toString(EvictionPolicy::Subtract), "subtract");
    EXPECT_STREQ(toString(DropPolicy::DropNewest), "newest");
    EXPECT_STREQ(toString(DropPolicy::DropOldest), "oldest");
    DropPolicy d{};
    EXPECT_EQ(parseDropPolicy("last", d).message(), "unknown drop policy 'last' (expected newest or oldest)");
    EvictionPolicy ev{};
    ASSERT_TRUE(parseEvictionPolicy("subtract", ev).ok());
    EXPECT_EQ(ev, EvictionPolicy::Subtract);
    EXPECT_EQ(parseEvictionPolicy("drop", ev).message(), "unknown eviction policy 'drop' (expected keep or subtract)");
    EXPECT_STREQ(choiceName(*findSetting("orb.search"), 1), "tree");
    EXPECT_STREQ(choiceName(*findSetting("K"), 0), "?") << "not a Choice";
}
} // namespace rost
