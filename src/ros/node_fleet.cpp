// rost_node in a fleet (node.hpp, docs/ros.md "Several vehicles"): the topic
// model on ~topic_model every ~model_period seconds, for rost_merge_node; with
// ~use_global_model, each frame's labels in the fleet's global topics on
// ~global_frame, through the merge node's lifting.

#include <chrono>
#include <cmath>
#include <limits>

#include "node.hpp"

namespace rost_node {

// ~model_period (seconds, >= 0; 0 or unset: never), ~vehicle (a non-empty
// string; default the node's namespace, or its name in the root namespace),
// ~use_global_model (bool). A bad one is fatal, naming it.
bool Node::readFleetParams() {
    XmlRpc::XmlRpcValue v;
    if (pnh_.getParam("model_period", v)) {
        const auto type = v.getType();
        if (type == XmlRpc::XmlRpcValue::TypeInt) model_period_ = static_cast<int>(v);
        else if (type == XmlRpc::XmlRpcValue::TypeDouble) model_period_ = static_cast<double>(v);
        else model_period_ = -1.0;
        if (!std::isfinite(model_period_) || model_period_ < 0.0) {
            ROS_FATAL("rost: ~model_period: expected seconds >= 0 (0: the model is never published)");
            return false;
        }
    }
    const std::string ns = ros::this_node::getNamespace();
    vehicle_ = (ns.empty() || ns == "/") ? ros::this_node::getName() : ns;
    if (!vehicle_.empty() && vehicle_[0] == '/') vehicle_.erase(0, 1);
    if (pnh_.getParam("vehicle", v)) {
        if (v.getType() != XmlRpc::XmlRpcValue::TypeString || static_cast<std::string>(v).empty()) {
            ROS_FATAL("rost: ~vehicle: expected the vehicle's name (a non-empty string)");
            return false;
        }
        vehicle_ = static_cast<std::string>(v);
    }
    if (pnh_.getParam("use_global_model", v)) {
        if (v.getType() != XmlRpc::XmlRpcValue::TypeBoolean) {
            ROS_FATAL("rost: ~use_global_model: expected true or false");
            return false;
        }
        use_global_model_ = static_cast<bool>(v);
    }
    return true;
}

void Node::advertiseFleet() {
    if (model_period_ > 0.0) {
        // Latched: a merge node started later gets the latest model at once.
        model_pub_ = pnh_.advertise<rost_msgs::TopicModel>("topic_model", 2, true);
        model_thread_ = std::thread([this] { modelMain(); });
        ROS_INFO("rost: vehicle '%s': the topic model on %s every %g s", vehicle_.c_str(),
                 model_pub_.getTopic().c_str(), model_period_);
    }
    if (use_global_model_) global_frame_pub_ = pnh_.advertise<rost_msgs::FrameTopics>("global_frame", 16);
}

// On the words thread once the engine is made (K known), before the
// publisher thread starts: the lifting table, then its subscription.
void Node::startFleet() {
    if (!use_global_model_) return;
    lift_K_ = pipeline_->K();
    lift_table_ = std::make_unique<std::atomic<int32_t>[]>(static_cast<std::size_t>(lift_K_));
    for (int k = 0; k < lift_K_; ++k) lift_table_[k].store(k, std::memory_order_relaxed);
    lift_copy_.assign(static_cast<std::size_t>(lift_K_), 0);
    lift_by_label_.assign(static_cast<std::size_t>(lift_K_), -1);  // sized here: the publisher does not allocate for it
    lifting_sub_ = nh_.subscribe("lifting", 2, &Node::onLifting, this);
    ROS_INFO("rost: ~use_global_model: vehicle '%s' labels in the global topics of the lifting on %s (~global_frame)",
             vehicle_.c_str(), lifting_sub_.getTopic().c_str());
}

void Node::stopModelThread() {
    if (!model_thread_.joinable()) return;
    {
        std::lock_guard<std::mutex> lock(model_mutex_);
        model_stop_ = true;
    }
    model_cv_.notify_all();
    model_thread_.join();
}

// The model thread: every ~model_period seconds, a copy of the counts
// (never stopping the refiner) published on ~topic_model, once it holds a word.
void Node::modelMain() {
    std::vector<int32_t> counts;
    const std::chrono::duration<double> period(model_period_);
    std::unique_lock<std::mutex> lock(model_mutex_);
    while (!model_cv_.wait_for(lock, period, [this] { return model_stop_; })) {
        lock.unlock();
        if (ready_.load(std::memory_order_acquire) && copyModel(counts)) publishModel(counts);
        lock.lock();
    }
}

// The refiner copies the counts at its next observation boundary; one with
// nothing to do copies none, so after a while the model is read here while
// the words thread's push waits (the model cannot change then). A refiner
// busy past that leaves the request standing for the next period.
bool Node::copyModel(std::vector<int32_t>& counts) {
    pipeline_->requestModel();
    for (int i = 0; i < 50; ++i) {
        if (pipeline_->takeModel(counts)) return true;
        std::this_thread::sleep_for(std::chrono::milliseconds(2));
    }
    std::lock_guard<std::mutex> lock(pipeline_mutex_);
    return pipeline_->copyModelIfIdle(counts);
}

void Node::publishModel(std::vector<int32_t>& counts) {
    rost_msgs::TopicModel msg;
    msg.header.stamp = ros::Time::now();
    msg.vehicle = vehicle_;
    msg.K = pipeline_->K();
    msg.V = pipeline_->V();
    msg.topic_weights.assign(static_cast<std::size_t>(msg.K), 0);
    const std::size_t V = static_cast<std::size_t>(msg.V);
    int64_t words = 0;
    for (std::size_t i = 0; i < counts.size(); ++i) msg.topic_weights[i / V] += counts[i], words += counts[i];
    if (words == 0) return;  // a model without a word yet: nothing to merge
    msg.counts.swap(counts);
    model_pub_.publish(msg);
}

// The merge node's lifting (ros::spin's thread): this vehicle's entry into
// the table, under the sequence lock.
void Node::onLifting(const rost_msgs::TopicLiftingConstPtr& msg) {
    const rost_msgs::VehicleLifting* mine = nullptr;
    for (const rost_msgs::VehicleLifting& e : msg->vehicles)
        if (e.vehicle == vehicle_) mine = &e;
    if (!mine) {
        if (!vehicle_missing_logged_)
            ROS_WARN("rost: the lifting on %s has no vehicle '%s' (~vehicle) yet", lifting_sub_.getTopic().c_str(),
                     vehicle_.c_str());
        vehicle_missing_logged_ = true;
        return;
    }
    const int32_t G = msg->G;
    bool ok = mine->global.size() == static_cast<std::size_t>(lift_K_) && G >= 1 &&
              G <= std::numeric_limits<int16_t>::max();
    for (std::size_t k = 0; ok && k < mine->global.size(); ++k) ok = mine->global[k] >= -1 && mine->global[k] < G;
    if (!ok) {
        ROS_ERROR_THROTTLE(5.0, "rost: the lifting of vehicle '%s' has %zu topics (K = %d) into G = %d: ignored",
                           vehicle_.c_str(), mine->global.size(), lift_K_, G);
        return;
    }
    const uint32_t v = lift_version_.load(std::memory_order_relaxed);
    lift_version_.store(v + 1, std::memory_order_relaxed);
    std::atomic_thread_fence(std::memory_order_release);
    for (int k = 0; k < lift_K_; ++k) lift_table_[k].store(mine->global[k], std::memory_order_relaxed);
    lift_G_.store(G, std::memory_order_relaxed);
    lift_version_.store(v + 2, std::memory_order_release);
    if (!lifting_logged_)
        ROS_INFO("rost: ~global_frame: labels in the fleet's %d global topics from now (vehicle '%s')", G,
                 vehicle_.c_str());
    lifting_logged_ = true;
}

bool Node::readLifting(int32_t& G) {
    for (;;) {
        const uint32_t v1 = lift_version_.load(std::memory_order_acquire);
        if (v1 == 0) return false;
        if (v1 & 1u) {
            std::this_thread::yield();
            continue;
        }
        G = lift_G_.load(std::memory_order_relaxed);
        for (int k = 0; k < lift_K_; ++k) lift_copy_[k] = lift_table_[k].load(std::memory_order_relaxed);
        std::atomic_thread_fence(std::memory_order_acquire);
        if (lift_version_.load(std::memory_order_relaxed) == v1) return true;
    }
}

// ~global_frame: the frame with its topics mapped through the lifting; each
// global topic's weight sums those of the local topics lifted to it (a local
// topic that was empty when the models were merged maps to none: its cells
// are -1, its share of the words counts nowhere). The lifting is by the
// model's slots (the rows of ~topic_model), each label through the frame's
// own slot, so topics that closed and renumbered the labels since the model
// was merged change nothing. Before any lifting, the local labels, said once
// in the log.
void Node::publishGlobal(const rost_msgs::FrameTopics& local, const std::vector<uint16_t>& topic_slots) {
    rost_msgs::FrameTopics g = local;
    int32_t G = 0;
    if (!readLifting(G)) {
        if (!local_logged_)
            ROS_INFO("rost: ~use_global_model: no lifting for vehicle '%s' yet: ~global_frame carries the local "
                     "labels until one comes", vehicle_.c_str());
        local_logged_ = true;
        global_frame_pub_.publish(g);
        return;
    }
    rost::bridge::liftLabels(topic_slots, lift_copy_, lift_K_, lift_by_label_);
    g.active_topics = G;
    g.topic_weights.assign(static_cast<std::size_t>(G), 0.0f);
    const int K = std::min<int>(lift_K_, static_cast<int>(local.topic_weights.size()));
    for (int k = 0; k < K; ++k)
        if (lift_by_label_[k] >= 0) g.topic_weights[lift_by_label_[k]] += local.topic_weights[k];
    for (int16_t& c : g.cell_topics)
        if (c >= 0) c = c < lift_K_ ? static_cast<int16_t>(lift_by_label_[c]) : -1;
    global_frame_pub_.publish(g);
}

} // namespace rost_node
