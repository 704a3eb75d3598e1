#include "stages.hpp"

#include <algorithm>
#include <cstdio>
#include <thread>

#include "progress.hpp"
#include "rost/text_io.hpp"
#include "rost/topic_model_csv.hpp"

namespace rost::tool {

Status WordsStage::open(const RunOptions& o) {
    vision::SourceOptions so;
    so.width = o.width;
    so.height = o.height;
    so.camera_width = o.camera_width;
    so.camera_height = o.camera_height;
    so.camera_format = o.camera_format;
    for (const auto& in : o.inputs) live = live || vision::isCameraInput(in);
    if (Status st = openSource(o, so); !st.ok()) return st;
    info = source->info();
    return words.open(o.model.settings.words, o.vocabulary);
}

void WordsStage::printNotes() const {
    for (const std::string& n : source->takeNotes()) std::fprintf(stderr, "rost: %s\n", text::printable(n).c_str());
}

// A bag (its image topic, read with rosbag) or the vision library's sources.
Status WordsStage::openSource(const RunOptions& o, const vision::SourceOptions& so) {
    const bool anyBag = std::any_of(o.inputs.begin(), o.inputs.end(), bag::isBagInput);
    if (!anyBag && !o.out_bag.empty()) return Status::error("--out.bag needs a bag as the input");
    if (!anyBag && !o.topic.empty()) return Status::error("--topic needs a bag as the input");
    Status st;
    if (!anyBag) {
        source = vision::openFrameSources(o.inputs, so, st);
        return source ? Status() : st;
    }
    if (o.inputs.size() != 1) return Status::error("a bag is read alone: give one INPUT.bag");
#if ROST_HAVE_ROS
    const std::string& path = o.inputs.front();
    if (o.topic.empty()) {
        std::vector<std::string> topics;
        if (st = bag::listImageTopics(path, topics); !st.ok()) return st;
        std::string m = path;
        m += topics.empty() ? ": no image topics in the bag" : ": which image topic? give --topic TOPIC, one of:";
        m += bag::imageTopicLines(topics);
        return Status::error(m);
    }
    auto b = bag::openBagSource(path, o.topic, so, st);
    if (!b) return st;
    bag = b.get();
    source = std::move(b);
    return {};
#else
    return Status::error(o.inputs.front() + ": this rost was built without ROS (ROST_ROS): bags cannot be read");
#endif
}

// The library's frame mission decides (rost/vision/mission.hpp): the engine
// made for the input, or the checkpoint's carried on, by one policy.
Status RunEngine::open(const RunOptions& o, const WordsStage& w, bool realtime) {
    vision::FrameMission m;
    if (Status st = vision::openFrameMission(missionOptions(o.model), missionInput(o.model, realtime), w.info, w.words,
                                             o.max_frames, m);
        !st.ok())
        return st;
    resuming = m.plan.resuming;
    resumed = m.plan.checkpoint;
    refinementChanged = m.plan.refinement_changed;
    ec = m.plan.config;
    V = ec.model.V;
    skipThrough = m.skip_through;
    before = m.before;
    frames = m.frames;
    engine = std::move(m.engine);
    return {};
}

void RunEngine::describe(const RunOptions& o, const WordsStage& w, bool realtime) const {
    const double mib = static_cast<double>(engine->memoryBytes()) / (1024.0 * 1024.0);
    std::fprintf(stderr,
                 "rost: %s\nrost: V = %d, K = %d, %s of %d px, ring of %d steps, max.words %d, %s budget %s, "
                 "model memory %.1f MiB%s\n",
                 text::printable(w.info.description).c_str(), V, ec.model.K, text::counted(ec.model.cellsPerStep(), "cell").c_str(), ec.model.cell_space,
                 ec.model.ring_steps, ec.model.max_words_per_frame, toString(ec.strategy.kind),
                 budgetText(ec.budget).c_str(),
                 mib, realtime ? ", realtime" : "");
    if (resuming)
        std::fprintf(stderr, "rost: resuming %s at observation %llu (frame %lld)%s%s\n", text::printable(o.model.resume).c_str(),
                     static_cast<unsigned long long>(resumed.observations), static_cast<long long>(resumed.last_timestamp),
                     w.live ? "; camera frames are numbered after it" : "; earlier frames are skipped",
                     refinementChanged ? "; refinement settings changed (not bit for bit)" : "");
}

bool Capture::readNext() {
    const vision::ReadStatus rs = vision::readMissionFrame(*w_.source, e_.skipThrough, e_.before, frame_);
    if (rs == vision::ReadStatus::Error) read_error_ = w_.source->error();
    return rs == vision::ReadStatus::Ok;
}

// File input at its own pace: each frame is due its time's step after the
// one before (a video's frames' own times, a variable frame rate kept;
// images 10 a second, vision::kImagePeriodUs), the first at t0. A step
// back in time, or forward by more than 5 s and 10 nominal periods (joined
// recordings, a stream's clock reset, a bag's paused recorder), is played
// as one period: a jump in the times never stalls the run. The wait is
// cut into slices that end on Ctrl-C.
void Capture::pace(Clock::time_point t0) {
    const int64_t period = vision::nominalPeriodUs(w_.info.fps);
    if (captured() == 0) {
        due_ = t0;
    } else {
        int64_t step = frame_.timestamp_us - last_us_;
        if (step < 0 || (step > 5'000'000 && step > 10 * period)) step = period;
        due_ += std::chrono::microseconds(step);
    }
    last_us_ = frame_.timestamp_us;
    for (Clock::time_point now = Clock::now(); now < due_ && !interrupted(); now = Clock::now())
        std::this_thread::sleep_until(std::min(due_, now + std::chrono::milliseconds(100)));
}

bool Capture::produceOne(bool pacing, Clock::time_point t0) {
    if (max_frames_ > 0 && e_.before + captured() >= max_frames_) return false;
    const bool more = readNext();
    w_.printNotes();  // images skipped as too small, on the way to this one
    if (!more) return false;
    if (pacing && !w_.info.live) pace(t0);
    w_.words.extractor->extract(frame_.image, words_);
    captured_.fetch_add(1, std::memory_order_relaxed);
    FrameSlot* s = ring_.beginPush();
    if (!s) {  // the writer is behind: skip this frame entirely (counted)
        dropped_.fetch_add(1, std::memory_order_relaxed);
        return true;
    }
    s->frame = frame_.index;
    s->timestamp_us = frame_.timestamp_us;
    s->words = words_.size();
    s->orb = words_.orb;
    s->intensity = words_.intensity;
    s->hue = words_.hue;
    frame_.image.copyTo(s->image);
    ObservationView view;
    view.timestamp = frame_.index;
    view.words = words_.words;
    view.positions = words_.positions;
    s->pushed = e_.engine->tryPush(view);
    ring_.commitPush();
    return true;
}

} // namespace rost::tool
