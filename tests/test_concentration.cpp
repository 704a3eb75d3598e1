// The growth concentration's update (src/core/concentration.hpp, Escobar and
// West's auxiliary-variable method): its Gamma draws have the right moments,
// and its chain, run with A and n fixed, has the exact posterior's mean
// p(gamma | A, n) ∝ Gamma(gamma; 1, 1) gamma^A Γ(gamma) / Γ(gamma + n),
// integrated numerically; and it draws the same values for the same seed.

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdint>

#include "concentration.hpp"

namespace {

namespace cc = rost::concentration;

// Posterior mean of gamma given A clusters and n observations, by the
// trapezoid rule on a log grid.
double posteriorMean(int A, uint64_t n) {
    const double nd = static_cast<double>(n);
    auto logDensity = [&](double g) {
        return (cc::kPriorShape - 1.0) * std::log(g) - cc::kPriorRate * g + A * std::log(g) + std::lgamma(g) -
               std::lgamma(g + nd);
    };
    double z = 0.0, m = 0.0, prevX = 0.0, prevW = 0.0, prevWx = 0.0;
    bool first = true;
    double peak = -1e300;
    for (double lx = -12.0; lx <= 4.0; lx += 1e-3) peak = std::max(peak, logDensity(std::exp(lx)));
    for (double lx = -12.0; lx <= 4.0; lx += 1e-3) {
        const double x = std::exp(lx);
        const double w = std::exp(logDensity(x) - peak);
        if (!first) {
            z += 0.5 * (w + prevW) * (x - prevX);
            m += 0.5 * (w * x + prevWx) * (x - prevX);
        }
        first = false;
        prevX = x;
        prevW = w;
        prevWx = w * x;
    }
    return m / z;
}

TEST(Concentration, GammaDrawsHaveTheirMoments) {
    rost::Rng rng(7);
    for (const double shape : {1.0, 2.5, 40.0, 60000.0}) {
        const int N = 200000;
        double s = 0.0, s2 = 0.0;
        for (int i = 0; i < N; ++i) {
            const double x = cc::gammaDraw(shape, rng);
            s += x;
            s2 += x * x;
        }
        const double mean = s / N, var = s2 / N - mean * mean;
        EXPECT_NEAR(mean, shape, 5.0 * std::sqrt(shape / N)) << "shape " << shape;
        EXPECT_NEAR(var / shape, 1.0, 0.03) << "shape " << shape;
    }
}

TEST(Concentration, ChainHasThePosteriorMean) {
    struct Case {
        int A;
        uint64_t n;
    };
    // Few words too (n = 3, 10), where the mixture's odds and the auxiliary
    // eta's Beta(gamma + 1, n) move the mean by several per cent.
    for (const Case c : {Case{1, 1000}, Case{5, 60000}, Case{20, 60000}, Case{2, 3}, Case{3, 10}}) {
        rost::Rng rng(11);
        double g = 1e-7;  // any start: the chain forgets it
        for (int i = 0; i < 200; ++i) g = cc::resample(g, c.A, c.n, rng);
        const int N = 100000;
        double s = 0.0;
        for (int i = 0; i < N; ++i) {
            g = cc::resample(g, c.A, c.n, rng);
            s += g;
        }
        const double expected = posteriorMean(c.A, c.n);
        EXPECT_NEAR(s / N, expected, 0.02 * expected) << "A " << c.A << ", n " << c.n;
    }
}

TEST(Concentration, SameSeedSameDraws) {
    rost::Rng a(3), b(3);
    double ga = 1e-5, gb = 1e-5;
    for (int i = 0; i < 1000; ++i) {
        ga = cc::resample(ga, 4, 5000, a);
        gb = cc::resample(gb, 4, 5000, b);
        ASSERT_EQ(ga, gb);
    }
}

} // namespace
