// The C++20 side of rost::bridge (bridge.hpp): settings, word extraction and
// the engine for the ROS node, behind a header that compiles as C++17.

#include "bridge.hpp"

#include <algorithm>
#include <atomic>
#include <cstdio>

#include <opencv2/imgproc.hpp>

#include "rost/checkpoint.hpp"
#include "rost/engine.hpp"
#include "rost/mission.hpp"
#include "rost/settings.hpp"
#include "rost/text_io.hpp"
#include "rost/vision/frame_source.hpp"
#include "rost/vision/mission.hpp"
#include "rost/vision/words.hpp"

namespace rost::bridge {

std::vector<ParamSpec> settingParams() {
    std::vector<ParamSpec> out;
    for (const SettingSpec& s : settingSpecs()) {
        ParamSpec p;
        p.key = std::string(s.key);
        p.param = paramName(s);
        p.def = std::string(s.def);
        p.range = settingRange(s);
        p.doc = std::string(s.doc);
        p.model = s.group == SettingGroup::Model;
        out.push_back(std::move(p));
    }
    return out;
}

std::string closestParam(const std::string& name) {
    const SettingSpec* near = closestSetting(name);
    return near ? paramName(*near) : std::string();
}

std::string printable(const std::string& text) { return rost::text::printable(text); }

struct NodeSettings::Impl {
    Settings settings;
    std::vector<std::string> given;
};

NodeSettings::NodeSettings() : impl_(std::make_unique<Impl>()) {}
NodeSettings::~NodeSettings() = default;
NodeSettings::NodeSettings(const NodeSettings& other) : impl_(std::make_unique<Impl>(*other.impl_)) {}
NodeSettings& NodeSettings::operator=(const NodeSettings& other) {
    *impl_ = *other.impl_;
    return *this;
}

// The node names a setting by its private parameter: ~eta, ~cell_space.
// (Appended, not "~" + name: GCC 12 at -O3 warns falsely on that; -Wrestrict.)
namespace {
std::string privateName(std::string_view param) {
    std::string out(1, '~');
    out += param;
    return out;
}
std::string spelled(const SettingSpec& spec) { return privateName(paramName(spec)); }
} // namespace

std::string NodeSettings::set(const std::string& name, const std::string& value) {
    const SettingSpec* spec = findSetting(name);
    if (!spec) return privateName(name) + ": no such parameter";
    if (auto p = setSettingText(impl_->settings, *spec, value)) return p->describe(spelled);
    impl_->given.emplace_back(spec->key);
    return {};
}
std::string NodeSettings::validate() const {
    const auto p = checkSettings(impl_->settings);
    return p ? p->describe(spelled) : std::string();
}
std::string NodeSettings::value(const std::string& name) const { return settingValue(impl_->settings, name); }
bool NodeSettings::given(const std::string& key) const {
    return std::find(impl_->given.begin(), impl_->given.end(), key) != impl_->given.end();
}

struct Pipeline::Impl {
    Settings settings;
    NodeSettings givenSettings;
    EngineConfig ec;
    Options options;
    vision::MissionWords extractors;  // the extractors and their vocabulary (rost/vision/mission.hpp)
    std::unique_ptr<Engine> engine;
    std::unique_ptr<CheckpointWriter> checkpoints;
    vision::FrameWords words;
    cv::Mat resized;
    PublishedResult record;

    MissionPlan plan;
    int64_t before = 0;  // frames the checkpoint holds (FrameMission::before)

    // The model's counts copied for a reader (requestModel, takeModel).
    std::vector<int32_t> captured;        // K x V, sized by makeEngine
    std::atomic<int> capture{kNoCopy};    // kNoCopy -> kAsked (reader) -> kCopied (refiner) -> kNoCopy (reader)
    std::atomic<uint64_t> taken_up{0};    // observations the hook has seen (refiner)
    uint64_t accepted_before = 0;         // observations accepted before the hook was set
    static constexpr int kNoCopy = 0, kAsked = 1, kCopied = 2;
    void copyCounts(const Model& model, int32_t* out, bool bySlot) const noexcept;
    uint64_t accepted() const noexcept;

