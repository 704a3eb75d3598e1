#include "stages.hpp"

#include <algorithm>
#include <cstdio>
#include <thread>

#include "rost/topic_model_csv.hpp"

namespace rost::tool {

namespace {
std::string fmtMs(double v) {
    char buf[64];
    std::snprintf(buf, sizeof buf, "%.3g ms", v);
    return buf;
}
} // namespace

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
    Status st;

    extractors = vision::ExtractorConfig::from(o.model.settings.words);
    if (extractors.orb) {
        if (o.vocabulary.empty()) {
            vocabulary = vision::defaultVocabulary(st);
        } else {
            auto v = std::make_shared<vision::Vocabulary>();
            st = vision::Vocabulary::load(o.vocabulary, *v);
            vocabulary = std::move(v);
        }
        if (!st.ok()) return st;
    }
    extractor = vision::WordExtractor::create(extractors, vocabulary, st);
    if (!extractor) return st;
    return {};
}

void WordsStage::printNotes() const {
    for (const std::string& n : source->takeNotes()) std::fprintf(stderr, "rost: %s\n", n.c_str());
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
        for (const std::string& t : topics) m += "\n  " + t;
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

// Frames the checkpoint already has: a file's are skipped (its frame index
// is at most the checkpoint's last time stamp); a camera's are numbered
// after them. --max-frames counts the whole mission: with --resume, the
// checkpoint's frames too.
Status RunEngine::countFrames(const RunOptions& o, const WordsStage& w) {
    skipThrough = resuming && resumed.observations > 0 ? resumed.last_timestamp : -1;
    before = skipThrough + 1;
    frames = w.info.frames;
    if (o.max_frames > 0) frames = frames > 0 ? std::min(frames, o.max_frames) : o.max_frames;
    if (frames > 0) {
        frames -= before;
        if (frames <= 0)
            return Status::error(w.info.description + ": nothing to resume with: " + o.model.resume +
                                 " has every frame up to " + std::to_string(skipThrough) +
                                 (o.max_frames > 0 ? " (--max-frames " + std::to_string(o.max_frames) + " counts the mission)"
                                                   : ""));
    }
    return {};
}

// The library's mission session decides (rost/mission.hpp): the engine made
// for the input, or the checkpoint's carried on, by one policy.
Status RunEngine::open(const RunOptions& o, const WordsStage& w, bool realtime) {
    const MissionOptions mission = missionOptions(o.model);
    MissionPlan plan;
    if (Status st = checkMission(mission, plan); !st.ok()) return st;
    resuming = plan.resuming;
    resumed = plan.checkpoint;
    MissionInput in = missionInput(o.model, realtime);
    in.width = w.info.width;
    in.height = w.info.height;
    // The words' ids must mean what they meant: the extractors' V (the
    // checkpoint's unless -V; a -V must hold them). A checkpoint does not
    // record which vocabulary made its words: another of the same size is not
    // detected (docs/tool.md).
    in.V = w.wordsV();
    in.vocabulary = true;
    const vision::WordLayout& l = w.extractor->layout();
    in.words_detail = "ORB " + std::to_string(l.orb_size) + " + intensity " + std::to_string(l.intensity_size) +
                      " + hue " + std::to_string(l.hue_size);
    if (resuming)  // frames of the checkpoint's size and words of its V first: nothing else matters otherwise
        if (Status st = planMission(mission, in, plan); !st.ok()) return st;
    if (Status st = countFrames(o, w); !st.ok()) return st;
    in.length = frames;
    in.max_words = vision::maxWordsPerFrame(w.extractors, w.info.width, w.info.height);
    if (!resuming)
        if (Status st = planMission(mission, in, plan); !st.ok()) return st;
    ec = plan.config;
    V = ec.model.V;
    refinementChanged = plan.refinement_changed;
    Status st;
    engine = openMission(mission, plan, st);
    return st;
}

void RunEngine::describe(const RunOptions& o, const WordsStage& w, bool realtime) const {
    const double mib = static_cast<double>(engine->memoryBytes()) / (1024.0 * 1024.0);
    std::fprintf(stderr,
                 "rost: %s\nrost: V = %d, K = %d, %d cells of %d px, ring of %d steps, max.words %d, %s budget %s, "
                 "model memory %.1f MiB%s\n",
                 w.info.description.c_str(), V, ec.model.K, ec.model.cellsPerStep(), ec.model.cell_space,
                 ec.model.ring_steps, ec.model.max_words_per_frame, toString(ec.strategy.kind),
                 ec.budget.kind == BudgetKind::Time ? fmtMs(ec.budget.ms).c_str()
                                                    : (std::to_string(ec.budget.count) + " refines").c_str(),
                 mib, realtime ? ", realtime" : "");
    if (resuming)
        std::fprintf(stderr, "rost: resuming %s at observation %llu (frame %lld)%s%s\n", o.model.resume.c_str(),
                     static_cast<unsigned long long>(resumed.observations), static_cast<long long>(resumed.last_timestamp),
                     w.live ? "; camera frames are numbered after it" : "; earlier frames are skipped",
                     refinementChanged ? "; refinement settings changed (not bit for bit)" : "");
}

bool Capture::readNext() {
    for (;;) {
        const vision::ReadStatus rs = w_.source->read(frame_);
        if (rs == vision::ReadStatus::End) return false;
        if (rs == vision::ReadStatus::Error) {
            read_error_ = w_.source->error();
            return false;
        }
        if (w_.info.live) frame_.index += e_.before;  // after the checkpoint's frames
        else if (frame_.index <= e_.skipThrough) continue;  // in the checkpoint already
        return true;
    }
}

// File input at its own frame rate: frame i is due at t0 + i / fps (i
// counted from the first frame this run plays).
void Capture::pace(Clock::time_point t0) const {
    const double fps = w_.info.fps > 0 ? w_.info.fps : 10.0;
    const auto due = t0 + std::chrono::duration_cast<Clock::duration>(std::chrono::duration<double>(
                              static_cast<double>(frame_.index - e_.before) / fps));
    std::this_thread::sleep_until(due);
}

bool Capture::produceOne(bool pacing, Clock::time_point t0) {
    if (max_frames_ > 0 && e_.before + captured() >= max_frames_) return false;
    const bool more = readNext();
    w_.printNotes();  // images skipped as too small, on the way to this one
    if (!more) return false;
    if (pacing && !w_.info.live) pace(t0);
    w_.extractor->extract(frame_.image, words_);
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
