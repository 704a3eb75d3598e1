// Escobar and West (1995), section 6: the concentration of a Dirichlet
// process mixture resampled given the number of clusters, with an auxiliary
// variable eta ~ Beta(gamma + 1, n).

#include "concentration.hpp"

#include <cmath>

namespace rost::concentration {

double normal(Rng& rng) noexcept {
    for (;;) {
        const double u = 2.0 * rng.uniformDouble() - 1.0;
        const double v = 2.0 * rng.uniformDouble() - 1.0;
        const double s = u * u + v * v;
        if (s > 0.0 && s < 1.0) return u * std::sqrt(-2.0 * std::log(s) / s);
    }
}

double gammaDraw(double shape, Rng& rng) noexcept {
    const double d = shape - 1.0 / 3.0;
    const double c = 1.0 / std::sqrt(9.0 * d);
    for (;;) {
        double x = 0.0;
        double v = 0.0;
        do {
            x = normal(rng);
            v = 1.0 + c * x;
        } while (v <= 0.0);
        v = v * v * v;
        const double u = rng.uniformDouble();
        if (u < 1.0 - 0.0331 * x * x * x * x) return d * v;
        if (u > 0.0 && std::log(u) < 0.5 * x * x + d * (1.0 - v + std::log(v))) return d * v;
    }
}

double resample(double gamma, int A, uint64_t n, Rng& rng) noexcept {
    if (A < 1 || n == 0) return gamma;
    const auto nd = static_cast<double>(n);
    // eta ~ Beta(gamma + 1, n) as X / (X + Y), X ~ Gamma(gamma + 1), Y ~ Gamma(n).
    const double x = gammaDraw(gamma + 1.0, rng);
    const double y = gammaDraw(nd, rng);
    double eta = x / (x + y);
    if (!(eta > 0.0)) eta = 0x1p-1000;
    const double rate = kPriorRate - std::log(eta);
    // The mixture weight: odds (a + A - 1) / (n (b - log eta)).
    const double odds = (kPriorShape + A - 1.0) / (nd * rate);
    const double shape = rng.uniformDouble() * (1.0 + odds) < odds ? kPriorShape + A : kPriorShape + A - 1.0;
    return gammaDraw(shape, rng) / rate;
}

} // namespace rost::concentration
