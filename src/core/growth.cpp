// Growth from the data (docs/design.md, "Growth from the data"): between
// sweeps, on the model's own tables, a split move and a merge move whose
// acceptance weighs the whole window's counts, and the concentration gamma
// learned from the open topics (Escobar and West). Serial and drawn from the
// model's Rng, so the same seed gives the same topics on any number of threads.

#include <cmath>
#include <cstdint>

#include "concentration.hpp"
#include "kernel.hpp"
#include "model_core.hpp"

namespace rost {

namespace {

// A token taken out of its topic while a split is drawn (no topic has this label: K <= 1024).
constexpr uint16_t kLimbo = 0xFFFF;
// Restricted Gibbs scans of a split's two topics after their sequential
// allocation: of whole cells, then of single tokens.
constexpr int kSplitScans = 1;
constexpr int kTokenScans = 1;
// Escobar and West's chain, run from the given gamma at every move: long
// enough to forget its start (each step draws from the posterior's mixture).
constexpr int kConcentrationSteps = 20;

// lgamma_r, not std::lgamma: std::lgamma writes the global signgam, a data
// race between models refined on different threads.
double lg(double x) noexcept {
    int sign = 0;
    return ::lgamma_r(x, &sign);
}

} // namespace

template <typename F>
void ModelCore::forEachWindowCell(F&& f) noexcept {
    forEachCellIn(oldestStep(), steps_, f);
}

template <typename F>
void ModelCore::forEachCellIn(int64_t s0, int64_t s1, F&& f) noexcept {
    for (int64_t step = s0; step < s1; ++step) {
        const std::size_t slot = slotOf(step);
        for (int c = 0; c < cells_; ++c) {
            const uint32_t n = cell_n_[slot * cells_ + c];
            if (n > 0) f(nck(slot, c), (slot * cells_ + static_cast<std::size_t>(c)) * cap_, n);
        }
    }
}

void ModelCore::moveToken(int32_t* cellCounts, std::size_t at, int from, int to) noexcept {
    const std::size_t row = static_cast<std::size_t>(cell_words_[at]) * Kp_;
    if (from >= 0) {
        --nkv_[row + from];
        --nk_[from];
        --cellCounts[from];
    }
    if (to >= 0) {
        ++nkv_[row + to];
        ++nk_[to];
        ++cellCounts[to];
    }
    cell_z_[at] = static_cast<uint16_t>(to >= 0 ? to : kLimbo);
}

// What the moves' joint needs of the whole window, counted once a move:
// the cells (tables) that use each topic, and the cells' Dirichlet
// normaliser's change when A topics become A + 1, for A = open - 1 (a merge)
// and A = open (a split), from a histogram of the cells' sizes.
struct ModelCore::Census {
    uint64_t tables = 0;
    uint32_t tablesOf[kMaxKp] = {};
    double moreTopics[2] = {0.0, 0.0};  // [0]: open - 1 -> open, [1]: open -> open + 1
};

void ModelCore::takeCensus(Census& c) noexcept {
    constexpr uint32_t kSizes = 1024;
    uint32_t sizes[kSizes] = {};
    const int A = tables_.active, hi = tables_.hi;
    const double alpha = cfg_.alpha;
    auto term = [alpha](double n, int a) { return lg((a + 1) * alpha) - lg(n + (a + 1) * alpha) - lg(a * alpha) + lg(n + a * alpha); };
    c = Census{};
    forEachWindowCell([&](const int32_t* g, std::size_t, uint32_t n) {
        for (int k = 0; k < hi; ++k) {
            const uint32_t used = g[k] > 0;
            c.tablesOf[k] += used;
            c.tables += used;
        }
        if (n < kSizes) {
            ++sizes[n];
        } else {
            if (A > 1) c.moreTopics[0] += term(n, A - 1);
            c.moreTopics[1] += term(n, A);
        }
    });
    for (uint32_t n = 1; n < kSizes; ++n) {
        if (sizes[n] == 0) continue;
        if (A > 1) c.moreTopics[0] += sizes[n] * term(n, A - 1);
        c.moreTopics[1] += sizes[n] * term(n, A);
    }
}

// log p(topics a and b apart) - log p(a and b one topic), on the current
// counts (a and b apart). The joint is the collapsed one of a window of
// cells: each open topic's words Dirichlet(beta), each cell's topics
// Dirichlet(alpha) over the open topics (`moreTopics`: the normalisers'
// change for one topic more), and the open topics a Dirichlet process of
// concentration gamma over the cells that use them (tables, as in an HDP's
// top level: gamma^topics prod Gamma(m_k) / Gamma(gamma + M)); `others`: the
// tables of every other topic.
double ModelCore::splitLogRatio(int a, int b, double moreTopics, uint64_t others, double gamma) noexcept {
    const double beta = cfg_.beta, alpha = cfg_.alpha, vb = V_ * cfg_.beta;
    const double lgBeta = lg(beta), lgAlpha = lg(alpha);
    double d = moreTopics;
    for (int v = 0; v < V_; ++v) {
        const int32_t* row = nkv_.data() + static_cast<std::size_t>(v) * Kp_;
        const int32_t na = row[a], nb = row[b];
        if ((na | nb) == 0) continue;
        d += lg(na + beta) + lg(nb + beta) - lg(na + nb + beta) - lgBeta;
    }
    const double Na = nk_[a], Nb = nk_[b];
    d += lg(vb) - lg(Na + vb) - lg(Nb + vb) + lg(Na + Nb + vb);
    uint64_t ma = 0, mb = 0, mBoth = 0;
    forEachWindowCell([&](const int32_t* g, std::size_t, uint32_t) {
        const int32_t ca = g[a], cb = g[b];
        if ((ca | cb) == 0) return;
        d += lg(ca + alpha) + lg(cb + alpha) - lg(ca + cb + alpha) - lgAlpha;
        ma += ca > 0;
        mb += cb > 0;
        mBoth += ca > 0 && cb > 0;
    });
    const double mJoint = static_cast<double>(ma + mb - mBoth);
    const double M = static_cast<double>(others) + mJoint;
    d += std::log(gamma);
    if (ma > 0) d += lg(static_cast<double>(ma));
    if (mb > 0) d += lg(static_cast<double>(mb));
    if (mJoint > 0) d -= lg(mJoint);
    d += lg(gamma + M) - lg(gamma + M + static_cast<double>(mBoth));
    return d;
}


// A split proposal of topic k into k and s (the lowest closed label), drawn
// on the model's tables: anchors i (stays in k) and j (goes to s); every
// other token of k is taken out (limbo), then put back cell by cell.
struct ModelCore::Split {
    ModelCore& m;
    uint64_t budget;  // tokens the split may take out at most (its steps' words)
    int k = -1, s = -1;
    // The label k's side takes while the split is drawn: k itself when the
    // split covers the whole window; otherwise a second closed label, so that
    // k's tokens outside the steps do not weigh on the allocation (both sides
    // start empty), folded back into k afterwards (or k when none is left).
    int side = -1;
    int64_t s0 = 0, s1 = 0;  // the steps it moves tokens in: around anchor i's, within the budget
    std::size_t anchorI = 0, anchorJ = 0;
    double cellsOn[2] = {0.0, 0.0};  // cells on each side (the allocation's prior)

