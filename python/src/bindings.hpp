#pragma once

// Shared parts of the Python bindings (`import rost`, docs/python.md): the
// settings a Config holds, numpy views of word and position arrays taken
// without a copy, and the guard that keeps one object from being used by
// two Python threads at once while the interpreter lock is released.

#include <atomic>
#include <cstdint>
#include <exception>
#include <span>
#include <initializer_list>
#include <memory>
#include <string>
#include <utility>
#include <vector>

#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>
#include <pybind11/stl.h>

#include "rost/engine.hpp"
#include "rost/position.hpp"
#include "rost/settings.hpp"
#include "rost/status.hpp"
#include "rost/text_io.hpp"

namespace rost::python {

namespace py = pybind11;

// rost.Config: every setting of the schema (rost/settings_schema.hpp).
struct PyConfig {
    Settings settings;
};

// Applies Python keyword arguments (parameter names such as cell_space, or
// keys such as "cell.space") to `s`. `allowed` (when set) limits the groups;
// `what` names the caller in messages. Raises ValueError naming the key.
void applySettings(Settings& s, const py::kwargs& kwargs, const char* what, bool wordsOnly = false);
// A setting's current value as a Python object (int, float, bool, str), or None
// for a budget key not in force.
py::object settingObject(const Settings& s, const SettingSpec& spec);

// Raises a failed Status (raiseStatus: RuntimeError unless it is about a file).
void check(const Status& st);

// A count or size argument that may not be negative: ValueError
// "WHAT = V, allowed at least 0 (0: ZERO)" otherwise.
void checkNotNegative(int64_t value, const std::string& what, const std::string& zero);

// A path argument as text: str or os.PathLike (TypeError naming the argument
// otherwise); an empty one is refused (ValueError: "WHAT: no file given").
std::string pathArgument(const py::handle& value, const char* what);

// Raises a failed Status as the Python exception its kind is, as open()
// raises them: FileNotFoundError (StatusKind::NotFound), PermissionError,
// IsADirectoryError, NotADirectoryError, OSError (another refusal of the
// system), and `otherwise` (ValueError unless given) for the rest;
// the message is `prefix` and the library's. The library decides what is
// missing or unreadable where it opens the file: no face looks again.
// It throws a StatusError, which touches no Python object: it may be called
// where the GIL is released; the module's translator raises it.
[[noreturn]] void raiseStatus(const Status& st, const std::string& prefix = {}, PyObject* otherwise = PyExc_ValueError);

class StatusError : public std::exception {
public:
    StatusError(PyObject* type, std::string message) : type_(type), message_(std::move(message)) {}
    const char* what() const noexcept override { return message_.c_str(); }
    PyObject* type() const noexcept { return type_; }

private:
    PyObject* type_;
    std::string message_;
};

// The engine for rost.Engine and rost.Model, built as every face builds it
// (Engine::create): settings this machine cannot hold raise MemoryError
// naming the settings the tables grow with, not "std::bad_alloc".
std::unique_ptr<Engine> makeEngine(const EngineConfig& cfg);

// Registers the translator that raises a StatusError as its Python exception (module init).
void registerStatusErrors();

// An object that cannot be pickled or copied: pickle.dumps and copy.deepcopy
// raise TypeError with `message` (which says what to do instead).
template <typename Class>
void refusePickling(Class& c, const char* message) {
    c.def("__reduce_ex__", [message](const py::object&, const py::object&) -> py::object { throw py::type_error(message); });
}

// Words (numpy int32, shape (N,)) and positions (numpy int32, shape (N, 2),
// or None: every word at (0, 0)) of one observation, viewed in place.
struct ObservationArrays {
    std::span<const uint32_t> words;
    std::span<const Position> positions;
    py::array words_ref, positions_ref;  // keep the arrays alive while viewed
    std::vector<Position> zeros;         // positions=None
};
// Checks dtype and shape (TypeError / ValueError naming the argument and
// what was found), word ids in [0, V) and positions inside the frame
// (ValueError naming the index and value). Never copies the arrays.
ObservationArrays viewObservation(const py::handle& words, const py::handle& positions, uint32_t V, int width,
                                  int height);

// Numpy arrays made from C++ data (these copy: outputs are owned by Python).
py::array_t<int32_t> toArray(std::span<const uint16_t> v);
py::array_t<int32_t> toArray(std::span<const uint32_t> v);
py::array_t<int32_t> toArray(std::span<const int32_t> v);
py::array_t<int32_t> toArray(std::span<const Position> v);  // shape (N, 2)
py::array_t<float> toGrid(std::span<const float> cells, int rows, int cols);

// One user at a time: a call that finds the object busy (another Python
// thread is inside a call that released the interpreter lock) raises
// RuntimeError instead of racing.
class BusyGuard {
public:
    BusyGuard(std::atomic<bool>& flag, const char* what);
    ~BusyGuard() { flag_.store(false, std::memory_order_release); }
    BusyGuard(const BusyGuard&) = delete;
    BusyGuard& operator=(const BusyGuard&) = delete;

private:
    std::atomic<bool>& flag_;
};

void bindConfig(py::module_& m);
void bindModel(py::module_& m);
void bindEngine(py::module_& m);
// rost.Mission: a word stream's mission (mission.cpp).
void bindMission(py::module_& m);
void bindMerge(py::module_& m);
// rost._rost.text: the core's text I/O layer for rost.io (io.cpp).
void bindText(py::module_& m);
#ifdef ROST_PYTHON_VISION
void bindVision(py::module_& m);
// rost.vision.Mission: a mission over frames (vision_mission.cpp).
void bindVisionMission(py::module_& m);
#endif

} // namespace rost::python
