#pragma once

// Synthetic observations drawn from the paper's generative process (section
// III) with the answer planted, for recovery tests, experiments and benches:
//
//   phi_k         K topics with distinct word distributions: each topic owns a
//                 disjoint block of `words_per_topic` words (Dirichlet(1)
//                 weights) and puts `noise_mass` of its probability uniformly
//                 on `noise_words` words that every topic shares;
//   region(t, c)  a planted topic per cell and time step, laid out as spatial
//                 regions (blobs or stripes over the cell grid) that move over
//                 time;
//   theta_{t,c}   (1 - topic_noise) on the region's topic plus topic_noise / K
//                 on every topic (so a word's topic is its region's with some
//                 noise);
//   z ~ theta_{t,c}, w ~ phi_z, position uniform inside the cell.
//
// Only rost::Rng is used (no std distributions, whose output differs between
// standard libraries), so the same Spec gives the same data everywhere.
//
// Also here: the true model's perplexity (the yardstick for a learned one)
// and label-agreement metrics (NMI, adjusted Rand index, best-match accuracy).

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <numbers>
#include <numeric>
#include <vector>

#include <Eigen/Core>

#include "rost/config.hpp"
#include "rost/model.hpp"
#include "rost/random.hpp"

namespace rost::synthetic {

enum class Layout : uint8_t {
    Blobs,    // Voronoi cells of `regions` moving centres on the torus (topic = centre index % K)
    Stripes,  // vertical stripes of width grid_width / regions drifting sideways (topic = stripe % K)
};

struct Spec {
    int K = 4;
    int words_per_topic = 16;
    int noise_words = 8;
    double noise_mass = 0.05;   // each topic's mass on the shared noise words, [0, 1]
    double topic_noise = 0.05;  // weight of the uniform part of theta, [0, 1]

    Layout layout = Layout::Blobs;
    int regions = 4;        // blob centres or stripes
    double speed = 0.25;    // cells per time step the layout moves

    int grid_width = 12;    // cells
    int grid_height = 12;
    int cell_space = 16;    // pixels per cell side
    int steps = 20;         // time steps (one observation each)
    int min_words = 20;     // words per cell and step, uniform in [min_words, max_words]
    int max_words = 30;

    uint64_t seed = 1;

    [[nodiscard]] int V() const noexcept { return K * words_per_topic + noise_words; }
    [[nodiscard]] int cells() const noexcept { return grid_width * grid_height; }
};

struct Data {
    Spec spec;
    Eigen::MatrixXd phi;                           // K x V, true topic-word distributions
    std::vector<uint16_t> region;                  // steps x cells: planted region topic
    std::vector<std::vector<uint32_t>> words;      // per step, in input order
    std::vector<std::vector<Position>> positions;  // per step
    std::vector<std::vector<uint16_t>> topics;     // per step: the planted z of each word

    [[nodiscard]] int cellOf(Position p) const noexcept {
        return (p.y / spec.cell_space) * spec.grid_width + p.x / spec.cell_space;
    }
    [[nodiscard]] uint16_t regionOf(int64_t t, int cell) const noexcept {
        return region[static_cast<std::size_t>(t) * static_cast<std::size_t>(spec.cells()) +
                      static_cast<std::size_t>(cell)];
    }
    // True theta_{t,c}(k).
    [[nodiscard]] double theta(int64_t t, int cell, int k) const noexcept {
        return (k == regionOf(t, cell) ? 1.0 - spec.topic_noise : 0.0) + spec.topic_noise / spec.K;
    }
    // True p(w) of a word of cell c at step t: sum_k phi_k(w) theta_{t,c}(k).
    [[nodiscard]] double trueWordProb(int64_t t, int cell, uint32_t w) const noexcept {
        double p = 0.0;
        for (int k = 0; k < spec.K; ++k) p += phi(k, static_cast<Eigen::Index>(w)) * theta(t, cell, k);
        return p;
    }
    [[nodiscard]] std::size_t totalWords() const noexcept {
        std::size_t n = 0;
        for (const auto& w : words) n += w.size();
        return n;
    }

