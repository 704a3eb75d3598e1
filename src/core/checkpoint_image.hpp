#pragma once

// A checkpoint's file image in three steps (internal; src/core/checkpoint.cpp
// defines them, the periodic CheckpointWriter of checkpoint_writer.cpp uses them).

#include <cstdint>
#include <vector>

#include "rost/checkpoint.hpp"
#include "rost/engine.hpp"
#include "rost/status.hpp"

namespace rost::detail {

// Lays out a file image: header, the config section (filled), then a
// section per state section (headers filled, payloads left for the fill).
Status buildCheckpointImage(Engine& engine, std::vector<uint8_t>& image, std::vector<CheckpointSlot>& slots);
// Copies the engine's state into the image (`fresh`: everything, else what
// may have changed since the last fill). False when the state no longer
// matches the image's layout.
bool fillCheckpointImage(Engine& engine, uint8_t* image, const std::vector<CheckpointSlot>& slots, bool fresh) noexcept;
// Computes every checksum of a filled image.
void sealCheckpointImage(std::vector<uint8_t>& image, const std::vector<CheckpointSlot>& slots) noexcept;

} // namespace rost::detail
