// rost.Engine: the realtime engine from Python. A refiner thread of its own
// (it never needs the interpreter lock), push() that never blocks, and
// snapshots of the newest results.

#include <cstdint>
#include <memory>
#include <string>

#include "bindings.hpp"
#include "rost/engine.hpp"

namespace rost::python {

// What rost.Engine.snapshot() returns: the newest observation's results.
struct PySnapshot {
    uint64_t version = 0, observation = 0, sequence = 0;
    int64_t timestamp = 0, step = 0;
    double perplexity = 0.0, surprise = 0.0;
    py::object labels, words, positions, cell_surprise, histograms;
    py::dict counters;
};

namespace {

py::dict countersDict(const EngineCounters& c) {
    py::dict d;
    d["pushed"] = c.pushed;
    d["dropped_newest"] = c.dropped_newest;
    d["dropped_oldest"] = c.dropped_oldest;
    d["words_truncated"] = c.words_truncated;
    d["ingested"] = c.ingested;
    d["rejected"] = c.rejected;
    d["words_dropped_cell"] = c.words_dropped_cell;
    d["refinements"] = c.refinements;
    d["tokens"] = c.tokens;
    d["overruns"] = c.overruns;
    d["published"] = c.published;
    return d;
}

class PyEngine {
public:
    explicit PyEngine(const Settings& s)
        : settings_(s), engine_(makeEngine(s.engine)), snap_(engine_->makeSnapshot()) {}

