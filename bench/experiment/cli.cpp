#include "cli.hpp"

#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <ctime>
#include <sstream>

#include "harness.hpp"
#include "rost/settings.hpp"

namespace rost::experiment {

namespace {

// The settings (rost/settings.hpp): the schema's defaults, then --config FILE, then --set KEY=VALUE.
Settings gSettings;

std::vector<std::string> splitList(const std::string& s) {
    std::vector<std::string> out;
    std::string cur;
    std::istringstream is(s);
    while (std::getline(is, cur, ','))
        if (!cur.empty()) out.push_back(cur);
    return out;
}

} // namespace

[[noreturn]] void fail(const std::string& what) {
    std::fprintf(stderr, "rost_experiment: %s\n", what.c_str());
    std::exit(1);
}

ModelParams modelParams() { return gSettings.engine.model; }

void applySettings(const std::string& config, const std::vector<std::string>& sets) {
    if (!config.empty())
        if (Status st = readSettingsFile(config, gSettings); !st.ok()) fail("--config: " + st.message());
    for (const std::string& kv : sets) {
        const std::size_t eq = kv.find('=');
        if (eq == std::string::npos) fail("--set " + kv + ": expected KEY=VALUE");
        if (Status st = setSetting(gSettings, kv.substr(0, eq), kv.substr(eq + 1)); !st.ok()) fail("--set: " + st.message());
    }
    if (Status st = gSettings.validate(); !st.ok()) fail(st.message());
}

std::vector<double> parseDoubles(const std::string& s, const char* what) {
    std::vector<double> out;
    for (const auto& f : splitList(s)) {
        char* end = nullptr;
        const double v = std::strtod(f.c_str(), &end);
        if (end == f.c_str() || *end != '\0' || !std::isfinite(v)) fail(std::string(what) + ": '" + f + "' is not a number");
        out.push_back(v);
    }
    if (out.empty()) fail(std::string(what) + ": empty list");
    return out;
}

std::vector<StrategyKind> parseStrategies(const std::string& s) {
    if (s == "all") return paperOrder();
    if (s == "mixed")
        return {StrategyKind::UniformNow, StrategyKind::AgeProportionalNow, StrategyKind::UniformExponential,
                StrategyKind::AgeProportionalExponential};
    std::vector<StrategyKind> out;
    for (const auto& name : splitList(s)) {
        StrategyKind k{};
        if (Status st = parseStrategy(name, k); !st.ok()) fail("--strategies: " + st.message());
        out.push_back(k);
    }
    if (out.empty()) fail("--strategies: empty list");
    return out;
}

BudgetSpec parseBudget(const std::string& s) {
    const auto eq = s.find('=');
    if (eq == std::string::npos) fail("--budget '" + s + "': expected TR_MS=tokens:N or TR_MS=time");
    BudgetSpec b;
    b.text = s;
    b.tr_ms = parseDoubles(s.substr(0, eq), "--budget T_R")[0];
    if (!(b.tr_ms > 0.0)) fail("--budget '" + s + "': T_R must be > 0 ms");
    const std::string spec = s.substr(eq + 1);
    if (spec == "time") {
        b.budget = Budget::time(b.tr_ms);
    } else if (spec.rfind("tokens:", 0) == 0) {
        char* end = nullptr;
        const unsigned long long n = std::strtoull(spec.c_str() + 7, &end, 10);
        if (end == spec.c_str() + 7 || *end != '\0' || n == 0) fail("--budget '" + s + "': bad token count");
        b.budget = Budget::tokens(n);
    } else {
        fail("--budget '" + s + "': expected tokens:N or time after '='");
    }
    return b;
}

std::string fmt(double v, const char* f) {
    if (!std::isfinite(v)) return "nan";
    char b[64];
    std::snprintf(b, sizeof b, f, v);
    return b;
}

std::string nowText() {
    const std::time_t t = std::time(nullptr);
    char b[64];
    std::strftime(b, sizeof b, "%Y-%m-%dT%H:%M:%SZ", std::gmtime(&t));
    return b;
}

std::string loadAverage() {
    std::string s;
    if (!readFile("/proc/loadavg", s).ok()) return "?";
    std::size_t n = 0, at = 0;
    while (n < 3 && (at = s.find(' ', at + 1)) != std::string::npos) ++n;
    return s.substr(0, at);
}

Dataset load(const std::string& dir, int64_t frames) {
    Dataset d;
    if (Status s = loadDataset(dir, frames, d); !s.ok()) fail(s.message());
    return d;
}

} // namespace rost::experiment
