// rost.vision: visual words of frames cv2 reads (numpy H x W x 3 uint8 BGR,
// viewed in place), and ORB vocabularies.

#include <memory>
#include <string>
#include <vector>

#include <opencv2/features2d.hpp>
#include <opencv2/imgproc.hpp>

#include "bindings.hpp"
#include "rost/vision/frame_source.hpp"
#include "rost/vision/vocabulary.hpp"
#include "rost/vision/words.hpp"

namespace rost::python {

namespace {

using vision::Vocabulary;

struct PyVocabulary {
    std::shared_ptr<const Vocabulary> vocabulary;
};

// A cv::Mat header over the numpy array's pixels (no copy): 8-bit, H x W x 3
// (BGR) or H x W (grey), pixels contiguous within a row.
cv::Mat viewFrame(const py::handle& h, py::array& keep) {
    if (!py::isinstance<py::array>(h))
        throw py::type_error("frame: expected a numpy.ndarray (H x W x 3 uint8 BGR, as cv2 reads it), found " +
                             py::str(py::type::handle_of(h).attr("__name__")).cast<std::string>());
    keep = py::reinterpret_borrow<py::array>(h);
    if (!keep.dtype().attr("__eq__")(py::dtype::of<uint8_t>()).cast<bool>())
        throw py::type_error("frame: expected dtype uint8, found " + py::str(keep.dtype()).cast<std::string>());
    const int channels = keep.ndim() == 3 ? static_cast<int>(keep.shape(2)) : 1;
    if ((keep.ndim() != 2 && keep.ndim() != 3) || (channels != 3 && channels != 1))
        throw py::value_error("frame: expected shape (H, W, 3) (BGR) or (H, W) (grey), found " +
                              py::str(keep.attr("shape")).cast<std::string>());
    if (keep.shape(0) < 1 || keep.shape(1) < 1 || keep.shape(0) > 65535 || keep.shape(1) > 65535)
        throw py::value_error("frame: " + py::str(keep.attr("shape")).cast<std::string>() +
                              " is empty or larger than 65535 pixels a side");
    // rost::vision's frame size rule: the same refusal as the tool's and the node's.
    if (const std::string why = vision::frameTooSmall(static_cast<int>(keep.shape(1)), static_cast<int>(keep.shape(0)));
        !why.empty())
        throw py::value_error("frame: " + why);
    const bool packed = keep.strides(1) == channels && (keep.ndim() == 2 || keep.strides(2) == 1) &&
                        keep.strides(0) >= keep.shape(1) * channels;
    if (!packed)
        throw py::value_error("frame: pixels are not contiguous within a row (use numpy.ascontiguousarray)");
    return cv::Mat(static_cast<int>(keep.shape(0)), static_cast<int>(keep.shape(1)), channels == 3 ? CV_8UC3 : CV_8UC1,
                   const_cast<void*>(keep.data()), static_cast<std::size_t>(keep.strides(0)));
}

PyVocabulary loadVocabulary(const std::string& path) {
    Vocabulary v;
    if (Status st = Vocabulary::load(path, v); !st.ok()) raiseStatus(st);
    return {std::make_shared<const Vocabulary>(std::move(v))};
}

PyVocabulary defaultVocabulary() {
    Status st;
    auto v = vision::defaultVocabulary(st);
    if (!v) throw std::runtime_error(text::printable(st.message()));
    return {std::move(v)};
}

// ORB descriptors of every frame (the extractor's ORB settings), then k-majority.
PyVocabulary train(const py::iterable& frames, uint32_t words, int features, int iterations, uint64_t seed,
                   int threads) {
    if (words < 1 || words > Vocabulary::kMaxWords || features < 1 || iterations < 1 || threads < 1)
        throw py::value_error("rost.vision.Vocabulary.train: words in [1, 1000000], features, iterations and threads >= 1");
    const vision::ExtractorConfig ex;
    cv::Ptr<cv::ORB> orb = cv::ORB::create(features, ex.orb_scale_factor, ex.orb_levels, 31, 0, 2,
                                           cv::ORB::HARRIS_SCORE, 31, ex.orb_fast_threshold);
    std::vector<vision::Descriptor> data;
    std::size_t n = 0;
    for (const py::handle f : frames) {
        py::array keep;
        cv::Mat image = viewFrame(f, keep), grey, desc;
        std::vector<cv::KeyPoint> kps;
        {
            py::gil_scoped_release nogil;
            if (image.channels() == 3)
                cv::cvtColor(image, grey, cv::COLOR_BGR2GRAY);
            else
                grey = image;
            orb->detectAndCompute(grey, cv::noArray(), kps, desc);
        }
        for (int r = 0; r < desc.rows; ++r) data.push_back(vision::Descriptor::fromBytes(desc.ptr<uint8_t>(r)));
        ++n;
    }
    vision::KMajorityOptions o;
    o.words = words;
    o.max_iterations = iterations;
    o.seed = seed;
    o.threads = threads;
    std::vector<vision::Descriptor> centres;
    Status st;
    {
        py::gil_scoped_release nogil;
        st = vision::trainKMajority(data, o, centres);
    }
    if (!st.ok()) throw py::value_error("rost.vision.Vocabulary.train: " + text::printable(st.message()));
    const std::string note = "trained from Python (rost.vision.Vocabulary.train): " + std::to_string(data.size()) +
                             " ORB descriptors of " + std::to_string(n) + " frames, seed " + std::to_string(seed);
    return {std::make_shared<const Vocabulary>(std::move(centres), note)};
}

class PyExtractor {
public:
    PyExtractor(const py::object& vocabulary, const py::kwargs& kw) {
        Settings s;
        applySettings(s, kw, "rost.vision.WordExtractor", true);
        const vision::ExtractorConfig cfg = vision::ExtractorConfig::from(s.words);
        if (Status st = cfg.validate(); !st.ok()) throw py::value_error("rost.vision.WordExtractor: " + text::printable(st.message()));
        std::shared_ptr<const Vocabulary> v;
        if (Status st = vision::unusedVocabulary(cfg, "vocabulary"); !st.ok() && !vocabulary.is_none())
            throw py::value_error("rost.vision.WordExtractor: " + text::printable(st.message()));  // before a path is read
        if (vocabulary.is_none()) {
            if (cfg.orb) v = defaultVocabulary().vocabulary;
        } else if (py::isinstance<PyVocabulary>(vocabulary)) {
            v = vocabulary.cast<const PyVocabulary&>().vocabulary;
        } else {
            v = loadVocabulary(pathArgument(vocabulary, "rost.vision.WordExtractor: vocabulary")).vocabulary;
        }
        Status st;
        ex_ = vision::WordExtractor::create(cfg, v, st);
        if (!ex_) throw py::value_error("rost.vision.WordExtractor: " + text::printable(st.message()));
    }

