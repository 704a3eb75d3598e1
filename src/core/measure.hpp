#pragma once

// The buffers of the measurements computed on the worker pool (internal;
// src/core/measure.cpp; docs/design.md, "Refinement on every core").

#include <atomic>
#include <cstddef>
#include <cstdint>

#include "rost/aligned_buffer.hpp"
#include "rost/model.hpp"

namespace rost {

// Sized when the model has workers (construction, setThreads): nothing here
// allocates afterwards.
struct Model::Measure {
    // One step's per-word terms (-log p or log p of each word), at cell * cap + slot.
    AlignedBuffer<double> terms;
    // An observation's inputs grouped by cell: cell c's are
    // by_cell[cell_begin[c], cell_begin[c + 1]); cursor and input_cell (each
    // input's cell, one division each) are the sort's scratch.
    AlignedBuffer<uint32_t> cell_begin;
    AlignedBuffer<uint32_t> cursor;
    AlignedBuffer<uint32_t> input_cell;
    AlignedBuffer<uint32_t> by_cell;
    // Held by the measurement that uses the pool and the buffers; another
    // thread's measurement finds it taken and computes serially.
    std::atomic<bool> busy{false};

    void size(std::size_t cells, std::size_t cap, std::size_t maxWords) {
        terms.reset(cells * cap);
        cell_begin.reset(cells + 1);
        cursor.reset(cells);
        input_cell.reset(maxWords);
        by_cell.reset(maxWords);
    }
    std::size_t bytes() const noexcept {
        return terms.bytes() + cell_begin.bytes() + cursor.bytes() + input_cell.bytes() + by_cell.bytes() +
               sizeof(Measure);
    }
};

} // namespace rost
