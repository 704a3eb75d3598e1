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
#include "rost/mission_records.hpp"

namespace rost::python {

// A mission's input files (`m`'s resume and topicmodel, and `inputs`) made
// absolute, so that its save(path) can be checked against them whatever the
// current directory is by then.
MissionOptions missionInputs(const MissionOptions& m, const std::vector<std::string>& inputs);
// save(path)'s check (checkMissionOutput): an empty path raises ValueError,
// one of the mission's inputs RuntimeError, both starting with `what`.
void checkSavePath(const MissionOptions& inputs, const char* what, const std::string& path);

// A mission's options from Python keywords (rost.Config's; ValueError naming
// one that is unknown or out of range), every setting and option spelled as
// a keyword in messages ("K=8 differs from m.ckpt's K = 4 (...; leave K out)").
MissionOptions missionOptions(const py::kwargs& settings, const char* what, const py::object& resume,
                              const py::object& topicmodel);

// Between two observations of a run: false when Ctrl-C (or another signal
// handler) raised, so the run stops there (briefly takes the interpreter lock).
bool keepRunning();

class MissionResults {
public:
    // The engine's observations from its next one on, read through the
    // library's MissionRecords (the rules `rost refine` and `rost run` write
    // by): the engine publishes its records, drained after each processNow.
    explicit MissionResults(Engine& engine);
    ~MissionResults();
    MissionResults(const MissionResults&) = delete;
    MissionResults& operator=(const MissionResults&) = delete;

    // After each processNow: its row. False (and why()) when the model refused it.
    bool observe();
    const std::string& why() const noexcept { return why_; }
    // The end of the stream: MissionRecords::finish. False when Ctrl-C (or
    // another signal handler) raised during the final sweeps: they stop,
    // the Python error is set, and the records are not to be used.
    [[nodiscard]] bool finish(int sweeps);
    // timestamp, instantaneous, final, plugin, topics, surprise (numpy),
    // surprise_cells (numpy, observations x cells) and labels (a list).
    py::dict toDict() const;

private:
    Engine& engine_;
    MissionRecords records_;
    std::vector<std::vector<uint16_t>> labels_;
    std::string why_;
};

} // namespace rost::python
