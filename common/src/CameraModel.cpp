#include <avatar/common/CameraModel.h>

#include <opencv2/core.hpp>  // Matx::inv

#include <cmath>

namespace avatar {

namespace {

bool isZero(const std::array<double, 5>& kc) {
    for (double k : kc)
        if (k != 0.0) return false;
    return true;
}

/// Distortion and its Jacobian at @p x.
struct DistortionEval {
    cv::Point2d value;
    double j11, j12, j21, j22;
};

DistortionEval evaluateDistortion(const std::array<double, 5>& kc, const cv::Point2d& p) {
    const double k1 = kc[0], k2 = kc[1], p1 = kc[2], p2 = kc[3], k3 = kc[4];
    const double x = p.x, y = p.y;
    const double r2 = x * x + y * y;
    const double radial = 1.0 + r2 * (k1 + r2 * (k2 + r2 * k3));
    const double dRadial = k1 + r2 * (2.0 * k2 + 3.0 * k3 * r2);  // d radial / d r2
    DistortionEval e{};
    e.value.x = radial * x + 2.0 * p1 * x * y + p2 * (r2 + 2.0 * x * x);
    e.value.y = radial * y + p1 * (r2 + 2.0 * y * y) + 2.0 * p2 * x * y;
    e.j11 = radial + 2.0 * x * x * dRadial + 2.0 * p1 * y + 6.0 * p2 * x;
    e.j12 = 2.0 * x * y * dRadial + 2.0 * p1 * x + 2.0 * p2 * y;
    e.j21 = 2.0 * x * y * dRadial + 2.0 * p1 * x + 2.0 * p2 * y;
    e.j22 = radial + 2.0 * y * y * dRadial + 6.0 * p1 * y + 2.0 * p2 * x;
    return e;
}

}  // namespace

cv::Point2d distortNormalized(const CameraIntrinsics& intrinsics, const cv::Point2d& undistorted) {
    return evaluateDistortion(intrinsics.kc, undistorted).value;
}

cv::Point2d normalizedToPixel(const CameraIntrinsics& intrinsics, const cv::Point2d& distorted) {
    return {intrinsics.fc[0] * (distorted.x + intrinsics.alphaC * distorted.y) + intrinsics.cc[0],
            intrinsics.fc[1] * distorted.y + intrinsics.cc[1]};
}

cv::Point2d pixelToNormalized(const CameraIntrinsics& intrinsics, const cv::Point2d& pixel) {
    // Bouguet normalize.m: subtract cc, divide by fc, then undo the skew.
    cv::Point2d xd{(pixel.x - intrinsics.cc[0]) / intrinsics.fc[0],
                   (pixel.y - intrinsics.cc[1]) / intrinsics.fc[1]};
    xd.x -= intrinsics.alphaC * xd.y;
    return xd;
}

std::optional<cv::Point2d> projectPoint(const CameraIntrinsics& intrinsics,
                                        const cv::Point3d& pointCameraMm) {
    if (!(pointCameraMm.z > 0.0)) return std::nullopt;
    const cv::Point2d xn{pointCameraMm.x / pointCameraMm.z, pointCameraMm.y / pointCameraMm.z};
    return normalizedToPixel(intrinsics, distortNormalized(intrinsics, xn));
}

cv::Point2d normalizePixel(const CameraIntrinsics& intrinsics, const cv::Point2d& pixel) {
    const cv::Point2d xd = pixelToNormalized(intrinsics, pixel);
    if (isZero(intrinsics.kc)) return xd;
    // comp_distortion_oulu.m, verbatim: 20 fixed-point iterations from x = xd.
    const double k1 = intrinsics.kc[0], k2 = intrinsics.kc[1], p1 = intrinsics.kc[2],
                 p2 = intrinsics.kc[3], k3 = intrinsics.kc[4];
    cv::Point2d x = xd;
    for (int kk = 0; kk < 20; ++kk) {
        const double r2 = x.x * x.x + x.y * x.y;
        const double kRadial = 1.0 + k1 * r2 + k2 * r2 * r2 + k3 * r2 * r2 * r2;
        const double dx = 2.0 * p1 * x.x * x.y + p2 * (r2 + 2.0 * x.x * x.x);
        const double dy = p1 * (r2 + 2.0 * x.y * x.y) + 2.0 * p2 * x.x * x.y;
        x = cv::Point2d{(xd.x - dx) / kRadial, (xd.y - dy) / kRadial};
    }
    return x;
}

std::optional<cv::Point2d> undistortNormalizedExact(const CameraIntrinsics& intrinsics,
                                                    const cv::Point2d& distorted,
                                                    double tolerance) {
    if (isZero(intrinsics.kc)) return distorted;
    cv::Point2d x = distorted;
    for (int iteration = 0; iteration < 50; ++iteration) {
        const DistortionEval e = evaluateDistortion(intrinsics.kc, x);
        const double fx = e.value.x - distorted.x;
        const double fy = e.value.y - distorted.y;
        const double det = e.j11 * e.j22 - e.j12 * e.j21;
        if (!(std::abs(det) > 1e-300)) return std::nullopt;
        const cv::Point2d step{(e.j22 * fx - e.j12 * fy) / det, (-e.j21 * fx + e.j11 * fy) / det};
        x -= step;
        if (!std::isfinite(x.x) || !std::isfinite(x.y)) return std::nullopt;
        if (std::abs(step.x) <= tolerance && std::abs(step.y) <= tolerance) {
            // Accept only the physical branch: the mapping must be orientation-preserving
            // there, otherwise Newton found a fold of an over-strong distortion.
            const DistortionEval check = evaluateDistortion(intrinsics.kc, x);
            if (check.j11 * check.j22 - check.j12 * check.j21 <= 0.0) return std::nullopt;
            if (std::hypot(check.value.x - distorted.x, check.value.y - distorted.y) > 1e-9)
                return std::nullopt;
            return x;
        }
    }
    return std::nullopt;
}

std::optional<cv::Point2d> normalizePixelExact(const CameraIntrinsics& intrinsics,
                                               const cv::Point2d& pixel) {
    return undistortNormalizedExact(intrinsics, pixelToNormalized(intrinsics, pixel));
}

cv::Matx33d cameraMatrix(const CameraIntrinsics& c) {
    return {c.fc[0], c.fc[0] * c.alphaC, c.cc[0], 0.0, c.fc[1], c.cc[1], 0.0, 0.0, 1.0};
}

cv::Matx33d essentialMatrix(const RigidTransform& rightTLeft) {
    // X_r = R X_l + T: X_r, T and R X_l are coplanar, X_r . (T x R X_l) = 0,
    // so x_r^T [T]x R x_l = 0 for normalised x.
    const cv::Vec3d t = translationVector(rightTLeft);
    const cv::Matx33d skewT(0.0, -t[2], t[1], t[2], 0.0, -t[0], -t[1], t[0], 0.0);
    return skewT * rotationMatrix(rightTLeft);
}

cv::Matx33d fundamentalMatrix(const StereoGeometry& stereo) {
    // p_r^T K_r^-T E K_l^-1 p_l = 0 for pixels p = K x.
    const cv::Matx33d kLeftInv = cameraMatrix(stereo.left).inv();
    const cv::Matx33d kRightInv = cameraMatrix(stereo.right).inv();
    return kRightInv.t() * essentialMatrix(stereo.rightTLeft) * kLeftInv;
}

}  // namespace avatar
