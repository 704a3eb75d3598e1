#pragma once

// `rost run FILE.bag --topic T --out.bag OUT.bag`: each frame's results as
// rost_msgs/FrameTopics on /rost/frame, stamped with its image's stamp and
// frame_id, so they replay beside the vehicle's other logs. The records are
// kept as they are drained (a few hundred bytes a frame); the bag is written
// at the end, when each frame's instantaneous perplexity is known, to a
// temporary file renamed into place.

#include <string>
#include <vector>

#include "bag.hpp"
#include "collector.hpp"
#include "outputs.hpp"

namespace rost::tool {

class BagSink {
public:
    // Nothing to do unless `path` is given (then `source` is the bag read).
    Status open(const std::string& path, const bag::BagFrameSource* source, const Config& model);
    bool active() const noexcept { return source_ != nullptr; }
    void onObservation(const ObservationRecord& r);
    // Writes every frame kept, with its perplexity from `rows`, and renames the bag into place.
    Status finish(const std::vector<FrameRow>& rows);

private:
    std::string path_;
    const bag::BagFrameSource* source_ = nullptr;
    int cells_x_ = 0, cells_y_ = 0;
    std::vector<bridge::FrameResult> results_;
    std::vector<int64_t> frames_;  // input frame index of each result
};

} // namespace rost::tool
