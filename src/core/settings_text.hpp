#pragma once

// Internal to the settings' two files: settings.cpp (the bindings, the one
// check, the problems) and settings_text.cpp (configuration files' text).

#include <string>
#include <string_view>

namespace rost::settings_detail {

// "'value'", cut after 40 characters ("'...'...").
std::string quoted(std::string_view s);
// " \t\r" trimmed from both ends.
std::string_view trim(std::string_view s);
// "unknown key 'alfa' (did you mean 'alpha'?)".
std::string unknownKey(std::string_view name);

} // namespace rost::settings_detail
