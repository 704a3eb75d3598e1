#pragma once

// rost as the ROS parts see it. Debian 12's ROS 1 message headers do not
// compile as C++20 (their allocators use std::allocator<T>::rebind), so the
// node (rost_node) and the tool's bag reader and writer are C++17
// translation units; this header is all of rost they include. It compiles as
// C++17 (the node's translation units include it as C++17, so the build
// checks) and hides the C++20 library behind plain structs and an opaque
// pipeline (bridge.cpp, compiled as C++20).

#include <cstddef>
#include <cstdint>
#include <memory>
#include <string>
#include <vector>

namespace cv {
class Mat;
}

namespace rost::bridge {

// One setting of the schema (rost/settings_schema.hpp) as a ROS parameter.
struct ParamSpec {
    std::string key;    // "cell.space"
    std::string param;  // "cell_space": dots and dashes as underscores (rost::paramName)
    std::string def;    // default, text form ("" for a budget kind not in force)
    std::string range;  // "[1, 65536]", "keep|subtract", "true|false"
    std::string doc;
    bool model = false;  // fixes a checkpoint's state (group Model)
};
// Every setting, in the schema's order.
std::vector<ParamSpec> settingParams();
// The parameter an unknown name most likely meant ("etta" -> "eta"); "" if none.
std::string closestParam(const std::string& name);

// Text as rost's errors print it (rost::text::printable): control bytes and
// bytes of no UTF-8 character escaped, so a path or a frame_id sent by
// another node is one line in the log and cannot drive a terminal.
std::string printable(const std::string& text);

// Every setting of rost in one value (rost::Settings), set by key or parameter name.
class NodeSettings {
public:
    NodeSettings();
    ~NodeSettings();
    NodeSettings(const NodeSettings& other);
    NodeSettings& operator=(const NodeSettings& other);

    // "" when set; else the error, naming the parameter as the node spells
    // it: "~alpha: expected a finite number, found 'x'".
    std::string set(const std::string& name, const std::string& value);
    // "" when every value is in range and the combination is valid; else the
    // first problem: "~eta = 2, allowed [0, 1]".
    std::string validate() const;
    std::string value(const std::string& name) const;
    // Keys set with set() (the node derives V and the frame size unless set).
    bool given(const std::string& key) const;

    struct Impl;
    const Impl& impl() const { return *impl_; }

private:
    std::unique_ptr<Impl> impl_;
};

// One processed frame, as rost_msgs/FrameTopics carries it.
struct FrameResult {
    uint64_t frame = 0;      // index of the frame among those handed to the engine
    int64_t timestamp = 0;   // as pushed (the node: the image's stamp in ns)
    float perplexity = 0.0f;
    float surprise = 0.0f;
    int32_t active_topics = 0;
    std::vector<float> topic_weights;  // K, summing to 1 (all 0 for a frame without words)
    int32_t cells_x = 0, cells_y = 0;
    std::vector<int16_t> cell_topics;  // cells_x * cells_y, row-major; the cell's most frequent topic, -1 when empty
    std::vector<float> cell_surprise;  // cells_x * cells_y, row-major
    // K: the model's slot of each label, as the frame was published. A topic
    // keeps its slot while it is open; with topics.grow its label moves as
    // topics below it close and open. The rows of ~topic_model are slots.
    std::vector<uint16_t> topic_slots;
};

// The global topic of each of a frame's labels (K values, -1 for none):
// `lifting` is indexed by the rows of the vehicle's ~topic_model, the
// model's slots (K values), so a lifting made from an earlier model still
// names each topic that is open in both, whatever its label now. A slot
// past the lifting's, or a label past `topic_slots`, lifts to -1.
void liftLabels(const std::vector<uint16_t>& topic_slots, const std::vector<int32_t>& lifting, int K,
                std::vector<int32_t>& byLabel);

// Words -> engine -> per-frame results, as the node runs it: the engine's
// refiner thread refines; push() (the capture side) extracts the words of a
// frame and queues them without blocking; next() (one consumer thread)
// takes the next frame's results.
class Pipeline {
public:
    struct Options {
        std::string vocabulary;  // ORB vocabulary file; "" the built-in one
        std::string checkpoint;  // "" : no checkpoints; else saved every checkpoint.every frames
        std::string resume;      // "" : a new model; else carry on this checkpoint's
        std::size_t result_slots = 64;
    };
    // Set-up: the settings checked, the word extractors and their
    // vocabulary. nullptr and `error` set on failure.
    static std::unique_ptr<Pipeline> create(const NodeSettings& settings, const Options& options,
                                            std::string& error);
    // Set-up: the engine for frames of width x height (unless the settings
    // give frame.width / frame.height: frames are then resized), V from the
    // extractors unless set, ~resume's state, the checkpoint writer. "" on
    // success, else the error. Before any other call but sizeGiven().
    std::string open(int width, int height);
    bool opened() const;
    // Whether the settings fix the frame size (frame.width and frame.height
    // given): open() can be called before the first image.
    bool sizeGiven() const;
    ~Pipeline();
    Pipeline(const Pipeline&) = delete;
    Pipeline& operator=(const Pipeline&) = delete;

