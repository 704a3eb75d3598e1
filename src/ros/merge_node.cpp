// rost_merge_node: the fleet's topic models merged into one global set
// (docs/ros.md, "Several vehicles"). It subscribes to the rost_msgs/TopicModel
// topics of ~models, keeps the latest model of each vehicle, and every
// ~period seconds, when a model came since the last round, merges them
// (rost/merge.hpp, through bridge.hpp) and publishes the global model on
// ~global_model (vehicle "global") and the lifting on ~lifting, both latched.
// Everything runs on ros::spin's one thread.

#include <cmath>
#include <cstdint>
#include <limits>
#include <map>
#include <sstream>
#include <string>
#include <utility>
#include <vector>

#include <ros/ros.h>
#include <rost_msgs/TopicLifting.h>
#include <rost_msgs/TopicModel.h>

#include "bridge.hpp"

namespace {

constexpr int kExitBadParameter = 2;

class MergeNode {
public:
    explicit MergeNode(ros::NodeHandle pnh) : pnh_(std::move(pnh)) {}
    bool init();

private:
    bool readParams();
    bool number(const char* name, double& value);
    void onModel(std::size_t topic, const rost_msgs::TopicModelConstPtr& msg);
    void merge();

    struct Latest {
        std::size_t topic = 0;  // its index in ~models: the merge order, then the vehicle's name
        rost_msgs::TopicModelConstPtr msg;
    };
    ros::NodeHandle pnh_;
    std::vector<std::string> topics_;
    double period_ = 5.0, threshold_ = 0.6, beta_ = 0.01;
    std::map<std::pair<std::size_t, std::string>, rost_msgs::TopicModelConstPtr> latest_;
    bool changed_ = false;
    uint64_t rounds_ = 0;
    std::vector<ros::Subscriber> subs_;
    ros::Publisher global_pub_, lifting_pub_;
    ros::WallTimer timer_;
};

bool MergeNode::number(const char* name, double& value) {
    XmlRpc::XmlRpcValue v;
    if (!pnh_.getParam(name, v)) return true;
    if (v.getType() == XmlRpc::XmlRpcValue::TypeInt) value = static_cast<int>(v);
    else if (v.getType() == XmlRpc::XmlRpcValue::TypeDouble) value = static_cast<double>(v);
    else {
        ROS_FATAL("rost_merge: ~%s: expected a number", name);
        return false;
    }
    return true;
}

bool MergeNode::readParams() {
    // A list of topics (YAML, rosparam, a launch file), or one string of
    // them separated by commas or spaces (the command line: roscpp reads no lists there).
    XmlRpc::XmlRpcValue v;
    bool ok = pnh_.getParam("models", v);
    if (ok && v.getType() == XmlRpc::XmlRpcValue::TypeString) {
        std::istringstream in(static_cast<std::string>(v));
        for (std::string t; std::getline(in, t, ',');)
            for (std::istringstream words(t); words >> t;) topics_.push_back(t);
    } else if (ok && v.getType() == XmlRpc::XmlRpcValue::TypeArray) {
        for (int i = 0; ok && i < v.size(); ++i) {
            ok = v[i].getType() == XmlRpc::XmlRpcValue::TypeString && !static_cast<std::string>(v[i]).empty();
            if (ok) topics_.push_back(static_cast<std::string>(v[i]));
        }
    }
    if (!ok || topics_.empty()) {
        ROS_FATAL("rost_merge: ~models: expected the rost_msgs/TopicModel topics to merge, at least one: a list, "
                  "or one string separated by commas (_models:=/auv1/rost/topic_model,/auv2/rost/topic_model)");
        return false;
    }
    if (!number("period", period_) || !number("threshold", threshold_) || !number("beta", beta_)) return false;
    if (!std::isfinite(period_) || period_ <= 0.0) {
        ROS_FATAL("rost_merge: ~period = %g: expected seconds > 0", period_);
        return false;
    }
    if (const std::string err = rost::bridge::checkMergeOptions(threshold_, beta_); !err.empty()) {
        ROS_FATAL("rost_merge: %s", rost::bridge::printable(err).c_str());
        return false;
    }
    return true;
}

bool MergeNode::init() {
    if (!readParams()) return false;
    global_pub_ = pnh_.advertise<rost_msgs::TopicModel>("global_model", 2, true);
    lifting_pub_ = pnh_.advertise<rost_msgs::TopicLifting>("lifting", 2, true);
    ros::NodeHandle nh;
    for (std::size_t i = 0; i < topics_.size(); ++i)
        subs_.push_back(nh.subscribe<rost_msgs::TopicModel>(
            topics_[i], 4, [this, i](const rost_msgs::TopicModelConstPtr& m) { onModel(i, m); }));
    timer_ = pnh_.createWallTimer(ros::WallDuration(period_), [this](const ros::WallTimerEvent&) { merge(); });
    ROS_INFO("rost_merge: %zu model topics, a merge every %g s (threshold %g, beta %g); the global model on %s, "
             "the lifting on %s", topics_.size(), period_, threshold_, beta_, global_pub_.getTopic().c_str(),
             lifting_pub_.getTopic().c_str());
    return true;
}

void MergeNode::onModel(std::size_t topic, const rost_msgs::TopicModelConstPtr& msg) {
    const bool ok = msg->K >= 1 && msg->V >= 1 && !msg->vehicle.empty() &&
                    msg->counts.size() == static_cast<std::size_t>(msg->K) * static_cast<std::size_t>(msg->V);
    if (!ok) {
        ROS_ERROR_THROTTLE(5.0, "rost_merge: a model on %s (vehicle '%s', K = %d, V = %d, %zu counts) is not K x V "
                                "counts of a named vehicle: ignored", topics_[topic].c_str(), msg->vehicle.c_str(),
                           msg->K, msg->V, msg->counts.size());
        return;
    }
    for (int32_t c : msg->counts)
        if (c < 0) {
            ROS_ERROR_THROTTLE(5.0, "rost_merge: the model of vehicle '%s' has a negative count: ignored",
                               msg->vehicle.c_str());
            return;
        }
    // One vehicle, one entry in the lifting: a name that came first on another topic of ~models
    // (two rost_nodes given one ~vehicle) would give the lifting two entries of that name, and
    // each node would take the last. The first topic keeps it.
    for (const auto& entry : latest_)
        if (entry.first.second == msg->vehicle && entry.first.first != topic) {
            ROS_ERROR_THROTTLE(5.0, "rost_merge: vehicle '%s' on %s came first on %s: ignored (give each rost_node "
                                    "its own ~vehicle)", msg->vehicle.c_str(), topics_[topic].c_str(),
                               topics_[entry.first.first].c_str());
            return;
        }
    if (latest_.find({topic, msg->vehicle}) == latest_.end())
        ROS_INFO("rost_merge: vehicle '%s' on %s (K = %d, V = %d)", msg->vehicle.c_str(), topics_[topic].c_str(),
                 msg->K, msg->V);
    latest_[{topic, msg->vehicle}] = msg;
    changed_ = true;
}

// A round: the latest models, in the order of ~models then of the vehicles'
// names, merged; the global model and the lifting published.
void MergeNode::merge() {
    if (!changed_ || latest_.empty()) return;
    changed_ = false;
    std::vector<rost::bridge::ModelCounts> models;
    rost_msgs::TopicLifting lifting;
    for (const auto& [key, msg] : latest_) {
        models.push_back({msg->K, msg->V, msg->counts});
        rost_msgs::VehicleLifting e;
        e.vehicle = key.second;
        lifting.vehicles.push_back(std::move(e));
    }
    rost::bridge::MergedModel merged;
    if (const std::string err = rost::bridge::mergeModels(models, threshold_, beta_, merged); !err.empty()) {
        ROS_ERROR_THROTTLE(5.0, "rost_merge: the merge failed: %s", rost::bridge::printable(err).c_str());
        return;
    }
    rost_msgs::TopicModel global;
    global.header.stamp = ros::Time::now();
    lifting.header.stamp = global.header.stamp;
    global.vehicle = "global";
    global.K = lifting.G = merged.K;
    global.V = merged.V;
    global.counts.resize(merged.counts.size());
    global.topic_weights.assign(static_cast<std::size_t>(merged.K), 0);
    for (std::size_t i = 0; i < merged.counts.size(); ++i) {
        if (merged.counts[i] > std::numeric_limits<int32_t>::max()) {
            ROS_ERROR_THROTTLE(5.0, "rost_merge: a global count exceeds int32 (TopicModel's counts): round skipped");
            return;
        }
        global.counts[i] = static_cast<int32_t>(merged.counts[i]);
        global.topic_weights[i / static_cast<std::size_t>(merged.V)] += merged.counts[i];
    }
    for (std::size_t m = 0; m < merged.lifting.size(); ++m)
        lifting.vehicles[m].global.assign(merged.lifting[m].begin(), merged.lifting[m].end());
    global_pub_.publish(global);
    lifting_pub_.publish(lifting);
    ROS_INFO_THROTTLE(30.0, "rost_merge: round %llu: %zu vehicles, %d global topics",
                      static_cast<unsigned long long>(++rounds_), models.size(), merged.K);
}

} // namespace

int main(int argc, char** argv) {
    ros::init(argc, argv, "rost_merge");
    int code = 0;
    {
        MergeNode node{ros::NodeHandle("~")};
        if (node.init()) ros::spin();
        else code = kExitBadParameter;
    }
    ros::shutdown();
    return code;
}
