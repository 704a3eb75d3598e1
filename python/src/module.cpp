// The extension module rost._rost; the package rost (python/rost/) re-exports it.

#include "bindings.hpp"
#include "rost/version.hpp"

PYBIND11_MODULE(_rost, m) {
    namespace rp = rost::python;
    m.doc() = "rost: realtime online spatiotemporal topic models (docs/python.md)";
    m.attr("__version__") = rost::version();
    m.attr("version_string") = rost::versionString();
    rp::registerStatusErrors();
    rp::bindConfig(m);
    rp::bindModel(m);
    rp::bindEngine(m);
    rp::bindMission(m);
    rp::bindMerge(m);
    pybind11::module_ text = m.def_submodule("text", "The core's text I/O layer (rost/text_io.hpp), for rost.io");
    rp::bindText(text);
#ifdef ROST_PYTHON_VISION
    pybind11::module_ vision = m.def_submodule("vision", "Visual words of frames (OpenCV): rost.vision");
    rp::bindVision(vision);
    rp::bindVisionMission(vision);
#endif
}
