// Checks of a model state written back from an untrusted source (a
// checkpoint file whose checksums hold but whose contents may not):
// Model::checkRestoredState. Every value the store could index with, divide
// by or count must be in range before anything reads it; stateRestored()
// and checkInvariants() then compare the counts with the labels. The ring
// store's own file, so the rules live beside the tables they protect.

#include <cmath>
#include <string>
#include <vector>

#include "model_core.hpp"

namespace rost {

namespace {

bool bad(StateProblem& problem, const char* section, std::size_t element, std::string what) {
    problem.section = section;
    problem.element = element;
    problem.what = std::move(what);
    return false;
}

std::string str(uint64_t v) { return std::to_string(v); }

} // namespace

bool ModelCore::checkRestoredState(StateProblem& problem) const {
    return restoredCounters(problem) && restoredCells(problem) && restoredInputs(problem) &&
           restoredSurprises(problem);
}

// Observation and step counts, the n_kv flag and the generator.
bool ModelCore::restoredCounters(StateProblem& problem) const {
    if (frames_ > (uint64_t{1} << 62))
        return bad(problem, "counters.frames", 0, "observation count " + str(frames_) + " is implausible");
    const auto ct = static_cast<uint64_t>(ct_);
    const auto expectSteps = static_cast<int64_t>((frames_ + ct - 1) / ct);
    if (steps_ != expectSteps) {
        std::string what = "step count " + std::to_string(steps_) + " does not follow from " + str(frames_);
        what += " observations and cell.time " + str(ct) + " (expected " + std::to_string(expectSteps) + ")";
        return bad(problem, "counters.steps", 0, what);
    }
    // A bool restored from a file byte: read the byte, not the bool.
    const uint8_t flag = *reinterpret_cast<const uint8_t*>(&nkv_is_window_);
    if (flag > 1) return bad(problem, "counters.nkv_is_window", 0, "flag value " + str(flag) + " (expected 0 or 1)");
    if (cfg_.fixed && flag != 0)
        return bad(problem, "counters.nkv_is_window", 0, "flag value 1, but a fixed topic model never holds the window");
    const auto words = rng_.stateWords();
    uint32_t any = 0;
    for (uint32_t w : words) any |= w;
    if (any == 0) return bad(problem, "rng", 0, "generator state is all zero (a stuck generator)");
    return true;
}

// Which step each slot holds, the words and labels of every cell, and n_kv
// at least the window's own counts.
bool ModelCore::restoredCells(StateProblem& problem) const {
    // (A fixed topic model holds none of the window's words.)
    const bool isWindow = *reinterpret_cast<const uint8_t*>(&nkv_is_window_) != 0;
    std::vector<int64_t> windowCounts(isWindow || cfg_.fixed ? 0 : static_cast<std::size_t>(V_) * Kp_, 0);
    const int64_t oldest = oldestStep();
    for (std::size_t slot = 0; slot < static_cast<std::size_t>(ring_); ++slot) {
        // The step this slot holds if one of the window's steps maps to it.
        int64_t step = -1;
        if (steps_ > 0) {
            const int64_t newest = steps_ - 1;
            const int64_t back = (newest % ring_ - static_cast<int64_t>(slot) + ring_) % ring_;
            step = newest - back;
        }
        const bool used = steps_ > 0 && step >= oldest;
        if (slot_step_[slot] != (used ? step : -1))
            return bad(problem, "ring.slot_step", slot,
                       "slot " + str(slot) + " holds step " + std::to_string(slot_step_[slot]) + ", expected " +
                           std::to_string(used ? step : -1));
        for (int c = 0; c < cells_; ++c)
            if (!restoredCell(slot, c, used, windowCounts, problem)) return false;
    }
    // With counts kept from outside the window (a prior, or evicted steps),
    // n_k^v must still hold at least the window's own words.
    for (std::size_t i = 0; i < windowCounts.size(); ++i)
        if (nkv_[i] < windowCounts[i])
            return bad(problem, "n_kv", i,
                       "count " + std::to_string(nkv_[i]) + " of word " + str(i / Kp_) + ", topic " + str(i % Kp_) +
                           " is below the " + std::to_string(windowCounts[i]) + " words in the window");
    return true;
}

bool ModelCore::restoredCell(std::size_t slot, int cell, bool used, std::vector<int64_t>& windowCounts,
                             StateProblem& problem) const {
    const std::size_t ci = slot * cells_ + static_cast<std::size_t>(cell);
    const uint32_t n = cell_n_[ci];
    if (n > (used ? static_cast<uint32_t>(cap_) : 0u)) {
        std::string what = str(n) + " words in cell " + str(static_cast<uint64_t>(cell)) + " of slot " + str(slot);
        what += used ? ", capacity " + str(static_cast<uint64_t>(cap_)) : ", which is not in the window";
        return bad(problem, "ring.cell_n", ci, what);
    }
    if (!used)
        for (std::size_t k = 0; k < static_cast<std::size_t>(Kp_); ++k)
            if (nck_[ci * Kp_ + k] != 0) return bad(problem, "ring.n_ck", ci * Kp_ + k, "topic count in a slot outside the window");
    for (std::size_t i = 0; i < n; ++i) {
        const std::size_t wi = ci * cap_ + i;
        const uint32_t w = cell_words_[wi];
        if (w >= static_cast<uint32_t>(V_))
            return bad(problem, "ring.cell_words", wi, "word id " + str(w) + " out of range [0, " + str(static_cast<uint64_t>(V_)) + ")");
        const uint16_t z = cell_z_[wi];
        if (z >= K_)
            return bad(problem, "ring.cell_z", wi, "topic label " + str(z) + " out of range [0, " + str(static_cast<uint64_t>(K_)) + ")");
        if (!windowCounts.empty()) ++windowCounts[static_cast<std::size_t>(w) * Kp_ + z];
    }
    return true;
}

// Every observation's kept inputs: word ids, positions, where each went.
bool ModelCore::restoredInputs(StateProblem& problem) const {
    const auto ring = static_cast<std::size_t>(ring_), ct = static_cast<std::size_t>(ct_);
    const auto maxw = static_cast<std::size_t>(maxw_);
    for (std::size_t o = 0; o < ring * ct; ++o)
        if (in_n_[o] > maxw)
            return bad(problem, "ring.in_n", o, str(in_n_[o]) + " words in an observation, at most " + str(maxw));
    for (uint64_t f = static_cast<uint64_t>(oldestStep()) * ct; f < frames_; ++f) {
        const std::size_t slot = static_cast<std::size_t>((f / ct) % ring);
        const std::size_t o = slot * ct + static_cast<std::size_t>(f % ct);
        for (std::size_t i = 0; i < in_n_[o]; ++i) {
            const std::size_t at = o * maxw + i;
            const uint32_t w = in_word_[at];
            if (w >= static_cast<uint32_t>(V_))
                return bad(problem, "ring.in_word", at, "word id " + str(w) + " out of range [0, " + str(static_cast<uint64_t>(V_)) + ")");
            const uint32_t xy = in_pos_[at];
            if ((xy & 0xFFFFu) >= static_cast<uint32_t>(cfg_.frame_width) || (xy >> 16) >= static_cast<uint32_t>(cfg_.frame_height))
                return bad(problem, "ring.in_pos", at,
                           "position (" + str(xy & 0xFFFFu) + ", " + str(xy >> 16) + ") outside the " +
                               std::to_string(cfg_.frame_width) + "x" + std::to_string(cfg_.frame_height) + " frame");
            const uint32_t s = in_slot_[at];
            if (s & kDropped) {
                if ((s & ~kDropped) >= static_cast<uint32_t>(cells_))
                    return bad(problem, "ring.in_slot", at, "cell " + str(s & ~kDropped) + " out of range");
                continue;
            }
            const std::size_t cell = s / cap_, i2 = s % cap_;
            if (cell >= static_cast<std::size_t>(cells_) || i2 >= cell_n_[slot * cells_ + cell])
                return bad(problem, "ring.in_slot", at, "word slot " + str(s) + " does not refer to a word in a cell");
        }
    }
    return true;
}

// Surprises: non-negative numbers.
bool ModelCore::restoredSurprises(StateProblem& problem) const {
    auto check = [&](const char* section, const AlignedBuffer<float>& b) {
        for (std::size_t i = 0; i < b.size(); ++i)
            if (std::isnan(b[i]) || b[i] < 0.f)
                return bad(problem, section, i, "surprise " + std::to_string(b[i]) + " is not a non-negative number");
        return true;
    };
    return check("ring.cell_surprise", cell_surprise_) && check("ring.obs_surprise", obs_surprise_);
}

} // namespace rost
