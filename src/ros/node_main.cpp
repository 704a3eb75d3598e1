// rost_node: see node.hpp and docs/ros.md.

#include <cstdio>
#include <cstring>

#include <ros/ros.h>

#include "bridge.hpp"
#include "node.hpp"

namespace {
// `rost_node --params`: every private parameter, made from the settings schema.
void printParams() {
    std::printf("# rost_node's private parameters: every setting of the schema (`rost config`), dots and dashes as\n"
                "# underscores, and image_transport, compressed, checkpoint, resume, vocabulary, model_period, vehicle,\n"
                "# use_global_model. ~name  default  range  meaning\n");
    for (const rost::bridge::ParamSpec& p : rost::bridge::settingParams())
        std::printf("~%s  %s  %s  %s\n", p.param.c_str(), p.def.empty() ? "-" : p.def.c_str(), p.range.c_str(),
                    p.doc.c_str());
    std::printf("~image_transport  raw  raw|compressed|PLUGIN  image_transport's transport for `image` (compressed: "
                "on image/compressed, decoded by rost_node where no plugin is installed)\n"
                "~compressed  false  true|false  deprecated (~image_transport): sensor_msgs/CompressedImage on `image`\n"
                "~checkpoint  -  FILE  save the state every checkpoint.every frames, at exit and on ~save_checkpoint\n"
                "~resume  -  FILE  carry on the mission this checkpoint holds\n"
                "~vocabulary  -  FILE  ORB vocabulary from `rost vocab` (default: the built-in one)\n"
                "~model_period  0  [0, inf)  seconds between two topic models published on ~topic_model (0: never)\n"
                "~vehicle  NAMESPACE  STRING  the vehicle id in ~topic_model and in the lifting (default: the "
                "namespace, or the node's name in /)\n"
                "~use_global_model  false  true|false  also publish ~global_frame: labels mapped through `lifting`\n");
}
} // namespace

int main(int argc, char** argv) {
    for (int i = 1; i < argc; ++i)
        if (std::strcmp(argv[i], "--params") == 0) return printParams(), 0;
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
