#include <avatar/common/StereoCoordinateCalculator.h>

#include <avatar/common/Error.h>

#include <cmath>
#include <functional>
#include <limits>

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
    point.rayGapMm = cv::norm(X1 - X2);
    if (XL[2] > 0.0 && XR[2] > 0.0) {
        const double el = geometry_.left.fc[0] * std::hypot(XL[0] / XL[2] - xl.x, XL[1] / XL[2] - xl.y);
        const double er = geometry_.right.fc[0] * std::hypot(XR[0] / XR[2] - xr.x, XR[1] / XR[2] - xr.y);
        point.reprojectionPx = std::sqrt(0.5 * (el * el + er * er));
    } else {
        point.reprojectionPx = std::numeric_limits<double>::infinity();  // behind a camera
    }
    if (geometry_.baseTVision) point.baseMm = transformPoint(*geometry_.baseTVision, point.leftMm);
    return point;
}

namespace {

/// J C J^T for the 3x4 Jacobian of a map of four inputs (left x, y, right x,
/// y) by central differences of @p step, C = diag(covLeft, covRight).
std::optional<cv::Matx33d> propagate(const std::function<std::optional<cv::Point3d>(const cv::Vec4d&)>& f,
                                     const cv::Vec4d& at, double step, const cv::Matx22d& covLeft,
                                     const cv::Matx22d& covRight) {
    cv::Matx<double, 3, 4> J;
    for (int k = 0; k < 4; ++k) {
        cv::Vec4d plus = at, minus = at;
        plus[k] += step;
        minus[k] -= step;
        const auto a = f(plus), b = f(minus);
        if (!a || !b) return std::nullopt;
        const cv::Point3d d = (*a - *b) * (0.5 / step);
        J(0, k) = d.x;
        J(1, k) = d.y;
        J(2, k) = d.z;
    }
    cv::Matx44d C = cv::Matx44d::zeros();
    for (int i = 0; i < 2; ++i)
        for (int j = 0; j < 2; ++j) {
            C(i, j) = covLeft(i, j);
            C(2 + i, 2 + j) = covRight(i, j);
        }
    return cv::Matx33d(J * C * J.t());
}

}  // namespace

std::optional<cv::Matx33d> StereoCoordinateCalculator::covarianceNormalized(const cv::Point2d& xl,
                                                                           const cv::Point2d& xr,
                                                                           const cv::Matx22d& covLeft,
                                                                           const cv::Matx22d& covRight) const {
    const auto f = [this](const cv::Vec4d& v) -> std::optional<cv::Point3d> {
        const auto p = triangulateNormalized({v[0], v[1]}, {v[2], v[3]});
        if (!p) return std::nullopt;
        return p->leftMm;
    };
    return propagate(f, {xl.x, xl.y, xr.x, xr.y}, 1e-6, covLeft, covRight);
}

std::optional<cv::Matx33d> StereoCoordinateCalculator::covariancePixels(const cv::Point2d& leftPx,
                                                                       const cv::Point2d& rightPx,
                                                                       const cv::Matx22d& covLeftPx,
                                                                       const cv::Matx22d& covRightPx) const {
    const auto f = [this](const cv::Vec4d& v) -> std::optional<cv::Point3d> {
        const auto p = triangulate({v[0], v[1]}, {v[2], v[3]});
        if (!p) return std::nullopt;
        return p->leftMm;
    };
    return propagate(f, {leftPx.x, leftPx.y, rightPx.x, rightPx.y}, 1e-3, covLeftPx, covRightPx);
}

cv::Matx33d StereoCoordinateCalculator::covarianceToBase(const cv::Matx33d& visionCovariance) const {
    if (!geometry_.baseTVision)
        throw InvalidArgument(
            "StereoCoordinateCalculator::covarianceToBase: the stereo configuration has no "
            "baseTVision registration");
    const cv::Matx33d R = rotationMatrix(*geometry_.baseTVision);
    return R * visionCovariance * R.t();
}

cv::Point3d StereoCoordinateCalculator::visionToBase(const cv::Point3d& visionMm) const {
    if (!geometry_.baseTVision)
        throw InvalidArgument(
            "StereoCoordinateCalculator::visionToBase: the stereo configuration has no "
            "baseTVision registration");
    return transformPoint(*geometry_.baseTVision, visionMm);
}

}  // namespace avatar
