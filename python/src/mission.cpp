// rost.Mission: a word stream's mission from Python, by the library's one
// policy (rost/mission.hpp, openStreamMission): the stream read whole, the
// model planned from it (or a checkpoint resumed, its own observations
// skipped), then played through the engine with its count budget, as
// `rost refine` plays it: the same seed, stream and settings give the same
// labels and perplexities as rost refine's topics.csv and perplexity.csv.

#include <atomic>
#include <chrono>
#include <exception>
#include <filesystem>
#include <future>
#include <memory>
#include <string>
#include <vector>

#include "bindings.hpp"
#include "mission_results.hpp"
#include "rost/checkpoint.hpp"
#include "rost/mission.hpp"

namespace rost::python {

namespace {

class PyMission {
public:
    PyMission(const py::object& words, const py::object& positions, const py::object& resume,
              const py::object& topicmodel, int width, int height, const py::kwargs& settings) {
        checkNotNegative(width, "rost.Mission: width", "the largest x + 1");
        checkNotNegative(height, "rost.Mission: height", "the largest y + 1");
        MissionOptions m = missionOptions(settings, "rost.Mission", resume, topicmodel);
        StreamMissionInput in;
        in.words = pathArgument(words, "rost.Mission: words");
        if (!positions.is_none()) in.positions = pathArgument(positions, "rost.Mission: positions");
        in.width = width;  // frame_width/frame_height given as settings: the library's rule
        in.height = height;
        in.base.threads = m.settings.engine.model.threads;
        Status st;
        {
            py::gil_scoped_release nogil;
            st = openStreamMission(m, in, mission_);
        }
        if (!st.ok()) raiseStatus(st, "rost.Mission: ");
        inputs_ = missionInputs(m, {in.words, in.positions});
        settings_ = m.settings;
        settings_.engine = mission_.plan.config;
        final_sweeps_ = settings_.final_sweeps;
    }

    std::size_t size() const { return played_ ? 0 : mission_.todo().size(); }
    bool resuming() const { return mission_.plan.resuming; }
    std::size_t skipped() const { return mission_.skipped; }
    const Settings& settings() const { return settings_; }

    // Plays the observations still to play, then the final sweeps; a mission
    // plays once. Ctrl-C stops it between two observations or two rounds of
    // the sweeps (KeyboardInterrupt; the model keeps what was played: save()
    // writes it).
    py::dict run() {
        BusyGuard guard(busy_, "rost.Mission");
        if (played_) throw std::runtime_error("rost.Mission.run: this mission was already played");
        played_ = true;
        MissionResults results(*mission_.engine);
        bool interrupted = false;
        {
            py::gil_scoped_release nogil;
            for (const StreamObservation& ob : mission_.todo()) {
                (void)mission_.engine->processNow(ObservationView{ob.timestamp, ob.words, ob.positions});
                if (!results.observe()) break;
                if (!keepRunning()) {
                    interrupted = true;
                    break;
                }
            }
            if (!interrupted && results.why().empty()) interrupted = !results.finish(final_sweeps_);
        }
        if (interrupted) throw py::error_already_set();
        if (!results.why().empty())
            throw py::value_error("rost.Mission.run: an observation was refused: " + results.why());
        return results.toDict();
    }

