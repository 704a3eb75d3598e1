#pragma once

// The checks both command lines (the rost tool, rost-cli's commands) put on
// values: an empty path, such as a shell variable that expanded to nothing,
// is refused by name ("--out: no directory given") rather than read as "none"
// or as standard input; a value that is one of the command's options is
// refused, naming both. Header-only: each face already builds CLI11.

#include <cctype>
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

// An option that takes a value takes the next argument whatever it is
// (CLI11 fills an option's values before it looks at them): `--checkpoint
// --quiet` wrote a checkpoint named "--quiet" and was not quiet, `-K --out
// o` said "--out is required", topics.refine.t's `--out.topics --online`
// wrote a file named "--online". A value that is the name of one of the
// command's options (alone or as `--name=value`) is refused, naming both,
// before the option's own checks (a transform runs first: `--width --quiet`
// is not "expected 0 or more"); a file named like an option can still be
// given to an option that `takesAPath` as ./--name, which its error says.
template <typename TakesAPath>
void refuseOptionsAsValues(CLI::App& cmd, TakesAPath takesAPath) {
    for (CLI::Option* opt :
         cmd.get_options([](const CLI::Option* o) { return o->nonpositional() && o->get_type_size_max() > 0; })) {
        const CLI::App* owner = &cmd;
        const bool path = takesAPath(opt);
        opt->transform(CLI::Validator(
            [owner, path](std::string& value) -> std::string {
                if (value.size() < 2 || value[0] != '-' ||
                    !(std::isalpha(static_cast<unsigned char>(value[1])) || value[1] == '-'))
                    return {};
                const std::string name = value.substr(0, value.find('='));
                const CLI::App* parent = owner->get_parent();
                if (owner->get_option_no_throw(name) == nullptr &&
                    (parent == nullptr || parent->get_option_no_throw(name) == nullptr) && name != "--help" &&
                    name != "-h")
                    return {};
                return "needs a value; " + name + " is an option" + (path ? " (a file of that name: ./" + value + ")" : "");
            },
            ""));
    }
}

} // namespace rost::cli
