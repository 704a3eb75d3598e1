// rost.vision.Mission: a mission over frames (a video, image files or
// folders, camera:N) from Python, by the library's one policy
// (rost/vision/mission.hpp): the words its settings name, the model planned
// for the frames or a checkpoint resumed (its frames skipped), played
// through the engine with its count budget as `rost run` plays a file: the
// same input, seed and settings give rost run's topics.csv and perplexity.csv.

#include <atomic>
#include <memory>
#include <string>
#include <vector>

#include <opencv2/core.hpp>

#include "bindings.hpp"
#include "mission_results.hpp"
#include "rost/checkpoint.hpp"
#include "rost/vision/mission.hpp"

namespace rost::python {

namespace {

std::vector<std::string> inputList(const py::object& inputs) {
    std::vector<std::string> out;
    if (py::isinstance<py::str>(inputs) || py::hasattr(inputs, "__fspath__")) {
        out.push_back(pathArgument(inputs, "rost.vision.Mission: inputs"));
    } else if (py::isinstance<py::list>(inputs) || py::isinstance<py::tuple>(inputs)) {
        for (const py::handle& h : inputs) out.push_back(pathArgument(h, "rost.vision.Mission: inputs"));
    } else {
        throw py::type_error("rost.vision.Mission: inputs: expected a path or a list of paths, found " +
                             std::string(py::str(py::type::handle_of(inputs).attr("__name__"))));
    }
    if (out.empty()) throw py::value_error("rost.vision.Mission: no inputs");
    return out;
}

class PyFrameMission {
public:
    PyFrameMission(const py::object& inputs, const py::object& resume, const py::object& topicmodel,
                   const py::object& vocabulary, int width, int height, int64_t maxFrames, const py::kwargs& settings)
        : max_frames_(maxFrames) {
        checkNotNegative(maxFrames, "rost.vision.Mission: max_frames", "every frame");
        checkNotNegative(width, "rost.vision.Mission: width", "as the input");
        checkNotNegative(height, "rost.vision.Mission: height", "as the input");
        MissionOptions m = missionOptions(settings, "rost.vision.Mission", resume, topicmodel);
        vision::SourceOptions so;  // sized by the library's rule (MissionOptions::frameWidth)
        so.width = m.frameWidth(width);
        so.height = m.frameHeight(height);
        so.max_frames_name = m.names.max_frames;
        const std::vector<std::string> paths = inputList(inputs);
        const std::string vocabularyPath =
            vocabulary.is_none() ? std::string() : pathArgument(vocabulary, "rost.vision.Mission: vocabulary");
        Status st;
        {
            py::gil_scoped_release nogil;  // opening a video and the vocabulary take a while
            st = open(m, paths, so, vocabularyPath);
        }
        if (!st.ok()) raiseStatus(st, "rost.vision.Mission: ");
        std::vector<std::string> files = paths;
        files.push_back(vocabularyPath);
        inputs_ = missionInputs(m, files);
        inputs_.would_read = vision::inputWouldRead;  // an image directory's frames, a glob's files
        settings_ = m.settings;
        settings_.engine = mission_.plan.config;
    }

    // Plays the frames still to play (up to max_frames for the whole mission), then the final sweeps.
    py::dict run() {
        BusyGuard guard(busy_, "rost.vision.Mission");
        if (played_) throw std::runtime_error("rost.vision.Mission.run: this mission was already played");
        played_ = true;
        MissionResults results(*mission_.engine);
        std::string error;
        {
            py::gil_scoped_release nogil;
            error = play(results);
            if (error.empty() && results.why().empty() && !interrupted_) interrupted_ = !results.finish(settings_.final_sweeps);
        }
        if (interrupted_) throw py::error_already_set();
        if (!error.empty()) throw py::value_error("rost.vision.Mission.run: " + error);
        if (!results.why().empty())
            throw py::value_error("rost.vision.Mission.run: a frame was refused: " + results.why());
        return results.toDict();
    }

    void save(const std::string& path) {
        BusyGuard guard(busy_, "rost.vision.Mission");
        checkSavePath(inputs_, "rost.vision.Mission.save", path);
        Status st;
        {
            py::gil_scoped_release nogil;
            st = saveCheckpoint(*mission_.engine, path);
        }
        if (!st.ok()) raiseStatus(st, "rost.vision.Mission.save: ", PyExc_RuntimeError);
    }

