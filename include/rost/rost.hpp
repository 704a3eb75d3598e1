#pragma once

// Umbrella header for the rost core.
#include "rost/config.hpp"
#include "rost/kernel_types.hpp"
#include "rost/model.hpp"
#include "rost/random.hpp"
#include "rost/status.hpp"
