#pragma once

// The buffers of the measurements computed on the worker pool (internal;
// src/core/measure.cpp; docs/design.md, "Refinement on every core").

#include <atomic>
#include <cstddef>
#include <cstdint>

#include "aligned_buffer.hpp"
#include "model_core.hpp"

namespace rost {

namespace detail {
// A worker's grouping scratch in finalMeasurements: cell_begin (cells + 1),
// cursor (cells), input_cell and by_cell (max.words each), rounded up so that
// each worker's part starts on a cache line of its own (16 words).
constexpr std::size_t measureGroupStride(std::size_t cells, std::size_t maxWords) noexcept {
    return (2 * cells + 1 + 2 * maxWords + 15) / 16 * 16;
}
} // namespace detail

// Sized when the model has workers (construction, setThreads): nothing here
// allocates afterwards.
struct ModelCore::Measure {
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

    // finalMeasurements: each worker's own grouping scratch, one stride a
    // worker (cell_begin, cursor, input_cell, by_cell as above).
    AlignedBuffer<uint32_t> worker_groups;
    std::size_t group_stride = 0;

    void size(std::size_t cells, std::size_t cap, std::size_t maxWords, std::size_t workers) {
        terms.reset(cells * cap);
        cell_begin.reset(cells + 1);
        cursor.reset(cells);
        input_cell.reset(maxWords);
        by_cell.reset(maxWords);
        group_stride = detail::measureGroupStride(cells, maxWords);
        worker_groups.reset(workers * group_stride);
    }
    ModelCore::CellGroups groups() noexcept {
        return {cell_begin.data(), cursor.data(), input_cell.data(), by_cell.data()};
    }
    ModelCore::CellGroups workerGroups(int worker, std::size_t cells, std::size_t maxWords) noexcept {
        uint32_t* p = worker_groups.data() + static_cast<std::size_t>(worker) * group_stride;
        return {p, p + cells + 1, p + 2 * cells + 1, p + 2 * cells + 1 + maxWords};
    }
    std::size_t bytes() const noexcept {
        return terms.bytes() + cell_begin.bytes() + cursor.bytes() + input_cell.bytes() + by_cell.bytes() +
               worker_groups.bytes() + sizeof(Measure);
    }
};

} // namespace rost
