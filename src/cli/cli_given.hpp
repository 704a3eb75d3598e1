#pragma once

// The one check both command lines (the rost tool, rost-cli's commands) put on
// a path: an empty value, such as a shell variable that expanded to nothing,
// is refused by name ("--out: no directory given") rather than read as "none"
// or as standard input. Header-only: each face already builds CLI11.

#include <string>
#include <utility>

#include <CLI/CLI.hpp>

namespace rost::cli {

// A CLI11 check refusing "": "no WHAT given", then " (HINT)" when a hint is given.
inline CLI::Validator nonEmpty(std::string what, std::string hint = {}) {
    std::string why = "no " + std::move(what) + " given";
    if (!hint.empty()) why += " (" + hint + ")";
    return CLI::Validator([why = std::move(why)](std::string& s) { return s.empty() ? why : std::string(); }, "");
}

} // namespace rost::cli
