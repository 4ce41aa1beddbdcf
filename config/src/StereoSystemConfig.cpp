#include <avatar/config/StereoSystemConfig.h>

namespace avatar {

RigidTransform rightTLeft(const StereoSystemConfig& config) {
    return makeRigidTransform(rodrigues(config.om),
                              cv::Vec3d(config.translationMm[0], config.translationMm[1], config.translationMm[2]));
}

StereoGeometry stereoGeometry(const StereoSystemConfig& config) {
    return {config.left, config.right, rightTLeft(config), config.baseTVision};
}

}  // namespace avatar