    std::string makeExtractor();
    MissionOptions missionOptions() const;
    std::string makeEngine(const NodeSettings& given, int width, int height);
};

std::string Pipeline::Impl::makeExtractor() { return extractors.open(settings.words, options.vocabulary).message(); }

// The library's frame mission (rost/vision/mission.hpp) decides, as for the
// rost tool's run: ~resume's checkpoint fixes the model (checked at
// start-up, in create()), its refinement settings stay unless given, the
// runtime ones are the node's. The first image fixes the frame size of a new
// model unless ~frame_width and ~frame_height are given; a resumed model
// keeps the checkpoint's (images are resized to it). V and max.words come
// from the extractors, unless given.
MissionOptions Pipeline::Impl::missionOptions() const {
    MissionOptions m;
    m.settings = settings;
    m.given = givenSettings.impl().given;
    m.resume = options.resume;
    m.inputs = {options.vocabulary};
    m.names.setting = spelled;
    m.names.given = [](const SettingSpec& s, const std::string& v) { return spelled(s) + " = " + v; };
    m.names.leave = spelled;
    m.names.resume = "~resume";
    return m;
}

std::string Pipeline::Impl::makeEngine(const NodeSettings& given, int width, int height) {
    const MissionOptions mission = missionOptions();
    vision::SourceInfo info;  // the image topic: live, of unknown length
    info.description = "the image topic";
    // Sized as every source is (one side given alone keeps the first image's aspect ratio).
    vision::SourceOptions asked;
    if (given.given("frame.width")) asked.width = settings.engine.model.frame_width;
    if (given.given("frame.height")) asked.height = settings.engine.model.frame_height;
    std::vector<std::string> notes;  // the first image was brought within the model's size already (ensureEngine)
    if (Status st = vision::chooseSize(asked, width, height, info, notes); !st.ok()) return st.message();
    info.live = true;
    if (!options.resume.empty()) info.width = info.height = 0;  // the checkpoint's: images are resized to it
    MissionInput in;
    in.threads = settings.engine.model.threads;
    in.flags = settings.engine.flags;
    vision::FrameMission m;
    if (Status st = vision::openFrameMission(mission, in, info, extractors, 0, m); !st.ok()) return st.message();
    plan = m.plan;
    before = m.before;
    ec = plan.config;
    engine = std::move(m.engine);
    Status st;
    if (Status ps = engine->publishResults(options.result_slots); !ps.ok()) return ps.message();
    captured.assign(static_cast<std::size_t>(ec.model.K) * static_cast<std::size_t>(ec.model.V), 0);
    accepted_before = accepted();
    // On the refining thread after each observation (taken up whole): a copy
    // of the counts when a reader asked for one, then the count of
    // observations seen (release: the model's writes before it).
    engine->setObservationHook([this](const ObservationResult&, const Model& model) {
        if (capture.load(std::memory_order_acquire) == kAsked) {
            copyCounts(model, captured.data(), true);
            capture.store(kCopied, std::memory_order_release);
        }
        taken_up.fetch_add(1, std::memory_order_release);
    });
    record = engine->makeResult();
    if (!options.checkpoint.empty()) {
        checkpoints = CheckpointWriter::create(*engine, options.checkpoint, st);
        if (!checkpoints) return "~checkpoint: " + st.message();
        engine->captureCheckpoints(checkpoints.get(), settings.checkpoint_every);
    }
    return {};
}

Pipeline::Pipeline(std::unique_ptr<Impl> impl) : impl_(std::move(impl)) {}
Pipeline::~Pipeline() {
    if (impl_ && impl_->engine) impl_->engine->stop(Engine::StopMode::Discard);
}

std::unique_ptr<Pipeline> Pipeline::create(const NodeSettings& settings, const Options& options,
                                           std::string& error) {
    auto impl = std::make_unique<Impl>();
    impl->settings = settings.impl().settings;
    impl->givenSettings = settings;
    impl->options = options;
    if (const std::string bad = settings.validate(); !bad.empty()) return error = bad, nullptr;
    // ~resume: what the checkpoint fixes against the parameters, at start-up (not at the first image).
    if (Status st = checkMission(impl->missionOptions(), impl->plan); !st.ok()) return error = st.message(), nullptr;
    // ~checkpoint: writable, and not the vocabulary it would replace (~resume's own file may be carried on).
    if (Status st = checkMissionOutput(impl->missionOptions(), "~checkpoint", options.checkpoint); !st.ok())
        return error = st.message(), nullptr;
    if (error = impl->makeExtractor(); !error.empty()) return nullptr;
    return std::unique_ptr<Pipeline>(new Pipeline(std::move(impl)));
}

std::string Pipeline::open(int width, int height) {
    if (impl_->engine) return "the engine is already made";
    std::string e = impl_->makeEngine(impl_->givenSettings, width, height);
    if (!e.empty()) impl_->engine.reset();
    return e;
}
bool Pipeline::opened() const { return impl_->engine != nullptr; }
bool Pipeline::sizeGiven() const { return impl_->givenSettings.given("frame.width") && impl_->givenSettings.given("frame.height"); }

std::string Pipeline::start() { return impl_->engine->start().message(); }
void Pipeline::stop() { impl_->engine->stop(Engine::StopMode::Drain); }

int Pipeline::K() const { return impl_->ec.model.K; }
int Pipeline::V() const { return impl_->ec.model.V; }
int Pipeline::width() const { return impl_->ec.model.frame_width; }
int Pipeline::height() const { return impl_->ec.model.frame_height; }
int Pipeline::cellsX() const { return impl_->ec.model.gridWidth(); }
int Pipeline::cellsY() const { return impl_->ec.model.gridHeight(); }
int Pipeline::cellSpace() const { return impl_->ec.model.cell_space; }
int64_t Pipeline::framesBefore() const { return impl_->before; }

bool Pipeline::push(const cv::Mat& image, int64_t timestamp) {
    Impl& m = *impl_;
    const cv::Mat* in = &image;
    if (image.cols != width() || image.rows != height()) {
        cv::resize(image, m.resized, cv::Size(width(), height()), 0, 0, cv::INTER_AREA);
        in = &m.resized;
    }
    if (!m.extractors.extractor->extract(*in, m.words)) return false;
    ObservationView view;
    view.timestamp = timestamp;
    view.words = m.words.words;
    view.positions = m.words.positions;
    return m.engine->tryPush(view);
}

bool Pipeline::canPush() { return impl_->engine->canPush(); }

bool Pipeline::next(FrameResult& out) {
    Impl& m = *impl_;
    if (!m.engine->readResult(m.record)) return false;
    const ObservationResult& r = m.record.result;
    const int K = this->K(), cells = cellsX() * cellsY();
    out.frame = r.sequence;
    out.timestamp = r.timestamp;
    out.perplexity = static_cast<float>(r.perplexity);
    out.surprise = static_cast<float>(r.surprise);
    out.active_topics = r.active_topics;  // K, or the open topics with topics.grow
    out.cells_x = cellsX();
    out.cells_y = cellsY();
    out.topic_weights.assign(static_cast<std::size_t>(K), 0.0f);
    out.cell_topics.assign(static_cast<std::size_t>(cells), -1);
    out.cell_surprise.assign(static_cast<std::size_t>(cells), 0.0f);
    const bool have = m.record.histograms.size() >= static_cast<std::size_t>(cells) * K;
    double total = 0.0;
    for (int c = 0; have && c < cells; ++c) {
        int32_t best = 0;
        for (int k = 0; k < K; ++k) {
            const int32_t n = m.record.histograms[static_cast<std::size_t>(c) * K + k];
            out.topic_weights[k] += static_cast<float>(n);
            total += n;
            if (n > best) best = n, out.cell_topics[c] = static_cast<int16_t>(k);
        }
    }
    if (total > 0)
        for (float& w : out.topic_weights) w = static_cast<float>(w / total);
    const std::size_t ns = std::min(m.record.cell_surprise.size(), out.cell_surprise.size());
    std::copy_n(m.record.cell_surprise.begin(), ns, out.cell_surprise.begin());
    out.topic_slots.assign(m.record.topic_slots.begin(), m.record.topic_slots.end());
    return true;
}

void liftLabels(const std::vector<uint16_t>& topic_slots, const std::vector<int32_t>& lifting, int K,
                std::vector<int32_t>& byLabel) {
    byLabel.assign(static_cast<std::size_t>(std::max(K, 0)), -1);
    for (std::size_t l = 0; l < byLabel.size() && l < topic_slots.size(); ++l)
        if (topic_slots[l] < lifting.size()) byLabel[l] = lifting[topic_slots[l]];
}

uint64_t Pipeline::dropped() const { return impl_->engine->counters().dropped() + impl_->engine->resultsLost(); }

std::string Pipeline::saveCheckpoint() {
    Impl& m = *impl_;
    if (!m.checkpoints) return "no ~checkpoint parameter: nowhere to save";
    const bool was = m.engine->running();
    m.engine->stop(Engine::StopMode::Drain);
    const Status st = m.checkpoints->finish();  // a periodic save in progress is superseded by this one
    if (was)
        if (Status s2 = m.engine->start(); !s2.ok()) return s2.message();
    return st.ok() ? std::string() : st.message() + " (" + m.options.checkpoint + ")";
}

std::string Pipeline::getTopicModel(std::vector<int32_t>& counts) const {
    Impl& m = *impl_;
    const bool was = m.engine->running();
    m.engine->stop(Engine::StopMode::Drain);
    counts.resize(static_cast<std::size_t>(m.ec.model.K) * static_cast<std::size_t>(m.ec.model.V));
    m.copyCounts(m.engine->model(), counts.data(), false);
    return was ? m.engine->start().message() : std::string();
}

// K rows of V counts: by slot (~topic_model: row k is slot k, so a lifting
// made from it names topics, not labels), or in label order
// (Model::slotsInLabelOrder; ~get_topic_model, as topicmodel.csv): row i is
// the topic the frames label i, the closed slots' zero rows last. On the
// refining thread (the observation hook): no allocation.
void Pipeline::Impl::copyCounts(const Model& model, int32_t* out, bool bySlot) const noexcept {
    const int K = ec.model.K, V = ec.model.V;
    uint16_t slots[1024];
    model.slotsInLabelOrder({slots, static_cast<std::size_t>(K)});
    std::size_t i = 0;
    for (int r = 0; r < K; ++r)
        for (int v = 0; v < V; ++v) out[i++] = model.topicWordCount(bySlot ? r : slots[r], v);
}

// Observations the engine accepted (pushed and not dropped): each is taken
// up by the refiner, which calls the hook after it.
uint64_t Pipeline::Impl::accepted() const noexcept {
    const EngineCounters c = engine->counters();
    return c.pushed - c.dropped();
}

void Pipeline::requestModel() noexcept {
    int expected = Impl::kNoCopy;
    impl_->capture.compare_exchange_strong(expected, Impl::kAsked, std::memory_order_acq_rel);
}

bool Pipeline::takeModel(std::vector<int32_t>& counts) {
    Impl& m = *impl_;
    if (m.capture.load(std::memory_order_acquire) != Impl::kCopied) return false;
    counts.assign(m.captured.begin(), m.captured.end());
    m.capture.store(Impl::kNoCopy, std::memory_order_release);
    return true;
}

bool Pipeline::copyModelIfIdle(std::vector<int32_t>& counts) {
    Impl& m = *impl_;
    if (m.taken_up.load(std::memory_order_acquire) != m.accepted() - m.accepted_before) return false;
    if (takeModel(counts)) return true;  // made by the last observation's hook
    counts.resize(m.captured.size());
    m.copyCounts(m.engine->model(), counts.data(), true);
    int expected = Impl::kAsked;  // nothing left to copy it for the request
    m.capture.compare_exchange_strong(expected, Impl::kNoCopy, std::memory_order_acq_rel);
    return true;
}

std::string Pipeline::addTopicModel(int K, int V, const std::vector<int32_t>& counts) {
    Impl& m = *impl_;
    if (K != this->K() || V != this->V())
    {
        std::string e = "the model has K = ";
        e += std::to_string(this->K()) + ", V = " + std::to_string(this->V()) + "; the request has K = " +
             std::to_string(K) + ", V = " + std::to_string(V);
        return e;
    }
    const bool was = m.engine->running();
    m.engine->stop(Engine::StopMode::Drain);
    // Row i is the topic labelled i (as ~get_topic_model gives them): into its slot.
    Model& model = m.engine->model();
    std::vector<uint16_t> slots(static_cast<std::size_t>(K));
    model.slotsInLabelOrder(slots);
    std::vector<int32_t> bySlot(counts.size(), 0);
    if (counts.size() == static_cast<std::size_t>(K) * static_cast<std::size_t>(V))
        for (int r = 0; r < K; ++r)
            std::copy_n(counts.begin() + static_cast<std::ptrdiff_t>(r) * V, V,
                        bySlot.begin() + static_cast<std::ptrdiff_t>(slots[static_cast<std::size_t>(r)]) * V);
    Status st = model.addTopicCounts(bySlot);
    if (m.checkpoints) m.checkpoints->invalidate();
    if (was)
        if (Status s2 = m.engine->start(); !s2.ok() && st.ok()) st = s2;
    return st.message();
}

} // namespace rost::bridge