    const Settings& settings() const { return settings_; }
    bool resuming() const { return mission_.plan.resuming; }
    int64_t frames() const { return mission_.frames; }
    py::list takeNotes() {
        py::list out;
        for (const std::string& n : notes_) out.append(n);
        notes_.clear();
        return out;
    }
    std::string description() const { return info_.description; }

private:
    Status open(const MissionOptions& m, const std::vector<std::string>& inputs, const vision::SourceOptions& so,
                const std::string& vocabulary) {
        Status st;
        source_ = vision::openFrameSources(inputs, so, st);
        if (!source_) return st;
        info_ = source_->info();
        if (st = words_.open(m.settings.words, vocabulary); !st.ok()) return st;
        MissionInput in;
        in.threads = m.settings.engine.model.threads;
        st = vision::openFrameMission(m, in, info_, words_, max_frames_, mission_);
        keepNotes();
        return st;
    }

    void keepNotes() {
        for (std::string& n : source_->takeNotes()) notes_.push_back(std::move(n));
    }

    // Reads, skips the checkpoint's frames, extracts and takes each up; "" or a read error.
    std::string play(MissionResults& results) {
        vision::Frame frame;
        vision::FrameWords words;
        for (int64_t played = 0; max_frames_ <= 0 || mission_.before + played < max_frames_;) {
            const vision::ReadStatus rs = vision::readMissionFrame(*source_, mission_.skip_through, mission_.before, frame);
            keepNotes();
            if (rs == vision::ReadStatus::End) return {};
            if (rs == vision::ReadStatus::Error) return source_->error();
            words_.extractor->extract(frame.image, words);
            (void)mission_.engine->processNow(ObservationView{frame.index, words.words, words.positions});
            if (!results.observe()) return {};
            ++played;
            if (!keepRunning()) {
                interrupted_ = true;
                return {};
            }
        }
        return {};
    }

    std::unique_ptr<vision::FrameSource> source_;
    vision::SourceInfo info_;
    vision::MissionWords words_;
    vision::FrameMission mission_;
    MissionOptions inputs_;  // its files, absolute (missionInputs)
    Settings settings_;
    std::vector<std::string> notes_;
    int64_t max_frames_ = 0;
    bool played_ = false;
    bool interrupted_ = false;
    std::atomic<bool> busy_{false};
};

} // namespace

void bindVisionMission(py::module_& m) {
    // OpenCV's own errors (out of memory for a huge frame): a MemoryError or a
    // RuntimeError in one line, "OpenCV: ..." (its short text), not its
    // multi-line report with its source file.
    py::register_exception_translator([](std::exception_ptr p) {
        try {
            if (p) std::rethrow_exception(p);
        } catch (const cv::Exception& e) {
            const bool memory = e.code == cv::Error::StsNoMem;
            PyErr_SetString(memory ? PyExc_MemoryError : PyExc_RuntimeError,
                            ((memory ? "out of memory: OpenCV: " : "OpenCV: ") + e.err).c_str());
        }
    });
    py::class_<PyFrameMission> c(m, "Mission", R"doc(A mission over frames, by the library's one policy (the rost tool's
`rost run` is the same session): Mission(inputs, resume=None, topicmodel=None, vocabulary=None,
width=0, height=0, max_frames=0, **settings). inputs: a video, image files or folders (played one
after the other), camera:N; a path or a list. The model is planned for the frames (V from the
extractors, the frame size, ring.steps, max.words) unless given (keywords as rost.Config's);
resume= carries a checkpoint on, its frames skipped. run() plays the frames with the count budget
and returns what rost.Mission.run() does (timestamp: the frame index), as rost run's topics.csv and
perplexity.csv; notes() says what the source skipped or scaled; save(path) writes a checkpoint.)doc");
    c.def(py::init<const py::object&, const py::object&, const py::object&, const py::object&, int, int, int64_t,
                      const py::kwargs&>(),
             py::arg("inputs"), py::arg("resume") = py::none(), py::arg("topicmodel") = py::none(),
             py::arg("vocabulary") = py::none(), py::arg("width") = 0, py::arg("height") = 0, py::arg("max_frames") = 0)
        .def("run", &PyFrameMission::run, "Plays the frames still to play; returns their results (dict).")
        .def("save", [](PyFrameMission& s, const py::object& path) { s.save(pathArgument(path, "rost.vision.Mission.save: path")); },
             py::arg("path"), "Writes the mission's checkpoint (rost run --resume and rost.vision.Mission(resume=) read it).")
        .def("notes", &PyFrameMission::takeNotes, "What the source did that a user should know (taken).")
        .def_property_readonly("resuming", &PyFrameMission::resuming)
        .def_property_readonly("frames", &PyFrameMission::frames, "Frames this mission plays, when known (-1).")
        .def_property_readonly("description", &PyFrameMission::description)
        .def_property_readonly("config", [](const PyFrameMission& s) { return PyConfig{s.settings()}; },
                               "The planned settings (rost.Config).");
    refusePickling(c, "rost.vision.Mission cannot be pickled or copied: save a checkpoint (mission.save(path)) "
                      "and resume from it (rost.vision.Mission(inputs, resume=path) or rost.Model.load(path))");
}

} // namespace rost::python
