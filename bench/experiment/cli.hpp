#pragma once

// Helpers of rost_experiment's command line (main.cpp): the settings, list and
// budget parsing, number and date formatting, and failing with a message.

#include <cstdint>
#include <string>
#include <vector>

#include "dataset.hpp"
#include "rost/engine.hpp"
#include "rost/strategy.hpp"

namespace rost::experiment {

// Prints "rost_experiment: WHAT" to stderr and exits with status 1.
[[noreturn]] void fail(const std::string& what);

// The settings (rost/settings.hpp): the schema's defaults, then --config FILE, then --set KEY=VALUE.
void applySettings(const std::string& config, const std::vector<std::string>& sets);
ModelParams modelParams();

// A comma-separated list of finite numbers (`what` names the option in errors).
std::vector<double> parseDoubles(const std::string& s, const char* what);
// all | mixed | comma-separated strategy names.
std::vector<StrategyKind> parseStrategies(const std::string& s);

// --budget LABEL=tokens:N | LABEL=time   (LABEL: T_R in ms)
struct BudgetSpec {
    double tr_ms = 0.0;
    Budget budget;
    std::string text;
};
BudgetSpec parseBudget(const std::string& s);

// `v` printed with printf format `f`; "nan" when not finite.
std::string fmt(double v, const char* f = "%.6g");
// The current UTC time, ISO 8601.
std::string nowText();
// The first three fields of /proc/loadavg, "?" if unreadable.
std::string loadAverage();
// The dataset in `dir` (its first `frames` frames when > 0); fails the program if it cannot be read.
Dataset load(const std::string& dir, int64_t frames);

} // namespace rost::experiment