    py::tuple operator()(const py::handle& frame) {
        BusyGuard guard(busy_, "rost.vision.WordExtractor");
        py::array keep;
        const cv::Mat image = viewFrame(frame, keep);
        last_input_ = image.data;
        {
            py::gil_scoped_release nogil;
            ex_->extract(image, out_);
        }
        return py::make_tuple(toArray(std::span<const uint32_t>(out_.words)),
                              toArray(std::span<const Position>(out_.positions)));
    }
    uint32_t vocabularySize() const { return ex_->vocabularySize(); }
    py::dict layout() const {
        const vision::WordLayout& l = ex_->layout();
        py::dict d;
        d["orb"] = py::make_tuple(l.orb_offset, l.orb_size);
        d["intensity"] = py::make_tuple(l.intensity_offset, l.intensity_size);
        d["hue"] = py::make_tuple(l.hue_offset, l.hue_size);
        return d;
    }
    uintptr_t lastInput() const { return reinterpret_cast<uintptr_t>(last_input_); }

private:
    std::unique_ptr<vision::WordExtractor> ex_;
    vision::FrameWords out_;
    std::atomic<bool> busy_{false};
    const void* last_input_ = nullptr;
};

} // namespace

void bindVision(py::module_& m) {
    py::class_<PyVocabulary> vocabulary(m, "Vocabulary", "ORB visual words (the .rostvoc format).");
    vocabulary.def_static("load", [](const py::object& path) { return loadVocabulary(pathArgument(path, "rost.vision.Vocabulary.load: path")); },
                    py::arg("path"))
        .def_static("default", &defaultVocabulary, "The vocabulary shipped with rost.")
        .def_static("train", &train, py::arg("frames"), py::arg("words") = vision::KMajorityOptions{}.words,
                    py::arg("features") = vision::kTrainingFeatures,
                    py::arg("iterations") = vision::KMajorityOptions{}.max_iterations,
                    py::arg("seed") = vision::KMajorityOptions{}.seed, py::arg("threads") = vision::KMajorityOptions{}.threads,
                    "Trains a vocabulary (k-majority) on the ORB descriptors of frames (numpy BGR or grey).")
        .def("save", [](const PyVocabulary& v, const py::object& path) {
                 check(v.vocabulary->save(pathArgument(path, "rost.vision.Vocabulary.save: path")));
             },
             py::arg("path"))
        .def("__len__", [](const PyVocabulary& v) { return v.vocabulary->size(); })
        .def_property_readonly("note", [](const PyVocabulary& v) { return v.vocabulary->note(); });
    refusePickling(vocabulary, "rost.vision.Vocabulary cannot be pickled or copied: save it (vocabulary.save(path)) "
                               "and read it back with rost.vision.Vocabulary.load(path)");
    py::class_<PyExtractor> extractor(m, "WordExtractor", R"doc(Visual words of a frame: extractor(frame) -> (words, positions).
frame: numpy H x W x 3 uint8 BGR (as cv2 reads it) or H x W grey, taken without a copy.
words: int32 (N,); positions: int32 (N, 2) as (x, y). Keywords: the word settings
(words_orb, words_intensity, words_hue, orb_features, orb_fast, orb_search, orb_probes, thumb_cell).)doc");
    extractor.def(py::init<const py::object&, const py::kwargs&>(), py::arg("vocabulary") = py::none())
        .def("__call__", &PyExtractor::operator(), py::arg("frame"))
        .def_property_readonly("vocabulary_size", &PyExtractor::vocabularySize, "V a model of these words needs.")
        .def_property_readonly("layout", &PyExtractor::layout, "(offset, size) of each extractor's word ids.")
        .def_property_readonly("_last_input_address", &PyExtractor::lastInput);
    refusePickling(extractor, "rost.vision.WordExtractor cannot be pickled or copied: build another with the same "
                              "vocabulary and word settings (rost.vision.WordExtractor(vocabulary, **settings))");
}

} // namespace rost::python
