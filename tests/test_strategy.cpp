// The eight P(t|T) strategies of the paper's section VI: draws match the
// formulas (restricted to the refinable window and renormalised there).

#include <gtest/gtest.h>

#include <cmath>
#include <string>
#include <vector>

#include "rost/random.hpp"
#include "rost/strategy.hpp"

namespace rost {
namespace {

constexpr StrategyKind kAll[] = {
    StrategyKind::Now,          StrategyKind::Uniform,           StrategyKind::AgeProportional,
    StrategyKind::Exponential,  StrategyKind::UniformNow,        StrategyKind::AgeProportionalNow,
    StrategyKind::UniformExponential, StrategyKind::AgeProportionalExponential,
};

// P(t|T) exactly as the paper writes it (1-based t), unnormalised where the
// paper's own formula does not sum to one (the geometric part).
double paperP(StrategyKind k, int64_t t, int64_t T, double eta, double q) {
    const auto sumTo = [](int64_t n) { return 0.5 * static_cast<double>(n) * static_cast<double>(n + 1); };
    const double geo = q * std::pow(1.0 - q, static_cast<double>(T - t));
    const double td = static_cast<double>(t), Td = static_cast<double>(T);
    switch (k) {
    case StrategyKind::Now: return t == T ? 1.0 : 0.0;
    case StrategyKind::Uniform: return 1.0 / Td;
    case StrategyKind::AgeProportional: return td / sumTo(T);
    case StrategyKind::Exponential: return geo;
    case StrategyKind::UniformNow:
        if (T == 1) return 1.0;
        return t == T ? eta : (1.0 - eta) / (Td - 1.0);
    case StrategyKind::AgeProportionalNow:
        if (T == 1) return 1.0;
        return t == T ? eta : (1.0 - eta) * td / sumTo(T - 1);
    case StrategyKind::UniformExponential: return eta * geo + (1.0 - eta) / Td;
    case StrategyKind::AgeProportionalExponential: return eta * geo + (1.0 - eta) * td / sumTo(T);
    }
    return 0.0;
}

// P(t|T) restricted to the window [T-W+1, T], renormalised (index 0 = oldest t).
std::vector<double> windowed(StrategyKind k, int64_t T, int64_t W, double eta, double q) {
    std::vector<double> p(static_cast<std::size_t>(W));
    double sum = 0.0;
    for (int64_t i = 0; i < W; ++i) sum += p[static_cast<std::size_t>(i)] = paperP(k, T - W + 1 + i, T, eta, q);
    for (double& x : p) x /= sum;
    return p;
}

// Upper 1e-6 quantile of chi-square with `df` degrees of freedom
// (Wilson-Hilferty; slightly conservative for df = 1).
double chiSquareCritical(int df) {
    const double z = 4.7534;  // standard normal upper 1e-6 quantile
    const double k = df;
    const double a = 2.0 / (9.0 * k);
    return k * std::pow(1.0 - a + z * std::sqrt(a), 3.0);
}

struct Fit {
    double stat = 0.0;
    int df = 0;
    bool outside_window = false;
};

// Pearson's chi-square of `counts` against `expected` probabilities, adjacent
// bins merged (in t order) until each expects at least 5 draws.
Fit chiSquare(const std::vector<uint64_t>& counts, const std::vector<double>& expected, uint64_t n) {
    Fit f;
    double e = 0.0, o = 0.0;
    int bins = 0;
    std::vector<std::pair<double, double>> merged;
    for (std::size_t i = 0; i < counts.size(); ++i) {
        e += expected[i] * static_cast<double>(n);
        o += static_cast<double>(counts[i]);
        if (e >= 5.0) {
            merged.emplace_back(o, e);
            e = o = 0.0;
        }
    }
    if (e > 0.0 || o > 0.0) {
        if (merged.empty()) merged.emplace_back(o, e);
        else {
            merged.back().first += o;
            merged.back().second += e;
        }
    }
    for (const auto& [oo, ee] : merged) {
        if (ee <= 0.0) {
            if (oo > 0.0) f.outside_window = true;  // draws where the formula says never
            continue;
        }
        f.stat += (oo - ee) * (oo - ee) / ee;
        ++bins;
    }
    f.df = std::max(bins - 1, 1);
    return f;
}

struct Case {
    StrategyKind kind;
    int64_t T;
    int64_t W;
    double eta;
    double q;
};

std::string caseName(const ::testing::TestParamInfo<Case>& info) {
    std::string s = toString(info.param.kind);
    for (char& c : s)
        if (c == '+') c = '_';
    s += "_T" + std::to_string(info.param.T) + "_W" + std::to_string(info.param.W);
    if (info.param.eta != 0.5 || info.param.q != 0.1) s += "_tuned";
    return s;
}

std::vector<Case> allCases() {
    // Small T (window = everything), T = ring, and T far beyond a 256-step
    // ring (1000, a million, five billion: the age-proportional sums near the
    // top of the 64-bit range).
    const std::pair<int64_t, int64_t> tw[] = {{1, 1},      {2, 2},         {5, 5},     {64, 64},
                                              {10, 4},     {256, 256},     {1000, 256}, {1000000, 256},
                                              {5000000000LL, 256}};
    std::vector<Case> out;
    for (StrategyKind k : kAll)
        for (auto [T, W] : tw) out.push_back({k, T, W, 0.5, 0.1});
    // Other parameters on the mixtures and the geometric part.
    for (StrategyKind k : kAll) out.push_back({k, 1000, 256, 0.2, 0.02});
    return out;
}

class StrategyDraws : public ::testing::TestWithParam<Case> {};

// 200,000 draws per case, fixed seed; the test fails when the chi-square
// statistic exceeds its 1e-6 upper quantile, so a correct sampler fails a
// given case with probability about 1e-6 (under 1e-4 over all cases).
TEST_P(StrategyDraws, MatchPaperFormulaRestrictedToWindowChiSquare) {
    const Case c = GetParam();
    const Strategy s(StrategyConfig{c.kind, c.eta, c.q});
    Rng rng(12345 + static_cast<uint64_t>(c.T));
    const uint64_t n = 200000;
    std::vector<uint64_t> counts(static_cast<std::size_t>(c.W), 0);
    const int64_t L = c.T - c.W + 1;
    for (uint64_t i = 0; i < n; ++i) {
        const int64_t t = s.draw(c.T, c.W, rng);
        ASSERT_GE(t, L) << "draw below the window";
        ASSERT_LE(t, c.T) << "draw above T";
        ++counts[static_cast<std::size_t>(t - L)];
    }
    const auto expected = windowed(c.kind, c.T, c.W, c.eta, c.q);
    const Fit f = chiSquare(counts, expected, n);
    EXPECT_FALSE(f.outside_window);
    EXPECT_LT(f.stat, chiSquareCritical(f.df)) << "chi-square " << f.stat << " with " << f.df << " df";
}

INSTANTIATE_TEST_SUITE_P(AllStrategies, StrategyDraws, ::testing::ValuesIn(allCases()), caseName);

// The goodness-of-fit test has power: it rejects draws from one strategy
// checked against a similar but different formula (uniform vs age-
// proportional on the window [745, 1000], where they differ by at most 34%).
TEST(StrategyGoodnessOfFit, RejectsDrawsCheckedAgainstAWrongFormula) {
    const Strategy uniform(StrategyConfig{StrategyKind::Uniform, 0.5, 0.1});
    Rng rng(99);
    const uint64_t n = 200000;
    std::vector<uint64_t> counts(256, 0);
    for (uint64_t i = 0; i < n; ++i) ++counts[static_cast<std::size_t>(uniform.draw(1000, 256, rng) - 745)];
    const Fit f = chiSquare(counts, windowed(StrategyKind::AgeProportional, 1000, 256, 0.5, 0.1), n);
    EXPECT_GT(f.stat, chiSquareCritical(f.df));

    // And a geometric part with the wrong q.
    const Strategy exp(StrategyConfig{StrategyKind::Exponential, 0.5, 0.1});
    std::vector<uint64_t> c2(256, 0);
    for (uint64_t i = 0; i < n; ++i) ++c2[static_cast<std::size_t>(exp.draw(1000, 256, rng) - 745)];
    const Fit f2 = chiSquare(c2, windowed(StrategyKind::Exponential, 1000, 256, 0.5, 0.11), n);
    EXPECT_GT(f2.stat, chiSquareCritical(f2.df));
}

TEST(Strategy, ProbabilityAgreesWithPaperFormulaAndSumsToOneOverWindow) {
    for (StrategyKind k : kAll) {
        const Strategy s(StrategyConfig{k, 0.3, 0.05});
        for (auto [T, W] : {std::pair<int64_t, int64_t>{1, 1}, {7, 7}, {300, 256}, {1000000, 100}}) {
            const auto expected = windowed(k, T, W, 0.3, 0.05);
            double sum = 0.0;
            for (int64_t i = 0; i < W; ++i) {
                const double p = s.probability(T - W + 1 + i, T, W);
                EXPECT_NEAR(p, expected[static_cast<std::size_t>(i)], 1e-9) << toString(k) << " T=" << T;
                sum += p;
            }
            EXPECT_NEAR(sum, 1.0, 1e-9) << toString(k);
            EXPECT_EQ(s.probability(T - W, T, W), 0.0) << "outside the window";
        }
    }
}

TEST(Strategy, DrawStepIsZeroBasedWithinTheModelsWindow) {
    Rng rng(3);
    for (StrategyKind k : kAll) {
        const Strategy s(StrategyConfig{k, 0.5, 0.1});
        for (int i = 0; i < 2000; ++i) {
            const int64_t step = s.drawStep(500, 16, rng);  // model steps 0..499, window 484..499
            ASSERT_GE(step, 484) << toString(k);
            ASSERT_LE(step, 499) << toString(k);
        }
        EXPECT_EQ(s.drawStep(1, 1, rng), 0) << toString(k);
    }
}

TEST(Strategy, NowAndQEqualOneAlwaysPickTheNewestStep) {
    Rng rng(5);
    const Strategy now(StrategyConfig{StrategyKind::Now, 0.5, 0.1});
    const Strategy exp1(StrategyConfig{StrategyKind::Exponential, 0.5, 1.0});
    for (int i = 0; i < 1000; ++i) {
        EXPECT_EQ(now.draw(777, 256, rng), 777);
        EXPECT_EQ(exp1.draw(777, 256, rng), 777);
    }
}

// q = 1 (the top of its range, "(0, 1]"): the geometric part is all at t = T,
// its mass in any window 1, so a mixture puts eta + (1 - eta) P_global(T) on
// T and the rest as its global part does. Window [7, 10] of T = 10, eta = 0.5:
// uni+exp gives T (0.5 + 0.05) / 0.7 and each older step 0.05 / 0.7; the
// probabilities and the draws both.
TEST(Strategy, QOfOneGivesTheMixturesTheirWholeLocalPartAtTheNewestStep) {
    const double eta = 0.5;
    const Strategy uniExp(StrategyConfig{StrategyKind::UniformExponential, eta, 1.0});
    EXPECT_NEAR(uniExp.probability(10, 10, 4), 0.55 / 0.7, 1e-12);
    EXPECT_NEAR(uniExp.probability(7, 10, 4), 0.05 / 0.7, 1e-12);
    for (StrategyKind k : {StrategyKind::Exponential, StrategyKind::UniformExponential, StrategyKind::AgeProportionalExponential}) {
        const Strategy s(StrategyConfig{k, eta, 1.0});
        const auto expected = windowed(k, 10, 4, eta, 1.0);
        for (int64_t t = 7; t <= 10; ++t)
            EXPECT_NEAR(s.probability(t, 10, 4), expected[static_cast<std::size_t>(t - 7)], 1e-12) << toString(k) << " t=" << t;
        Rng rng(41);
        const uint64_t n = 100000;
        std::vector<uint64_t> counts(4, 0);
        for (uint64_t i = 0; i < n; ++i) {
            const int64_t t = s.draw(10, 4, rng);
            ASSERT_GE(t, 7);
            ASSERT_LE(t, 10);
            ++counts[static_cast<std::size_t>(t - 7)];
        }
        const Fit f = chiSquare(counts, expected, n);
        EXPECT_FALSE(f.outside_window) << toString(k);
        EXPECT_LT(f.stat, chiSquareCritical(f.df)) << toString(k) << ": chi-square " << f.stat << " with " << f.df << " df";
    }
}

// A window wider than the steps there are (W > T, as a ring not yet full
// would give) is clamped to them: every strategy's probabilities are those of
// W = T, and its draws lie in [1, T].
TEST(Strategy, AWindowWiderThanTheStepsIsClampedToThem) {
    Rng rng(17);
    for (StrategyKind k : kAll) {
        const Strategy s(StrategyConfig{k, 0.3, 0.2});
        for (int64_t t = 0; t <= 6; ++t)
            EXPECT_DOUBLE_EQ(s.probability(t, 5, 300), s.probability(t, 5, 5)) << toString(k) << " t=" << t;
        for (int i = 0; i < 2000; ++i) {
            const int64_t t = s.draw(5, 300, rng);
            ASSERT_GE(t, 1) << toString(k);
            ASSERT_LE(t, 5) << toString(k);
        }
    }
}

TEST(StrategyNames, ParseRoundTripsEveryName) {
    for (StrategyKind k : kAll) {
        StrategyKind parsed = StrategyKind::Now;
        ASSERT_TRUE(parseStrategy(toString(k), parsed).ok()) << toString(k);
        EXPECT_EQ(parsed, k);
    }
}

TEST(StrategyNames, ParseRejectsUnknownNameAndListsTheValidOnes) {
    StrategyKind k = StrategyKind::Now;
    const Status s = parseStrategy("unifrom", k);
    ASSERT_FALSE(s.ok());
    EXPECT_NE(s.message().find("'unifrom'"), std::string::npos) << s.message();
    EXPECT_NE(s.message().find("agep+exp"), std::string::npos) << s.message();
}

TEST(StrategyConfig, ValidateNamesEtaOrQOutOfRange) {
    StrategyConfig c;
    c.eta = 1.5;
    EXPECT_EQ(c.validate().message(), "invalid configuration: eta = 1.5, allowed [0, 1]");
    c.eta = 0.5;
    c.q = 0.0;
    EXPECT_EQ(c.validate().message(), "invalid configuration: q = 0, allowed (0, 1]");
    c.q = std::nan("");
    EXPECT_FALSE(c.validate().ok());
    c.q = 1.0;
    EXPECT_TRUE(c.validate().ok());
}

// A kind past the last name (an enum cast from a number) is refused naming
// the setting, as a range: the names are the allowed values.
TEST(StrategyConfig, ValidateRefusesAKindPastTheLastName) {
    StrategyConfig c;
    c.kind = static_cast<StrategyKind>(7);
    EXPECT_TRUE(c.validate().ok());
    c.kind = static_cast<StrategyKind>(8);
    EXPECT_EQ(c.validate().message(),
              "invalid configuration: sampler = 8, allowed now|uniform|agep|exp|uni+now|agep+now|uni+exp|agep+exp");
}

static_assert(noexcept(std::declval<const Strategy&>().draw(1, 1, std::declval<Rng&>())));

} // namespace
} // namespace rost
