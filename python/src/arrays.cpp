// numpy in and out: observations viewed in place (no copy), results copied
// into arrays Python owns.

#include <cstring>
#include <string>

#include "bindings.hpp"

namespace rost::python {

namespace {

std::string typeName(const py::handle& h) { return py::str(py::type::handle_of(h).attr("__name__")); }

// The array behind `h`: numpy, int32 in native byte order, C-contiguous, of
// `ndim` dimensions. TypeError for anything else than such an array's type,
// ValueError for its layout.
py::array checkedInt32(const py::handle& h, const char* name, int ndim) {
    if (!py::isinstance<py::array>(h))
        throw py::type_error(std::string(name) + ": expected a numpy.ndarray of int32, found " + typeName(h) +
                             " (convert with numpy.asarray(x, dtype=numpy.int32))");
    auto a = py::reinterpret_borrow<py::array>(h);
    const py::dtype want = py::dtype::of<int32_t>();
    if (!a.dtype().attr("__eq__")(want).cast<bool>())
        throw py::type_error(std::string(name) + ": expected dtype int32, found " +
                             py::str(a.dtype()).cast<std::string>() + " (convert with .astype(numpy.int32))");
    if (a.ndim() != ndim) {
        std::string shape = py::str(a.attr("shape"));
        throw py::value_error(std::string(name) + ": expected " + (ndim == 1 ? "shape (N,)" : "shape (N, 2)") +
                              ", found shape " + shape);
    }
    if (!(a.flags() & py::array::c_style))
        throw py::value_error(std::string(name) +
                              ": the array is not C-contiguous (it is taken without a copy; use "
                              "numpy.ascontiguousarray)");
    return a;
}

void checkWords(std::span<const uint32_t> words, uint32_t V) {
    for (std::size_t i = 0; i < words.size(); ++i)
        if (words[i] >= V) {
            const auto v = static_cast<int32_t>(words[i]);
            throw py::value_error("words[" + std::to_string(i) + "] = " + std::to_string(v) +
                                  (v < 0 ? ": word ids are not negative" : ": out of range") + " (word ids lie in [0, V = " +
                                  std::to_string(V) + "))");
        }
}

void checkPositions(std::span<const Position> p, int width, int height) {
    for (std::size_t i = 0; i < p.size(); ++i)
        if (p[i].x < 0 || p[i].y < 0 || p[i].x >= width || p[i].y >= height)
            throw py::value_error("positions[" + std::to_string(i) + "] = (" + std::to_string(p[i].x) + ", " +
                                  std::to_string(p[i].y) + ") lies outside the frame [0, " + std::to_string(width) +
                                  ") x [0, " + std::to_string(height) + ") (frame_width, frame_height)");
}

} // namespace

ObservationArrays viewObservation(const py::handle& words, const py::handle& positions, uint32_t V, int width,
                                  int height) {
    ObservationArrays o;
    o.words_ref = checkedInt32(words, "words", 1);
    const auto n = static_cast<std::size_t>(o.words_ref.shape(0));
    // int32 and uint32 share their representation: a negative id reads as one >= V.
    o.words = {static_cast<const uint32_t*>(o.words_ref.data()), n};
    if (positions.is_none()) {
        o.zeros.assign(n, Position{});
        o.positions = o.zeros;
    } else {
        o.positions_ref = checkedInt32(positions, "positions", 2);
        if (o.positions_ref.shape(1) != 2 || static_cast<std::size_t>(o.positions_ref.shape(0)) != n)
            throw py::value_error("positions: expected shape (" + std::to_string(n) + ", 2) for " + std::to_string(n) +
                                  " words, found shape " + py::str(o.positions_ref.attr("shape")).cast<std::string>());
        static_assert(sizeof(Position) == 2 * sizeof(int32_t), "Position is two int32: (x, y)");
        o.positions = {static_cast<const Position*>(o.positions_ref.data()), n};
    }
    checkWords(o.words, V);
    checkPositions(o.positions, width, height);
    return o;
}

namespace {
template <typename T>
py::array_t<int32_t> copyInt32(std::span<const T> v) {
    py::array_t<int32_t> a(static_cast<py::ssize_t>(v.size()));
    int32_t* out = a.mutable_data();
    for (std::size_t i = 0; i < v.size(); ++i) out[i] = static_cast<int32_t>(v[i]);
    return a;
}
} // namespace

py::array_t<int32_t> toArray(std::span<const uint16_t> v) { return copyInt32(v); }
py::array_t<int32_t> toArray(std::span<const uint32_t> v) { return copyInt32(v); }
py::array_t<int32_t> toArray(std::span<const int32_t> v) { return copyInt32(v); }

py::array_t<int32_t> toArray(std::span<const Position> v) {
    py::array_t<int32_t> a({static_cast<py::ssize_t>(v.size()), py::ssize_t{2}});
    if (!v.empty()) std::memcpy(a.mutable_data(), v.data(), v.size() * sizeof(Position));
    return a;
}

py::array_t<float> toGrid(std::span<const float> cells, int rows, int cols) {
    py::array_t<float> a({static_cast<py::ssize_t>(rows), static_cast<py::ssize_t>(cols)});
    const std::size_t n = std::min(cells.size(), static_cast<std::size_t>(rows) * static_cast<std::size_t>(cols));
    float* out = a.mutable_data();
    std::fill_n(out, static_cast<std::size_t>(rows) * static_cast<std::size_t>(cols), 0.0f);
    if (n) std::memcpy(out, cells.data(), n * sizeof(float));
    return a;
}

BusyGuard::BusyGuard(std::atomic<bool>& flag, const char* what) : flag_(flag) {
    if (flag_.exchange(true, std::memory_order_acq_rel))
        throw std::runtime_error(std::string(what) +
                                 " is in use by another thread (a call that releases the interpreter lock, such as "
                                 "refine(), is running); use one object per thread or a lock");
}

void checkNotNegative(int64_t value, const std::string& what, const std::string& zero) {
    if (value < 0)
        throw py::value_error(what + " = " + std::to_string(value) + ", allowed at least 0 (0: " + zero + ")");
}

void check(const Status& st) {
    if (!st.ok()) raiseStatus(st, {}, PyExc_RuntimeError);
}

} // namespace rost::python
