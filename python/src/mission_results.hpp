#pragma once

// What rost.Mission and rost.vision.Mission return of a mission played in
// Python: each observation's results as `rost refine` and `rost run` write
// them (perplexity.csv's instantaneous and final perplexities, topics.csv's
// final labels) and its surprise. Filled on the calling thread while the
// engine takes each observation up synchronously (Engine::processNow).

#include <cstdint>
#include <vector>

#include "bindings.hpp"
#include "rost/engine.hpp"
#include "rost/mission.hpp"

namespace rost::python {

// A mission's options from Python keywords (rost.Config's; ValueError naming
// one that is unknown or out of range), every setting and option spelled as
// a keyword in messages ("K=8 differs from m.ckpt's K = 4 (...; leave K out)").
MissionOptions missionOptions(const py::kwargs& settings, const char* what, const py::object& resume,
                              const py::object& topicmodel);

// A path argument as text: str or os.PathLike (TypeError naming the argument otherwise).
std::string pathArgument(const py::handle& value, const char* what);

// Between two observations of a run: false when Ctrl-C (or another signal
// handler) raised, so the run stops there (briefly takes the interpreter lock).
bool keepRunning();

class MissionResults {
public:
    // The engine's observations from its next one on; sets its eviction hook
    // (final labels of observations that leave the window) until finish().
    explicit MissionResults(Engine& engine);
    ~MissionResults();
    MissionResults(const MissionResults&) = delete;
    MissionResults& operator=(const MissionResults&) = delete;

    // After each processNow: its row; a step's instantaneous perplexity is
    // taken as the next step opens. False (and why()) when the model refused it.
    bool observe(const ObservationResult& r);
    const std::string& why() const noexcept { return why_; }
    // The end of the stream: the last step's instantaneous perplexity at the
    // end of its budget, then `sweeps` final sweeps, then the window's final
    // perplexities and labels.
    void finish(int sweeps);
    // timestamp, instantaneous, final, surprise (numpy) and labels (a list).
    py::dict toDict() const;

private:
    void final(uint64_t observation, int64_t step, const Model& model);

    Engine& engine_;
    uint64_t first_;
    std::vector<int64_t> ts_, step_;
    std::vector<double> inst_, fin_, surprise_;
    std::vector<std::vector<uint16_t>> labels_;
    std::string why_;
};

} // namespace rost::python
