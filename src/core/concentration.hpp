#pragma once

// The growth concentration learned from the data (docs/design.md, "Topics
// that grow"): Escobar and West's auxiliary-variable update of a Dirichlet
// process's concentration under a Gamma(a, b) prior, given A open topics and
// n words. Draws only from the given Rng, so the result depends on its state
// alone (and the C library's log, exp and sqrt).

#include <cstdint>

#include "rost/random.hpp"

namespace rost::concentration {

// The prior on gamma: Gamma(shape kPriorShape, rate kPriorRate), an
// exponential of mean 1. Vague against the data's term (rate about log n),
// so the learned value does not depend on the starting one.
inline constexpr double kPriorShape = 1.0;
inline constexpr double kPriorRate = 1.0;

// A standard normal draw (Marsaglia's polar method).
double normal(Rng& rng) noexcept;
// A Gamma(shape, 1) draw for shape >= 1 (Marsaglia and Tsang).
double gammaDraw(double shape, Rng& rng) noexcept;
// One update of gamma given A >= 1 open topics and n >= 1 words.
double resample(double gamma, int A, uint64_t n, Rng& rng) noexcept;

} // namespace rost::concentration