    void start() {
        BusyGuard guard(busy_, "rost.Engine");
        check(engine_->start());
        stopped_ = false;
    }
    void stop(bool drain) {
        BusyGuard guard(busy_, "rost.Engine");
        stopped_ = true;
        py::gil_scoped_release nogil;  // draining the queue refines every queued observation
        engine_->stop(drain ? Engine::StopMode::Drain : Engine::StopMode::Discard);
    }
    bool push(int64_t t, const py::handle& words, const py::handle& positions) {
        // Before start() an observation waits in the queue; after stop() nothing would take it up.
        if (stopped_) throw std::runtime_error("rost.Engine.push: the engine is stopped (start() it again first)");
        // Runs under the interpreter lock: one producer at a time, as tryPush needs.
        const Config& c = engine_->config().model;
        const ObservationArrays obs = viewObservation(words, positions, static_cast<uint32_t>(c.V), c.frame_width,
                                                      c.frame_height);
        last_words_ = obs.words.data();
        last_positions_ = obs.positions.data();
        return engine_->tryPush(ObservationView{t, obs.words, obs.positions});
    }
    // The buffers last handed to the engine (tests: viewed in place, not copied before the push).
    uintptr_t lastWords() const { return reinterpret_cast<uintptr_t>(last_words_); }
    uintptr_t lastPositions() const { return reinterpret_cast<uintptr_t>(last_positions_); }
    py::object snapshot() {
        if (!engine_->readSnapshot(snap_)) return py::none();
        PySnapshot s;
        s.version = snap_.version;
        s.observation = snap_.observation;
        s.sequence = snap_.sequence;
        s.timestamp = snap_.timestamp;
        s.step = snap_.step;
        s.perplexity = snap_.perplexity;
        s.surprise = snap_.surprise;
        s.labels = toArray(snap_.labels());
        s.words = toArray(snap_.wordIds());
        s.positions = toArray(snap_.positions());
        const Config& c = engine_->config().model;
        s.cell_surprise = toGrid(snap_.cellSurprise(), c.gridHeight(), c.gridWidth());
        py::array_t<int32_t> h = toArray(snap_.histograms());
        s.histograms = h.reshape({static_cast<py::ssize_t>(snap_.cells()), static_cast<py::ssize_t>(snap_.K())});
        s.counters = countersDict(snap_.counters);
        return py::cast(std::move(s));
    }
    bool running() const { return engine_->running(); }
    py::dict counters() const { return countersDict(engine_->counters()); }
    const Settings& settings() const { return settings_; }
    std::size_t memoryBytes() const { return engine_->memoryBytes(); }

private:
    Settings settings_;
    std::unique_ptr<Engine> engine_;
    Snapshot snap_;
    std::atomic<bool> busy_{false};
    bool stopped_ = false;  // stop() called and no start() since
    const void* last_words_ = nullptr;
    const void* last_positions_ = nullptr;
};

void bindSnapshot(py::module_& m) {
    py::class_<PySnapshot>(m, "Snapshot", "The newest observation's results, as rost.Engine.snapshot() copied them.")
        .def_readonly("version", &PySnapshot::version, "publications so far")
        .def_readonly("observation", &PySnapshot::observation, "index among ingested observations")
        .def_readonly("sequence", &PySnapshot::sequence, "push sequence number (dropped pushes count)")
        .def_readonly("timestamp", &PySnapshot::timestamp, "t as pushed")
        .def_readonly("step", &PySnapshot::step, "the model's time step")
        .def_readonly("perplexity", &PySnapshot::perplexity, "of its step, after its budget")
        .def_readonly("surprise", &PySnapshot::surprise, "surprise of the observation")
        .def_readonly("labels", &PySnapshot::labels, "maximum-likelihood topic per kept word (int32)")
        .def_readonly("words", &PySnapshot::words, "its kept words (int32)")
        .def_readonly("positions", &PySnapshot::positions, "their positions (int32, shape (N, 2))")
        .def_readonly("cell_surprise", &PySnapshot::cell_surprise, "surprise per cell (float32, grid rows x columns)")
        .def_readonly("histograms", &PySnapshot::histograms, "topic counts per cell (int32, cells x K)")
        .def_readonly("counters", &PySnapshot::counters, "the engine's counters (dict)")
        .def(py::pickle(
            [](const PySnapshot& s) {
                return py::make_tuple(s.version, s.observation, s.sequence, s.timestamp, s.step, s.perplexity, s.surprise,
                                      s.labels, s.words, s.positions, s.cell_surprise, s.histograms, s.counters);
            },
            [](const py::tuple& t) {
                if (t.size() != 13) throw py::value_error("rost.Snapshot: not a pickled rost.Snapshot");
                PySnapshot s;
                s.version = t[0].cast<uint64_t>();
                s.observation = t[1].cast<uint64_t>();
                s.sequence = t[2].cast<uint64_t>();
                s.timestamp = t[3].cast<int64_t>();
                s.step = t[4].cast<int64_t>();
                s.perplexity = t[5].cast<double>();
                s.surprise = t[6].cast<double>();
                s.labels = t[7];
                s.words = t[8];
                s.positions = t[9];
                s.cell_surprise = t[10];
                s.histograms = t[11];
                s.counters = t[12].cast<py::dict>();
                return s;
            }))
        .def("__repr__", [](const PySnapshot& s) {
            return "rost.Snapshot(timestamp=" + std::to_string(s.timestamp) + ", step=" + std::to_string(s.step) +
                   ", perplexity=" + std::to_string(s.perplexity) + ", surprise=" + std::to_string(s.surprise) + ")";
        });
}

} // namespace

void bindEngine(py::module_& m) {
    bindSnapshot(m);
    py::class_<PyEngine> c(m, "Engine", R"doc(The realtime engine: start(), push(t, words, positions) from one
producer (never blocks; False when the queue dropped it), snapshot() from anywhere,
stop(). A context manager: `with rost.Engine(cfg) as e:` starts and stops it.)doc");
    c.def(py::init([](const std::optional<PyConfig>& config) {
                 return std::make_unique<PyEngine>(config ? config->settings : Settings{});
             }),
             py::arg("config") = py::none())
        .def("start", &PyEngine::start, "Starts the refiner thread.")
        .def("stop", &PyEngine::stop, py::arg("drain") = true,
             "Stops the refiner (drain: after refining every queued observation; else the observation in "
             "hand's refinement is cut short and the rest stay queued). Releases the interpreter lock.")
        .def("push", &PyEngine::push, py::arg("t"), py::arg("words"), py::arg("positions") = py::none(),
             "Queues observation t (int32 words, (N, 2) int32 positions). Never blocks; False when it was dropped; "
             "RuntimeError after stop() (until start()).")
        .def("snapshot", &PyEngine::snapshot, "The newest results (rost.Snapshot), None before the first.")
        .def("counters", &PyEngine::counters, "The engine's counters (dict).")
        .def_property_readonly("_last_input_address", &PyEngine::lastWords)
        .def_property_readonly("_last_positions_address", &PyEngine::lastPositions)
        .def_property_readonly("running", &PyEngine::running)
        .def_property_readonly("config", [](const PyEngine& e) { return PyConfig{e.settings()}; })
        .def_property_readonly("memory_bytes", &PyEngine::memoryBytes)
        .def("__enter__", [](PyEngine& e) -> PyEngine& {
                 e.start();
                 return e;
             }, py::return_value_policy::reference)
        .def("__exit__", [](PyEngine& e, const py::args&) { e.stop(true); });
    refusePickling(c, "rost.Engine cannot be pickled or copied (it runs a refiner thread): pickle its config "
                      "(engine.config) and build a new rost.Engine, or use a rost.Model (it pickles with its state)");
}

} // namespace rost::python
