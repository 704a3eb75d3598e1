// rost.Model: the topic model driven from Python, one call at a time (rostpy's
// add_observation / refine / topics). Backed by a rost::Engine in its
// synchronous mode, so observations enter exactly as they do in the tool and
// in the realtime engine, and save()/load() are the checkpoint format.

#include <climits>
#include <cstring>
#include <limits>
#include <memory>
#include <optional>
#include <string>
#include <type_traits>
#include <unordered_map>
#include <vector>

#include "bindings.hpp"
#include "mission_results.hpp"
#include "rost/checkpoint.hpp"
#include "rost/engine.hpp"
#include "rost/mission.hpp"

namespace rost::python {

namespace {

// The engine behind a Model adds observations without refining them
// (budget 0: Model.refine() refines) and publishes nothing it would not read.
EngineConfig internalConfig(const EngineConfig& user) {
    EngineConfig c = user;
    c.budget = Budget::steps(0);
    c.queue_slots = 1;
    c.flags.instantaneous_perplexity = false;
    c.flags.snapshot_perplexity = false;
    c.flags.snapshot_labels = false;
    return c;
}

// Copies every state section of `from` into `to` (same model keys) and puts
// the engine's counters in use.
Status copyState(Engine& from, Engine& to) {
    StateLayout a, b;
    from.describeState(a);
    to.describeState(b);
    if (a.size() != b.size()) return Status::error("internal: state layouts differ");
    for (std::size_t i = 0; i < a.size(); ++i) {
        if (a[i].name != b[i].name || a[i].bytes != b[i].bytes)
            return Status::error("internal: state section '" + std::string(a[i].name) + "' differs");
        std::memcpy(b[i].data, a[i].data, a[i].bytes);
    }
    return to.applyState();
}

} // namespace

class PyModel {
public:
    explicit PyModel(const Settings& s) : settings_(s), engine_(makeEngine(internalConfig(s.engine))) {}

    const Settings& settings() const { return settings_; }
    Engine& engine() { return *engine_; }
    const Model& model() const { return engine_->model(); }
    std::atomic<bool>& busy() { return busy_; }
    const void* lastInput() const { return last_input_; }
    const void* lastPositions() const { return last_positions_; }

    void add(int64_t t, const py::handle& words, const py::handle& positions) {
        BusyGuard guard(busy_, "rost.Model");
        const Config& c = model().config();
        const ObservationArrays obs = viewObservation(words, positions, static_cast<uint32_t>(c.V), c.frame_width,
                                                      c.frame_height);
        // topics(t) and ml_topics(t) find an observation by its time stamp:
        // a second one in the window would hide the first.
        if (const auto it = by_time_.find(t); it != by_time_.end() && model().observationInWindow(it->second))
            throw py::value_error("rost.Model.add_observation: time stamp " + std::to_string(t) +
                                  " is already an observation's in the window (topics(t) looks it up by its time "
                                  "stamp: give each observation its own)");
        last_input_ = obs.words.data();
        last_positions_ = obs.positions.data();
        ObservationResult r;
        {
            py::gil_scoped_release nogil;
            r = engine_->processNow(ObservationView{t, obs.words, obs.positions});
        }
        if (!r.add.ok() || r.step < 0)  // checked above: not reached
            throw py::value_error(std::string("rost.Model.add_observation: the model refused the observation (") +
                                  toString(r.add.error) + " at word " + std::to_string(r.add.index) + ")");
        by_time_[t] = r.observation;
        const std::size_t window = static_cast<std::size_t>(c.ring_steps) * static_cast<std::size_t>(c.cell_time);
        if (by_time_.size() > 2 * window + 64) reindex();
    }

    uint64_t refine(std::optional<int64_t> steps, std::optional<int64_t> sweeps) {
        if (steps && sweeps) throw py::value_error("rost.Model.refine: give steps or sweeps, not both");
        if ((steps && *steps < 0) || (sweeps && *sweeps < 0))
            throw py::value_error("rost.Model.refine: steps and sweeps are not negative");
        if (sweeps && *sweeps > INT_MAX) throw py::value_error("rost.Model.refine: sweeps beyond 2^31 - 1");
        BusyGuard guard(busy_, "rost.Model");
        const uint64_t before = model().tokensRefined();
        py::gil_scoped_release nogil;
        if (sweeps)
            engine_->finalPass(static_cast<int>(*sweeps));
        else
            engine_->refineExtra(steps ? Budget::steps(static_cast<uint64_t>(*steps)) : settings_.engine.budget);
        return model().tokensRefined() - before;
    }

