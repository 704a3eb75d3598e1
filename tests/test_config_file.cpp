// Configuration files (rost/config_file.hpp): keys named like the tool's
// options, exact round trips, and errors naming the file, line and key.

#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <string>

#include "rost/config_file.hpp"
#include "rost/random.hpp"
#include "rost/word_stream.hpp"

namespace rost {
namespace {

std::string parseError(const std::string& text) {
    EngineConfig c;
    const Status st = parseConfigText(text, "rost.conf", c);
    return st.ok() ? std::string("ok") : st.message();
}

TEST(ConfigFile, ParsesEveryKindOfKeyOntoTheGivenConfiguration) {
    EngineConfig c;
    c.model.V = 1000;  // not in the file: kept
    const std::string text =
        "# a survey configuration\n"
        "K = 32\n"
        "  alpha=0.25   # trailing comment\n"
        "\n"
        "cell.space = 32\r\n"
        "eviction = subtract\n"
        "seed = 18446744073709551615\n"
        "sampler = agep+exp\n"
        "eta = 0.75\n"
        "q = 0.2\n"
        "budget.ms = 12.5\n"
        "drop = newest\n"
        "thread.fifo = yes\n"
        "thread.cpu = 1\n"
        "ppx.instantaneous = off\n"
        "stop-on-arrival = 1";
    const Status st = parseConfigText(text, "rost.conf", c);
    ASSERT_TRUE(st.ok()) << st.message();
    EXPECT_EQ(c.model.K, 32);
    EXPECT_EQ(c.model.V, 1000);
    EXPECT_EQ(c.model.alpha, 0.25);
    EXPECT_EQ(c.model.cell_space, 32);
    EXPECT_EQ(c.model.eviction, EvictionPolicy::Subtract);
    EXPECT_EQ(c.model.seed, UINT64_MAX);
    EXPECT_EQ(c.strategy.kind, StrategyKind::AgeProportionalExponential);
    EXPECT_EQ(c.strategy.eta, 0.75);
    EXPECT_EQ(c.strategy.q, 0.2);
    EXPECT_EQ(c.budget.kind, BudgetKind::Time);
    EXPECT_EQ(c.budget.ms, 12.5);
    EXPECT_EQ(c.drop, DropPolicy::DropNewest);
    EXPECT_TRUE(c.thread.fifo);
    EXPECT_EQ(c.thread.cpu, 1);
    EXPECT_FALSE(c.flags.instantaneous_perplexity);
    EXPECT_TRUE(c.flags.stop_on_arrival);

    EngineConfig d;
    ASSERT_TRUE(parseConfigText("budget.refines = 7\n", "a", d).ok());
    EXPECT_EQ(d.budget.kind, BudgetKind::Steps);
    EXPECT_EQ(d.budget.count, 7u);
    ASSERT_TRUE(parseConfigText("budget.tokens = 5000\n", "a", d).ok());
    EXPECT_EQ(d.budget.kind, BudgetKind::Tokens);
    EXPECT_EQ(d.budget.count, 5000u);
    ASSERT_TRUE(parseConfigText("", "empty", d).ok());
}

TEST(ConfigFile, FormatParsesBackExactlyForRandomConfigurations) {
    Rng r(3);
    for (int i = 0; i < 200; ++i) {
        EngineConfig c;
        c.model.K = 1 + static_cast<int>(r.below(64));
        c.model.alpha = 1e-3 + r.uniformDouble() * 10.0;  // full 53-bit mantissas
        c.model.beta = r.uniformDouble() + 1e-9;
        c.model.seed = (uint64_t{r.next()} << 32) | r.next();
        c.model.eviction = r.below(2) ? EvictionPolicy::Keep : EvictionPolicy::Subtract;
        c.strategy.kind = static_cast<StrategyKind>(r.below(8));
        c.strategy.eta = r.uniformDouble();
        c.strategy.q = 1.0 - r.uniformDouble() * 0.99;
        const uint32_t b = r.below(3);
        c.budget = b == 0 ? Budget::steps(r.below(100)) : b == 1 ? Budget::tokens(r.next()) : Budget::time(0.01 + r.uniformDouble() * 100);
        c.thread.lock_memory = r.below(2) != 0;
        const std::string text = formatConfig(c);
        EngineConfig back;
        const Status st = parseConfigText(text, "formatted", back);
        ASSERT_TRUE(st.ok()) << st.message() << "\n" << text;
        EXPECT_EQ(formatConfig(back), text);
        EXPECT_EQ(back.model.alpha, c.model.alpha);
        EXPECT_EQ(back.model.beta, c.model.beta);
        EXPECT_EQ(back.model.seed, c.model.seed);
        EXPECT_EQ(back.strategy.eta, c.strategy.eta);
        EXPECT_EQ(back.budget.kind, c.budget.kind);
        if (c.budget.kind == BudgetKind::Time) {
            EXPECT_EQ(back.budget.ms, c.budget.ms);
        } else {
            EXPECT_EQ(back.budget.count, c.budget.count);
        }
        EXPECT_TRUE(configDifferences(c, back, {ConfigGroup::Model, ConfigGroup::Refinement, ConfigGroup::Runtime}, "a",
                                      "b")
                        .empty());
    }
}

TEST(ConfigFile, EveryKeyIsWrittenAndDocumented) {
    const std::string text = formatConfig(EngineConfig{});
    for (const ConfigKey& k : configKeys()) {
        const bool budget = std::string(k.name).rfind("budget.", 0) == 0;
        if (!budget) {
            EXPECT_NE(text.find(std::string(k.name) + " = "), std::string::npos) << k.name;
        }
        EXPECT_GT(std::string(k.help).size(), 5u) << k.name;
    }
    EXPECT_NE(text.find("budget.refines = 40\n"), std::string::npos);  // the default budget
}

TEST(ConfigFile, ErrorsNameTheFileLineAndKey) {
    EXPECT_EQ(parseError("K = 16\nalfa = 0.1\n"), "rost.conf:2: unknown key 'alfa' (did you mean 'alpha'?)");
    EXPECT_EQ(parseError("frobnicate = 1\n"), "rost.conf:1: unknown key 'frobnicate'");
    EXPECT_EQ(parseError("K = 16\n\nK = 8\n"), "rost.conf:3: key 'K' set again (first set on line 1)");
    EXPECT_EQ(parseError("alpha = x\n"), "rost.conf:1: key 'alpha': expected a finite number, found 'x'");
    EXPECT_EQ(parseError("alpha = nan\n"), "rost.conf:1: key 'alpha': expected a finite number, found 'nan'");
    EXPECT_EQ(parseError("K = 1.5\n"), "rost.conf:1: key 'K': expected an integer, found '1.5'");
    EXPECT_EQ(parseError("K = 99999999999\n"), "rost.conf:1: key 'K' = 99999999999, allowed [1, 1024]");
    EXPECT_EQ(parseError("seed = -1\n"), "rost.conf:1: key 'seed': expected a non-negative integer, found '-1'");
    // Past what the type holds: the range, as any value out of it (not "expected ... integer").
    EXPECT_EQ(parseError("seed = 18446744073709551616\n"), "rost.conf:1: key 'seed' = 18446744073709551616, allowed [0, 2^64-1]");
    EXPECT_EQ(parseError("K = 99999999999999999999\n"), "rost.conf:1: key 'K' = 99999999999999999999, allowed [1, 1024]");
    EXPECT_EQ(parseError("budget.refines = 99999999999999999999\n"),
              "rost.conf:1: key 'budget.refines' = 99999999999999999999, allowed [0, 1099511627776]");
    EXPECT_EQ(parseError("thread.fifo = maybe\n"), "rost.conf:1: key 'thread.fifo': expected true or false, found 'maybe'");
    EXPECT_EQ(parseError("sampler = best\n"),
              "rost.conf:1: key 'sampler': expected one of now, uniform, agep, exp, uni+now, agep+now, uni+exp, "
              "agep+exp, found 'best'");
    EXPECT_EQ(parseError("eviction = drop\n"), "rost.conf:1: key 'eviction': expected keep or subtract, found 'drop'");
    EXPECT_EQ(parseError("K 16\n"), "rost.conf:1: expected 'key = value', found 'K 16'");
    EXPECT_EQ(parseError("= 16\n"), "rost.conf:1: missing key before '='");
    EXPECT_EQ(parseError("K =\n"), "rost.conf:1: key 'K': missing value");
    EXPECT_EQ(parseError("budget.refines = 4\nbudget.ms = 40\n"),
              "rost.conf:2: key 'budget.ms': a budget was already set by 'budget.refines' on line 1 (give one of "
              "budget.refines, budget.tokens, budget.ms)");
    // Values in range for their type but not for the model: the line that set them.
    EXPECT_EQ(parseError("V = 5436\nK = 0\n"), "rost.conf:2: key 'K': invalid configuration: K = 0, allowed [1, 1024]");
    EXPECT_EQ(parseError("# x\neta = 1.5\n"), "rost.conf:2: key 'eta': invalid configuration: eta = 1.5, allowed [0, 1]");
    EXPECT_EQ(parseError("queue.slots = 0\n"),
              "rost.conf:1: key 'queue.slots': invalid configuration: queue.slots = 0, allowed [1, 65536]");
    EXPECT_EQ(parseError("budget.ms = 0\n"),
              "rost.conf:1: key 'budget.ms': invalid configuration: budget.ms = 0, allowed (0, 3600000]");
    // A grid whose cell count overflows an int is refused, not computed, and
    // blamed on the cell size, with the least that fits.
    EXPECT_EQ(parseError("frame.width = 65536\nframe.height = 65536\ncell.space = 1\n"),
              "rost.conf:3: key 'cell.space': invalid configuration: cell.space = 1, allowed at least 64 for "
              "frame.width = 65536 by frame.height = 65536; 4294967296 cells a step, at most 1048576");
    EXPECT_EQ(parseError("K = 16\nx\0y = 1\n"), "rost.conf:2: expected 'key = value', found 'x'");
    EXPECT_EQ(parseError(std::string("K = 16\nx\0y = 1\n", 15)), "rost.conf:2: NUL byte in the text");
}

TEST(ConfigFile, ReportsTheKeysItSetWithTheirLinesForLayeringUnderACommandLine) {
    EngineConfig c;
    std::vector<ConfigKeyLine> set;
    ASSERT_TRUE(parseConfigText("# x\nseed = 3\n\nK = 4\nsampler = now\n", "a.conf", c, &set).ok());
    ASSERT_EQ(set.size(), 3u);
    EXPECT_EQ(set[0].key, "seed");
    EXPECT_EQ(set[0].line, 2);
    EXPECT_EQ(set[1].key, "K");
    EXPECT_EQ(set[1].line, 4);
    EXPECT_EQ(set[2].key, "sampler");
    EXPECT_EQ(set[2].line, 5);
}

TEST(ConfigFile, AFailedParseLeavesTheConfigurationUnchanged) {
    EngineConfig c;
    c.model.K = 5;
    EXPECT_FALSE(parseConfigText("K = 9\nalpha = -1\n", "x", c).ok());
    EXPECT_EQ(c.model.K, 5);
    EXPECT_FALSE(setConfigValue("K", "zero", c).ok());
    EXPECT_EQ(c.model.K, 5);
}

TEST(ConfigFile, SingleValuesAndDifferencesForCommandLinesAndCheckpoints) {
    EngineConfig c;
    ASSERT_TRUE(setConfigValue("cell.time", "3", c).ok());
    EXPECT_EQ(c.model.cell_time, 3);
    EXPECT_EQ(configValue(c, "cell.time"), "3");
    EXPECT_EQ(configValue(c, "alpha"), "0.1");
    EXPECT_EQ(configValue(c, "nope"), "");
    // A key of the settings that is not the engine's has no value in an EngineConfig.
    EXPECT_EQ(configValue(c, "orb.features"), "");
    EXPECT_EQ(configValue(c, "final.sweeps"), "");
    // Python's spelling of a key is the key: read, set, and refused alike.
    EXPECT_EQ(configValue(c, "cell_time"), "3");
    EXPECT_EQ(setConfigValue("orb_features", "5", c).message(), "key 'orb_features' is not an engine setting");
    EXPECT_EQ(setConfigValue("orb.features", "5", c).message(), "key 'orb.features' is not an engine setting");
    EXPECT_EQ(setConfigValue("cel.time", "3", c).message(), "unknown key 'cel.time' (did you mean 'cell.time'?)");
    EngineConfig d = c;
    d.model.K = 20;
    d.queue_slots = 3;
    EXPECT_EQ(configDifferences(c, d, {ConfigGroup::Model}, "file", "run"),
              (std::vector<std::string>{"K = 16 in file, 20 in run"}));
    EXPECT_EQ(configDifferences(c, d, {ConfigGroup::Runtime}, "file", "run"),
              (std::vector<std::string>{"queue.slots = 8 in file, 3 in run"}));
}

TEST(ConfigFile, ReadsAFileAndNamesAMissingOne) {
    const auto dir = std::filesystem::temp_directory_path() / "rost_config_file_test";
    std::filesystem::create_directories(dir);
    const std::string path = (dir / "survey.conf").string();
    ASSERT_TRUE(writeFileAtomic(path, "K = 12\nbudget.refines = 2\n").ok());
    EngineConfig c;
    ASSERT_TRUE(readConfigFile(path, c).ok());
    EXPECT_EQ(c.model.K, 12);
    ASSERT_TRUE(writeFileAtomic(path, "K = 12\nbeta = 0\n").ok());
    EXPECT_EQ(readConfigFile(path, c).message(),
              path + ":2: key 'beta': invalid configuration: beta = 0, allowed [1e-30, 1000000]");
    EXPECT_EQ(readConfigFile("/nonexistent/x.conf", c).message(), "/nonexistent/x.conf: cannot open: No such file or directory");
    std::filesystem::remove_all(dir);
}

} // namespace
} // namespace rost
