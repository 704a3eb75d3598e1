// rost.merge_topic_models: the library's merge of topic models into one
// global set (rost/merge.hpp; docs/fleet.md), for rost.fleet and scripts.

#include <cstdint>
#include <limits>
#include <string>
#include <vector>

#include "bindings.hpp"
#include "rost/merge.hpp"

namespace rost::python {

namespace {

// A model argument: a path (topicmodel.csv or a checkpoint) or a 2-D integer array (K x V).
TopicCounts topicCounts(const py::handle& model, std::size_t index) {
    if (py::isinstance<py::str>(model) || py::hasattr(model, "__fspath__")) {
        TopicCounts c;
        const std::string path = pathArgument(model, "models");
        if (Status st = readTopicCounts(path, c); !st.ok()) raiseStatus(st);
        return c;
    }
    const py::array a = py::array::ensure(model);
    if (!a || a.ndim() != 2 || (a.dtype().kind() != 'i' && a.dtype().kind() != 'u'))
        throw py::type_error("models[" + std::to_string(index) +
                             "]: expected a path or a 2-D integer numpy array (K x V counts)");
    // Unsigned counts past int64 would be cast to negative ones: named as they are here. The
    // rest go to the library, whose checkModel refuses a count past what a topic model holds.
    if (a.dtype().kind() == 'u' && a.size() > 0) {
        const auto u = py::array_t<uint64_t, py::array::c_style | py::array::forcecast>::ensure(a);
        for (py::ssize_t i = 0; i < u.size(); ++i)
            if (u.data()[i] > static_cast<uint64_t>(std::numeric_limits<int64_t>::max()))
                throw py::value_error("model " + std::to_string(index) + ": count of topic " +
                                      std::to_string(i / a.shape(1)) + ", word " + std::to_string(i % a.shape(1)) +
                                      " is " + std::to_string(u.data()[i]) +
                                      ", more than a topic model file holds (2^31 - 1)");
    }
    const auto counts = py::array_t<int64_t, py::array::c_style | py::array::forcecast>::ensure(a);
    TopicCounts c;
    c.K = static_cast<int>(a.shape(0));
    c.V = static_cast<int>(a.shape(1));
    c.counts.assign(counts.data(), counts.data() + counts.size());
    return c;
}

struct PyMerged {
    MergedTopics merged;
};

} // namespace

void bindMerge(py::module_& m) {
    py::class_<PyMerged> c(m, "MergedTopics", "Topic models merged into one global set (rost.merge_topic_models).");
    c.def_property_readonly("global_counts", [](const PyMerged& p) {
         const TopicCounts& g = p.merged.global;
         py::array_t<int64_t> out({g.K, g.V});
         std::copy(g.counts.begin(), g.counts.end(), out.mutable_data());
         return out;
     }, "The global model: one row per global topic, V counts each (int64).")
        .def_property_readonly("lifting", [](const PyMerged& p) {
            py::list out;
            for (const auto& l : p.merged.lifting) out.append(py::array_t<int32_t>(static_cast<py::ssize_t>(l.size()), l.data()));
            return out;
        }, "For each model, its topics' global topics (int32; -1 for a topic that holds no word).")
        .def_property_readonly("distance", [](const PyMerged& p) {
            py::list out;
            for (const auto& d : p.merged.distance) out.append(py::array_t<double>(static_cast<py::ssize_t>(d.size()), d.data()));
            return out;
        }, "For each model, each topic's Hellinger distance to the global topic it joined (0: it opened one; -1: empty).")
        .def("topicmodel_csv", [](const PyMerged& p) { return formatTopicCountsCsv(p.merged.global); },
             "The global model as topicmodel.csv text (rost merge's).")
        .def("lifting_csv", [](const PyMerged& p, const std::optional<std::vector<std::string>>& names) {
            if (names && names->size() != p.merged.lifting.size())
                throw py::value_error("names: " + std::to_string(names->size()) + " names for " +
                                      std::to_string(p.merged.lifting.size()) + " models");
            return formatLiftingCsv(p.merged, names ? std::span<const std::string>(*names) : std::span<const std::string>());
        }, py::arg("names") = py::none(), "lifting.csv text (model,local,global); names: the models' names, else 0, 1, ...")
        .def("__repr__", [](const PyMerged& p) {
            return "rost.MergedTopics(" + std::to_string(p.merged.lifting.size()) + " models -> " +
                   std::to_string(p.merged.global.K) + " global topics, V = " + std::to_string(p.merged.global.V) + ")";
        });
    m.def("merge_topic_models", [](const py::sequence& models, double threshold, double beta) {
        // One path is a sequence of characters: refused, not read as many one-letter paths.
        if (py::isinstance<py::str>(models) || py::isinstance<py::bytes>(models))
            throw py::type_error("rost.merge_topic_models: models is a list of paths or arrays, not one path "
                                 "(write [path])");
        std::vector<TopicCounts> in;
        for (std::size_t i = 0; i < models.size(); ++i) in.push_back(topicCounts(models[i], i));
        MergeOptions o;
        o.threshold = threshold;
        o.beta = beta;
        PyMerged out;
        if (Status st = mergeTopicModels(in, o, out.merged); !st.ok()) throw py::value_error(text::printable(st.message()));
        return out;
    }, py::arg("models"), py::kw_only(), py::arg("threshold") = MergeOptions{}.threshold,
       py::arg("beta") = MergeOptions{}.beta,
       R"doc(Matches the topics of several models into one global set (rost merge; docs/fleet.md).

models: paths (topicmodel.csv files or checkpoints) or 2-D integer arrays (K x V counts), in order; the
first model's topics open the global set. threshold: the Hellinger distance in [0, 1] up to which a topic
joins a global topic. beta: smoothing of the distributions compared. Returns a MergedTopics.)doc");
}

} // namespace rost::python
