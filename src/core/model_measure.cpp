// The model's measurements and outputs (rost/model.hpp: perplexity,
// curiosity, outputs): the left-out predictive probability of a word, the
// surprise of a new observation, maximum-likelihood labels, an
// observation's words, positions and samples. On the workers: measure.cpp;
// the plug-in perplexity: plugin_perplexity.cpp.


#include "model_core.hpp"

#include "kernel.hpp"
#include "measure.hpp"

#include <algorithm>
#include <cmath>

namespace rost {

void ModelCore::observeSurprise(int64_t step, std::size_t slot, std::size_t obs, const uint32_t* firstNew) noexcept {
    // Surprise, before the new words touch any count.
    double globalSum = 0.0;
    for (int k = 0; k < K_; ++k) globalSum += nk_[k];
    const double* terms = surpriseTermsOnPool(step, slot, firstNew, globalSum);
    double frameNll = 0.0;
    uint64_t frameWords = 0;
    float* cs = cell_surprise_.data() + slot * cells_;
    const uint32_t* cellN = cell_n_.data() + slot * cells_;
    for (int c = 0; c < cells_; ++c) {
        const uint32_t s0 = firstNew[c], s1 = cellN[c];
        if (s1 == s0) continue;
        const double nll = cellSurpriseNll(step, slot, c, s0, globalSum, terms);
        cs[c] = static_cast<float>(std::exp(nll / (s1 - s0)));
        frameNll += nll;
        frameWords += s1 - s0;
    }
    if (terms) releaseMeasure();
    obs_surprise_[obs] = frameWords ? static_cast<float>(std::exp(frameNll / static_cast<double>(frameWords))) : 0.f;
}

double ModelCore::cellSurpriseNll(int64_t step, std::size_t slot, int cell, uint32_t s0, double globalSum,
                              const double* terms) const noexcept {
    const std::size_t at = (slot * cells_ + static_cast<std::size_t>(cell)) * cap_;
    const uint32_t s1 = cell_n_[slot * cells_ + cell];
    double nll = 0.0;
    if (terms) {
        for (uint32_t s = s0; s < s1; ++s) nll -= terms[static_cast<std::size_t>(cell) * cap_ + s];
        return nll;
    }
    alignas(64) int32_t g[kMaxKp];
    double thetaNorm = 0.0;
    const int32_t* prior = surprisePrior(step, cell, globalSum, g, thetaNorm);
    for (uint32_t s = s0; s < s1; ++s) nll -= surpriseLogProb(cell_words_[at + s], prior, thetaNorm);
    return nll;
}

const int32_t* ModelCore::surprisePrior(int64_t step, int cell, double globalSum, int32_t* g,
                                    double& thetaNorm) const noexcept {
    neighbourhood(step, cell, g, true);
    double gsum = 0.0;
    for (int k = 0; k < K_; ++k) gsum += g[k];
    const int32_t* prior = g;
    if (gsum == 0.0) {
        prior = nk_.data();
        gsum = globalSum;
    }
    thetaNorm = 1.0 / (gsum + tables_.active * cfg_.alpha + freshMass());
    return prior;
}

double ModelCore::surpriseLogProb(uint32_t v, const int32_t* prior, double thetaNorm) const noexcept {
    const int32_t* row = nkv_.data() + static_cast<std::size_t>(v) * Kp_;
    double p = 0.0;
    for (int k = 0; k < K_; ++k)
        if (topicOpen(k)) p += (row[k] + cfg_.beta) / (nk_[k] + V_ * cfg_.beta) * (prior[k] + cfg_.alpha);
    p += freshMass() / V_;
    return std::log(p * thetaNorm);
}

void ModelCore::reciprocals(Reciprocals& r) const noexcept {
    const double vb = V_ * cfg_.beta;
    for (int k = 0; k < K_; ++k) {
        const bool open = topicOpen(k);
        r.inv[k] = open ? 1.0 / (nk_[k] + vb) : 0.0;
        // A word that is its topic's last leaves it closed (growth).
        // A fixed topic model holds none of the window's words: nothing to leave out of n_k.
        r.invLeftOut[k] = cfg_.fixed ? r.inv[k] : open && !(cfg_.grow && nk_[k] == 1) ? 1.0 / (nk_[k] - 1 + vb) : 0.0;
    }
}

double ModelCore::logProbLeftOut(uint32_t v, int z, const int32_t* nG, int32_t nGsum, const Reciprocals& r) const noexcept {
    const int32_t* row = nkv_.data() + static_cast<std::size_t>(v) * Kp_;
    double p = 0.0;
    // Open topics A (growth: a word that was its topic's last closes it, and
    // frees a slot for a new topic, whose words are uniform: beta / (V beta)).
    int A = tables_.active;
    double fresh = freshMass();
    if (cfg_.grow && z >= 0 && nk_[z] == 1) {
        --A;
        fresh = kFreshMass;
    }
    for (int k = 0; k < K_; ++k) p += (row[k] + cfg_.beta) * r.inv[k] * (nG[k] + cfg_.alpha);
    p += fresh / V_;
    if (z >= 0) {
        // Word i leaves its own topic: replace topic z's term.
        p -= (row[z] + cfg_.beta) * r.inv[z] * (nG[z] + cfg_.alpha);
        p += (row[z] - ownCount() + cfg_.beta) * r.invLeftOut[z] * (nG[z] - 1 + cfg_.alpha);
    }
    const double norm = (nGsum - (z >= 0 ? 1 : 0)) + A * cfg_.alpha + fresh;
    return std::log(p / norm);
}

int ModelCore::mlTopic(uint32_t v, int z, const int32_t* nG, const Reciprocals& r) const noexcept {
    const int32_t* row = nkv_.data() + static_cast<std::size_t>(v) * Kp_;
    int best = 0;
    double bestP = -1.0;
    for (int k = 0; k < K_; ++k) {
        if (!topicOpen(k)) continue;
        const double p = k == z ? (row[k] - ownCount() + cfg_.beta) * r.invLeftOut[k] * (nG[k] - 1 + cfg_.alpha)
                                : (row[k] + cfg_.beta) * r.inv[k] * (nG[k] + cfg_.alpha);
        if (p > bestP) {
            bestP = p;
            best = k;
        }
    }
    return best;
}

// The neighbourhood sums of `cell` at `step`: from the output cache when this
// call holds it (`own`: epoch bumped by the caller), else computed into `local`.
const int32_t* ModelCore::cachedNeighbourhood(int64_t step, int cell, bool own, int32_t* local) const noexcept {
    if (!own) {
        neighbourhood(step, cell, local, false);
        return local;
    }
    int32_t* g = out_g_.data() + static_cast<std::size_t>(cell) * Kp_;
    if (out_g_epoch_[cell] != out_epoch_) {
        neighbourhood(step, cell, g, false);
        out_g_epoch_[cell] = out_epoch_;
    }
    return g;
}

LogLoss ModelCore::cellLogLoss(int64_t step, int cell) const noexcept {
    LogLoss out;
    if (!inWindow(step) || cell < 0 || cell >= cells_) return out;
    const std::size_t slot = slotOf(step);
    const uint32_t n = cell_n_[slot * cells_ + cell];
    if (n == 0) return out;
    alignas(64) int32_t g[kMaxKp];
    neighbourhood(step, cell, g, false);
    int32_t gsum = 0;
    for (int k = 0; k < K_; ++k) gsum += g[k];
    const std::size_t base = (slot * cells_ + static_cast<std::size_t>(cell)) * cap_;
    Reciprocals r;
    reciprocals(r);
    for (uint32_t i = 0; i < n; ++i) out.nll -= logProbLeftOut(cell_words_[base + i], cell_z_[base + i], g, gsum, r);
    out.words = n;
    return out;
}

LogLoss ModelCore::stepLogLoss(int64_t step) const noexcept {
    LogLoss out;
    if (!inWindow(step) || parallelStepLogLoss(step, out)) return out;
    return serialStepLogLoss(step);
}

LogLoss ModelCore::serialStepLogLoss(int64_t step) const noexcept {
    LogLoss out;
    if (!inWindow(step)) return out;
    const std::size_t slot = slotOf(step);
    Reciprocals r;
    reciprocals(r);
    alignas(64) int32_t g[kMaxKp];
    for (int c = 0; c < cells_; ++c) {
        const uint32_t n = cell_n_[slot * cells_ + c];
        if (n == 0) continue;
        neighbourhood(step, c, g, false);
        int32_t gsum = 0;
        for (int k = 0; k < K_; ++k) gsum += g[k];
        const std::size_t base = (slot * cells_ + static_cast<std::size_t>(c)) * cap_;
        for (uint32_t i = 0; i < n; ++i) out.nll -= logProbLeftOut(cell_words_[base + i], cell_z_[base + i], g, gsum, r);
        out.words += n;
    }
    return out;
}

double ModelCore::wordLogProb(int64_t step, int cell, uint32_t slot) const noexcept {
    if (!inWindow(step) || cell < 0 || cell >= cells_) return std::numeric_limits<double>::quiet_NaN();
    const std::size_t s = slotOf(step);
    if (slot >= cell_n_[s * cells_ + cell]) return std::numeric_limits<double>::quiet_NaN();
    alignas(64) int32_t g[kMaxKp];
    neighbourhood(step, cell, g, false);
    int32_t gsum = 0;
    for (int k = 0; k < K_; ++k) gsum += g[k];
    const std::size_t base = (s * cells_ + static_cast<std::size_t>(cell)) * cap_;
    Reciprocals r;
    reciprocals(r);
    return logProbLeftOut(cell_words_[base + slot], cell_z_[base + slot], g, gsum, r);
}

double ModelCore::observationSurprise(uint64_t frame) const noexcept {
    if (!observationInWindow(frame)) return std::numeric_limits<double>::quiet_NaN();
    const std::size_t slot = slotOf(stepOfObservation(frame));
    return obs_surprise_[slot * ct_ + frame % static_cast<uint64_t>(ct_)];
}

std::span<const float> ModelCore::cellSurprise(int64_t step) const noexcept {
    if (!inWindow(step)) return {};
    return {cell_surprise_.data() + slotOf(step) * cells_, static_cast<std::size_t>(cells_)};
}

uint32_t ModelCore::observationSize(uint64_t frame) const noexcept {
    if (!observationInWindow(frame)) return 0;
    return in_n_[slotOf(stepOfObservation(frame)) * ct_ + frame % static_cast<uint64_t>(ct_)];
}

template <typename F>
void ModelCore::forEachInput(uint64_t frame, F&& f) const noexcept {
    if (!observationInWindow(frame)) return;
    const std::size_t obs = slotOf(stepOfObservation(frame)) * ct_ + frame % static_cast<uint64_t>(ct_);
    const std::size_t base = obs * static_cast<std::size_t>(maxw_);
    for (uint32_t i = 0; i < in_n_[obs]; ++i) f(i, base + i);
}

void ModelCore::observationWords(uint64_t frame, std::span<uint32_t> out) const noexcept {
    forEachInput(frame, [&](uint32_t i, std::size_t at) {
        if (i < out.size()) out[i] = in_word_[at];
    });
}

void ModelCore::observationPositions(uint64_t frame, std::span<Position> out) const noexcept {
    forEachInput(frame, [&](uint32_t i, std::size_t at) {
        if (i < out.size()) out[i] = {static_cast<int32_t>(in_pos_[at] & 0xFFFFu), static_cast<int32_t>(in_pos_[at] >> 16)};
    });
}

void ModelCore::observationLabels(uint64_t frame, std::span<uint16_t> out) const noexcept {
    if (parallelLabels(frame, out)) return;
    const int64_t step = stepOfObservation(frame);
    const std::size_t slot = slotOf(step);
    Reciprocals r;
    reciprocals(r);
    const bool own = !out_cache_busy_.exchange(true, std::memory_order_acquire);
    if (own) ++out_epoch_;
    alignas(64) int32_t local[kMaxKp];
    forEachInput(frame, [&](uint32_t i, std::size_t at) {
        if (i >= out.size()) return;
        const uint32_t s = in_slot_[at];
        const bool dropped = (s & kDropped) != 0;
        const uint32_t cell = dropped ? (s & ~kDropped) : s / static_cast<uint32_t>(cap_);
        const int z = dropped ? -1 : cell_z_[slot * cells_ * cap_ + s];
        out[i] = static_cast<uint16_t>(
            mlTopic(in_word_[at], z, cachedNeighbourhood(step, static_cast<int>(cell), own, local), r));
    });
    if (own) out_cache_busy_.store(false, std::memory_order_release);
    renumber(frame, out);
}

// Output numbering of labels (growth): open topics 0..A-1.
void ModelCore::renumber(uint64_t frame, std::span<uint16_t> out) const noexcept {
    if (!cfg_.grow) return;
    uint16_t map[kMaxKp];
    outputNumbering({map, static_cast<std::size_t>(K_)});
    const std::size_t n = std::min<std::size_t>(out.size(), observationSize(frame));
    for (std::size_t i = 0; i < n; ++i) out[i] = map[out[i]];
}

void ModelCore::observationSamples(uint64_t frame, std::span<uint16_t> out) const noexcept {
    const int64_t step = stepOfObservation(frame);
    const std::size_t slot = slotOf(step);
    Reciprocals r;
    reciprocals(r);
    const bool own = !out_cache_busy_.exchange(true, std::memory_order_acquire);
    if (own) ++out_epoch_;
    alignas(64) int32_t local[kMaxKp];
    forEachInput(frame, [&](uint32_t i, std::size_t at) {
        if (i >= out.size()) return;
        const uint32_t s = in_slot_[at];
        if (s & kDropped) {
            const int cell = static_cast<int>(s & ~kDropped);
            out[i] = static_cast<uint16_t>(mlTopic(in_word_[at], -1, cachedNeighbourhood(step, cell, own, local), r));
        } else {
            out[i] = cell_z_[slot * cells_ * cap_ + s];
        }
    });
    if (own) out_cache_busy_.store(false, std::memory_order_release);
    renumber(frame, out);
}

std::span<const int32_t> ModelCore::cellHistogram(int64_t step, int cell) const noexcept {
    if (!inWindow(step) || cell < 0 || cell >= cells_) return {};
    return {nck(slotOf(step), cell), static_cast<std::size_t>(K_)};
}

uint32_t ModelCore::cellWordCount(int64_t step, int cell) const noexcept {
    if (!inWindow(step) || cell < 0 || cell >= cells_) return 0;
    return cell_n_[slotOf(step) * cells_ + cell];
}

} // namespace rost
