// Fuzzes the configuration file parser (parseConfigText). Whatever the
// input: no crash, no sanitizer report; an accepted text gives a valid
// configuration whose formatConfig() text parses back to the same text.

#include <cstddef>
#include <cstdint>
#include <string>
#include <string_view>

#include "rost/config_file.hpp"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, std::size_t size) {
    const std::string_view text(reinterpret_cast<const char*>(data), size);
    rost::EngineConfig cfg;
    const rost::EngineConfig before = cfg;
    const rost::Status st = rost::parseConfigText(text, "fuzz.conf", cfg);
    if (!st.ok()) {
        if (st.message().empty() || rost::formatConfig(cfg) != rost::formatConfig(before)) __builtin_trap();
        return 0;
    }
    if (!cfg.validate().ok()) __builtin_trap();
    const std::string once = rost::formatConfig(cfg);
    rost::EngineConfig again;
    if (!rost::parseConfigText(once, "formatted", again).ok()) __builtin_trap();
    if (rost::formatConfig(again) != once) __builtin_trap();
    return 0;
}
