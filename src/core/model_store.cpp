// The model's ring store (rost/model.hpp, src/core/model_core.hpp): the
// tables and the ring of temporal cells, their construction, ingest of an
// observation, eviction, the state sections a checkpoint holds, the checks
// of state restored from an untrusted checkpoint, and the invariants that
// tie the counts to the labels.


#include "model_core.hpp"

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

ModelCore::ModelCore(const Config& config) : cfg_(config), rng_(config.seed) {
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
    nkv_is_window_ = !cfg_.fixed;

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
    tables_.fresh = cfg_.grow ? static_cast<float>(kFreshMass / V_) : 0.f;
    tables_.Kp = Kp_;
    tables_.alpha = alpha_f_;
    tables_.beta = beta_f_;
    tables_.vbeta = vbeta_f_;
    kernel::refreshReciprocals(tables_);
    kernel::updateTopics(tables_);

    memory_bytes_ = nkv_.bytes() + nk_.bytes() + inv_.bytes() + inv_dec_.bytes() + inv_inc_.bytes() + slot_step_.bytes() + cell_n_.bytes() +
                    cell_words_.bytes() + cell_z_.bytes() + nck_.bytes() + cell_surprise_.bytes() +
                    in_word_.bytes() + in_pos_.bytes() + in_slot_.bytes() + in_n_.bytes() + obs_surprise_.bytes() +
                    nbr_begin_.bytes() + nbr_cell_.bytes() + cell_of_x_.bytes() + cell_of_y_.bytes() + scratch_cell_.bytes() + scratch_z_.bytes() + scratch_count_.bytes() +
                    scratch_need_.bytes() + scratch_g_.bytes() + scratch_ll_.bytes() + scratch_wn_.bytes() +
                    out_g_.bytes() + out_g_epoch_.bytes() +
                    sizeof(ModelCore);
    allocateWindows();
    sizeMeasure();
}

