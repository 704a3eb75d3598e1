// Builds without libcamera: camera:N is reported as unavailable.

#include "camera_source.hpp"

namespace rost::vision {

std::unique_ptr<FrameSource> openCamera(int index, const SourceOptions&, Status& status) {
    status = Status::error("camera:" + std::to_string(index) +
                           ": no camera found (this build of rost has no libcamera support; rebuild with "
                           "libcamera-dev installed and -DROST_LIBCAMERA=ON)");
    return nullptr;
}

std::vector<std::string> listCameras() { return {}; }

bool haveLibcamera() noexcept { return false; }

} // namespace rost::vision
