#include "rost/config.hpp"

#include "rost/settings.hpp"

namespace rost {
Status Config::validate() const {
    // The ranges are the settings schema's, checked by one generic check (rost/settings.hpp).
    if (auto p = checkModelSettings(*this)) return Status::error("invalid configuration: " + p->describe(p->spec->key));
    return {};
}

const char* toString(EvictionPolicy p) noexcept {
    return p == EvictionPolicy::Keep ? "keep" : "subtract";
}

Status parseEvictionPolicy(const std::string& text, EvictionPolicy& out) {
    if (text == "keep") {
        out = EvictionPolicy::Keep;
        return {};
    }
    if (text == "subtract") {
        out = EvictionPolicy::Subtract;
        return {};
    }
    return Status::error("invalid eviction policy '" + text + "', allowed keep|subtract");
}

} // namespace rost