void ModelCore::allocateState() {
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
    scratch_z_.reset(static_cast<std::size_t>(maxw_));
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

void ModelCore::buildNeighbourhoods() {
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

void ModelCore::describeState(StateLayout& out) noexcept {
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

void ModelCore::evict(std::size_t slot) noexcept {
    if (cfg_.eviction == EvictionPolicy::Subtract && !cfg_.fixed) {
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
    for (int c = 0; c < cells_; ++c) window_words_ -= cell_n_[slot * cells_ + c];
    std::fill_n(cell_n_.data() + slot * cells_, cells_, 0u);
    std::fill_n(nck_.data() + slot * cells_ * Kp_, static_cast<std::size_t>(cells_) * Kp_, 0);
    std::fill_n(cell_surprise_.data() + slot * cells_, cells_, 0.f);
    slot_step_[slot] = -1;
}

void ModelCore::neighbourhood(int64_t step, int cell, int32_t* out, bool pastOnly) const noexcept {
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

AddResult ModelCore::validateObservation(std::span<const uint32_t> words, std::span<const Position> positions) const noexcept {
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

AddResult ModelCore::addObservation(std::span<const uint32_t> words, std::span<const Position> positions,
                                     std::span<const uint16_t> labels) noexcept {
    AddResult res = validateObservation(words, positions);
    if (!res.ok()) return res;
    const bool labelled = !labels.empty();
    if (labelled) {
        res = checkObservationSizes(words.size(), labels.size());
        if (!res.ok()) return res;
        for (std::size_t i = 0; i < labels.size() && i < UINT32_MAX; ++i)
            if (labels[i] >= K_) {
                res.error = AddError::LabelOutOfRange;
                res.index = static_cast<uint32_t>(i);
                return res;
            }
    }
    const uint64_t frame = frames_;
    const int64_t step = stepOfObservation(frame);
    const auto sub = static_cast<std::size_t>(frame % static_cast<uint64_t>(ct_));
    const std::size_t slot = slotOf(step);
    if (sub == 0) openStep(step, slot);
    const std::size_t obs = slot * ct_ + sub;

    const uint32_t m = keepInputs(words, positions, labels, obs);
    res.dropped_frame = static_cast<uint32_t>(std::min<std::size_t>(words.size(), UINT32_MAX)) - m;
    // firstNew[c]: the cell's words before this observation.
    uint32_t* firstNew = scratch_wn_.data();
    const uint32_t* cellN = cell_n_.data() + slot * cells_;
    std::copy_n(cellN, cells_, firstNew);
    fillCells(slot, obs, m, labelled, res);
    observeSurprise(step, slot, obs, firstNew);
    drawInitialLabels(slot, firstNew, labelled);
    if (!cfg_.fixed) words_in_model_ += res.kept;
    window_words_ += res.kept;
    ++frames_;
    return res;
}

void ModelCore::openStep(int64_t step, std::size_t slot) noexcept {
    if (slot_step_[slot] >= 0) evict(slot);
    slot_step_[slot] = step;
    steps_ = step + 1;
}

uint32_t ModelCore::keepInputs(std::span<const uint32_t> words, std::span<const Position> positions,
                               std::span<const uint16_t> labels, std::size_t obs) noexcept {
    // Frame-level uniform subsample (selection sampling keeps input order).
    const std::size_t ibase = obs * static_cast<std::size_t>(maxw_);
    const std::size_t n = std::min<std::size_t>(words.size(), UINT32_MAX);
    uint32_t j = 0;
    selectUniform(n, static_cast<std::size_t>(maxw_), rng_, [&](std::size_t i) {
        in_word_[ibase + j] = words[i];
        in_pos_[ibase + j] = static_cast<uint32_t>(positions[i].x) | (static_cast<uint32_t>(positions[i].y) << 16);
        if (!labels.empty()) scratch_z_[j] = labels[i];
        ++j;
    });
    in_n_[obs] = j;
    return j;
}

void ModelCore::fillCells(std::size_t slot, std::size_t obs, uint32_t m, bool labelled, AddResult& res) noexcept {
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
            if (labelled) cell_z_[(slot * cells_ + c) * cap_ + s] = scratch_z_[i];  // counted by drawInitialLabels
            in_slot_[ibase + i] = c * static_cast<uint32_t>(cap_) + s;
            ++res.kept;
        } else {
            in_slot_[ibase + i] = kDropped | c;
            ++res.dropped_cell;
        }
    }
}

void ModelCore::drawInitialLabels(std::size_t slot, const uint32_t* firstNew, bool labelled) noexcept {
    // Initial labels z ~ Uniform(K) (paper Algorithm 2; with growth, uniform
    // over the active topics), or the given ones (`labelled`: already in
    // cell_z_), and their counts.
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
            const int z = labelled ? cell_z_[base + s] : open[rng_.below(nopen)];
            cell_z_[base + s] = static_cast<uint16_t>(z);
            ++h[z];
            if (cfg_.fixed) continue;  // the topic model stays as given
            ++nkv_[static_cast<std::size_t>(cell_words_[base + s]) * Kp_ + z];
            ++nk_[z];
        }
    }
    if (cfg_.fixed) return;
    kernel::refreshReciprocals(tables_);
    kernel::updateTopics(tables_);
}

Status ModelCore::addTopicCounts(std::span<const int32_t> counts) {
    const std::size_t expect = static_cast<std::size_t>(K_) * static_cast<std::size_t>(V_);
    if (counts.size() != expect)
        return Status::error("topic model has " + std::to_string(counts.size()) + " counts, expected K x V = " +
                             std::to_string(expect));
    for (std::size_t i = 0; i < counts.size(); ++i)
        if (counts[i] < 0)
            return Status::error("topic model count at topic " + std::to_string(i / V_) + ", word " +
                                 std::to_string(i % V_) + " is negative");
    // n_k is 32-bit: a topic's total with the model's own counts (an earlier
    // prior, a ROS client's second model) must leave room for every word the
    // window can hold, and one more (the kernel's cached 1 / (n_k + 1 + V beta)).
    const int64_t room = static_cast<int64_t>(cfg_.ring_steps) * cells_ * cap_ + 1;
    const int64_t most = std::numeric_limits<int32_t>::max() - room;
    for (int k = 0; k < K_; ++k) {
        int64_t total = nk_[k];
        for (int v = 0; v < V_; ++v) total += counts[static_cast<std::size_t>(k) * V_ + v];
        if (total > most)
            return Status::error("topic " + std::to_string(k) + " would hold " + std::to_string(total) +
                                 " words with the model's own counts, more than the " + std::to_string(most) +
                                 " that leave room for the window's " + std::to_string(room - 1) + " (n_k is 32-bit)");
    }
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

void ModelCore::outputNumbering(std::span<uint16_t> map) const noexcept {
    uint16_t next = 0;
    for (int k = 0; k < K_ && static_cast<std::size_t>(k) < map.size(); ++k)
        map[k] = topicOpen(k) ? next++ : uint16_t{0xFFFF};
}

void ModelCore::stateRestored() noexcept {
    kernel::updateTopics(tables_);
    window_words_ = 0;
    for (int64_t t = oldestStep(); t < steps_; ++t)
        for (int c = 0; c < cells_; ++c) window_words_ += cell_n_[slotOf(t) * cells_ + c];
}

bool ModelCore::checkInvariants(std::string* why) const {
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
    uint64_t windowWords = 0;
    for (int64_t t = oldestStep(); t < steps_; ++t) {
        const std::size_t slot = slotOf(t);
        if (slot_step_[slot] != t) return fail("ring slot " + std::to_string(slot) + " does not hold step " + std::to_string(t));
        for (int c = 0; c < cells_; ++c) {
            std::vector<int32_t> h(Kp_, 0);
            const std::size_t base = (slot * cells_ + static_cast<std::size_t>(c)) * cap_;
            const uint32_t n = cell_n_[slot * cells_ + c];
            if (n > static_cast<uint32_t>(cap_)) return fail("cell over capacity");
            windowWords += n;
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
    if (windowWords != window_words_)
        return fail("words in the window's cells = " + std::to_string(windowWords) + " but counted " +
                    std::to_string(window_words_));
    if (nkv_is_window_)
        for (std::size_t i = 0; i < hist.size(); ++i)
            if (hist[i] != nkv_[i])
                return fail("n_k^v mismatch at word " + std::to_string(i / Kp_) + ", topic " + std::to_string(i % Kp_));
    return true;
}

} // namespace rost
