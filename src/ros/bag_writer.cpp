// C++17: rosbag's headers. Per-frame results as rost_msgs/FrameTopics into a bag.

#include <cerrno>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <filesystem>

#include <fcntl.h>
#include <unistd.h>

#include <rosbag/bag.h>

#include "bag.hpp"
#include "frame_msg.hpp"
#include "rost/file_target.hpp"

namespace rost::bag {

struct ResultBagWriter::Impl {
    std::string path, tmp, topic, target;  // target: where path's links lead (path itself without)
    rosbag::Bag bag;
    bool open = false;
};

ResultBagWriter::ResultBagWriter() : impl_(std::make_unique<Impl>()) {}
ResultBagWriter::~ResultBagWriter() {
    if (impl_->open) {
        impl_->bag.close();
        std::error_code ec;
        std::filesystem::remove(impl_->tmp, ec);
    }
}

Status ResultBagWriter::open(const std::string& path, const std::string& topic) {
    impl_->path = path;
    impl_->topic = topic;
    // A bag is seeked and renamed into place: a device or a FIFO cannot take
    // one, and renaming over it would replace the node itself.
    std::error_code ec;
    const auto st = std::filesystem::status(path, ec);
    if (!ec && std::filesystem::exists(st) && !std::filesystem::is_regular_file(st))
        return Status::error("--out.bag " + path + ": not a regular file (a bag is written to a file)");
    // Written where a link leads (the link kept), staged in a file of its own
    // beside that (rost/file_target.hpp), never a fixed name another file of
    // the run may have.
    std::string target, dir;
    if (Status linked = text::linkTarget(path, target); !linked.ok()) return linked.prefixed("--out.bag ");
    impl_->target = target;
    const int fd = text::makeTemporaryBeside(target, dir, impl_->tmp);
    if (fd < 0) return Status::error("--out.bag " + path + ": cannot create a file in " + dir + ": " + std::strerror(errno));
    ::close(fd);
    try {
        impl_->bag.open(impl_->tmp, rosbag::bagmode::Write);
    } catch (const rosbag::BagException& e) {
        std::filesystem::remove(impl_->tmp, ec);
        return Status::error("--out.bag " + path + ": " + e.what());
    }
    impl_->open = true;
    return {};
}

Status ResultBagWriter::write(const bridge::FrameResult& r, const ImageStamp& stamp) {
    rost_msgs::FrameTopics msg;
    bridge::fillFrameTopics(r, msg);
    msg.header.stamp.fromNSec(static_cast<uint64_t>(stamp.stamp_ns));
    msg.header.frame_id = stamp.frame_id;
    try {
        impl_->bag.write(impl_->topic, msg.header.stamp, msg);
    } catch (const rosbag::BagException& e) {
        return Status::error("--out.bag " + impl_->path + ": " + e.what());
    }
    return {};
}

Status ResultBagWriter::commit() {
    if (!impl_->open) return {};
    try {
        impl_->bag.close();
    } catch (const rosbag::BagException& e) {
        return Status::error("--out.bag " + impl_->path + ": " + e.what());
    }
    impl_->open = false;
    std::error_code ec;
    std::filesystem::rename(impl_->tmp, impl_->target, ec);
    if (ec) return Status::error("--out.bag " + impl_->path + ": " + ec.message());
    return {};
}

} // namespace rost::bag
