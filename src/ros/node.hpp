#pragma once

// rost_node (C++17: ROS headers): a camera topic in; per-frame topics,
// perplexity and surprise out, stamped like the images. docs/ros.md.
//
//   image callback (ros::spin's thread): image (through image_transport, or
//                                        rost's own decoder of compressed images) -> BGR, numbered in the order
//                                        received, into the image queue (~image_queue
//                                        images; a full queue drops its oldest, counted)
//   words thread:                        image -> words -> Engine::tryPush
//   refiner thread (the engine's):       refine within the budget, publish results
//   publisher thread:                    results -> ~frame, ~topic_map, ~surprise_map,
//                                        ~perplexity, ~surprise (and ~global_frame)
//   model thread (~model_period > 0):    the model's counts -> ~topic_model (node_fleet.cpp)
// The engine's time stamp of an observation is its number in the order
// received: the publisher finds the image's header (stamp, whole frame_id)
// by it. Services run on ros::spin's thread, between images.

#include <atomic>
#include <condition_variable>
#include <cstdint>
#include <deque>
#include <map>
#include <memory>
#include <mutex>
#include <string>
#include <thread>
#include <vector>

#include <image_transport/image_transport.h>
#include <opencv2/core.hpp>
#include <ros/callback_queue.h>
#include <ros/ros.h>
#include <rost_msgs/FrameTopics.h>
#include <rost_msgs/GetTopicModel.h>
#include <rost_msgs/SetTopicModel.h>
#include <rost_msgs/TopicLifting.h>
#include <rost_msgs/TopicModel.h>
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
    bool failed() const noexcept { return failed_.load(std::memory_order_acquire); }

private:
    bool readSettings();
    bool readTransport();
    bool subscribe();
    void warnUnknownParams();
    void advertise();
    void onImage(const sensor_msgs::ImageConstPtr& msg);
    void onCompressed(const sensor_msgs::CompressedImageConstPtr& msg);
    void receive(const cv::Mat& bgr, const std_msgs::Header& header);
    bool ensureEngine(int width, int height);
    void badImage(const std::string& why, const std_msgs::Header& header);
    void wordsMain();
    void waitForSlot();  // words thread: until the engine has a slot or a newer image waits
    void publisherMain();
    void publish(const rost::bridge::FrameResult& r);

    // The fleet (node_fleet.cpp): the model on ~topic_model every
    // ~model_period seconds, and with ~use_global_model the frames' labels in
    // the fleet's global topics on ~global_frame, through the lifting.
    bool readFleetParams();
    void advertiseFleet();
    void startFleet();  // once the engine is made (K known): the lifting table and subscription
    void stopModelThread();
    void modelMain();
    bool copyModel(std::vector<int32_t>& counts);
    void publishModel(std::vector<int32_t>& counts);
    void onLifting(const rost_msgs::TopicLiftingConstPtr& msg);
    bool readLifting(int32_t& G);  // publisher thread: the table into lift_copy_; false before any lifting
    void publishGlobal(const rost_msgs::FrameTopics& local, const std::vector<uint16_t>& topic_slots);

    bool onSave(std_srvs::Trigger::Request& req, std_srvs::Trigger::Response& res);
    bool onPause(std_srvs::SetBool::Request& req, std_srvs::SetBool::Response& res);
    bool onGetModel(rost_msgs::GetTopicModel::Request& req, rost_msgs::GetTopicModel::Response& res);
    bool onSetModel(rost_msgs::SetTopicModel::Request& req, rost_msgs::SetTopicModel::Response& res);

    ros::NodeHandle nh_, pnh_;
    rost::bridge::NodeSettings settings_;
    rost::bridge::Pipeline::Options options_;
    // How images arrive: ~image_transport's transport through image_transport,
    // or rost's own decoder of sensor_msgs/CompressedImage on own_topic_
    // (compressed where no plugin is installed, and ~compressed, deprecated).
    std::string transport_ = "raw";
    bool own_decoder_ = false;
    std::string own_topic_;
    std::string topic_;  // the topic subscribed, for messages
    int image_queue_ = 4;                               // ~image_queue: images waiting for the words thread
    std::unique_ptr<rost::bridge::Pipeline> pipeline_;  // made on the words thread's first image
    std::atomic<bool> failed_{false};                   // the engine could not be made
    std::atomic<bool> ready_{false};                    // the engine is made and started
    std::mutex pipeline_mutex_;                         // the words thread's push against the services
    std::map<std::string, ros::WallTime> bad_logged_;   // kind of bad image -> when last logged (callback thread)
    std::atomic<bool> paused_{false};
    std::atomic<bool> publishing_{false};
    std::thread words_, publisher_;

    // Images received and not yet made words of (callback -> words thread).
    struct Received {
        uint64_t index = 0;  // in the order received, from 0
        cv::Mat bgr;
        std_msgs::Header header;
    };
    std::mutex queue_mutex_;
    std::condition_variable queue_cv_;
    std::deque<Received> queue_;
    bool stopping_ = false;
    uint64_t received_ = 0;                  // images received (callback thread)
    std::atomic<uint64_t> not_modelled_{0};  // dropped by a queue, bad or too small, or while paused

    // The header of each image handed to the engine, by its number (words
    // thread -> publisher); the publisher removes those up to the one it
    // publishes (the others were dropped by the engine's queue).
    std::mutex headers_mutex_;
    std::map<uint64_t, std_msgs::Header> headers_;
    uint64_t published_ = 0;  // publisher thread

    // The services on their own queue and thread: a checkpoint's write must
    // not hold up the image callbacks (ROS's queue would drop images unseen).
    ros::CallbackQueue service_queue_;
    std::unique_ptr<ros::AsyncSpinner> service_spinner_;
    std::unique_ptr<image_transport::ImageTransport> image_transport_;
    image_transport::Subscriber image_sub_;  // through image_transport
    ros::Subscriber compressed_sub_;         // rost's own decoder
    ros::Publisher frame_pub_, topic_map_pub_, surprise_map_pub_, perplexity_pub_, surprise_pub_;
    ros::ServiceServer save_srv_, pause_srv_, get_srv_, set_srv_;

    // The fleet (node_fleet.cpp).
    double model_period_ = 0.0;  // ~model_period: seconds; 0 never
    std::string vehicle_;        // ~vehicle
    bool use_global_model_ = false;
    std::thread model_thread_;
    std::mutex model_mutex_;
    std::condition_variable model_cv_;
    bool model_stop_ = false;
    ros::Publisher model_pub_, global_frame_pub_;
    ros::Subscriber lifting_sub_;
    // The vehicle's lifting (local topic -> global topic), K entries sized
    // once the engine is made: written by the lifting callback (ros::spin's
    // thread), read by the publisher thread, under a sequence lock (no lock,
    // no allocation on the publisher's side).
    std::unique_ptr<std::atomic<int32_t>[]> lift_table_;
    int lift_K_ = 0;
    std::atomic<int32_t> lift_G_{0};
    std::atomic<uint32_t> lift_version_{0};  // odd while written; 0 before any lifting
    std::vector<int32_t> lift_copy_;         // publisher thread
    std::vector<int32_t> lift_by_label_;     // publisher thread: lift_copy_ through a frame's topic slots
    bool local_logged_ = false;              // publisher thread
    bool lifting_logged_ = false, vehicle_missing_logged_ = false;  // ros::spin's thread
};

} // namespace rost_node