    bool member(std::size_t at) const noexcept {
        const int z = m.cell_z_[at];
        return (z == side || z == s) && at != anchorI && at != anchorJ;
    }
    // A cell's tokens in limbo, all to side x.
    void place(int32_t* g, std::size_t base, uint32_t n, int x) noexcept {
        for (uint32_t i = 0; i < n; ++i)
            if (m.cell_z_[base + i] == kLimbo) m.moveToken(g, base + i, -1, x);
    }
    void lift(int32_t* g, std::size_t base, uint32_t n) noexcept {
        for (uint32_t i = 0; i < n; ++i)
            if (member(base + i)) m.moveToken(g, base + i, m.cell_z_[base + i], -1);
    }
    // A cell's tokens of the split (in limbo) drawn to one side as a block:
    // a side weighs (its cells + 1) times its words' predictive (each token
    // against the side's counts without the cell: a proposal, so the cell's
    // own repeats are left out; the acceptance weighs the exact joint).
    // The ratios are multiplied, their log taken when the product nears the
    // double's range.
    void chooseCell(int32_t* g, std::size_t base, uint32_t n) noexcept {
        const double beta = m.cfg_.beta, vb = m.V_ * m.cfg_.beta;
        double logOdds = 0.0, run = 1.0;  // log p(side s) - log p(side k)
        uint32_t tokens = 0;
        for (uint32_t i = 0; i < n; ++i) {
            const std::size_t at = base + i;
            if (m.cell_z_[at] != kLimbo) continue;
            const std::size_t row = static_cast<std::size_t>(m.cell_words_[at]) * m.Kp_;
            run *= (m.nkv_[row + s] + beta) / (m.nkv_[row + side] + beta);
            ++tokens;
            if (run > 1e100 || run < 1e-100) {  // any beta and count: no overflow
                logOdds += std::log(run);
                run = 1.0;
            }
        }
        logOdds += std::log(run) + tokens * std::log((m.nk_[side] + vb) / (m.nk_[s] + vb));
        logOdds += std::log(cellsOn[1] + 1.0) - std::log(cellsOn[0] + 1.0);
        const double pk = 1.0 / (1.0 + std::exp(logOdds));
        const int x = m.rng_.uniformDouble() < pk ? side : s;
        place(g, base, n, x);
        cellsOn[x == s] += 1.0;
    }
    // One token of the split between the two sides.
    int draw(const int32_t* g, std::size_t at) noexcept {
        const double alpha = m.cfg_.alpha, beta = m.cfg_.beta, vb = m.V_ * m.cfg_.beta;
        const std::size_t row = static_cast<std::size_t>(m.cell_words_[at]) * m.Kp_;
        const double wk = (g[side] + alpha) * (m.nkv_[row + side] + beta) / (m.nk_[side] + vb);
        const double ws = (g[s] + alpha) * (m.nkv_[row + s] + beta) / (m.nk_[s] + vb);
        return m.rng_.uniformDouble() * (wk + ws) < wk ? side : s;
    }
    bool anchors() noexcept;
    void chooseSteps(int64_t stepI) noexcept;
    void allocate() noexcept;
};

// The steps around anchor i's, alternately later and earlier, while their
// words stay within the budget (at least anchor i's step).
void ModelCore::Split::chooseSteps(int64_t stepI) noexcept {
    s0 = stepI;
    s1 = stepI + 1;
    uint64_t words = m.wordsInStep(stepI);
    const int64_t first = m.oldestStep(), end = m.steps_;
    for (bool later = true;; later = !later) {
        const bool canLater = s1 < end, canEarlier = s0 > first;
        if (!canLater && !canEarlier) return;
        const int64_t next = (later && canLater) || !canEarlier ? s1 : s0 - 1;
        const uint64_t w = m.wordsInStep(next);
        if (words + w > budget) return;
        words += w;
        if (next == s1) {
            ++s1;
        } else {
            --s0;
        }
    }
}

// Anchor i uniformly over the window's tokens (its topic is k), the steps
// around it (chooseSteps), anchor j uniformly over k's other tokens there;
// k's other tokens there to limbo, j to s, and the anchors' cells to their
// sides. False when there is nothing to split.
bool ModelCore::Split::anchors() noexcept {
    const uint64_t N = m.windowTokens();
    s = m.tables_.slot;
    if (N < 2 || s >= m.K_ || m.nk_[s] != 0) return false;
    const uint64_t pick = static_cast<uint64_t>(m.rng_.uniformDouble() * static_cast<double>(N));
    std::size_t baseI = 0, baseJ = 0;
    uint32_t nI = 0, nJ = 0;
    int32_t *cellI = nullptr, *cellJ = nullptr;
    uint64_t seen = 0, inK = 0;
    for (int64_t step = m.oldestStep(); step < m.steps_ && k < 0; ++step) {
        m.forEachCellIn(step, step + 1, [&](int32_t* g, std::size_t base, uint32_t n) {
            if (k < 0 && pick < seen + n) {
                anchorI = base + (pick - seen);
                k = m.cell_z_[anchorI];
                cellI = g;
                baseI = base;
                nI = n;
                chooseSteps(step);
            }
            seen += n;
        });
    }
    if (k < 0) return false;
    side = k;
    if (s0 > m.oldestStep() || s1 < m.steps_)
        for (int t = s + 1; t < m.K_ && side == k; ++t)
            if (m.nk_[t] == 0) side = t;
    m.forEachCellIn(s0, s1, [&](const int32_t* g, std::size_t, uint32_t) { inK += static_cast<uint64_t>(g[k]); });
    if (inK < 2) return false;
    const uint64_t pickJ = static_cast<uint64_t>(m.rng_.uniformDouble() * static_cast<double>(inK - 1));
    seen = 0;
    m.forEachCellIn(s0, s1, [&](int32_t* g, std::size_t base, uint32_t n) {
        for (uint32_t i = 0; i < n; ++i) {
            const std::size_t at = base + i;
            if (m.cell_z_[at] != k || at == anchorI) continue;
            if (seen++ == pickJ) {
                anchorJ = at;
                cellJ = g;
                baseJ = base;
                nJ = n;
            }
            m.moveToken(g, at, k, -1);  // out of k: limbo
        }
    });
    m.moveToken(cellJ, anchorJ, -1, s);
    if (side != k) m.moveToken(cellI, anchorI, k, side);
    place(cellJ, baseJ, nJ, s);
    place(cellI, baseI, nI, side);
    cellsOn[cellJ[s] > cellJ[side]] += 1.0;
    if (cellI != cellJ) cellsOn[cellI[s] > cellI[side]] += 1.0;
    return true;
}

// Cells as blocks first (a cell's tokens keep together under alpha, so
// single tokens could not carry a cell over): every cell in window order
// (sequential allocation), then Gibbs scans of the cells; then restricted
// Gibbs scans of single tokens.
void ModelCore::Split::allocate() noexcept {
    m.forEachCellIn(s0, s1, [&](int32_t* g, std::size_t base, uint32_t n) {
        bool any = false;
        for (uint32_t i = 0; i < n && !any; ++i) any = m.cell_z_[base + i] == kLimbo;
        if (any) chooseCell(g, base, n);
    });
    for (int scan = 0; scan < kSplitScans; ++scan) {
        m.forEachCellIn(s0, s1, [&](int32_t* g, std::size_t base, uint32_t n) {
            if (g[side] == 0 && g[s] == 0) return;
            double& on = cellsOn[g[s] > g[side]];
            on = on > 0.0 ? on - 1.0 : 0.0;
            lift(g, base, n);
            chooseCell(g, base, n);
        });
    }
    for (int scan = 0; scan < kTokenScans; ++scan) {
        m.forEachCellIn(s0, s1, [&](int32_t* g, std::size_t base, uint32_t n) {
            for (uint32_t i = 0; i < n; ++i) {
                const std::size_t at = base + i;
                if (!member(at)) continue;
                m.moveToken(g, at, m.cell_z_[at], -1);
                m.moveToken(g, at, -1, draw(g, at));
            }
        });
    }
}

// Topic k's tokens (in the steps the budget allows) split into k and a new
// topic (Split), the proposal accepted with probability min(1, joint ratio),
// else the new topic folds back into k.
bool ModelCore::trySplit(double gamma, const Census& census, uint64_t budget) noexcept {
    Split split{*this, budget};
    if (!split.anchors()) return false;
    split.allocate();
    if (split.side != split.k) foldTopic(split.side, split.k);
    const uint64_t others = census.tables - census.tablesOf[split.k];
    const double logRatio = splitLogRatio(split.k, split.s, census.moreTopics[1], others, gamma);
    const double u = rng_.uniformDouble();
    if (u > 0.0 && std::log(u) < logRatio) return true;
    foldTopic(split.s, split.k);
    return false;
}

// Every count and label of topic `from` moves to topic `into`, which stays open.
void ModelCore::foldTopic(int from, int into) noexcept {
    for (int v = 0; v < V_; ++v) {
        int32_t* row = nkv_.data() + static_cast<std::size_t>(v) * Kp_;
        row[into] += row[from];
        row[from] = 0;
    }
    nk_[into] += nk_[from];
    nk_[from] = 0;
    forEachWindowCell([&](int32_t* g, std::size_t base, uint32_t n) {
        if (g[from] == 0) return;
        g[into] += g[from];
        g[from] = 0;
        for (uint32_t i = 0; i < n; ++i)
            if (cell_z_[base + i] == from) cell_z_[base + i] = static_cast<uint16_t>(into);
    });
}

// Two open topics drawn uniformly become one (the lower label) with
// probability min(1, joint ratio).
bool ModelCore::tryMerge(double gamma, const Census& census) noexcept {
    const int A = tables_.active;
    if (A < 2) return false;
    const auto first = static_cast<int>(rng_.below(static_cast<uint32_t>(A)));
    auto second = static_cast<int>(rng_.below(static_cast<uint32_t>(A - 1)));
    if (second >= first) ++second;
    int a = -1, b = -1;
    for (int k = 0, seen = 0; k < K_; ++k) {
        if (nk_[k] == 0) continue;
        if (seen == first) a = k;
        if (seen == second) b = k;
        ++seen;
    }
    if (a < 0 || b < 0) return false;  // tables_ not current: no move
    if (a > b) std::swap(a, b);
    const uint64_t others = census.tables - census.tablesOf[a] - census.tablesOf[b];
    const double logRatio = -splitLogRatio(a, b, census.moreTopics[0], others, gamma);
    const double u = rng_.uniformDouble();
    if (!(u > 0.0 && std::log(u) < logRatio)) return false;
    foldTopic(b, a);
    return true;
}

void ModelCore::growthMoves(uint64_t budget) noexcept {
    if (!cfg_.grow || cfg_.fixed || steps_ == 0 || tables_.active == 0) return;
    Census census;
    takeCensus(census);
    // The concentration from the data: Escobar and West's chain given the
    // open topics and the cells that use them, from the setting's gamma.
    double gamma = cfg_.gamma;
    for (int i = 0; i < kConcentrationSteps; ++i) gamma = concentration::resample(gamma, tables_.active, census.tables, rng_);
    gamma_learned_ = gamma;
    if (trySplit(gamma, census, budget)) {
        ++growth_moves_;
        kernel::updateTopics(tables_);
        takeCensus(census);
    }
    if (tryMerge(gamma, census)) ++growth_moves_;
    kernel::refreshReciprocals(tables_);
    kernel::updateTopics(tables_);
}

} // namespace rost
