// rost_node: see node.hpp and docs/ros.md.

#include <ros/ros.h>

#include "node.hpp"

int main(int argc, char** argv) {
    ros::init(argc, argv, "rost");
    int code = rost_node::kExitOk;
    {
        rost_node::Node node(ros::NodeHandle(), ros::NodeHandle("~"));
        if (!node.init()) {
            code = rost_node::kExitBadParameter;
        } else {
            ros::spin();
            node.shutdown();
            if (node.failed()) code = rost_node::kExitBadParameter;
        }
    }
    ros::shutdown();
    return code;
}
