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

Status RunEngine::checkV(const RunOptions& o, const WordsStage& w) const {
    const int wordsV = w.wordsV();
    const bool vGiven = o.model.isGiven("V");
    // The word ids must mean what they meant: the extractors must produce the
    // checkpoint's V (unless -V, then equal to it, made room for more). The
    // checkpoint does not record which vocabulary made them: a different one
    // of the same size is not detected (docs/tool.md).
    if (resuming && (V < wordsV || (V != wordsV && !vGiven)))
        return Status::error("--resume " + o.model.resume + ": its model has V = " + std::to_string(V) +
                             " words but the extractors produce " + std::to_string(wordsV) +
                             " (use the vocabulary and word options of the run that made it)");
    if (V < wordsV)
        return Status::error("-V " + std::to_string(V) + " is smaller than the " + std::to_string(wordsV) +
                             " words the extractors produce (ORB " + std::to_string(w.extractor->layout().orb_size) +
                             " + intensity " + std::to_string(w.extractor->layout().intensity_size) + " + hue " +
                             std::to_string(w.extractor->layout().hue_size) + ")");
    return {};
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

Status RunEngine::open(const RunOptions& o, const WordsStage& w, bool realtime) {
    // --resume: the checkpoint's model, for frames of its size.
    resuming = !o.model.resume.empty();
    Status st;
    if (resuming) {
        st = resumeConfig(o.model, w.info.width, w.info.height, realtime, ec, resumed, refinementChanged);
        if (!st.ok()) return st;
    }
    V = resuming ? ec.model.V : o.model.isGiven("V") ? o.model.settings.engine.model.V : w.wordsV();
    if (st = checkV(o, w); !st.ok()) return st;
    if (st = countFrames(o, w); !st.ok()) return st;
    if (!resuming) {
        const uint64_t maxWords = vision::maxWordsPerFrame(w.extractors, w.info.width, w.info.height);
        st = makeEngineConfig(o.model, w.info.width, w.info.height, V, frames, maxWords, realtime, ec);
        if (!st.ok()) return st;
    }
    engine = Engine::create(ec, st);
    if (!engine) return st;
    if (resuming) {
        st = loadResumed(o.model, refinementChanged, *engine);
        if (!st.ok()) return st;
    }
    if (!o.model.in_topicmodel.empty()) {
        st = loadTopicModelCsv(o.model.in_topicmodel, engine->model());
        if (!st.ok()) return Status::error("--in.topicmodel: " + st.message());
    }
    return {};
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
    if (!readNext()) return false;
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

// ---- rost refine: the word stream --------------------------------------------

Status StreamStage::read(const RefineOptions& o) {
    WordStreamLimits limits;
    const Config& given = o.model.settings.engine.model;
    limits.vocabulary = resuming ? static_cast<uint32_t>(ec.model.V) : o.model.isGiven("V") ? static_cast<uint32_t>(given.V) : 0;
    limits.width = resuming ? ec.model.frame_width : o.width;
    limits.height = resuming ? ec.model.frame_height : o.height;
    // max.words (the checkpoint's, or set): longer observations are an error
    // here; otherwise max.words is the longest observation's size (configFromData).
    if (resuming || o.model.isGiven("max.words"))
        limits.max_words = static_cast<uint32_t>(std::max(1, resuming ? ec.model.max_words_per_frame : given.max_words_per_frame));
    else
        limits.max_words = static_cast<uint32_t>(settingSpec("max.words").hi);
    if (Status st = readWordStream(o.words, o.positions, limits, ws); !st.ok()) return st;
    if (ws.observations.empty()) return Status::error(o.words + ": no observations (the file has no data lines)");
    if (!ws.has_positions)  // no positions: every word at (0, 0)
        for (auto& ob : ws.observations) ob.positions.assign(ob.words.size(), Position{});
    return {};
}

// What the checkpoint already has. Either this is the stream it was made
// from (its first `observations` observations are the checkpoint's: skip
// them), or what came after it (every time stamp later than the checkpoint's last).
Status StreamStage::resumeSkip(const RefineOptions& o) {
    if (!ws.has_positions && (ec.model.frame_width != 1 || ec.model.frame_height != 1))
        return Status::error(o.words + ": no --positions, but " + o.model.resume + " models " +
                             std::to_string(ec.model.frame_width) + "x" + std::to_string(ec.model.frame_height) +
                             " frames: give the words' positions");
    const auto n = static_cast<std::size_t>(resumed.observations);
    const auto& obs = ws.observations;
    const std::string last = std::to_string(resumed.last_timestamp);
    if (n == 0) {
        skipped = 0;
    } else if (n <= obs.size() && obs[n - 1].timestamp == resumed.last_timestamp) {
        skipped = n;
    } else if (obs.front().timestamp > resumed.last_timestamp) {
        skipped = 0;
    } else if (n > obs.size()) {
        return Status::error(o.words + ": " + std::to_string(obs.size()) + " observations, fewer than the " +
                             std::to_string(n) + " " + o.model.resume +
                             " holds, and not the ones after them (they would start after time stamp " + last + ")");
    } else {
        return Status::error(o.words + ": neither the stream " + o.model.resume + " was made from (its observation " +
                             std::to_string(n) + " has time stamp " + last + ", here " +
                             std::to_string(obs[n - 1].timestamp) + ") nor what came after it (the first time stamp here, " +
                             std::to_string(obs.front().timestamp) + ", is not after " + last + ")");
    }
    if (skipped == ws.observations.size())
        return Status::error(o.words + ": nothing to resume with: its " + std::to_string(skipped) +
                             " observations are all in " + o.model.resume);
    return {};
}

// V and the frame geometry from the data unless given.
Status StreamStage::configFromData(const RefineOptions& o) {
    uint32_t maxWord = 0;
    int32_t maxX = 0, maxY = 0;
    uint64_t longest = 0;
    for (const auto& ob : ws.observations) {
        longest = std::max<uint64_t>(longest, ob.words.size());
        for (uint32_t w : ob.words) maxWord = std::max(maxWord, w);
        for (const Position& p : ob.positions) maxX = std::max(maxX, p.x), maxY = std::max(maxY, p.y);
    }
    const int V = o.model.isGiven("V") ? o.model.settings.engine.model.V : static_cast<int>(maxWord) + 1;
    int width = o.width > 0 ? o.width : maxX + 1;
    int height = o.height > 0 ? o.height : maxY + 1;
    if (!ws.has_positions) width = height = 1;  // one cell per time step (a temporal topic model)
    return makeEngineConfig(o.model, width, height, V, static_cast<int64_t>(ws.observations.size()), longest, false,
                            ec);
}

Status StreamStage::makeEngine(const RefineOptions& o) {
    Status st;
    engine = Engine::create(ec, st);
    if (!engine) return st;
    if (resuming) {
        if (st = loadResumed(o.model, refinementChanged, *engine); !st.ok()) return st;
        if (!o.quiet)
            std::fprintf(stderr, "rost: resuming %s at observation %llu (time stamp %lld); %zu observations skipped%s\n",
                         o.model.resume.c_str(), static_cast<unsigned long long>(resumed.observations),
                         static_cast<long long>(resumed.last_timestamp), skipped,
                         refinementChanged ? "; refinement settings changed (not bit for bit)" : "");
    }
    if (!o.model.in_topicmodel.empty()) {
        st = loadTopicModelCsv(o.model.in_topicmodel, engine->model());
        if (!st.ok()) return Status::error("--in.topicmodel: " + st.message());
    }
    return {};
}

Status StreamStage::open(const RefineOptions& o) {
    // --resume: the checkpoint fixes V and the frame size before the words are read.
    resuming = !o.model.resume.empty();
    Status st;
    if (resuming) {
        st = resumeConfig(o.model, o.width, o.height, false, ec, resumed, refinementChanged);
        if (!st.ok()) return st;
    }
    if (st = read(o); !st.ok()) return st;
    st = resuming ? resumeSkip(o) : configFromData(o);
    if (!st.ok()) return st;
    return makeEngine(o);
}

} // namespace rost::tool
