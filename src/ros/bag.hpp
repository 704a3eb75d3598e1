#pragma once

// Bag files for the rost tool: images read with rosbag's C++ API as a frame
// source, and per-frame results written as rost_msgs/FrameTopics. This
// header compiles as C++17 and C++20 (it includes no ROS header); its
// implementation (bag_source.cpp, bag_writer.cpp) is C++17.

#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include "bridge.hpp"
#include "rost/status.hpp"
#include "rost/vision/frame_source.hpp"

namespace rost::bag {

// Whether INPUT names a bag file (ends in ".bag"). Inline: the tool asks
// also when built without ROS (to say so).
inline bool isBagInput(const std::string& input) {
    return input.size() > 4 && input.compare(input.size() - 4, 4, ".bag") == 0;
}

// The image topics of a bag (sensor_msgs/Image and CompressedImage), one
// line each: "/camera/image_raw (sensor_msgs/Image, 351 messages)".
Status listImageTopics(const std::string& path, std::vector<std::string>& lines);

// Those lines as an error lists them after its first line, one indented
// line each ("" for none): the one wording of a bag's topics in every error.
std::string imageTopicLines(const std::vector<std::string>& lines);

// Stamp and frame of one image message (header stamp; the bag's receive
// time when the header has none).
struct ImageStamp {
    int64_t stamp_ns = 0;
    std::string frame_id;
};

// A bag's image topic as a frame source: frames in the bag's order, 8-bit
// BGR, sized like the first image (or options.width / height), timestamp_us
// the message's stamp. A message rost cannot read, or a truncated bag: read()
// returns Error with one line naming the bag, the topic and the message.
// stamps() holds, for every frame read so far, its stamp and frame id.
class BagFrameSource : public vision::FrameSource {
public:
    ~BagFrameSource() override;
    virtual const std::vector<ImageStamp>& stamps() const noexcept = 0;

protected:
    BagFrameSource() = default;
};
std::unique_ptr<BagFrameSource> openBagSource(const std::string& path, const std::string& topic,
                                              const vision::SourceOptions& options, Status& status);

// rost_msgs/FrameTopics into a new bag on `topic`, written atomically:
// the file appears at `path` only on commit().
class ResultBagWriter {
public:
    ResultBagWriter();
    ~ResultBagWriter();
    Status open(const std::string& path, const std::string& topic);
    Status write(const bridge::FrameResult& r, const ImageStamp& stamp);
    Status commit();

private:
    struct Impl;
    std::unique_ptr<Impl> impl_;
};

} // namespace rost::bag
