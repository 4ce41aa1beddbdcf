#include <avatar/common/RigidTransform.h>

#include <opencv2/calib3d.hpp>

namespace avatar {

cv::Matx33d rodrigues(const std::array<double, 3>& om) {
    cv::Matx33d rotation;
    cv::Rodrigues(cv::Vec3d(om[0], om[1], om[2]), rotation);
    return rotation;
}

std::array<double, 3> rodriguesVector(const cv::Matx33d& rotation) {
    cv::Vec3d om;
    cv::Rodrigues(rotation, om);
    return {om[0], om[1], om[2]};
}

cv::Matx33d rotationMatrix(const RigidTransform& transform) {
    const auto& r = transform.rotation;
    return cv::Matx33d(r[0], r[1], r[2], r[3], r[4], r[5], r[6], r[7], r[8]);
}

cv::Vec3d translationVector(const RigidTransform& transform) {
    const auto& t = transform.translationMm;
    return {t[0], t[1], t[2]};
}

cv::Point3d transformPoint(const RigidTransform& targetTSource, const cv::Point3d& pointSource) {
    const cv::Vec3d p = rotationMatrix(targetTSource) * cv::Vec3d(pointSource) + translationVector(targetTSource);
    return {p[0], p[1], p[2]};
}

RigidTransform makeRigidTransform(const cv::Matx33d& rotation, const cv::Vec3d& translationMm) {
    RigidTransform t;
    for (int i = 0; i < 9; ++i) t.rotation[static_cast<std::size_t>(i)] = rotation.val[i];
    t.translationMm = {translationMm[0], translationMm[1], translationMm[2]};
    return t;
}

RigidTransform inverse(const RigidTransform& targetTSource) {
    const cv::Matx33d rt = rotationMatrix(targetTSource).t();
    return makeRigidTransform(rt, -(rt * translationVector(targetTSource)));
}

}  // namespace avatar
