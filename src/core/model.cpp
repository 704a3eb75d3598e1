#include "rost/model.hpp"

#include "kernel.hpp"
#include "measure.hpp"
#include "refine_windows.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <sstream>
#include <stdexcept>
#include <vector>

namespace rost {

namespace {

constexpr int kMaxKp = 1024;

} // namespace

const char* toString(AddError e) noexcept {
    switch (e) {
    case AddError::None: return "ok";
    case AddError::SizeMismatch: return "words and positions differ in length";
    case AddError::WordOutOfRange: return "word id out of range";
    case AddError::PositionOutOfRange: return "position outside the frame";
    }
    return "unknown";
}

double LogLoss::perplexity() const noexcept {
    if (words == 0) return std::numeric_limits<double>::quiet_NaN();
    return std::exp(nll / static_cast<double>(words));
}

std::unique_ptr<Model> Model::create(const Config& config, Status& status) {
    status = config.validate();
    if (!status.ok()) return nullptr;
    return std::make_unique<Model>(config);
}

Model::Model(const Config& config) : cfg_(config), rng_(config.seed) {
    const Status st = cfg_.validate();
    if (!st.ok()) throw std::invalid_argument(st.message());
    K_ = cfg_.K;
    Kp_ = kernel::paddedK(K_);
    V_ = cfg_.V;
    gw_ = cfg_.gridWidth();
    gh_ = cfg_.gridHeight();
    cells_ = gw_ * gh_;
    cap_ = cfg_.cell_capacity;
    maxw_ = cfg_.max_words_per_frame;
    ct_ = cfg_.cell_time;
    ring_ = cfg_.ring_steps;
    alpha_f_ = static_cast<float>(cfg_.alpha);
    beta_f_ = static_cast<float>(cfg_.beta);
    vbeta_f_ = static_cast<float>(static_cast<double>(V_) * cfg_.beta);

    allocateState();
    buildNeighbourhoods();
    selectKernels();
    tables_.nkv = nkv_.data();
    tables_.nk = nk_.data();
    tables_.inv = inv_.data();
    tables_.dec = inv_dec_.data();
    tables_.inc = inv_inc_.data();
    tables_.K = K_;
    tables_.grow = cfg_.grow;
    tables_.fresh = cfg_.grow ? static_cast<float>(cfg_.gamma / V_) : 0.f;
    tables_.Kp = Kp_;
    tables_.alpha = alpha_f_;
    tables_.beta = beta_f_;
    tables_.vbeta = vbeta_f_;
    kernel::refreshReciprocals(tables_);
    kernel::updateTopics(tables_);

    memory_bytes_ = nkv_.bytes() + nk_.bytes() + inv_.bytes() + inv_dec_.bytes() + inv_inc_.bytes() + slot_step_.bytes() + cell_n_.bytes() +
                    cell_words_.bytes() + cell_z_.bytes() + nck_.bytes() + cell_surprise_.bytes() +
                    in_word_.bytes() + in_pos_.bytes() + in_slot_.bytes() + in_n_.bytes() + obs_surprise_.bytes() +
                    nbr_begin_.bytes() + nbr_cell_.bytes() + cell_of_x_.bytes() + cell_of_y_.bytes() + scratch_cell_.bytes() + scratch_count_.bytes() +
                    scratch_need_.bytes() + scratch_g_.bytes() + scratch_ll_.bytes() + scratch_wn_.bytes() +
                    out_g_.bytes() + out_g_epoch_.bytes() +
                    sizeof(Model);
    allocateWindows();
    sizeMeasure();
}

void Model::allocateState() {
    const auto ring = static_cast<std::size_t>(ring_);
    const auto cells = static_cast<std::size_t>(cells_);
    const auto cap = static_cast<std::size_t>(cap_);
    const auto Kp = static_cast<std::size_t>(Kp_);
    const auto inputs = ring * static_cast<std::size_t>(ct_) * static_cast<std::size_t>(maxw_);

    // The ring's large tables are zeroed (their pages faulted in) together,
    // on `threads` threads, at the end.
    PageZeroer zeroer;
    nkv_.reset(static_cast<std::size_t>(V_) * Kp, zeroer);
    nk_.reset(Kp);
    inv_.reset(Kp);
    inv_dec_.reset(Kp);
    inv_inc_.reset(Kp);

    slot_step_.reset(ring);
    for (std::size_t s = 0; s < ring; ++s) slot_step_[s] = -1;
    cell_n_.reset(ring * cells);
    cell_words_.reset(ring * cells * cap, zeroer);
    cell_z_.reset(ring * cells * cap, zeroer);
    nck_.reset(ring * cells * Kp, zeroer);
    cell_surprise_.reset(ring * cells);
    in_word_.reset(inputs, zeroer);
    in_pos_.reset(inputs, zeroer);
    in_slot_.reset(inputs, zeroer);
    in_n_.reset(ring * static_cast<std::size_t>(ct_));
    obs_surprise_.reset(ring * static_cast<std::size_t>(ct_));

    scratch_cell_.reset(static_cast<std::size_t>(maxw_));
    cell_of_x_.reset(static_cast<std::size_t>(cfg_.frame_width));
    cell_of_y_.reset(static_cast<std::size_t>(cfg_.frame_height));
    for (int x = 0; x < cfg_.frame_width; ++x) cell_of_x_[static_cast<std::size_t>(x)] = static_cast<uint32_t>(x / cfg_.cell_space);
    for (int y = 0; y < cfg_.frame_height; ++y)
        cell_of_y_[static_cast<std::size_t>(y)] = static_cast<uint32_t>(y / cfg_.cell_space * gw_);
    scratch_count_.reset(cells);
    scratch_need_.reset(cells);
    scratch_g_.reset(Kp);
    scratch_ll_.reset(cells);
    scratch_wn_.reset(cells);
    out_g_.reset(cells * Kp);
    out_g_epoch_.reset(cells);
    zeroer.run(cfg_.threads);
}

void Model::buildNeighbourhoods() {
    const auto cells = static_cast<std::size_t>(cells_);
    // Spatial neighbourhood: the cell itself, then every cell within
    // Manhattan distance g.space (g.space = 1: the paper's 4 neighbours).
    std::vector<uint32_t> begin(cells + 1), list;
    const int r = cfg_.g_space;
    for (int cy = 0; cy < gh_; ++cy)
        for (int cx = 0; cx < gw_; ++cx) {
            begin[static_cast<std::size_t>(cy * gw_ + cx)] = static_cast<uint32_t>(list.size());
            list.push_back(static_cast<uint32_t>(cy * gw_ + cx));
            for (int dy = -r; dy <= r; ++dy)
                for (int dx = -r; dx <= r; ++dx) {
                    if ((dx == 0 && dy == 0) || std::abs(dx) + std::abs(dy) > r) continue;
                    const int x = cx + dx, y = cy + dy;
                    if (x < 0 || y < 0 || x >= gw_ || y >= gh_) continue;
                    list.push_back(static_cast<uint32_t>(y * gw_ + x));
                }
        }
    begin[cells] = static_cast<uint32_t>(list.size());
    nbr_begin_.reset(cells + 1);
    std::copy(begin.begin(), begin.end(), nbr_begin_.data());
    nbr_cell_.reset(list.size());
    std::copy(list.begin(), list.end(), nbr_cell_.data());
}

void Model::selectKernels() noexcept {
    // Compile-time K for the common sizes (unrolled blocks, registers);
    // growing topics take the runtime kernels that look at active topics only.
    if (cfg_.grow) {
        simd_kernel_ = &Model::refineCells<kernel::kGrow, kernel::Path::Simd>;
        scalar_kernel_ = &Model::refineCells<kernel::kGrow, kernel::Path::Scalar>;
        setTaskKernels<kernel::kGrow>();
        return;
    }
    switch (Kp_) {
    case 16:
        simd_kernel_ = &Model::refineCells<16, kernel::Path::Simd>;
        scalar_kernel_ = &Model::refineCells<16, kernel::Path::Scalar>;
        setTaskKernels<16>();
        break;
    case 32:
        simd_kernel_ = &Model::refineCells<32, kernel::Path::Simd>;
        scalar_kernel_ = &Model::refineCells<32, kernel::Path::Scalar>;
        setTaskKernels<32>();
        break;
    case 64:
        simd_kernel_ = &Model::refineCells<64, kernel::Path::Simd>;
        scalar_kernel_ = &Model::refineCells<64, kernel::Path::Scalar>;
        setTaskKernels<64>();
        break;
    default:
        simd_kernel_ = &Model::refineCells<0, kernel::Path::Simd>;
        scalar_kernel_ = &Model::refineCells<0, kernel::Path::Scalar>;
        setTaskKernels<0>();
        break;
    }
}

void Model::describeState(StateLayout& out) noexcept {
    // Section names and order are checkpoint format 1's; a change to what a
    // section holds bumps its version.
    out.add("counters.frames", 0, &frames_, 1);
    out.add("counters.steps", 0, &steps_, 1);
    out.add("counters.tokens_refined", 0, &tokens_refined_, 1);
    out.add("counters.words_in_model", 0, &words_in_model_, 1);
    out.add("counters.nkv_is_window", 0, &nkv_is_window_, 1);
    out.add("rng", 0, std::span<uint32_t>(rng_.stateWords()));
    auto buf = [&out](std::string_view name, auto& b) { out.add(name, 0, b.data(), b.size()); };
    buf("n_kv", nkv_);
    buf("n_k", nk_);
    buf("inv", inv_);
    buf("inv_dec", inv_dec_);
    buf("inv_inc", inv_inc_);
    buf("ring.slot_step", slot_step_);
    buf("ring.cell_n", cell_n_);
    buf("ring.cell_words", cell_words_);
    buf("ring.cell_z", cell_z_);
    buf("ring.n_ck", nck_);
    buf("ring.cell_surprise", cell_surprise_);
    buf("ring.in_word", in_word_);
    buf("ring.in_pos", in_pos_);
    buf("ring.in_slot", in_slot_);
    buf("ring.in_n", in_n_);
    buf("ring.obs_surprise", obs_surprise_);
}

void Model::evict(std::size_t slot) noexcept {
    if (cfg_.eviction == EvictionPolicy::Subtract) {
        for (int c = 0; c < cells_; ++c) {
            const std::size_t base = (slot * cells_ + static_cast<std::size_t>(c)) * cap_;
            const uint32_t n = cell_n_[slot * cells_ + c];
            for (uint32_t i = 0; i < n; ++i) {
                const uint32_t v = cell_words_[base + i];
                const int z = cell_z_[base + i];
                --nkv_[static_cast<std::size_t>(v) * Kp_ + z];
                --nk_[z];
            }
            words_in_model_ -= n;
        }
        kernel::refreshReciprocals(tables_);
        kernel::updateTopics(tables_);
    } else {
        nkv_is_window_ = false;
    }
    std::fill_n(cell_n_.data() + slot * cells_, cells_, 0u);
    std::fill_n(nck_.data() + slot * cells_ * Kp_, static_cast<std::size_t>(cells_) * Kp_, 0);
    std::fill_n(cell_surprise_.data() + slot * cells_, cells_, 0.f);
    slot_step_[slot] = -1;
}

void Model::neighbourhood(int64_t step, int cell, int32_t* out, bool pastOnly) const noexcept {
    std::fill_n(out, Kp_, 0);
    auto addCell = [&](int64_t s, uint32_t c) {
        const int32_t* h = nck(slotOf(s), static_cast<int>(c));
        for (int k = 0; k < Kp_; ++k) out[k] += h[k];
    };
    const uint32_t b = nbr_begin_[cell], e = nbr_begin_[cell + 1];
    if (pastOnly) {
        // Earlier steps only, with the spatial shape (a moving camera sees
        // this cell's content in a neighbouring cell of the previous frame).
        const int gt = std::max(cfg_.g_time, 1);
        for (int dt = 1; dt <= gt; ++dt)
            if (inWindow(step - dt))
                for (uint32_t j = b; j < e; ++j) addCell(step - dt, nbr_cell_[j]);
        return;
    }
    // G(c): the cell and its spatial neighbours, and the same cell at steps t +- 1..g.time.
    for (uint32_t j = b; j < e; ++j) addCell(step, nbr_cell_[j]);
    for (int dt = 1; dt <= cfg_.g_time; ++dt) {
        if (inWindow(step - dt)) addCell(step - dt, static_cast<uint32_t>(cell));
        if (inWindow(step + dt)) addCell(step + dt, static_cast<uint32_t>(cell));
    }
}

AddResult checkObservationSizes(std::size_t words, std::size_t positions) noexcept {
    AddResult res;
    if (words != positions) {
        res.error = AddError::SizeMismatch;
        res.index = static_cast<uint32_t>(std::min<std::size_t>(std::min(words, positions), UINT32_MAX));
    }
    return res;
}

AddResult Model::validateObservation(std::span<const uint32_t> words, std::span<const Position> positions) const noexcept {
    AddResult res = checkObservationSizes(words.size(), positions.size());
    if (!res.ok()) return res;
    const auto n = static_cast<uint32_t>(std::min<std::size_t>(words.size(), UINT32_MAX));
    for (uint32_t i = 0; i < n; ++i) {
        const Position p = positions[i];
        if (words[i] >= static_cast<uint32_t>(V_))
            res.error = AddError::WordOutOfRange;
        else if (p.x < 0 || p.y < 0 || p.x >= cfg_.frame_width || p.y >= cfg_.frame_height)
            res.error = AddError::PositionOutOfRange;
        else
            continue;
        res.index = i;
        return res;
    }
    return res;
}

AddResult Model::addObservation(std::span<const uint32_t> words, std::span<const Position> positions) noexcept {
    AddResult res = validateObservation(words, positions);
    if (!res.ok()) return res;
    const uint64_t frame = frames_;
    const int64_t step = stepOfObservation(frame);
    const auto sub = static_cast<std::size_t>(frame % static_cast<uint64_t>(ct_));
    const std::size_t slot = slotOf(step);
    if (sub == 0) openStep(step, slot);
    const std::size_t obs = slot * ct_ + sub;

    const uint32_t m = keepInputs(words, positions, obs);
    res.dropped_frame = static_cast<uint32_t>(std::min<std::size_t>(words.size(), UINT32_MAX)) - m;
    // firstNew[c]: the cell's words before this observation.
    uint32_t* firstNew = scratch_wn_.data();
    const uint32_t* cellN = cell_n_.data() + slot * cells_;
    std::copy_n(cellN, cells_, firstNew);
    fillCells(slot, obs, m, res);
    observeSurprise(step, slot, obs, firstNew);
    drawInitialLabels(slot, firstNew);
    words_in_model_ += res.kept;
    ++frames_;
    return res;
}

void Model::openStep(int64_t step, std::size_t slot) noexcept {
    if (slot_step_[slot] >= 0) evict(slot);
    slot_step_[slot] = step;
    steps_ = step + 1;
}

uint32_t Model::keepInputs(std::span<const uint32_t> words, std::span<const Position> positions, std::size_t obs) noexcept {
    // Frame-level uniform subsample (selection sampling keeps input order).
    const std::size_t ibase = obs * static_cast<std::size_t>(maxw_);
    const std::size_t n = std::min<std::size_t>(words.size(), UINT32_MAX);
    uint32_t j = 0;
    selectUniform(n, static_cast<std::size_t>(maxw_), rng_, [&](std::size_t i) {
        in_word_[ibase + j] = words[i];
        in_pos_[ibase + j] = static_cast<uint32_t>(positions[i].x) | (static_cast<uint32_t>(positions[i].y) << 16);
        ++j;
    });
    in_n_[obs] = j;
    return j;
}

void Model::fillCells(std::size_t slot, std::size_t obs, uint32_t m, AddResult& res) noexcept {
    const std::size_t ibase = obs * static_cast<std::size_t>(maxw_);
    // Cells of the kept inputs, and how many each cell can still take.
    uint32_t* cellOf = scratch_cell_.data();
    uint32_t* count = scratch_count_.data();
    uint32_t* needc = scratch_need_.data();
    std::fill_n(count, cells_, 0u);
    for (uint32_t i = 0; i < m; ++i) {
        const uint32_t packed = in_pos_[ibase + i];
        // Validated: x < frame.width, y < frame.height.
        cellOf[i] = cell_of_y_[packed >> 16] + cell_of_x_[packed & 0xFFFFu];
        ++count[cellOf[i]];
    }
    uint32_t* cellN = cell_n_.data() + slot * cells_;
    for (int c = 0; c < cells_; ++c) needc[c] = std::min<uint32_t>(count[c], static_cast<uint32_t>(cap_) - cellN[c]);
    // Cell-level uniform subsample, again by selection sampling.
    for (uint32_t i = 0; i < m; ++i) {
        const uint32_t c = cellOf[i];
        const bool keep = needc[c] > 0 && (needc[c] == count[c] || rng_.below(count[c]) < needc[c]);
        --count[c];
        if (keep) {
            --needc[c];
            const uint32_t s = cellN[c]++;
            cell_words_[(slot * cells_ + c) * cap_ + s] = in_word_[ibase + i];
            in_slot_[ibase + i] = c * static_cast<uint32_t>(cap_) + s;
            ++res.kept;
        } else {
            in_slot_[ibase + i] = kDropped | c;
            ++res.dropped_cell;
        }
    }
}

void Model::observeSurprise(int64_t step, std::size_t slot, std::size_t obs, const uint32_t* firstNew) noexcept {
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

double Model::cellSurpriseNll(int64_t step, std::size_t slot, int cell, uint32_t s0, double globalSum,
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

const int32_t* Model::surprisePrior(int64_t step, int cell, double globalSum, int32_t* g,
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

double Model::surpriseLogProb(uint32_t v, const int32_t* prior, double thetaNorm) const noexcept {
    const int32_t* row = nkv_.data() + static_cast<std::size_t>(v) * Kp_;
    double p = 0.0;
    for (int k = 0; k < K_; ++k)
        if (topicOpen(k)) p += (row[k] + cfg_.beta) / (nk_[k] + V_ * cfg_.beta) * (prior[k] + cfg_.alpha);
    p += freshMass() / V_;
    return std::log(p * thetaNorm);
}

void Model::drawInitialLabels(std::size_t slot, const uint32_t* firstNew) noexcept {
    // Initial labels z ~ Uniform(K) (paper Algorithm 2; with growth, uniform
    // over the active topics) and their counts.
    const uint32_t* cellN = cell_n_.data() + slot * cells_;
    // With growth: uniform over the open topics (the slot when none is open).
    uint16_t open[kMaxKp];
    uint32_t nopen = 0;
    for (int k = 0; k < K_; ++k)
        if (topicOpen(k)) open[nopen++] = static_cast<uint16_t>(k);
    if (nopen == 0) open[nopen++] = static_cast<uint16_t>(tables_.slot);
    for (int c = 0; c < cells_; ++c) {
        const std::size_t base = (slot * cells_ + static_cast<std::size_t>(c)) * cap_;
        int32_t* h = nck(slot, c);
        for (uint32_t s = firstNew[c]; s < cellN[c]; ++s) {
            const int z = open[rng_.below(nopen)];
            cell_z_[base + s] = static_cast<uint16_t>(z);
            ++nkv_[static_cast<std::size_t>(cell_words_[base + s]) * Kp_ + z];
            ++nk_[z];
            ++h[z];
        }
    }
    kernel::refreshReciprocals(tables_);
    kernel::updateTopics(tables_);
}

void Model::stepSlots(int64_t step, StepSlots& out) const noexcept {
    out.self = slotOf(step);
    out.count = 0;
    for (int dt = 1; dt <= cfg_.g_time; ++dt) {
        if (inWindow(step - dt)) out.temporal[out.count++] = slotOf(step - dt);
        if (inWindow(step + dt)) out.temporal[out.count++] = slotOf(step + dt);
    }
}

template <int KP, kernel::Path P>
uint32_t Model::refineCells(const StepSlots& slots, int c0, int c1) noexcept {
    const int Kp = KP > 0 ? KP : Kp_;
    const std::size_t slot = slots.self;
    int32_t* g = scratch_g_.data();
    uint32_t total = 0;
    for (int cell = c0; cell < c1; ++cell) {
        const uint32_t n = cell_n_[slot * cells_ + cell];
        if (n == 0) continue;
        // G(c): the cell, its spatial neighbours, the same cell at t +- 1..g.time
        // (with growth only the live blocks: a closed topic's counts are all 0).
        const int L = kernel::liveLanes<KP>(tables_, Kp);
        for (int k = L; k < Kp; ++k) g[k] = 0;
        const int32_t* h = nck(slot, nbr_cell_[nbr_begin_[cell]]);
        for (int k = 0; k < L; ++k) g[k] = h[k];
        for (uint32_t j = nbr_begin_[cell] + 1; j < nbr_begin_[cell + 1]; ++j) {
            h = nck(slot, static_cast<int>(nbr_cell_[j]));
            for (int k = 0; k < L; ++k) g[k] += h[k];
        }
        for (int j = 0; j < slots.count; ++j) {
            h = nck(slots.temporal[j], cell);
            for (int k = 0; k < L; ++k) g[k] += h[k];
        }
        const std::size_t base = (slot * cells_ + static_cast<std::size_t>(cell)) * cap_;
        kernel::refineCell<KP, P>(tables_, g, nck(slot, cell), cell_words_.data() + base, cell_z_.data() + base, n,
                                  rng_);
        total += n;
    }
    tokens_refined_ += total;
    return total;
}

uint32_t Model::refineCell(int64_t step, int cell) noexcept {
    if (!inWindow(step) || cell < 0 || cell >= cells_) return 0;
    StepSlots slots;
    stepSlots(step, slots);
    return (this->*(path_ == kernel::Path::Simd ? simd_kernel_ : scalar_kernel_))(slots, cell, cell + 1);
}

uint32_t Model::refineStep(int64_t step) noexcept {
    if (!inWindow(step)) return 0;
    StepSlots slots;
    stepSlots(step, slots);
    return (this->*(path_ == kernel::Path::Simd ? simd_kernel_ : scalar_kernel_))(slots, 0, cells_);
}

uint32_t Model::wordsInStep(int64_t step) const noexcept {
    if (!inWindow(step)) return 0;
    const std::size_t slot = slotOf(step);
    uint32_t total = 0;
    for (int c = 0; c < cells_; ++c) total += cell_n_[slot * cells_ + c];
    return total;
}

void Model::reciprocals(Reciprocals& r) const noexcept {
    const double vb = V_ * cfg_.beta;
    for (int k = 0; k < K_; ++k) {
        const bool open = topicOpen(k);
        r.inv[k] = open ? 1.0 / (nk_[k] + vb) : 0.0;
        // A word that is its topic's last leaves it closed (growth).
        r.invLeftOut[k] = open && !(cfg_.grow && nk_[k] == 1) ? 1.0 / (nk_[k] - 1 + vb) : 0.0;
    }
}

double Model::logProbLeftOut(uint32_t v, int z, const int32_t* nG, int32_t nGsum, const Reciprocals& r) const noexcept {
    const int32_t* row = nkv_.data() + static_cast<std::size_t>(v) * Kp_;
    double p = 0.0;
    // Open topics A (growth: a word that was its topic's last closes it, and
    // frees a slot for a new topic, whose words are uniform: beta / (V beta)).
    int A = tables_.active;
    double fresh = freshMass();
    if (cfg_.grow && z >= 0 && nk_[z] == 1) {
        --A;
        fresh = cfg_.gamma;
    }
    for (int k = 0; k < K_; ++k) p += (row[k] + cfg_.beta) * r.inv[k] * (nG[k] + cfg_.alpha);
    p += fresh / V_;
    if (z >= 0) {
        // Word i leaves its own topic: replace topic z's term.
        p -= (row[z] + cfg_.beta) * r.inv[z] * (nG[z] + cfg_.alpha);
        p += (row[z] - 1 + cfg_.beta) * r.invLeftOut[z] * (nG[z] - 1 + cfg_.alpha);
    }
    const double norm = (nGsum - (z >= 0 ? 1 : 0)) + A * cfg_.alpha + fresh;
    return std::log(p / norm);
}

int Model::mlTopic(uint32_t v, int z, const int32_t* nG, const Reciprocals& r) const noexcept {
    const int32_t* row = nkv_.data() + static_cast<std::size_t>(v) * Kp_;
    int best = 0;
    double bestP = -1.0;
    for (int k = 0; k < K_; ++k) {
        if (!topicOpen(k)) continue;
        const double p = k == z ? (row[k] - 1 + cfg_.beta) * r.invLeftOut[k] * (nG[k] - 1 + cfg_.alpha)
                                : (row[k] + cfg_.beta) * r.inv[k] * (nG[k] + cfg_.alpha);
        if (p > bestP) {
            bestP = p;
            best = k;
        }
    }
    return best;
}

const int32_t* Model::cachedNeighbourhood(int64_t step, int cell) const noexcept {
    int32_t* g = out_g_.data() + static_cast<std::size_t>(cell) * Kp_;
    if (out_g_epoch_[cell] != out_epoch_) {
        neighbourhood(step, cell, g, false);
        out_g_epoch_[cell] = out_epoch_;
    }
    return g;
}

LogLoss Model::cellLogLoss(int64_t step, int cell) const noexcept {
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

LogLoss Model::stepLogLoss(int64_t step) const noexcept {
    LogLoss out;
    if (!inWindow(step) || parallelStepLogLoss(step, out)) return out;
    return serialStepLogLoss(step);
}

LogLoss Model::serialStepLogLoss(int64_t step) const noexcept {
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

double Model::wordLogProb(int64_t step, int cell, uint32_t slot) const noexcept {
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

double Model::observationSurprise(uint64_t frame) const noexcept {
    if (!observationInWindow(frame)) return std::numeric_limits<double>::quiet_NaN();
    const std::size_t slot = slotOf(stepOfObservation(frame));
    return obs_surprise_[slot * ct_ + frame % static_cast<uint64_t>(ct_)];
}

std::span<const float> Model::cellSurprise(int64_t step) const noexcept {
    if (!inWindow(step)) return {};
    return {cell_surprise_.data() + slotOf(step) * cells_, static_cast<std::size_t>(cells_)};
}

uint32_t Model::observationSize(uint64_t frame) const noexcept {
    if (!observationInWindow(frame)) return 0;
    return in_n_[slotOf(stepOfObservation(frame)) * ct_ + frame % static_cast<uint64_t>(ct_)];
}

template <typename F>
void Model::forEachInput(uint64_t frame, F&& f) const noexcept {
    if (!observationInWindow(frame)) return;
    const std::size_t obs = slotOf(stepOfObservation(frame)) * ct_ + frame % static_cast<uint64_t>(ct_);
    const std::size_t base = obs * static_cast<std::size_t>(maxw_);
    for (uint32_t i = 0; i < in_n_[obs]; ++i) f(i, base + i);
}

void Model::observationWords(uint64_t frame, std::span<uint32_t> out) const noexcept {
    forEachInput(frame, [&](uint32_t i, std::size_t at) {
        if (i < out.size()) out[i] = in_word_[at];
    });
}

void Model::observationPositions(uint64_t frame, std::span<Position> out) const noexcept {
    forEachInput(frame, [&](uint32_t i, std::size_t at) {
        if (i < out.size()) out[i] = {static_cast<int32_t>(in_pos_[at] & 0xFFFFu), static_cast<int32_t>(in_pos_[at] >> 16)};
    });
}

void Model::observationLabels(uint64_t frame, std::span<uint16_t> out) const noexcept {
    if (parallelLabels(frame, out)) return;
    const int64_t step = stepOfObservation(frame);
    const std::size_t slot = slotOf(step);
    Reciprocals r;
    reciprocals(r);
    ++out_epoch_;
    forEachInput(frame, [&](uint32_t i, std::size_t at) {
        if (i >= out.size()) return;
        const uint32_t s = in_slot_[at];
        const bool dropped = (s & kDropped) != 0;
        const uint32_t cell = dropped ? (s & ~kDropped) : s / static_cast<uint32_t>(cap_);
        const int z = dropped ? -1 : cell_z_[slot * cells_ * cap_ + s];
        out[i] = static_cast<uint16_t>(mlTopic(in_word_[at], z, cachedNeighbourhood(step, static_cast<int>(cell)), r));
    });
    renumber(frame, out);
}

// Output numbering of labels (growth): open topics 0..A-1.
void Model::renumber(uint64_t frame, std::span<uint16_t> out) const noexcept {
    if (!cfg_.grow) return;
    uint16_t map[kMaxKp];
    outputNumbering({map, static_cast<std::size_t>(K_)});
    const std::size_t n = std::min<std::size_t>(out.size(), observationSize(frame));
    for (std::size_t i = 0; i < n; ++i) out[i] = map[out[i]];
}

void Model::observationSamples(uint64_t frame, std::span<uint16_t> out) const noexcept {
    const int64_t step = stepOfObservation(frame);
    const std::size_t slot = slotOf(step);
    Reciprocals r;
    reciprocals(r);
    ++out_epoch_;
    forEachInput(frame, [&](uint32_t i, std::size_t at) {
        if (i >= out.size()) return;
        const uint32_t s = in_slot_[at];
        if (s & kDropped) {
            const int cell = static_cast<int>(s & ~kDropped);
            out[i] = static_cast<uint16_t>(mlTopic(in_word_[at], -1, cachedNeighbourhood(step, cell), r));
        } else {
            out[i] = cell_z_[slot * cells_ * cap_ + s];
        }
    });
    renumber(frame, out);
}

std::span<const int32_t> Model::cellHistogram(int64_t step, int cell) const noexcept {
    if (!inWindow(step) || cell < 0 || cell >= cells_) return {};
    return {nck(slotOf(step), cell), static_cast<std::size_t>(K_)};
}

uint32_t Model::cellWordCount(int64_t step, int cell) const noexcept {
    if (!inWindow(step) || cell < 0 || cell >= cells_) return 0;
    return cell_n_[slotOf(step) * cells_ + cell];
}

Status Model::addTopicCounts(std::span<const int32_t> counts) {
    const std::size_t expect = static_cast<std::size_t>(K_) * static_cast<std::size_t>(V_);
    if (counts.size() != expect)
        return Status::error("topic model has " + std::to_string(counts.size()) + " counts, expected K x V = " +
                             std::to_string(expect));
    for (std::size_t i = 0; i < counts.size(); ++i)
        if (counts[i] < 0)
            return Status::error("topic model count at topic " + std::to_string(i / V_) + ", word " +
                                 std::to_string(i % V_) + " is negative");
    uint64_t added = 0;
    for (int k = 0; k < K_; ++k)
        for (int v = 0; v < V_; ++v) {
            const int32_t c = counts[static_cast<std::size_t>(k) * V_ + v];
            nkv_[static_cast<std::size_t>(v) * Kp_ + k] += c;
            nk_[k] += c;
            added += static_cast<uint64_t>(c);
        }
    kernel::refreshReciprocals(tables_);
    kernel::updateTopics(tables_);  // topics with counts are open
    words_in_model_ += added;
    if (added) nkv_is_window_ = false;
    return {};
}

void Model::outputNumbering(std::span<uint16_t> map) const noexcept {
    uint16_t next = 0;
    for (int k = 0; k < K_ && static_cast<std::size_t>(k) < map.size(); ++k)
        map[k] = topicOpen(k) ? next++ : uint16_t{0xFFFF};
}

void Model::stateRestored() noexcept {
    kernel::updateTopics(tables_);
}

bool Model::checkInvariants(std::string* why) const {
    std::ostringstream os;
    auto fail = [&](const std::string& msg) {
        if (why) *why = msg;
        return false;
    };
    std::vector<int64_t> nk(Kp_, 0);
    for (int v = 0; v < V_; ++v)
        for (int k = 0; k < Kp_; ++k) {
            const int32_t c = nkv_[static_cast<std::size_t>(v) * Kp_ + k];
            if (c < 0) return fail("n_k^v negative at word " + std::to_string(v) + ", topic " + std::to_string(k));
            if (k >= K_ && c != 0) return fail("padding count non-zero at word " + std::to_string(v));
            nk[k] += c;
        }
    if (!workerCopiesAgree(why)) return false;
    kernel::Tables topics = tables_;
    kernel::updateTopics(topics);
    if (topics.active != tables_.active || topics.hi != tables_.hi || topics.slot != tables_.slot)
        return fail("open topics stale: " + std::to_string(tables_.active) + " active, " +
                    std::to_string(topics.active) + " hold words");
    int64_t total = 0;
    for (int k = 0; k < Kp_; ++k) {
        if (nk[k] != nk_[k])
            return fail("n_k[" + std::to_string(k) + "] = " + std::to_string(nk_[k]) + " but sum_v n_k^v = " +
                        std::to_string(nk[k]));
        if (k < K_ && !topicOpen(k) && inv_[k] != 0.f)
            return fail("topic " + std::to_string(k) + " is closed but weighs");
        if (k < K_ && ((topicOpen(k) && inv_[k] != kernel::reciprocal(nk_[k], vbeta_f_)) ||
                       inv_dec_[k] != kernel::reciprocal(nk_[k] - 1, vbeta_f_) ||
                       inv_inc_[k] != kernel::reciprocal(nk_[k] + 1, vbeta_f_)))
            return fail("cached reciprocal stale for topic " + std::to_string(k));
        total += nk[k];
    }
    if (static_cast<uint64_t>(total) != words_in_model_)
        return fail("sum n_k^v = " + std::to_string(total) + " but words in model = " +
                    std::to_string(words_in_model_));
    std::vector<int32_t> hist;
    if (nkv_is_window_) hist.assign(static_cast<std::size_t>(V_) * Kp_, 0);
    for (int64_t t = oldestStep(); t < steps_; ++t) {
        const std::size_t slot = slotOf(t);
        if (slot_step_[slot] != t) return fail("ring slot " + std::to_string(slot) + " does not hold step " + std::to_string(t));
        for (int c = 0; c < cells_; ++c) {
            std::vector<int32_t> h(Kp_, 0);
            const std::size_t base = (slot * cells_ + static_cast<std::size_t>(c)) * cap_;
            const uint32_t n = cell_n_[slot * cells_ + c];
            if (n > static_cast<uint32_t>(cap_)) return fail("cell over capacity");
            for (uint32_t i = 0; i < n; ++i) {
                const int z = cell_z_[base + i];
                if (z >= K_) return fail("label out of range in step " + std::to_string(t));
                ++h[z];
                if (nkv_is_window_) ++hist[static_cast<std::size_t>(cell_words_[base + i]) * Kp_ + z];
            }
            const int32_t* stored = nck(slot, c);
            for (int k = 0; k < Kp_; ++k)
                if (stored[k] != h[k])
                    return fail("n_c^k mismatch at step " + std::to_string(t) + ", cell " + std::to_string(c) +
                                ", topic " + std::to_string(k));
        }
    }
    if (nkv_is_window_)
        for (std::size_t i = 0; i < hist.size(); ++i)
            if (hist[i] != nkv_[i])
                return fail("n_k^v mismatch at word " + std::to_string(i / Kp_) + ", topic " + std::to_string(i % Kp_));
    return true;
}

} // namespace rost
