#pragma once

// The state of a Model or an Engine described as one layout: an ordered
// list of named, versioned sections, each a typed block of memory owned by
// the object that described it. Checkpoints (rost/checkpoint.hpp) write,
// read and check a layout section by section without knowing what the
// sections mean; the object that owns them says what they are.
//
// Filling a layout allocates nothing (a fixed number of entries), so it can
// be done on the refining thread.

#include <cstddef>
#include <cstdint>
#include <span>
#include <string_view>
#include <type_traits>

namespace rost {

// Whether a section's size follows from the Config alone (every state
// section) or from its contents (the configuration text of a checkpoint).
enum class SectionSize : uint8_t { Fixed, Variable };

struct StateSection {
    std::string_view name;   // at most 31 ASCII characters
    uint32_t version = 0;    // revision of this section's contents (0: as in checkpoint format 1)
    void* data = nullptr;    // owned by the object that described it
    std::size_t bytes = 0;   // a multiple of width
    uint32_t width = 1;      // element width in bytes (1, 2, 4 or 8): how it is byte-swapped
    SectionSize size = SectionSize::Fixed;
};

class StateLayout {
public:
    static constexpr std::size_t kMaxSections = 64;

    // A section of `count` elements of T at `data` (T an integer, float or
    // bool of 1, 2, 4 or 8 bytes).
    template <typename T>
    void add(std::string_view name, uint32_t version, T* data, std::size_t count,
             SectionSize size = SectionSize::Fixed) noexcept {
        static_assert(std::is_arithmetic_v<T>, "a state section holds integers or floats");
        static_assert(sizeof(T) == 1 || sizeof(T) == 2 || sizeof(T) == 4 || sizeof(T) == 8);
        addBytes(name, version, static_cast<void*>(data), count * sizeof(T), static_cast<uint32_t>(sizeof(T)), size);
    }
    template <typename T>
    void add(std::string_view name, uint32_t version, std::span<T> elements,
             SectionSize size = SectionSize::Fixed) noexcept {
        add(name, version, elements.data(), elements.size(), size);
    }
    // A struct of `bytes` bytes made of `width`-byte fields only, no padding.
    void addBytes(std::string_view name, uint32_t version, void* data, std::size_t bytes, uint32_t width,
                  SectionSize size = SectionSize::Fixed) noexcept {
        if (count_ == kMaxSections) {
            overflow_ = true;
            return;
        }
        sections_[count_++] = StateSection{name, version, data, bytes, width, size};
    }

    std::span<const StateSection> sections() const noexcept { return {sections_, count_}; }
    std::size_t size() const noexcept { return count_; }
    const StateSection& operator[](std::size_t i) const noexcept { return sections_[i]; }
    // The section called `name`, or nullptr.
    const StateSection* find(std::string_view name) const noexcept {
        for (std::size_t i = 0; i < count_; ++i)
            if (sections_[i].name == name) return &sections_[i];
        return nullptr;
    }
    // More sections were added than kMaxSections (the extra ones are not listed).
    bool overflowed() const noexcept { return overflow_; }
    void clear() noexcept {
        count_ = 0;
        overflow_ = false;
    }

private:
    StateSection sections_[kMaxSections];
    std::size_t count_ = 0;
    bool overflow_ = false;
};

} // namespace rost
