// The plug-in perplexity: the definition the public ROST code of the paper
// used (ROST::estimate(cell, update_ppx = true) in yogeshgirdhar/rost-ros,
// rost_topics/include/rost.hpp), computed beside the library's left-out one
// (ModelCore::cellLogLoss). For word i of cell c:
//
//   p(w_i) = sum_k (n_k^w + beta) / (n_k + V beta) * (n_c^k + alpha) / (n_c + K alpha)
//
// with every count as it stands (word i still in n_k^w, n_k and n_c^k) and
// the topic mix of the cell alone. A step's perplexity is exp of the mean
// -log p(w) over the words of all its cells (the code's per-time-step sum of
// cell log likelihoods over the step's word count).

#include <cmath>

#include "model_core.hpp"

namespace rost {

namespace {
constexpr int kMaxK = 1024;
} // namespace

LogLoss ModelCore::cellPluginLogLoss(int64_t step, int cell) const noexcept {
    LogLoss out;
    if (!inWindow(step) || cell < 0 || cell >= cells_) return out;
    const std::size_t slot = slotOf(step);
    const uint32_t n = cell_n_[slot * cells_ + cell];
    if (n == 0) return out;
    double weight[kMaxK];
    const double freshP = pluginWeights(slot, cell, n, weight);
    const uint32_t* words = cell_words_.data() + (slot * cells_ + static_cast<std::size_t>(cell)) * cap_;
    for (uint32_t i = 0; i < n; ++i) out.nll -= pluginLogProb(words[i], weight, freshP);
    out.words = n;
    return out;
}

// weight[k] = theta_c(k) / (n_k + V beta): one multiply-add per topic and word.
double ModelCore::pluginWeights(std::size_t slot, int cell, uint32_t n, double* weight) const noexcept {
    const int32_t* h = nck(slot, cell);
    const double vbeta = V_ * cfg_.beta;
    const int A = tables_.active;
    const double fresh = freshMass();
    const double thetaNorm = 1.0 / (static_cast<double>(n) + A * cfg_.alpha + fresh);
    for (int k = 0; k < K_; ++k) weight[k] = topicOpen(k) ? (h[k] + cfg_.alpha) * thetaNorm / (nk_[k] + vbeta) : 0.0;
    return fresh * thetaNorm / V_;  // a new topic, its words uniform
}

double ModelCore::pluginLogProb(uint32_t v, const double* weight, double freshP) const noexcept {
    const int32_t* row = nkv_.data() + static_cast<std::size_t>(v) * Kp_;
    double p = 0.0;
    for (int k = 0; k < K_; ++k) p += (row[k] + cfg_.beta) * weight[k];
    p += freshP;
    return std::log(p);
}

LogLoss ModelCore::stepPluginLogLoss(int64_t step) const noexcept {
    LogLoss out;
    if (!inWindow(step) || parallelStepPluginLogLoss(step, out)) return out;
    for (int c = 0; c < cells_; ++c) out += cellPluginLogLoss(step, c);
    return out;
}

} // namespace rost