    // rostpy's parallel_refine: `sweeps` batch sweeps on `threads` threads
    // (the model keeps refining on that many). The result is the same for
    // any number of threads (windows of refine_window cell picks).
    uint64_t parallelRefine(int64_t threads, int64_t sweeps) {
        if (threads < 1 || threads > 1024) throw py::value_error("rost.parallel_refine: threads must be in [1, 1024]");
        if (sweeps < 0 || sweeps > INT_MAX) throw py::value_error("rost.parallel_refine: sweeps must be in [0, 2^31 - 1]");
        BusyGuard guard(busy_, "rost.Model");
        engine_->model().setThreads(static_cast<int>(threads));
        const uint64_t before = model().tokensRefined();
        py::gil_scoped_release nogil;
        engine_->finalPass(static_cast<int>(sweeps));
        return model().tokensRefined() - before;
    }

    // The observation with time stamp t (the latest one when several share it).
    uint64_t frameOf(int64_t t) const {
        const auto it = by_time_.find(t);
        if (it == by_time_.end() || !model().observationInWindow(it->second))
            throw py::key_error("rost.Model: no observation with time stamp t = " + std::to_string(t) +
                                (it == by_time_.end() ? std::string() : " in the window (it has left the ring)"));
        return it->second;
    }
    int64_t stepOf(int64_t t) const { return model().stepOfObservation(frameOf(t)); }

    void reindex() {
        by_time_.clear();
        engine_->visitWindow([&](const WindowObservation& w, const Model&) { by_time_[w.timestamp] = w.observation; });
    }

    void save(const py::object& pathObject) {
        const std::string path = pathArgument(pathObject, "rost.Model.save: path");
        BusyGuard guard(busy_, "rost.Model");
        // The library's check of a mission's output, as rost.Mission.save's: "-" and a directory refused by name.
        if (Status st = checkMissionOutput(MissionOptions{}, "rost.Model.save", path); !st.ok())
            raiseStatus(st, {}, PyExc_RuntimeError);
        // The file holds the Config the user gave (its budget included), so the
        // tool's --resume carries on as configured.
        Engine out(settings_.engine);
        check(copyState(*engine_, out));
        py::gil_scoped_release nogil;
        if (Status st = saveCheckpoint(out, path); !st.ok()) raiseStatus(st, "rost.Model.save: ", PyExc_RuntimeError);
    }

    // The library's mission session decides what the checkpoint fixes and what
    // `settings` (rost.Config keywords) may change (rost/mission.hpp): a model
    // setting given with another value is refused, naming the keyword;
    // refinement settings given replace the checkpoint's.
    static std::unique_ptr<PyModel> load(const py::object& pathObject, const py::kwargs& settings) {
        const std::string path = pathArgument(pathObject, "rost.Model.load: path");
        MissionOptions mission = missionOptions(settings, "rost.Model.load", py::str(path), py::none());
        mission.names.resume = "rost.Model.load";
        MissionPlan plan;
        if (Status st = checkMission(mission, plan); !st.ok()) raiseStatus(st);
        MissionInput in;
        in.threads = plan.checkpoint.config.model.threads;  // the checkpoint's unless `threads` is given
        if (Status st = planMission(mission, in, plan); !st.ok()) throw py::value_error(text::printable(st.message()));
        Settings s;
        s.engine = plan.config;
        auto m = std::make_unique<PyModel>(s);
        CheckpointLoadOptions options;
        options.allow_refinement_change = true;  // the internal budget is 0
        if (Status st = loadCheckpoint(path, *m->engine_, options); !st.ok()) raiseStatus(st);
        m->reindex();
        return m;
    }