    // A model configuration that holds every word of this data (no subsampling)
    // in a window covering all steps. Hyperparameters and radii keep Config's
    // defaults; set them on the result.
    [[nodiscard]] Config config() const {
        Config c;
        c.K = spec.K;
        c.V = spec.V();
        c.cell_space = spec.cell_space;
        c.frame_width = spec.grid_width * spec.cell_space;
        c.frame_height = spec.grid_height * spec.cell_space;
        c.ring_steps = spec.steps;
        c.cell_capacity = spec.max_words;
        c.max_words_per_frame = spec.max_words * spec.cells();
        c.seed = spec.seed;
        return c;
    }
};

namespace detail {

// Distance on a ring of circumference n.
inline double ringDistance(double a, double b, double n) noexcept {
    const double d = std::fabs(a - b);
    const double m = std::fmod(d, n);
    return std::min(m, n - m);
}

} // namespace detail

// Four planted topics on disjoint blocks of 16 words (8 noise words, 5 %),
// as vertical stripes drifting over a grid of 16 px cells, 8-12 words a cell.
inline Spec fourStripes(uint64_t seed, int gridWidth, int gridHeight, int steps) {
    Spec s;
    s.K = 4;
    s.words_per_topic = 16;
    s.noise_words = 8;
    s.noise_mass = 0.05;
    s.topic_noise = 0.02;
    s.layout = Layout::Stripes;
    s.regions = 4;
    s.speed = 0.2;
    s.grid_width = gridWidth;
    s.grid_height = gridHeight;
    s.cell_space = 16;
    s.steps = steps;
    s.min_words = 8;
    s.max_words = 12;
    s.seed = seed;
    return s;
}

inline Data generate(const Spec& s) {
    Data d;
    d.spec = s;
    Rng rng(s.seed * 0x9E3779B97F4A7C15ull + 12345u);
    const int K = s.K, V = s.V(), C = s.cells();

    // phi: Dirichlet(1) weights on the topic's own block (exponential draws,
    // normalised), plus the shared noise words.
    d.phi = Eigen::MatrixXd::Zero(K, V);
    for (int k = 0; k < K; ++k) {
        double sum = 0.0;
        for (int j = 0; j < s.words_per_topic; ++j) {
            const double e = -std::log(1.0 - rng.uniformDouble());
            d.phi(k, k * s.words_per_topic + j) = e;
            sum += e;
        }
        const double own = s.noise_words > 0 ? 1.0 - s.noise_mass : 1.0;
        for (int j = 0; j < s.words_per_topic; ++j) d.phi(k, k * s.words_per_topic + j) *= own / sum;
        for (int j = 0; j < s.noise_words; ++j) d.phi(k, K * s.words_per_topic + j) = s.noise_mass / s.noise_words;
    }

    // Moving layout: blob centres with random positions and headings.
    std::vector<double> cx(static_cast<std::size_t>(s.regions)), cy(cx.size()), vx(cx.size()), vy(cx.size());
    for (std::size_t r = 0; r < cx.size(); ++r) {
        cx[r] = rng.uniformDouble() * s.grid_width;
        cy[r] = rng.uniformDouble() * s.grid_height;
        const double a = 2.0 * std::numbers::pi * rng.uniformDouble();
        vx[r] = s.speed * std::cos(a);
        vy[r] = s.speed * std::sin(a);
    }
    const double stripeOffset = rng.uniformDouble() * s.grid_width;
    d.region.resize(static_cast<std::size_t>(s.steps) * static_cast<std::size_t>(C));
    for (int t = 0; t < s.steps; ++t)
        for (int y = 0; y < s.grid_height; ++y)
            for (int x = 0; x < s.grid_width; ++x) {
                const double px = x + 0.5, py = y + 0.5;
                int topic = 0;
                if (s.layout == Layout::Blobs) {
                    double best = 1e300;
                    for (std::size_t r = 0; r < cx.size(); ++r) {
                        const double dx = detail::ringDistance(px, cx[r] + vx[r] * t, s.grid_width);
                        const double dy = detail::ringDistance(py, cy[r] + vy[r] * t, s.grid_height);
                        const double dist = dx * dx + dy * dy;
                        if (dist < best) {
                            best = dist;
                            topic = static_cast<int>(r) % K;
                        }
                    }
                } else {
                    const double width = static_cast<double>(s.grid_width) / s.regions;
                    const double u = std::fmod(px + stripeOffset + s.speed * t, static_cast<double>(s.grid_width));
                    topic = static_cast<int>(u / width) % K;
                }
                d.region[static_cast<std::size_t>(t) * C + static_cast<std::size_t>(y * s.grid_width + x)] =
                    static_cast<uint16_t>(topic);
            }

    // Words: per step, cells in raster order, each with its words.
    std::vector<double> cdf(static_cast<std::size_t>(V));
    std::vector<std::vector<double>> phiCdf(static_cast<std::size_t>(K));
    for (int k = 0; k < K; ++k) {
        double acc = 0.0;
        for (int v = 0; v < V; ++v) {
            acc += d.phi(k, v);
            cdf[static_cast<std::size_t>(v)] = acc;
        }
        phiCdf[static_cast<std::size_t>(k)] = cdf;
    }
    auto drawWord = [&](int k) {
        const auto& f = phiCdf[static_cast<std::size_t>(k)];
        const double u = rng.uniformDouble() * f.back();
        const auto it = std::upper_bound(f.begin(), f.end(), u);
        return static_cast<uint32_t>(std::min<std::ptrdiff_t>(it - f.begin(), V - 1));
    };
    d.words.resize(static_cast<std::size_t>(s.steps));
    d.positions.resize(d.words.size());
    d.topics.resize(d.words.size());
    for (int t = 0; t < s.steps; ++t) {
        auto& W = d.words[static_cast<std::size_t>(t)];
        auto& P = d.positions[static_cast<std::size_t>(t)];
        auto& Z = d.topics[static_cast<std::size_t>(t)];
        for (int c = 0; c < C; ++c) {
            const int n = s.min_words + static_cast<int>(rng.below(static_cast<uint32_t>(s.max_words - s.min_words + 1)));
            const int reg = d.regionOf(t, c);
            for (int i = 0; i < n; ++i) {
                int z = reg;
                if (rng.uniformDouble() < s.topic_noise) z = static_cast<int>(rng.below(static_cast<uint32_t>(K)));
                W.push_back(drawWord(z));
                Z.push_back(static_cast<uint16_t>(z));
                const int x = (c % s.grid_width) * s.cell_space + static_cast<int>(rng.below(static_cast<uint32_t>(s.cell_space)));
                const int y = (c / s.grid_width) * s.cell_space + static_cast<int>(rng.below(static_cast<uint32_t>(s.cell_space)));
                P.push_back({x, y});
            }
        }
    }
    return d;
}

// ---- the true model's perplexity ---------------------------------------------

// Perplexity of step t's words under the true model, with the definition the
// model uses (model.hpp, stepLogLoss): exp(-sum_i log p(w_i) / N_t), where here
// p(w_i) = sum_k phi_k(w_i) theta_{t,c_i}(k) with the generating phi and the
// generating theta of the word's cell. Nothing is estimated, so there is no
// word to leave out: this is the best any model can do in expectation.
inline double trueStepPerplexity(const Data& d, int64_t t) {
    const auto& W = d.words[static_cast<std::size_t>(t)];
    const auto& P = d.positions[static_cast<std::size_t>(t)];
    double nll = 0.0;
    for (std::size_t i = 0; i < W.size(); ++i) nll -= std::log(d.trueWordProb(t, d.cellOf(P[i]), W[i]));
    return std::exp(nll / static_cast<double>(W.size()));
}

// Mean over steps of the per-step perplexity (the paper's Tables II-III average per-step figures).
inline double trueMeanPerplexity(const Data& d) {
    double sum = 0.0;
    for (int t = 0; t < d.spec.steps; ++t) sum += trueStepPerplexity(d, t);
    return sum / d.spec.steps;
}

// ---- label agreement -----------------------------------------------------------

// Contingency table n[a][b] of two labelings of the same items.
inline std::vector<std::vector<double>> contingency(const std::vector<uint16_t>& a, const std::vector<uint16_t>& b,
                                                    int Ka, int Kb) {
    std::vector<std::vector<double>> n(static_cast<std::size_t>(Ka), std::vector<double>(static_cast<std::size_t>(Kb), 0.0));
    for (std::size_t i = 0; i < a.size() && i < b.size(); ++i) n[a[i]][b[i]] += 1.0;
    return n;
}

// Normalised mutual information, I(A;B) / ((H(A) + H(B)) / 2) (arithmetic-mean
// normalisation, the stricter of the common ones: it is <= I / sqrt(H(A) H(B))).
// Invariant to relabelling; 1 for identical partitions, ~0 for independent ones.
inline double nmi(const std::vector<uint16_t>& a, const std::vector<uint16_t>& b, int Ka, int Kb) {
    const auto n = contingency(a, b, Ka, Kb);
    const double N = static_cast<double>(std::min(a.size(), b.size()));
    std::vector<double> ra(static_cast<std::size_t>(Ka), 0.0), rb(static_cast<std::size_t>(Kb), 0.0);
    for (int i = 0; i < Ka; ++i)
        for (int j = 0; j < Kb; ++j) {
            ra[i] += n[i][j];
            rb[j] += n[i][j];
        }
    auto entropy = [N](const std::vector<double>& m) {
        double h = 0.0;
        for (double x : m)
            if (x > 0) h -= x / N * std::log(x / N);
        return h;
    };
    double mi = 0.0;
    for (int i = 0; i < Ka; ++i)
        for (int j = 0; j < Kb; ++j)
            if (n[i][j] > 0) mi += n[i][j] / N * std::log(n[i][j] * N / (ra[i] * rb[j]));
    const double h = 0.5 * (entropy(ra) + entropy(rb));
    return h > 0 ? mi / h : 1.0;
}

// Adjusted Rand index (Hubert & Arabie): pair-counting agreement corrected for chance.
inline double adjustedRand(const std::vector<uint16_t>& a, const std::vector<uint16_t>& b, int Ka, int Kb) {
    const auto n = contingency(a, b, Ka, Kb);
    auto pairs = [](double x) { return x * (x - 1.0) / 2.0; };
    const double N = static_cast<double>(std::min(a.size(), b.size()));
    double sumCells = 0.0, sumA = 0.0, sumB = 0.0;
    std::vector<double> rb(static_cast<std::size_t>(Kb), 0.0);
    for (int i = 0; i < Ka; ++i) {
        double ra = 0.0;
        for (int j = 0; j < Kb; ++j) {
            sumCells += pairs(n[i][j]);
            ra += n[i][j];
            rb[j] += n[i][j];
        }
        sumA += pairs(ra);
    }
    for (double x : rb) sumB += pairs(x);
    const double expected = sumA * sumB / pairs(N);
    const double maxIndex = 0.5 * (sumA + sumB);
    return maxIndex > expected ? (sumCells - expected) / (maxIndex - expected) : 1.0;
}

// Fraction of items whose label in `b`, mapped through the best one-to-one
// matching of b's labels onto a's (maximum total agreement over all K!
// permutations; K <= 8), equals their label in `a`.
inline double bestMatchAccuracy(const std::vector<uint16_t>& a, const std::vector<uint16_t>& b, int K) {
    const auto n = contingency(a, b, K, K);
    std::vector<int> perm(static_cast<std::size_t>(K));
    std::iota(perm.begin(), perm.end(), 0);
    double best = 0.0;
    do {
        double agree = 0.0;
        for (int j = 0; j < K; ++j) agree += n[perm[j]][j];
        best = std::max(best, agree);
    } while (std::next_permutation(perm.begin(), perm.end()));
    return best / static_cast<double>(std::min(a.size(), b.size()));
}

} // namespace rost::synthetic
