#include "rost/strategy.hpp"

#include <algorithm>
#include <bit>
#include <cmath>
#include <string>

#include "rost/settings.hpp"

namespace rost {

namespace {

// Uniform integer in [0, n), n > 0, exact (masked rejection, < 2 tries on average).
uint64_t below64(Rng& rng, uint64_t n) noexcept {
    if (n <= 0xFFFFFFFFull) return rng.below(static_cast<uint32_t>(n));
    const uint64_t mask = ~0ull >> std::countl_zero(n - 1);
    for (;;) {
        const uint64_t hi = rng.next();
        const uint64_t x = ((hi << 32) | rng.next()) & mask;
        if (x < n) return x;
    }
}

// sum_{i=1..t} i without overflow for t < 6.07e9.
uint64_t tri(int64_t t) noexcept {
    if (t <= 0) return 0;
    const auto u = static_cast<uint64_t>(t);
    return (u % 2 == 0) ? (u / 2) * (u + 1) : u * ((u + 1) / 2);
}

// Age-proportional part on [a, b] (1-based, 1 <= a <= b): P(t) ∝ t. Exact
// inverse CDF on the integers: x uniform in [tri(a-1), tri(b)), t the
// smallest with tri(t) > x.
int64_t drawAgeProportional(int64_t a, int64_t b, Rng& rng) noexcept {
    const uint64_t lo = tri(a - 1);
    const uint64_t x = lo + below64(rng, tri(b) - lo);
    auto t = static_cast<int64_t>(std::floor((std::sqrt(8.0 * static_cast<double>(x) + 1.0) - 1.0) / 2.0));
    t = std::clamp<int64_t>(t, a - 1, b);
    while (t < b && tri(t) <= x) ++t;  // a correction of at most one or two for rounding
    while (t > a && tri(t - 1) > x) --t;
    return std::max(t, a);
}

// Geometric part on ages 0..W-1 (age = T - t): P(age) ∝ (1-q)^age, by the
// inverse of its truncated CDF F(a) = (1 - r^(a+1)) / (1 - r^W), r = 1 - q.
int64_t drawGeometricAge(int64_t W, double log1mq, Rng& rng) noexcept {
    if (W <= 1 || !std::isfinite(log1mq)) return 0;  // q = 1: always the newest
    const double u = rng.uniformDouble();
    const double massW = -std::expm1(static_cast<double>(W) * log1mq);  // 1 - r^W
    const double a = std::floor(std::log1p(-u * massW) / log1mq);
    if (!(a >= 0.0)) return 0;
    return std::min<int64_t>(static_cast<int64_t>(std::min(a, 9.0e18)), W - 1);
}

// Mass of the geometric part q (1-q)^(T-t) over the window: 1 - (1-q)^W.
double geometricMass(int64_t W, double log1mq) noexcept {
    if (!std::isfinite(log1mq)) return 1.0;
    return -std::expm1(static_cast<double>(W) * log1mq);
}

} // namespace

// The names are the schema's (the `sampler` row's choices, in enum order).
const char* toString(StrategyKind k) noexcept { return choiceName(settingSpec("sampler"), static_cast<std::size_t>(k)); }

Status parseStrategy(const std::string& name, StrategyKind& out) {
    const int i = choiceIndexOf(settingSpec("sampler"), name);
    if (i < 0) return Status::error("unknown strategy '" + name + "' (" + choiceExpected(settingSpec("sampler")) + ")");
    out = static_cast<StrategyKind>(i);
    return {};
}

Status StrategyConfig::validate() const {
    if (auto p = checkStrategySettings(*this)) return Status::error("invalid configuration: " + p->describe(p->spec->key));
    return {};
}

Strategy::Strategy(const StrategyConfig& cfg) noexcept : cfg_(cfg), log1mq_(std::log1p(-cfg.q)) {}

int64_t Strategy::draw(int64_t T, int64_t W, Rng& rng) const noexcept {
    if (T <= 1) return 1;
    W = std::clamp<int64_t>(W, 1, T);
    const int64_t L = T - W + 1;  // oldest refinable t
    const double eta = cfg_.eta;
    switch (cfg_.kind) {
    case StrategyKind::Now:
        return T;
    case StrategyKind::Uniform:
        return L + static_cast<int64_t>(below64(rng, static_cast<uint64_t>(W)));
    case StrategyKind::AgeProportional:
        return drawAgeProportional(L, T, rng);
    case StrategyKind::Exponential:
        return T - drawGeometricAge(W, log1mq_, rng);
    case StrategyKind::UniformNow: {
        if (W == 1) return T;
        // Window masses: eta at T, (1-eta)(W-1)/(T-1) spread uniformly over [L, T-1].
        const double rest = (1.0 - eta) * static_cast<double>(W - 1) / static_cast<double>(T - 1);
        const double total = eta + rest;
        if (total <= 0.0 || rng.uniformDouble() * total < eta) return T;
        return L + static_cast<int64_t>(below64(rng, static_cast<uint64_t>(W - 1)));
    }
    case StrategyKind::AgeProportionalNow: {
        if (W == 1) return T;
        const double rest = (1.0 - eta) * static_cast<double>(tri(T - 1) - tri(L - 1)) / static_cast<double>(tri(T - 1));
        const double total = eta + rest;
        if (total <= 0.0 || rng.uniformDouble() * total < eta) return T;
        return drawAgeProportional(L, T - 1, rng);
    }
    case StrategyKind::UniformExponential: {
        const double local = eta * geometricMass(W, log1mq_);
        const double global = (1.0 - eta) * static_cast<double>(W) / static_cast<double>(T);
        const double total = local + global;
        if (total <= 0.0) return T;
        if (rng.uniformDouble() * total < local) return T - drawGeometricAge(W, log1mq_, rng);
        return L + static_cast<int64_t>(below64(rng, static_cast<uint64_t>(W)));
    }
    case StrategyKind::AgeProportionalExponential: {
        const double local = eta * geometricMass(W, log1mq_);
        const double global = (1.0 - eta) * static_cast<double>(tri(T) - tri(L - 1)) / static_cast<double>(tri(T));
        const double total = local + global;
        if (total <= 0.0) return T;
        if (rng.uniformDouble() * total < local) return T - drawGeometricAge(W, log1mq_, rng);
        return drawAgeProportional(L, T, rng);
    }
    }
    return T;
}

double Strategy::probability(int64_t t, int64_t T, int64_t W) const noexcept {
    if (T <= 1) return t == 1 ? 1.0 : 0.0;
    W = std::clamp<int64_t>(W, 1, T);
    const int64_t L = T - W + 1;
    if (t < L || t > T) return 0.0;
    const double eta = cfg_.eta;
    const double r = 1.0 - cfg_.q;
    // Unnormalised P(t|T) as the paper writes it, and its sum over the window.
    double p = 0.0, sum = 0.0;
    const auto geo = [&](int64_t tt) { return cfg_.q * std::pow(r, static_cast<double>(T - tt)); };
    const double ageSumAll = static_cast<double>(tri(T));
    const double ageSumWin = static_cast<double>(tri(T) - tri(L - 1));
    const double gm = geometricMass(W, log1mq_);
    switch (cfg_.kind) {
    case StrategyKind::Now:
        return t == T ? 1.0 : 0.0;
    case StrategyKind::Uniform:
        return 1.0 / static_cast<double>(W);
    case StrategyKind::AgeProportional:
        return static_cast<double>(t) / ageSumWin;
    case StrategyKind::Exponential:
        return geo(t) / gm;
    case StrategyKind::UniformNow:
        if (W == 1) return 1.0;
        p = t == T ? eta : (1.0 - eta) / static_cast<double>(T - 1);
        sum = eta + (1.0 - eta) * static_cast<double>(W - 1) / static_cast<double>(T - 1);
        break;
    case StrategyKind::AgeProportionalNow: {
        if (W == 1) return 1.0;
        const double s1 = static_cast<double>(tri(T - 1));
        p = t == T ? eta : (1.0 - eta) * static_cast<double>(t) / s1;
        sum = eta + (1.0 - eta) * static_cast<double>(tri(T - 1) - tri(L - 1)) / s1;
        break;
    }
    case StrategyKind::UniformExponential:
        p = eta * geo(t) + (1.0 - eta) / static_cast<double>(T);
        sum = eta * gm + (1.0 - eta) * static_cast<double>(W) / static_cast<double>(T);
        break;
    case StrategyKind::AgeProportionalExponential:
        p = eta * geo(t) + (1.0 - eta) * static_cast<double>(t) / ageSumAll;
        sum = eta * gm + (1.0 - eta) * ageSumWin / ageSumAll;
        break;
    }
    if (sum <= 0.0) return t == T ? 1.0 : 0.0;
    return p / sum;
}

} // namespace rost