    // pickle and copy.deepcopy: the Config and the internal engine's checkpoint
    // bytes (its random state included), so a copy continues bit for bit.
    py::tuple getState() {
        BusyGuard guard(busy_, "rost.Model");
        std::vector<uint8_t> bytes;
        check(encodeCheckpoint(*engine_, bytes));
        return py::make_tuple(PyConfig{settings_},
                              py::bytes(reinterpret_cast<const char*>(bytes.data()), bytes.size()));
    }
    static std::unique_ptr<PyModel> fromState(const py::tuple& state) {
        if (state.size() != 2) throw py::value_error("rost.Model: not a pickled rost.Model");
        auto m = std::make_unique<PyModel>(state[0].cast<PyConfig>().settings);
        const std::string bytes = state[1].cast<py::bytes>();
        const std::span<const uint8_t> view(reinterpret_cast<const uint8_t*>(bytes.data()), bytes.size());
        if (Status st = loadCheckpoint(view, "pickled rost.Model", *m->engine_); !st.ok())
            throw py::value_error(text::printable(st.message()));
        m->reindex();
        return m;
    }

private:
    Settings settings_;
    std::unique_ptr<Engine> engine_;
    std::unordered_map<int64_t, uint64_t> by_time_;
    std::atomic<bool> busy_{false};
    const void* last_input_ = nullptr;
    const void* last_positions_ = nullptr;
};

namespace {

// Read access under the busy guard (a refine() on another thread may be running).
template <typename F>
auto reading(PyModel& m, F&& f) {
    BusyGuard guard(m.busy(), "rost.Model");
    return f(m.model());
}

py::array_t<int32_t> labels(PyModel& m, int64_t t, bool ml) {
    return reading(m, [&](const Model& model) {
        const uint64_t f = m.frameOf(t);
        std::vector<uint16_t> z(model.observationSize(f));
        if (ml)
            model.observationLabels(f, z);
        else
            model.observationSamples(f, z);
        return toArray(std::span<const uint16_t>(z));
    });
}

double perplexity(PyModel& m, std::optional<int64_t> t) {
    return reading(m, [&](const Model& model) {
        if (t) return model.stepPerplexity(m.stepOf(*t));
        LogLoss all;
        for (int64_t s = model.oldestStep(); s < model.steps(); ++s) all += model.stepLogLoss(s);
        return all.words ? all.perplexity() : std::numeric_limits<double>::quiet_NaN();
    });
}

// The model's topic slots in label order (Model::slotsInLabelOrder): row i of
// topic_model() and topic_weights() (and of set_topic_model's counts) is slot
// slots[i]; rows 0..A-1 the open topics, as in topicmodel.csv, then the closed
// slots' zero rows.
std::vector<int> slotsInLabelOrder(const Model& model) {
    std::vector<uint16_t> order(static_cast<std::size_t>(model.K()));
    model.slotsInLabelOrder(order);
    return {order.begin(), order.end()};
}

py::array_t<int32_t> topicModel(PyModel& m) {
    return reading(m, [&](const Model& model) {
        py::array_t<int32_t> a({static_cast<py::ssize_t>(model.K()), static_cast<py::ssize_t>(model.V())});
        auto r = a.mutable_unchecked<2>();
        const std::vector<int> slots = slotsInLabelOrder(model);
        for (int i = 0; i < model.K(); ++i)
            for (int v = 0; v < model.V(); ++v) r(i, v) = model.topicWordCount(slots[static_cast<std::size_t>(i)], v);
        return a;
    });
}

// The K x V counts of `a` (elements of type T) as n_k^v additions, each named
// by its own value when it is negative or too large (a uint64 2^63 is not -2^63).
template <typename T>
std::vector<int32_t> topicCounts(const Model& model, const py::array& a) {
    auto c = py::array_t<T, py::array::c_style | py::array::forcecast>::ensure(a);
    auto r = c.template unchecked<2>();
    std::vector<int32_t> flat(static_cast<std::size_t>(model.K()) * static_cast<std::size_t>(model.V()));
    const std::vector<int> slots = slotsInLabelOrder(model);  // row k: this slot (as topic_model() gives them)
    for (int k = 0; k < model.K(); ++k) {
        const int slot = slots[static_cast<std::size_t>(k)];
        int64_t total = model.topicCount(slot);
        for (int v = 0; v < model.V(); ++v) {
            const T x = r(k, v);
            const auto cell = [&] {
                return "counts[" + std::to_string(k) + ", " + std::to_string(v) + "] = " + std::to_string(x);
            };
            if constexpr (std::is_signed_v<T>)
                if (x < 0) throw py::value_error(cell() + " is negative");
            if (static_cast<uint64_t>(x) > static_cast<uint64_t>(INT32_MAX))
                throw py::value_error(cell() + " exceeds 2^31 - 1 (n_k is 32-bit)");
            total += static_cast<int64_t>(x);
            if (total > INT32_MAX)
                throw py::value_error("counts: topic " + std::to_string(k) +
                                      " would hold more than 2^31 - 1 words (n_k is 32-bit)");
            flat[static_cast<std::size_t>(slot) * model.V() + v] = static_cast<int32_t>(x);
        }
    }
    return flat;
}

void setTopicModel(PyModel& m, const py::handle& counts) {
    if (!py::isinstance<py::array>(counts))
        throw py::type_error("counts: expected a numpy.ndarray of integers (K x V)");
    auto a = py::reinterpret_borrow<py::array>(counts);
    const char kind = a.dtype().kind();
    if (kind != 'i' && kind != 'u')
        throw py::type_error("counts: expected an integer dtype, found " + py::str(a.dtype()).cast<std::string>());
    BusyGuard guard(m.busy(), "rost.Model");
    Model& model = m.engine().model();
    if (a.ndim() != 2 || a.shape(0) != model.K() || a.shape(1) != model.V())
        throw py::value_error("counts: expected shape (K, V) = (" + std::to_string(model.K()) + ", " +
                              std::to_string(model.V()) + "), found " + py::str(a.attr("shape")).cast<std::string>());
    // What the library refuses here is a value (a total with no room left for the window): ValueError.
    const Status st = model.addTopicCounts(kind == 'u' ? topicCounts<uint64_t>(model, a) : topicCounts<int64_t>(model, a));
    if (!st.ok()) raiseStatus(st, "counts: ", PyExc_ValueError);
}

void bindModelOutputs(py::class_<PyModel>& c) {
    c.def("topics", [](PyModel& m, int64_t t) { return labels(m, t, false); }, py::arg("t"),
          "The current Gibbs sample of each kept word of observation t (int32).")
        .def("ml_topics", [](PyModel& m, int64_t t) { return labels(m, t, true); }, py::arg("t"),
             "The maximum-likelihood topic of each kept word of observation t (int32).")
        .def("words", [](PyModel& m, int64_t t) {
                 return reading(m, [&](const Model& model) {
                     const uint64_t f = m.frameOf(t);
                     std::vector<uint32_t> w(model.observationSize(f));
                     model.observationWords(f, w);
                     return toArray(std::span<const uint32_t>(w));
                 });
             }, py::arg("t"), "The kept words of observation t (int32).")
        .def("positions", [](PyModel& m, int64_t t) {
                 return reading(m, [&](const Model& model) {
                     const uint64_t f = m.frameOf(t);
                     std::vector<Position> p(model.observationSize(f));
                     model.observationPositions(f, p);
                     return toArray(std::span<const Position>(p));
                 });
             }, py::arg("t"), "Their positions, shape (N, 2) (int32).")
        .def("perplexity", &perplexity, py::arg("t") = py::none(),
             "Perplexity of observation t's time step (None: of the whole window); NaN when that holds no words "
             "(an observation without words, or a window without any).")
        .def("surprise", [](PyModel& m, int64_t t) {
                 return reading(m, [&](const Model& model) { return model.observationSurprise(m.frameOf(t)); });
             }, py::arg("t"), "Surprise of observation t, computed when it was added.")
        .def("cell_surprise", [](PyModel& m, int64_t t) {
                 return reading(m, [&](const Model& model) {
                     const Config& cfg = model.config();
                     return toGrid(model.cellSurprise(m.stepOf(t)), cfg.gridHeight(), cfg.gridWidth());
                 });
             }, py::arg("t"), "Surprise per cell of observation t's step, shape (grid rows, grid columns).")
        .def("topic_model", &topicModel,
             "n_k^v: K x V word counts per topic (int32), row i for label i (with growth the A open topics "
             "first, as in topicmodel.csv; closed ones are zero rows after them).")
        .def("topic_weights", [](PyModel& m) {
                 return reading(m, [&](const Model& model) {
                     std::vector<int32_t> w(static_cast<std::size_t>(model.K()));
                     const std::vector<int> slots = slotsInLabelOrder(model);
                     for (int i = 0; i < model.K(); ++i)
                         w[static_cast<std::size_t>(i)] = model.topicCount(slots[static_cast<std::size_t>(i)]);
                     return toArray(std::span<const int32_t>(w));
                 });
             }, "n_k: words per topic (int32), in label order as topic_model()'s rows.")
        .def("set_topic_model", &setTopicModel, py::arg("counts"),
             "Adds K x V counts learned elsewhere to n_k^v (a prior refinement never removes).");
}

void bindModelState(py::class_<PyModel>& c) {
    c.def_property_readonly("config", [](PyModel& m) { return PyConfig{m.settings()}; })
        .def_property_readonly("K", [](PyModel& m) { return m.model().K(); })
        .def_property_readonly("V", [](PyModel& m) { return m.model().V(); })
        .def_property_readonly("active_topics",
                               [](PyModel& m) { return reading(m, [](const Model& x) { return x.activeTopics(); }); },
                               "open topics: K, or with topics_grow the topics that hold a word (labels 0..A-1)")
        .def_property_readonly("observations", [](PyModel& m) { return reading(m, [](const Model& x) { return x.observations(); }); })
        .def_property_readonly("steps", [](PyModel& m) { return reading(m, [](const Model& x) { return x.steps(); }); })
        .def_property_readonly("memory_bytes", [](PyModel& m) { return m.engine().memoryBytes(); })
        .def("timestamps", [](PyModel& m) {
                 BusyGuard guard(m.busy(), "rost.Model");
                 std::vector<int64_t> ts;
                 m.engine().visitWindow([&](const WindowObservation& w, const Model&) { ts.push_back(w.timestamp); });
                 return py::array_t<int64_t>(static_cast<py::ssize_t>(ts.size()), ts.data());
             }, "Time stamps of the observations in the window, oldest first.")
        .def_property_readonly("_last_input_address", [](PyModel& m) { return reinterpret_cast<uintptr_t>(m.lastInput()); },
                               "Address of the last words buffer handed to the library (tests: no copy).")
        .def_property_readonly("_last_positions_address",
                               [](PyModel& m) { return reinterpret_cast<uintptr_t>(m.lastPositions()); },
                               "Address of the last positions buffer handed to the library (tests: no copy).")
        .def("save", &PyModel::save, py::arg("path"), "Writes a checkpoint (atomically); rost run --resume reads it.")
        .def_static("load", &PyModel::load, py::arg("path"),
                    "A Model from a checkpoint (Model.save, rost run --checkpoint). Keywords (rost.Config's) may change "
                    "the refinement and runtime settings; a model setting must repeat the checkpoint's.")
        .def(py::pickle([](PyModel& m) { return m.getState(); }, &PyModel::fromState))
        .def("__repr__", [](PyModel& m) {
            return "rost.Model(K=" + std::to_string(m.model().K()) + ", V=" + std::to_string(m.model().V()) +
                   ", observations=" + std::to_string(m.model().observations()) + ")";
        });
}

} // namespace

void bindModel(py::module_& m) {
    py::class_<PyModel> c(m, "Model", R"doc(The topic model of rost, driven one call at a time:
add_observation(t, words, positions), refine(steps=N) or refine(sweeps=N), then
topics(t), perplexity(t), surprise(t), ... The interpreter lock is released while
it refines; one Python thread at a time may use a Model (another gets RuntimeError).)doc");
    c.def(py::init([](const std::optional<PyConfig>& config) {
              return std::make_unique<PyModel>(config ? config->settings : Settings{});
          }),
          py::arg("config") = py::none())
        .def("add_observation", &PyModel::add, py::arg("t"), py::arg("words"), py::arg("positions") = py::none(),
             "Adds observation t: words (int32, shape (N,)) at positions (int32, shape (N, 2); None: all at (0, 0)). "
             "Taken without a copy; it is not refined (see refine).")
        .def("parallel_refine", &PyModel::parallelRefine, py::arg("threads"), py::arg("sweeps") = 1,
             "rostpy's parallel_refine: `sweeps` batch sweeps on `threads` threads (kept for later refinement); "
             "releases the interpreter lock; the result does not depend on `threads`. Returns the tokens refined.")
        .def("refine", &PyModel::refine, py::kw_only(), py::arg("steps") = py::none(), py::arg("sweeps") = py::none(),
             "Refines `steps` time steps drawn by the Config's sampler (as budget.refines), or `sweeps` batch sweeps "
             "over the window, or (neither) the Config's budget. Releases the interpreter lock. Returns the tokens refined.");
    bindModelOutputs(c);
    bindModelState(c);
}

} // namespace rost::python
