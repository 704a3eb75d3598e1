#pragma once

// rost's per-frame results as ROS messages (C++17: ROS message headers).

#include <rost_msgs/FrameTopics.h>
#include <sensor_msgs/Image.h>

#include "bridge.hpp"

namespace rost::bridge {

// Everything but the header.
void fillFrameTopics(const FrameResult& r, rost_msgs::FrameTopics& msg);
// rgb8, cells_x * cell x cells_y * cell pixels: each cell in its topic's
// colour (black without words), for rqt_image_view.
void fillTopicMap(const FrameResult& r, int cell, sensor_msgs::Image& msg);
// 32FC1, cells_x x cells_y: each cell's surprise.
void fillSurpriseMap(const FrameResult& r, sensor_msgs::Image& msg);

} // namespace rost::bridge
