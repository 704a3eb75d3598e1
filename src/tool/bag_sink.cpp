#include "bag_sink.hpp"

#include <unordered_map>

namespace rost::tool {

Status BagSink::open(const std::string& path, const bag::BagFrameSource* source, const Config& model) {
    path_ = path;
    cells_x_ = model.gridWidth();
    cells_y_ = model.gridHeight();
    source_ = path.empty() ? nullptr : source;
    if (!path.empty() && !source) return Status::error("--out.bag needs a bag as the input");
    return {};
}

void BagSink::onObservation(const ObservationRecord& r) {
    if (!source_ || r.rejected) return;
    bridge::FrameResult f;
    f.frame = static_cast<uint64_t>(r.timestamp);
    f.timestamp = r.timestamp;
    f.surprise = static_cast<float>(r.surprise);
    f.active_topics = r.active_topics;  // K, or the open topics with topics.grow
    f.topic_weights = r.topic_share;
    f.cells_x = cells_x_;
    f.cells_y = cells_y_;
    f.cell_topics.reserve(r.dominant.size());
    for (const uint16_t k : r.dominant)
        f.cell_topics.push_back(k == ObservationRecord::kNoTopic ? int16_t{-1} : static_cast<int16_t>(k));
    f.cell_surprise = r.cell_surprise;
    results_.push_back(std::move(f));
    frames_.push_back(r.timestamp);
}

Status BagSink::finish(const std::vector<FrameRow>& rows) {
#if ROST_HAVE_ROS
    if (!source_) return {};
    std::unordered_map<int64_t, const FrameRow*> byFrame;
    for (const FrameRow& row : rows) byFrame[row.timestamp] = &row;
    bag::ResultBagWriter writer;
    if (Status st = writer.open(path_, "/rost/frame"); !st.ok()) return st;
    const std::vector<bag::ImageStamp>& stamps = source_->stamps();
    for (std::size_t i = 0; i < results_.size(); ++i) {
        bridge::FrameResult& f = results_[i];
        const auto row = byFrame.find(frames_[i]);
        if (row != byFrame.end()) f.perplexity = static_cast<float>(row->second->instantaneous);
        if (frames_[i] < 0 || static_cast<std::size_t>(frames_[i]) >= stamps.size()) continue;
        if (Status st = writer.write(f, stamps[static_cast<std::size_t>(frames_[i])]); !st.ok()) return st;
    }
    return writer.commit();
#else
    (void)rows;
    return source_ ? Status::error("--out.bag: this rost was built without ROS (ROST_ROS)") : Status();
#endif
}

} // namespace rost::tool