    std::string start();  // the refiner thread
    void stop();          // drains the queue, joins the refiner

    int K() const;
    int V() const;
    int width() const;
    int height() const;
    int cellsX() const;
    int cellsY() const;
    int cellSpace() const;
    // Frames ~resume's checkpoint holds (0 for a new mission): the node's
    // images are numbered after them, as a camera's are in `rost run
    // --resume` (rost::vision::FrameMission::before).
    int64_t framesBefore() const;

    // Capture side (one thread): extracts the words of an 8-bit BGR or grey
    // image and hands them to the engine (Engine::tryPush: never blocks). False
    // when the image is unusable or the queue dropped it.
    bool push(const cv::Mat& image, int64_t timestamp);
    // A slot of the engine's queue is free: a push now would not drop.
    bool canPush();
    // Consumer side (one thread): the next frame's results; false when none.
    bool next(FrameResult& out);
    uint64_t dropped() const;  // frames lost to a full queue or a full result ring

    // Services (not concurrently with push): each stops the refiner, does
    // its work and starts it again. "" on success, else the error.
    std::string saveCheckpoint();
    std::string getTopicModel(std::vector<int32_t>& counts) const;  // K x V, topic-major, in label order
    // Adds K x V counts to the model as a prior (Model::addTopicCounts).
    std::string addTopicModel(int K, int V, const std::vector<int32_t>& counts);

    // The model's counts (K x V, topic-major, row k the model's slot k: with
    // topics.grow a closed topic's row is zeros where it lies) for a reader
    // thread (the node's model publisher), without stopping the refiner. requestModel() asks the
    // refiner for a copy at its next observation boundary (the observation
    // hook copies K x V counts into a buffer sized at open(): no allocation,
    // no lock, the stall of one copy); takeModel() hands the copy over once it
    // is made. A refiner with nothing to do makes none: copyModelIfIdle(),
    // called while push() is held off (the node's push mutex), copies the
    // model itself when everything pushed has been taken up (the model cannot
    // change then), else returns false.
    void requestModel() noexcept;
    bool takeModel(std::vector<int32_t>& counts);
    bool copyModelIfIdle(std::vector<int32_t>& counts);

    struct Impl;

private:
    explicit Pipeline(std::unique_ptr<Impl> impl);
    std::unique_ptr<Impl> impl_;
};

// Merging the fleet's topic models (rost/merge.hpp), for rost_merge_node.
struct ModelCounts {
    int K = 0;
    int V = 0;
    std::vector<int32_t> counts;  // K x V, topic-major
};
struct MergedModel {
    int K = 0;  // global topics G
    int V = 0;  // the largest input V
    std::vector<int64_t> counts;  // G x V, topic-major
    std::vector<std::vector<int>> lifting;  // lifting[m][k]: model m's topic k in the global set, -1 if empty
};
// "" when the merge options are valid, else the error, naming the parameter
// as the merge node spells it (~threshold, ~beta).
std::string checkMergeOptions(double threshold, double beta);
// The models merged in the order given (the first one's topics open the
// global set). "" on success, else the error.
std::string mergeModels(const std::vector<ModelCounts>& models, double threshold, double beta, MergedModel& out);

} // namespace rost::bridge
