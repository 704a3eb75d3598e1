#include "node.hpp"

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <cstring>
#include <vector>

#include <opencv2/core.hpp>
#include <std_msgs/Float32.h>

#include "frame_msg.hpp"
#include "image_convert.hpp"
#include "rost/vision/frame_source.hpp"

namespace rost_node {

namespace {
// A parameter's value as the text a rost configuration file would hold.
// (XmlRpcValue's conversions are not const.)
bool paramText(XmlRpc::XmlRpcValue& v, std::string& text) {
    switch (v.getType()) {
    case XmlRpc::XmlRpcValue::TypeBoolean: text = static_cast<bool>(v) ? "true" : "false"; return true;
    case XmlRpc::XmlRpcValue::TypeInt: text = std::to_string(static_cast<int>(v)); return true;
    case XmlRpc::XmlRpcValue::TypeDouble: {
        char buf[64];
        std::snprintf(buf, sizeof buf, "%.17g", static_cast<double>(v));
        text = buf;
        return true;
    }
    case XmlRpc::XmlRpcValue::TypeString: text = static_cast<std::string>(v); return true;
    default: return false;
    }
}
} // namespace

Node::Node(ros::NodeHandle nh, ros::NodeHandle pnh) : nh_(std::move(nh)), pnh_(std::move(pnh)) {}

Node::~Node() { shutdown(); }

// The node's own private parameters, beside one per setting of the schema.
const char* const kNodeParams[] = {"image_transport", "compressed", "checkpoint", "resume", "vocabulary",
                                   "model_period", "vehicle", "use_global_model"};

// Every setting of the schema as a private parameter (dots as underscores).
// Errors name the parameter as the node spells it (~eta) and stop the node
// before it subscribes; a private parameter that is no setting and none of
// the node's own is logged at start-up, with the one it most likely meant.
bool Node::readSettings() {
    std::string budget;  // the budget parameter given, if any
    for (const rost::bridge::ParamSpec& p : rost::bridge::settingParams()) {
        XmlRpc::XmlRpcValue v;
        if (!pnh_.getParam(p.param, v)) continue;
        std::string text;
        if (!paramText(v, text)) {
            ROS_FATAL("rost: ~%s: expected a number, a boolean or a string (%s)", p.param.c_str(), p.range.c_str());
            return false;
        }
        if (p.key.rfind("budget.", 0) == 0) {
            if (!budget.empty()) {
                ROS_FATAL("rost: ~%s and ~%s both set a budget (give one of ~budget_refines, ~budget_tokens, "
                          "~budget_ms)", budget.c_str(), p.param.c_str());
                return false;
            }
            budget = p.param;
        }
        if (const std::string err = settings_.set(p.key, text); !err.empty()) {
            ROS_FATAL("rost: %s", rost::bridge::printable(err).c_str());
            return false;
        }
    }
    if (const std::string err = settings_.validate(); !err.empty()) {
        ROS_FATAL("rost: %s", rost::bridge::printable(err).c_str());
        return false;
    }
    warnUnknownParams();
    if (!readTransport() || !readFleetParams()) return false;
    pnh_.param("checkpoint", options_.checkpoint, std::string());
    pnh_.param("resume", options_.resume, std::string());
    pnh_.param("vocabulary", options_.vocabulary, std::string());
    image_queue_ = std::stoi(settings_.value("image.queue"));  // a setting of the schema: checked above
    return true;
}

void Node::warnUnknownParams() {
    std::vector<std::string> names;
    if (!ros::param::getParamNames(names)) return;
    const std::string prefix = pnh_.getNamespace() + "/";
    std::vector<std::string> known;
    for (const rost::bridge::ParamSpec& p : rost::bridge::settingParams()) known.push_back(p.param);
    for (const char* n : kNodeParams) known.emplace_back(n);
    std::vector<std::string> warned;
    for (const std::string& full : names) {
        if (full.compare(0, prefix.size(), prefix) != 0) continue;
        const std::string name = full.substr(prefix.size(), full.find('/', prefix.size()) - prefix.size());
        if (std::find(known.begin(), known.end(), name) != known.end() ||
            std::find(warned.begin(), warned.end(), name) != warned.end())
            continue;
        warned.push_back(name);
        const std::string near = rost::bridge::closestParam(name);
        if (!near.empty())
            ROS_WARN("rost: ~%s is not a parameter of rost_node; ignored (did you mean ~%s?)", name.c_str(), near.c_str());
        else
            ROS_WARN("rost: ~%s is not a parameter of rost_node; ignored (rost_node --params lists them)", name.c_str());
    }
}

void Node::advertise() {
    frame_pub_ = pnh_.advertise<rost_msgs::FrameTopics>("frame", 16);
    topic_map_pub_ = pnh_.advertise<sensor_msgs::Image>("topic_map", 4);
    surprise_map_pub_ = pnh_.advertise<sensor_msgs::Image>("surprise_map", 4);
    perplexity_pub_ = pnh_.advertise<std_msgs::Float32>("perplexity", 16);
    surprise_pub_ = pnh_.advertise<std_msgs::Float32>("surprise", 16);
    ros::NodeHandle services(pnh_);
    services.setCallbackQueue(&service_queue_);
    save_srv_ = services.advertiseService("save_checkpoint", &Node::onSave, this);
    pause_srv_ = services.advertiseService("pause", &Node::onPause, this);
    get_srv_ = services.advertiseService("get_topic_model", &Node::onGetModel, this);
    set_srv_ = services.advertiseService("set_topic_model", &Node::onSetModel, this);
    advertiseFleet();
    service_spinner_ = std::make_unique<ros::AsyncSpinner>(1, &service_queue_);
    service_spinner_->start();
}

// ~image_transport (image_transport's own parameter name) picks the
// transport; ~compressed, deprecated, is the old switch. Either is checked
// here, before the node subscribes: a wrong type, a transport no plugin
// provides, or the two disagreeing is fatal, naming them.
bool Node::readTransport() {
    XmlRpc::XmlRpcValue v;
    const bool transport_given = pnh_.getParam("image_transport", v);
    if (transport_given) {
        if (v.getType() != XmlRpc::XmlRpcValue::TypeString || static_cast<std::string>(v).empty()) {
            ROS_FATAL("rost: ~image_transport: expected the name of a transport (raw, compressed, theora, ...)");
            return false;
        }
        transport_ = static_cast<std::string>(v);
    }
    image_transport_ = std::make_unique<image_transport::ImageTransport>(nh_);
    if (pnh_.getParam("compressed", v)) {
        if (v.getType() != XmlRpc::XmlRpcValue::TypeBoolean) {
            ROS_FATAL("rost: ~compressed: expected true or false (deprecated: give ~image_transport instead)");
            return false;
        }
        const bool compressed = static_cast<bool>(v);
        if (compressed && transport_given && transport_ != "compressed") {
            ROS_FATAL("rost: ~compressed = true and ~image_transport = %s disagree (~compressed is deprecated: "
                      "give ~image_transport alone)", transport_.c_str());
            return false;
        }
        ROS_WARN("rost: ~compressed is deprecated and goes in the next release: use ~image_transport "
                 "(_image_transport:=compressed subscribes the compressed images on <image>/compressed)%s",
                 compressed ? "; ~compressed = true still subscribes sensor_msgs/CompressedImage on image itself" : "");
        if (compressed) {  // as before: the compressed images on `image` itself
            transport_ = "compressed";
            own_decoder_ = true;
            own_topic_ = nh_.resolveName("image");
            return true;
        }
    }
    if (transport_ == "raw") return true;
    const std::vector<std::string> loadable = image_transport_->getLoadableTransports();
    if (std::find(loadable.begin(), loadable.end(), transport_) != loadable.end()) return true;
    if (transport_ == "compressed") {  // no plugin installed (Debian 12 packages none): rost decodes them itself
        own_decoder_ = true;
        own_topic_ = nh_.resolveName("image") + "/compressed";
        return true;
    }
    std::string names;
    for (const std::string& n : loadable) names += n + ", ";
    ROS_FATAL("rost: ~image_transport = %s: no image_transport plugin provides it here (installed: %scompressed, "
              "which rost_node decodes itself)", transport_.c_str(), names.c_str());
    return false;
}

// The callback only converts and queues an image (the words thread makes
// its words), so ROS's own queue rarely fills; ~image_queue bounds the rest.
bool Node::subscribe() {
    const uint32_t queue = 64;
    if (own_decoder_) {
        compressed_sub_ = nh_.subscribe(own_topic_, queue, &Node::onCompressed, this);
        topic_ = compressed_sub_.getTopic();
        return true;
    }
    try {
        image_sub_ = image_transport_->subscribe("image", queue, &Node::onImage, this,
                                                 image_transport::TransportHints(transport_, ros::TransportHints(), pnh_));
    } catch (const std::exception& e) {
        ROS_FATAL("rost: ~image_transport = %s: %s", transport_.c_str(), e.what());
        return false;
    }
    topic_ = image_sub_.getTopic();
    return true;
}

bool Node::init() {
    if (!readSettings()) return false;
    std::string err;
    pipeline_ = rost::bridge::Pipeline::create(settings_, options_, err);
    if (!pipeline_) {
        ROS_FATAL("rost: %s", rost::bridge::printable(err).c_str());
        return false;
    }
    if (pipeline_->sizeGiven() && !ensureEngine(0, 0)) return false;
    words_ = std::thread([this] { wordsMain(); });
    advertise();
    if (!subscribe()) return false;
    // A resumed mission's model settings are its checkpoint's (logged with the frame size).
    const std::string k = options_.resume.empty() ? settings_.value("K") : "the checkpoint's";
    ROS_INFO("rost: listening on %s (%s transport%s); K = %s, cell.space = %s", topic_.c_str(), transport_.c_str(),
             own_decoder_ ? ", decoded by rost_node" : "", k.c_str(),
             options_.resume.empty() ? settings_.value("cell.space").c_str() : "the checkpoint's");
    return true;
}

void Node::shutdown() {
    stopModelThread();
    lifting_sub_.shutdown();
    if (service_spinner_) service_spinner_->stop();
    image_sub_.shutdown();
    compressed_sub_.shutdown();
    if (words_.joinable()) {  // the queued images are made words of first
        {
            std::lock_guard<std::mutex> lock(queue_mutex_);
            stopping_ = true;
        }
        queue_cv_.notify_all();
        words_.join();
    }
    if (pipeline_ && ready_.load(std::memory_order_acquire)) pipeline_->stop();  // the queued frames' results are still published
    if (publisher_.joinable()) {
        publishing_.store(false, std::memory_order_release);
        publisher_.join();
    }
    if (pipeline_ && ready_.load(std::memory_order_acquire) && !options_.checkpoint.empty()) {
        if (const std::string err = pipeline_->saveCheckpoint(); !err.empty())
            ROS_ERROR("rost: final checkpoint: %s", rost::bridge::printable(err).c_str());
    }
    pipeline_.reset();
}

// Each kind of bad image is logged, at most every 5 s per kind, and counted
// as received and not modelled.
void Node::badImage(const std::string& why, const std_msgs::Header& header) {
    ++received_;
    not_modelled_.fetch_add(1, std::memory_order_relaxed);
    const ros::WallTime now = ros::WallTime::now();
    auto it = bad_logged_.find(why);
    if (it != bad_logged_.end() && (now - it->second).toSec() < 5.0) return;
    bad_logged_[why] = now;
    ROS_ERROR("rost: topic %s, message seq %u (stamp %u.%09u, frame_id '%s'): %s; skipping it",
              topic_.c_str(), header.seq, header.stamp.sec, header.stamp.nsec, rost::bridge::printable(header.frame_id).c_str(),
              rost::bridge::printable(why).c_str());
}

void Node::onImage(const sensor_msgs::ImageConstPtr& msg) {
    cv::Mat bgr;
    std::string why;
    if (!rost::bridge::toBgr(*msg, bgr, why)) return badImage(why, msg->header);
    receive(bgr, msg->header);
}

void Node::onCompressed(const sensor_msgs::CompressedImageConstPtr& msg) {
    cv::Mat bgr;
    std::string why;
    if (!rost::bridge::toBgr(*msg, bgr, why)) return badImage(why, msg->header);
    receive(bgr, msg->header);
}

// The callback's part: the image numbered in the order received, then queued
// for the words thread; a full queue drops its oldest image, so the newest
// is always modelled.
void Node::receive(const cv::Mat& bgr, const std_msgs::Header& header) {
    // rost::vision's frame size rule: an image too small to extract words
    // from is skipped and never sizes the model.
    if (const std::string why = rost::vision::frameTooSmall(bgr.cols, bgr.rows); !why.empty())
        return badImage(why, header);
    if (paused_.load(std::memory_order_acquire)) {
        ++received_;
        not_modelled_.fetch_add(1, std::memory_order_relaxed);
        return;
    }
    Received r{received_++, bgr.clone(), header};  // our own copy: the message's buffer goes with it
    bool dropped = false;
    {
        std::lock_guard<std::mutex> lock(queue_mutex_);
        if (queue_.size() >= static_cast<std::size_t>(image_queue_)) {
            queue_.pop_front();
            dropped = true;
        }
        queue_.push_back(std::move(r));
    }
    queue_cv_.notify_one();
    if (dropped) {
        const uint64_t n = not_modelled_.fetch_add(1, std::memory_order_relaxed) + 1;
        ROS_WARN_THROTTLE(5.0, "rost: the image queue (~image_queue = %d) was full: its oldest image dropped; "
                               "%llu images not modelled so far", image_queue_, static_cast<unsigned long long>(n));
    }
}

// The first image fixes the frame size (unless ~frame_width and ~frame_height).
bool Node::ensureEngine(int width, int height) {
    if (ready_.load(std::memory_order_acquire)) return true;
    if (failed_.load(std::memory_order_acquire)) return false;
    const rost::vision::FrameSize model = rost::vision::modelFrameSize(width, height);
    if (!pipeline_->sizeGiven() && (model.width != width || model.height != height))
        ROS_WARN("rost: images of %dx%d are modelled at %dx%d (at most %d pixels on the longer side unless "
                 "~frame_width and ~frame_height are given)", width, height, model.width, model.height,
                 rost::vision::kMaxModelSide);
    std::string err = pipeline_->open(model.width, model.height);
    if (err.empty()) err = pipeline_->start();
    if (err.empty()) {
        ROS_INFO("rost: frames of %dx%d, %dx%d cells, K = %d, V = %d%s%s", pipeline_->width(), pipeline_->height(),
                 pipeline_->cellsX(), pipeline_->cellsY(), pipeline_->K(), pipeline_->V(),
                 options_.resume.empty() ? "" : ", resumed from ", options_.resume.c_str());
        startFleet();
        publishing_.store(true, std::memory_order_release);
        publisher_ = std::thread([this] { publisherMain(); });
        ready_.store(true, std::memory_order_release);
        return true;
    }
    failed_.store(true, std::memory_order_release);
    ROS_FATAL("rost: %s", rost::bridge::printable(err).c_str());
    ros::shutdown();
    return false;
}

// The words thread: each queued image's words to the engine, its header kept
// for the publisher under its number (the observation's time stamp).
void Node::wordsMain() {
    for (;;) {
        Received r;
        {
            std::unique_lock<std::mutex> lock(queue_mutex_);
            queue_cv_.wait(lock, [this] { return stopping_ || !queue_.empty(); });
            if (queue_.empty()) return;  // stopping, and drained
            r = std::move(queue_.front());
            queue_.pop_front();
        }
        if (!ensureEngine(r.bgr.cols, r.bgr.rows)) {
            not_modelled_.fetch_add(1, std::memory_order_relaxed);
            continue;
        }
        {
            std::lock_guard<std::mutex> lock(headers_mutex_);
            headers_[r.index] = r.header;
        }
        waitForSlot();
        std::lock_guard<std::mutex> lock(pipeline_mutex_);  // the services stop and restart the engine
        // The observation's time stamp: the image's number in the mission,
        // after the frames ~resume's checkpoint holds.
        if (!pipeline_->push(r.bgr, pipeline_->framesBefore() + static_cast<int64_t>(r.index)))
            ROS_WARN_THROTTLE(5.0, "rost: frames dropped (the refiner is behind, or images without words): %llu so far",
                              static_cast<unsigned long long>(pipeline_->dropped()));
    }
}

// The engine's queue is full while the refiner takes up an observation: the
// image in hand waits for a slot unless a newer one is waiting (or the node
// stops), so the newest image is always modelled and an older one is the one
// dropped. (Pushed into a full queue, the newest would be refused whenever
// the refiner holds the only slot.)
void Node::waitForSlot() {
    for (;;) {
        {
            std::lock_guard<std::mutex> lock(pipeline_mutex_);
            if (pipeline_->canPush()) return;
        }
        {
            std::lock_guard<std::mutex> lock(queue_mutex_);
            if (stopping_ || !queue_.empty()) return;
        }
        std::this_thread::sleep_for(std::chrono::milliseconds(1));
    }
}

void Node::publisherMain() {
    rost::bridge::FrameResult r;
    for (;;) {
        const bool more = publishing_.load(std::memory_order_acquire);
        if (pipeline_->next(r)) {
            publish(r);
        } else if (!more) {
            return;  // stopped and drained
        } else {
            std::this_thread::sleep_for(std::chrono::milliseconds(2));
        }
    }
}

void Node::publish(const rost::bridge::FrameResult& r) {
    // The observation's time stamp is the image's number in the mission: the
    // checkpoint's frames, then the images in the order this node received them.
    const auto index = static_cast<uint64_t>(r.timestamp - pipeline_->framesBefore());
    std_msgs::Header header;
    {
        std::lock_guard<std::mutex> lock(headers_mutex_);
        const auto it = headers_.find(index);
        if (it != headers_.end()) header = it->second;
        else ROS_ERROR_THROTTLE(5.0, "rost: no header for image %llu (a bug): published without stamp and frame_id",
                                static_cast<unsigned long long>(index));
        headers_.erase(headers_.begin(), headers_.upper_bound(index));  // those before were dropped by the engine
    }
    ++published_;
    rost_msgs::FrameTopics frame;
    rost::bridge::fillFrameTopics(r, frame);
    frame.header = header;
    frame.frame = static_cast<uint64_t>(r.timestamp);
    // Images received up to this one that no message carries (dropped, bad, too small, paused).
    frame.dropped = static_cast<uint32_t>(index + 1 > published_ ? index + 1 - published_ : 0);
    frame_pub_.publish(frame);
    if (use_global_model_) publishGlobal(frame, r.topic_slots);
    if (topic_map_pub_.getNumSubscribers() > 0) {
        sensor_msgs::Image map;
        rost::bridge::fillTopicMap(r, pipeline_->cellSpace(), map);
        map.header = header;
        topic_map_pub_.publish(map);
    }
    if (surprise_map_pub_.getNumSubscribers() > 0) {
        sensor_msgs::Image map;
        rost::bridge::fillSurpriseMap(r, map);
        map.header = header;
        surprise_map_pub_.publish(map);
    }
    std_msgs::Float32 v;
    v.data = r.perplexity;
    perplexity_pub_.publish(v);
    v.data = r.surprise;
    surprise_pub_.publish(v);
}

bool Node::onSave(std_srvs::Trigger::Request&, std_srvs::Trigger::Response& res) {
    std::lock_guard<std::mutex> lock(pipeline_mutex_);
    if (!ready_.load(std::memory_order_acquire)) {
        res.success = false;
        res.message = "no image yet: nothing to save";
        return true;
    }
    const std::string err = pipeline_->saveCheckpoint();
    res.success = err.empty();
    res.message = err.empty() ? options_.checkpoint : err;
    return true;
}

bool Node::onPause(std_srvs::SetBool::Request& req, std_srvs::SetBool::Response& res) {
    paused_.store(req.data, std::memory_order_release);
    res.success = true;
    res.message = req.data ? "paused: images are ignored" : "running";
    return true;
}

bool Node::onGetModel(rost_msgs::GetTopicModel::Request&, rost_msgs::GetTopicModel::Response& res) {
    std::lock_guard<std::mutex> lock(pipeline_mutex_);
    if (!ready_.load(std::memory_order_acquire)) return false;  // no model before the first image
    std::vector<int32_t> counts;
    if (const std::string err = pipeline_->getTopicModel(counts); !err.empty()) {
        ROS_ERROR("rost: get_topic_model: %s", rost::bridge::printable(err).c_str());
        return false;
    }
    res.K = pipeline_->K();
    res.V = pipeline_->V();
    res.counts = std::move(counts);
    return true;
}

bool Node::onSetModel(rost_msgs::SetTopicModel::Request& req, rost_msgs::SetTopicModel::Response& res) {
    std::lock_guard<std::mutex> lock(pipeline_mutex_);
    if (!ready_.load(std::memory_order_acquire)) {
        res.success = false;
        res.message = "no image yet: the model is made on the first image";
        return true;
    }
    const std::string err = pipeline_->addTopicModel(req.K, req.V, req.counts);
    res.success = err.empty();
    res.message = err.empty() ? "added" : err;
    return true;
}

} // namespace rost_node
