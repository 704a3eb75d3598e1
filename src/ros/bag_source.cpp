// C++17: rosbag's headers. A bag's image topic as a rost frame source.

#include <algorithm>
#include <fstream>
#include <optional>

#include <opencv2/imgproc.hpp>
#include <rosbag/bag.h>
#include <rosbag/view.h>

#include "bag.hpp"
#include "image_convert.hpp"

namespace rost::bag {

namespace {

// rost::text::counted's words (its header is C++20; this file is ROS's C++17).
std::string counted(long long n, const char* noun) { return std::to_string(n) + " " + noun + (n == 1 ? "" : "s"); }

bool isImageType(const std::string& type) {
    return type == "sensor_msgs/Image" || type == "sensor_msgs/CompressedImage";
}

// `topic` (when given) is named in the message. A file that does not begin
// as a bag does is said to be none (rosbag's own "Error reading version
// line" would be taken for a damaged bag).
Status openBag(const std::string& path, rosbag::Bag& bag, const std::string& topic = {}) {
    if (std::ifstream f(path, std::ios::binary); f) {
        char head[8] = {};
        f.read(head, sizeof head);
        if (f.gcount() > 0 && std::string(head, static_cast<std::size_t>(f.gcount())) != std::string("#ROSBAG ", 8))
            return Status::error(path + ": not a ROS bag (a bag begins with '#ROSBAG V2.0')");
    }
    try {
        bag.open(path, rosbag::bagmode::Read);
    } catch (const rosbag::BagException& e) {
        std::string m = path;
        if (!topic.empty()) m += ": topic " + topic;
        m += ": cannot read the bag (truncated? `rosbag reindex` rebuilds a lost index): ";
        m += e.what();
        return Status::error(m);
    }
    return {};
}

class Source final : public BagFrameSource {
public:
    Status open(const std::string& path, const std::string& topic, const vision::SourceOptions& options);
    vision::ReadStatus read(vision::Frame& out) override;
    const std::vector<ImageStamp>& stamps() const noexcept override { return stamps_; }

private:
    bool decode(const rosbag::MessageInstance& m, cv::Mat& bgr, std::string& why, ImageStamp& stamp) const;
    vision::ReadStatus fail(const std::string& why);
    // bgr_ too small to extract words from: a note naming the message (message_ - back), and true.
    bool skipSmall(int64_t back = 0) {
        const std::string why = vision::frameTooSmall(bgr_.cols, bgr_.rows);
        if (why.empty()) return false;
        notes_.push_back(path_ + ": topic " + topic_ + ", message " + std::to_string(message_ - back) + ": " + why +
                         "; skipped");
        return true;
    }

