#include <avatar/analyze/StereoCoordinateCalculator.h>

#include <avatar/analyze/CameraModel.h>
#include <avatar/common/Error.h>

#include <cmath>

namespace avatar {

StereoCoordinateCalculator::StereoCoordinateCalculator(const StereoSystemConfig& config)
    : config_(config),
      rightRLeft_(rodrigues(config.om)),
      rightTLeftMm_(config.translationMm[0], config.translationMm[1], config.translationMm[2]),
      baseTVision_(config.baseTVision) {}

std::optional<StereoPoint> StereoCoordinateCalculator::triangulate(const cv::Point2d& leftPx,
                                                                   const cv::Point2d& rightPx) const {
    return triangulateNormalized(normalizePixel(config_.left, leftPx),
                                 normalizePixel(config_.right, rightPx));
}

std::optional<StereoPoint> StereoCoordinateCalculator::triangulateNormalized(
    const cv::Point2d& xl, const cv::Point2d& xr) const {
    const cv::Vec3d Xl(xl.x, xl.y, 1.0);
    const cv::Vec3d Xr(xr.x, xr.y, 1.0);
    const cv::Vec3d& T = rightTLeftMm_;

    const cv::Vec3d u = rightRLeft_ * Xl;
    const double nXl2 = Xl.dot(Xl);
    const double nXr2 = Xr.dot(Xr);
    const double XrU = Xr.dot(u);
    const double XrT = Xr.dot(T);
    const double uT = u.dot(T);
    const double DD = nXl2 * nXr2 - XrU * XrU;
    // Parallel rays: DD vanishes relative to its terms.
    if (!(std::abs(DD) > 1e-15 * nXl2 * nXr2)) return std::nullopt;
    const double NN1 = XrU * XrT - nXr2 * uT;
    const double NN2 = nXl2 * XrT - uT * XrU;
    const double Zl = NN1 / DD;
    const double Zr = NN2 / DD;
    const cv::Vec3d X1 = Xl * Zl;
    const cv::Vec3d X2 = rightRLeft_.t() * (Xr * Zr - T);
    const cv::Vec3d XL = 0.5 * (X1 + X2);
    const cv::Vec3d XR = rightRLeft_ * XL + T;

    StereoPoint point;
    point.leftMm = {XL[0], XL[1], XL[2]};
    point.rightMm = {XR[0], XR[1], XR[2]};
    if (baseTVision_) point.baseMm = transformPoint(*baseTVision_, point.leftMm);
    return point;
}

cv::Point3d StereoCoordinateCalculator::visionToBase(const cv::Point3d& visionMm) const {
    if (!baseTVision_)
        throw InvalidArgument(
            "StereoCoordinateCalculator::visionToBase: the stereo configuration has no "
            "baseTVision registration");
    return transformPoint(*baseTVision_, visionMm);
}

}  // namespace avatar