    void save(const std::string& path) {
        BusyGuard guard(busy_, "rost.Mission");
        checkSavePath(inputs_, "rost.Mission.save", path);
        Status st;
        {
            py::gil_scoped_release nogil;
            st = saveCheckpoint(*mission_.engine, path);
        }
        if (!st.ok()) raiseStatus(st, "rost.Mission.save: ", PyExc_RuntimeError);
    }

private:
    StreamMission mission_;
    MissionOptions inputs_;  // its files, absolute (missionInputs)
    Settings settings_;
    int final_sweeps_ = 0;
    bool played_ = false;
    std::atomic<bool> busy_{false};
};

} // namespace

// ---- bindings.hpp and mission_results.hpp ----------------------------------------------

std::string pathArgument(const py::handle& value, const char* what) {
    // An empty one (a script's unset variable) is refused, as the tool refuses `--resume ''`: not read as "none".
    const auto given = [what](std::string path) {
        if (path.empty()) throw py::value_error(std::string(what) + ": no file given (an empty path)");
        return path;
    };
    if (py::isinstance<py::str>(value)) return given(value.cast<std::string>());
    if (py::hasattr(value, "__fspath__")) {
        const py::object p = value.attr("__fspath__")();
        if (py::isinstance<py::str>(p)) return given(p.cast<std::string>());
    }
    throw py::type_error(std::string(what) + ": expected a path (str or os.PathLike), found " +
                         std::string(py::str(py::type::handle_of(value).attr("__name__"))));
}

void raiseStatus(const Status& st, const std::string& prefix, PyObject* otherwise) {
    PyObject* type = otherwise;
    switch (st.kind()) {
    case StatusKind::NotFound: type = PyExc_FileNotFoundError; break;
    case StatusKind::PermissionDenied: type = PyExc_PermissionError; break;
    case StatusKind::IsADirectory: type = PyExc_IsADirectoryError; break;
    case StatusKind::NotADirectory: type = PyExc_NotADirectoryError; break;
    case StatusKind::OsError: type = PyExc_OSError; break;
    case StatusKind::OutOfMemory: type = PyExc_MemoryError; break;
    case StatusKind::Invalid: break;
    }
    throw StatusError(type, prefix + text::printable(st.message()));
}

std::unique_ptr<Engine> makeEngine(const EngineConfig& cfg) {
    Status st;
    std::unique_ptr<Engine> e = Engine::create(cfg, st);
    if (!e) raiseStatus(st, {}, PyExc_ValueError);  // MemoryError for StatusKind::OutOfMemory
    return e;
}

void registerStatusErrors() {
    py::register_exception_translator([](std::exception_ptr p) {
        try {
            if (p) std::rethrow_exception(p);
        } catch (const StatusError& e) {
            PyErr_SetString(e.type(), e.what());
        }
    });
}

MissionOptions missionInputs(const MissionOptions& m, const std::vector<std::string>& inputs) {
    const auto absolute = [](const std::string& p) {
        std::error_code ec;
        const std::filesystem::path a = p.empty() ? std::filesystem::path() : std::filesystem::absolute(p, ec);
        return ec ? p : a.string();
    };
    MissionOptions out;
    out.resume = absolute(m.resume);
    out.in_topicmodel = absolute(m.in_topicmodel);
    for (const std::string& in : inputs) out.inputs.push_back(absolute(in));
    return out;
}

void checkSavePath(const MissionOptions& inputs, const char* what, const std::string& path) {
    // The stream, its positions, frames or vocabulary, or the starting topic model would be replaced: refused.
    if (Status st = checkMissionOutput(inputs, what, path); !st.ok()) raiseStatus(st, {}, PyExc_RuntimeError);
}

bool keepRunning() {
    py::gil_scoped_acquire gil;
    return PyErr_CheckSignals() == 0;
}

MissionOptions missionOptions(const py::kwargs& settings, const char* what, const py::object& resume,
                              const py::object& topicmodel) {
    MissionOptions m;
    applySettings(m.settings, settings, what);
    for (const auto& [k, v] : settings) m.given.emplace_back(findSetting(py::str(k).cast<std::string>())->key);
    if (!resume.is_none()) m.resume = pathArgument(resume, (std::string(what) + ": resume").c_str());
    if (!topicmodel.is_none()) m.in_topicmodel = pathArgument(topicmodel, (std::string(what) + ": topicmodel").c_str());
    m.names.setting = [](const SettingSpec& s) { return paramName(s); };
    m.names.given = [](const SettingSpec& s, const std::string& v) { return paramName(s) + "=" + v; };
    m.names.leave = [](const SettingSpec& s) { return paramName(s); };
    m.names.key = [](const SettingSpec& s) { return paramName(s); };
    m.names.resume = "resume";
    m.names.topicmodel = "topicmodel";
    m.names.positions = "positions";
    m.names.max_frames = "max_frames";
    return m;
}

MissionResults::MissionResults(Engine& engine) : engine_(engine), records_(engine, 4) {
    if (!records_.status().ok()) throw std::runtime_error(text::printable(records_.status().message()));
    const uint64_t first = engine.model().observations();
    records_.setFirstObservation(first);
    records_.setFinalSink(
        [this, first](const FinalLabels& f) {
            if (f.where.observation < first) return;  // the checkpoint's, played before
            const auto i = static_cast<std::size_t>(f.where.observation - first);
            if (labels_.size() <= i) labels_.resize(i + 1);
            labels_[i].assign(f.labels.begin(), f.labels.begin() + f.n);
        },
        false);
}

MissionResults::~MissionResults() { (void)engine_.publishResults(0); }

bool MissionResults::observe() {
    records_.drain();
    const MissionRejection& r = records_.rejection();
    if (!r.any) return true;
    why_ = std::string(toString(r.error)) + " at word " + std::to_string(r.index);
    return false;
}

bool MissionResults::finish(int sweeps) {
    if (sweeps <= 0) {
        records_.finish(sweeps);
        return true;
    }
    // The sweeps on a thread of their own; this one, which Python's signals
    // reach, looks for Ctrl-C every 20 ms while they run and stops them
    // between two rounds (KeyboardInterrupt, as between two observations).
    std::atomic<bool> stop{false};
    std::future<void> sweeping = std::async(std::launch::async, [&] { records_.finish(sweeps, &stop); });
    bool interrupted = false;
    while (sweeping.wait_for(std::chrono::milliseconds(20)) != std::future_status::ready) {
        if (!interrupted && !keepRunning()) {
            interrupted = true;
            stop.store(true, std::memory_order_relaxed);
        }
    }
    sweeping.get();  // an exception of the sweeps, rethrown here
    return !interrupted;
}

py::dict MissionResults::toDict() const {
    const std::vector<MissionRow>& rows = records_.rows();
    const auto n = static_cast<py::ssize_t>(rows.size());
    const auto cells = static_cast<py::ssize_t>(records_.cells());
    py::array_t<int64_t> ts(n);
    py::array_t<double> inst(n), fin(n), plugin(n), surprise(n);
    py::array_t<int32_t> topics(n);
    py::array_t<float> surpriseCells({n, cells});
    auto c = surpriseCells.mutable_unchecked<2>();
    for (py::ssize_t i = 0; i < n; ++i) {
        const MissionRow& r = rows[static_cast<std::size_t>(i)];
        ts.mutable_at(i) = r.timestamp;
        inst.mutable_at(i) = r.instantaneous;
        fin.mutable_at(i) = r.final;
        plugin.mutable_at(i) = r.plugin;
        topics.mutable_at(i) = r.topics;
        surprise.mutable_at(i) = r.surprise;
        for (py::ssize_t j = 0; j < cells; ++j)
            c(i, j) = j < static_cast<py::ssize_t>(r.cell_surprise.size()) ? r.cell_surprise[static_cast<std::size_t>(j)] : 0.f;
    }
    py::list z;
    for (py::ssize_t i = 0; i < n; ++i) {
        const auto j = static_cast<std::size_t>(i);
        z.append(toArray(j < labels_.size() ? std::span<const uint16_t>(labels_[j]) : std::span<const uint16_t>()));
    }
    py::dict out;
    out["timestamp"] = ts;
    out["instantaneous"] = inst;
    out["final"] = fin;
    out["plugin"] = plugin;
    out["topics"] = topics;
    out["surprise"] = surprise;
    out["surprise_cells"] = surpriseCells;
    out["labels"] = z;
    return out;
}

void bindMission(py::module_& m) {
    py::class_<PyMission> c(m, "Mission", R"doc(A word stream's mission, by the library's one policy (the rost tool's
`rost refine` is the same session): Mission(words, positions=None, resume=None, topicmodel=None,
width=0, height=0, **settings). The stream (words.csv, positions.csv) is read whole; a new mission
takes V, the frame size, ring.steps and max.words from it unless given (keywords as rost.Config's);
resume= carries a checkpoint on (its model is fixed: a model keyword with another value raises
ValueError naming it; its observations in the stream are skipped). run() plays the rest through the
engine with its count budget and returns a dict of numpy arrays: timestamp, instantaneous, final
(perplexities as rost refine's perplexity.csv), plugin, topics, surprise, surprise_cells
(observations x cells, as surprise_cells.csv), labels (a list: each observation's final
maximum-likelihood topics, as topics.csv). save(path) writes a checkpoint.)doc");
    c.def(py::init<const py::object&, const py::object&, const py::object&, const py::object&, int, int,
                      const py::kwargs&>(),
             py::arg("words"), py::arg("positions") = py::none(), py::arg("resume") = py::none(),
             py::arg("topicmodel") = py::none(), py::arg("width") = 0, py::arg("height") = 0)
        .def("run", &PyMission::run, "Plays the observations still to play; returns their results (dict).")
        .def("save", [](PyMission& s, const py::object& path) { s.save(pathArgument(path, "rost.Mission.save: path")); },
             py::arg("path"),
             "Writes the mission's checkpoint (rost run/refine --resume and rost.Model.load read it); "
             "the mission's own input files are refused (RuntimeError).")
        .def("__len__", &PyMission::size, "Observations still to play.")
        .def_property_readonly("resuming", &PyMission::resuming)
        .def_property_readonly("skipped", &PyMission::skipped, "The checkpoint's observations skipped in the stream.")
        .def_property_readonly("config", [](const PyMission& s) { return PyConfig{s.settings()}; },
                               "The planned settings (rost.Config).");
    refusePickling(c, "rost.Mission cannot be pickled or copied: save a checkpoint (mission.save(path)) and "
                      "resume from it (rost.Mission(words, resume=path) or rost.Model.load(path))");
}

} // namespace rost::python