    std::string path_, topic_;
    rosbag::Bag bag_;
    std::optional<rosbag::View> view_;
    rosbag::View::iterator it_;
    cv::Mat bgr_;
    int64_t index_ = 0;    // frames delivered
    int64_t message_ = 0;  // the topic's message it_ is at
    std::vector<ImageStamp> stamps_;
};

bool Source::decode(const rosbag::MessageInstance& m, cv::Mat& bgr, std::string& why, ImageStamp& stamp) const {
    ros::Time t = m.getTime();
    if (auto im = m.instantiate<sensor_msgs::Image>()) {
        if (!bridge::toBgr(*im, bgr, why)) return false;
        if (!im->header.stamp.isZero()) t = im->header.stamp;
        stamp.frame_id = im->header.frame_id;
    } else if (auto ci = m.instantiate<sensor_msgs::CompressedImage>()) {
        if (!bridge::toBgr(*ci, bgr, why)) return false;
        if (!ci->header.stamp.isZero()) t = ci->header.stamp;
        stamp.frame_id = ci->header.frame_id;
    } else {
        why = "a " + m.getDataType() + ", not an image";
        return false;
    }
    stamp.stamp_ns = static_cast<int64_t>(t.toNSec());
    return true;
}

Status Source::open(const std::string& path, const std::string& topic, const vision::SourceOptions& options) {
    path_ = path;
    topic_ = topic;
    if (Status st = openBag(path, bag_, topic); !st.ok()) return st;
    try {
        view_.emplace(bag_, rosbag::TopicQuery(topic));
        const auto conns = view_->getConnections();
        if (conns.empty()) {
            std::vector<std::string> topics;
            std::string m = path + ": no topic " + topic + " in the bag";
            if (Status st = listImageTopics(path, topics); st.ok()) {
                m += topics.empty() ? " (and no image topic)" : "; its image topics:";
                m += imageTopicLines(topics);
            }
            return Status::error(m);
        }
        for (const rosbag::ConnectionInfo* c : conns)
            if (!isImageType(c->datatype))
                return Status::error(path + ": topic " + topic + " carries " + c->datatype +
                                     ", not sensor_msgs/Image or sensor_msgs/CompressedImage");
        info_.frames = static_cast<int64_t>(view_->size());
        const double span = (view_->getEndTime() - view_->getBeginTime()).toSec();
        info_.fps = info_.frames > 1 && span > 0 ? static_cast<double>(info_.frames - 1) / span : 0.0;
        it_ = view_->begin();
        if (it_ == view_->end()) return Status::error(path + ": topic " + topic + " has no messages");
        // The first image words can be extracted from fixes the size; smaller ones are skipped (noted).
        for (;; ++it_, ++message_) {
            if (it_ == view_->end())
                return Status::error(path + ": topic " + topic + ": no image large enough to extract words from");
            std::string why;
            ImageStamp first;
            if (!decode(*it_, bgr_, why, first))
                return Status::error(path + ": topic " + topic + ", message " + std::to_string(message_) + ": " + why);
            if (!skipSmall()) break;
        }
    } catch (const rosbag::BagException& e) {
        return Status::error(path + ": topic " + topic + ", message " + std::to_string(message_) +
                             ": cannot read the bag: " + e.what());
    } catch (const ros::Exception& e) {  // a message that does not deserialise (StreamOverrunException)
        return Status::error(path + ": topic " + topic + ", message " + std::to_string(message_) +
                             ": cannot read the message: " + e.what());
    } catch (const std::exception& e) {  // anything else converting a message throws
        return Status::error(path + ": topic " + topic + ", message " + std::to_string(message_) +
                             ": cannot convert the message: " + e.what());
    }
    // Sized as every source is (one side given alone keeps the aspect ratio).
    if (Status st = vision::chooseSize(options, bgr_.cols, bgr_.rows, info_, notes_); !st.ok())
        return st.prefixed(path + ": topic " + topic + ": ");
    const int w = info_.width, h = info_.height;
    info_.description = "bag " + path + " topic " + topic + " (" + std::to_string(w) + "x" + std::to_string(h) +
                        ", " + counted(info_.frames, "frame") + ")";
    return {};
}

vision::ReadStatus Source::fail(const std::string& why) {
    error_ = path_ + ": topic " + topic_ + ", message " + std::to_string(message_) + ": " + why;
    return vision::ReadStatus::Error;
}

vision::ReadStatus Source::read(vision::Frame& out) {
    ImageStamp stamp;
    try {
        do {
            if (it_ == view_->end()) return vision::ReadStatus::End;
            std::string why;
            if (!decode(*it_, bgr_, why, stamp)) return fail(why);
            ++it_;
            ++message_;
        } while (skipSmall(1));
    } catch (const rosbag::BagException& e) {
        return fail(std::string("cannot read the bag: ") + e.what());
    } catch (const ros::Exception& e) {
        return fail(std::string("cannot read the message: ") + e.what());
    } catch (const std::exception& e) {  // anything else converting a message throws
        return fail(std::string("cannot convert the message: ") + e.what());
    }
    const cv::Mat* img = &bgr_;
    cv::Mat colour;
    if (bgr_.channels() == 1) {
        cv::cvtColor(bgr_, colour, cv::COLOR_GRAY2BGR);
        img = &colour;
    }
    if (img->cols != info_.width || img->rows != info_.height)
        cv::resize(*img, out.image, cv::Size(info_.width, info_.height), 0, 0, cv::INTER_AREA);
    else
        img->copyTo(out.image);
    out.index = index_++;
    out.timestamp_us = stamp.stamp_ns / 1000;
    stamps_.push_back(std::move(stamp));
    return vision::ReadStatus::Ok;
}

} // namespace

BagFrameSource::~BagFrameSource() = default;

std::string imageTopicLines(const std::vector<std::string>& lines) {
    std::string out;
    for (const std::string& l : lines) out += "\n  " + l;
    return out;
}

Status listImageTopics(const std::string& path, std::vector<std::string>& lines) {
    lines.clear();
    rosbag::Bag bag;
    if (Status st = openBag(path, bag); !st.ok()) return st;
    try {
        rosbag::View all(bag);
        std::vector<std::string> seen;
        for (const rosbag::ConnectionInfo* c : all.getConnections()) {
            if (!isImageType(c->datatype) || std::find(seen.begin(), seen.end(), c->topic) != seen.end()) continue;
            seen.push_back(c->topic);
            rosbag::View one(bag, rosbag::TopicQuery(c->topic));
            lines.push_back(c->topic + " (" + c->datatype + ", " + counted(static_cast<long long>(one.size()), "message") + ")");
        }
    } catch (const rosbag::BagException& e) {
        return Status::error(path + ": cannot read the bag: " + e.what());
    }
    std::sort(lines.begin(), lines.end());
    return {};
}

std::unique_ptr<BagFrameSource> openBagSource(const std::string& path, const std::string& topic,
                                              const vision::SourceOptions& options, Status& status) {
    auto s = std::make_unique<Source>();
    status = s->open(path, topic, options);
    if (!status.ok()) return nullptr;
    return s;
}

} // namespace rost::bag
