#pragma once

// rost_node (C++17: ROS headers): a camera topic in; per-frame topics,
// perplexity and surprise out, stamped like the images. docs/ros.md.
//
//   image callback (ros::spin's thread): image -> BGR -> words -> Engine::tryPush
//                                        (never blocks; a full queue drops)
//   refiner thread (the engine's):       refine within the budget, publish results
//   publisher thread:                    results -> ~frame, ~topic_map, ~surprise_map,
//                                        ~perplexity, ~surprise
// Services run on ros::spin's thread, between images.

#include <array>
#include <atomic>
#include <cstdint>
#include <memory>
#include <string>
#include <thread>

#include <ros/ros.h>
#include <rost_msgs/GetTopicModel.h>
#include <rost_msgs/SetTopicModel.h>
#include <sensor_msgs/CompressedImage.h>
#include <sensor_msgs/Image.h>
#include <std_srvs/SetBool.h>
#include <std_srvs/Trigger.h>

#include "bridge.hpp"

namespace rost_node {

// Exit codes.
inline constexpr int kExitOk = 0;
inline constexpr int kExitBadParameter = 2;

class Node {
public:
    Node(ros::NodeHandle nh, ros::NodeHandle pnh);
    ~Node();
    // Parameters, subscriptions, advertisements, services. False after a
    // ROS_FATAL naming the parameter.
    bool init();
    // After ros::spin: stops the threads, saves the final checkpoint.
    void shutdown();
    // The pipeline could not be made (a fatal error was logged).
    bool failed() const noexcept { return failed_; }

private:
    bool readSettings();
    void warnUnknownParams();
    void advertise();
    void onImage(const sensor_msgs::ImageConstPtr& msg);
    void onCompressed(const sensor_msgs::CompressedImageConstPtr& msg);
    void handle(const cv::Mat& bgr, const std_msgs::Header& header);
    bool ensureEngine(int width, int height);
    void badImage(const std::string& why, const std_msgs::Header& header);
    void publisherMain();
    void publish(const rost::bridge::FrameResult& r);
    void rememberStamp(const std_msgs::Header& header);
    std::string frameIdOf(int64_t stamp_ns) const;

    bool onSave(std_srvs::Trigger::Request& req, std_srvs::Trigger::Response& res);
    bool onPause(std_srvs::SetBool::Request& req, std_srvs::SetBool::Response& res);
    bool onGetModel(rost_msgs::GetTopicModel::Request& req, rost_msgs::GetTopicModel::Response& res);
    bool onSetModel(rost_msgs::SetTopicModel::Request& req, rost_msgs::SetTopicModel::Response& res);

    ros::NodeHandle nh_, pnh_;
    rost::bridge::NodeSettings settings_;
    rost::bridge::Pipeline::Options options_;
    bool compressed_ = false;
    std::unique_ptr<rost::bridge::Pipeline> pipeline_;  // made by init(); its engine on the first image
    bool failed_ = false;                               // the engine could not be made
    bool warned_bad_image_ = false;
    std::atomic<bool> paused_{false};
    std::atomic<bool> publishing_{false};
    std::thread publisher_;

    // Stamp -> frame_id of recent images, for the publisher thread: a ring
    // written by the image callback (no lock, no allocation).
    static constexpr std::size_t kStampSlots = 256;
    static constexpr std::size_t kFrameIdWords = 8;  // frame ids up to 63 characters
    struct StampSlot {
        std::atomic<int64_t> stamp_ns{-1};
        std::array<std::atomic<uint64_t>, kFrameIdWords> frame_id{};
    };
    std::array<StampSlot, kStampSlots> stamps_;
    std::size_t stamp_next_ = 0;

    ros::Subscriber image_sub_;
    ros::Publisher frame_pub_, topic_map_pub_, surprise_map_pub_, perplexity_pub_, surprise_pub_;
    ros::ServiceServer save_srv_, pause_srv_, get_srv_, set_srv_;
};

} // namespace rost_node
