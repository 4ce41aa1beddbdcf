#pragma once
/// @file RigidTransform.h
/// Rigid transforms named by their frames (thesis 2.1, 3.1): target_T_source
/// maps a point given in the source frame into the target frame,
/// p_target = R p_source + t. Lengths are millimetres, angles radians.

#include <opencv2/core/matx.hpp>
#include <opencv2/core/types.hpp>

#include <array>

namespace avatar {

/// A rotation and a translation, plain values (as the configuration stores them).
struct RigidTransform {
    /// Row-major rotation matrix.
    std::array<double, 9> rotation{1, 0, 0, 0, 1, 0, 0, 0, 1};
    std::array<double, 3> translationMm{0, 0, 0};
    bool operator==(const RigidTransform& o) const {
        return rotation == o.rotation && translationMm == o.translationMm;
    }
};

/// Rotation matrix of a Rodrigues vector (radians), as the Bouguet toolbox's `rodrigues`.
cv::Matx33d rodrigues(const std::array<double, 3>& om);
/// Rodrigues vector of a rotation matrix (inverse of rodrigues()).
std::array<double, 3> rodriguesVector(const cv::Matx33d& rotation);

/// The rotation of a RigidTransform as a matrix.
cv::Matx33d rotationMatrix(const RigidTransform& transform);
/// The translation of a RigidTransform as a vector (mm).
cv::Vec3d translationVector(const RigidTransform& transform);
/// target_T_source applied to a point in the source frame.
cv::Point3d transformPoint(const RigidTransform& targetTSource, const cv::Point3d& pointSource);
/// source_T_target from target_T_source.
RigidTransform inverse(const RigidTransform& targetTSource);
/// Builds a RigidTransform from a rotation matrix and a translation (mm).
RigidTransform makeRigidTransform(const cv::Matx33d& rotation, const cv::Vec3d& translationMm);

}  // namespace avatar
