#include <avatar/common/StereoCoordinateCalculator.h>

#include <avatar/common/Error.h>

#include <cmath>

namespace avatar {

StereoCoordinateCalculator::StereoCoordinateCalculator(const StereoGeometry& geometry)
    : geometry_(geometry),
      rightRLeft_(rotationMatrix(geometry.rightTLeft)),
      rightTLeftMm_(translationVector(geometry.rightTLeft)) {}

std::optional<StereoPoint> StereoCoordinateCalculator::triangulate(const cv::Point2d& leftPx,
                                                                   const cv::Point2d& rightPx) const {
    return triangulateNormalized(normalizePixel(geometry_.left, leftPx),
                                 normalizePixel(geometry_.right, rightPx));
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
    if (geometry_.baseTVision) point.baseMm = transformPoint(*geometry_.baseTVision, point.leftMm);
    return point;
}

cv::Point3d StereoCoordinateCalculator::visionToBase(const cv::Point3d& visionMm) const {
    if (!geometry_.baseTVision)
        throw InvalidArgument(
            "StereoCoordinateCalculator::visionToBase: the stereo configuration has no "
            "baseTVision registration");
    return transformPoint(*geometry_.baseTVision, visionMm);
}

}  // namespace avatar
