#include <avatar/analyze/StereoCalibration.h>

#include <avatar/common/CameraModel.h>
#include <avatar/common/Error.h>
#include <avatar/common/Logging.h>

#include <log4cpp/Category.hh>
#include <opencv2/calib3d.hpp>
#include <opencv2/core.hpp>
#include <opencv2/imgproc.hpp>

#include <algorithm>
#include <cmath>
#include <functional>
#include <numeric>

namespace avatar {

namespace {

log4cpp::Category& logger() { return logging::category("analyze"); }

/// An 8-bit grey image for the corner detector.
cv::Mat grey8(const cv::Mat& image, int bitDepth) {
    cv::Mat grey;
    if (image.channels() == 3) cv::cvtColor(image, grey, cv::COLOR_BGR2GRAY);
    else if (image.channels() == 1) grey = image;
    else throw FormatError("findBoardCorners: an image of 1 or 3 channels is required, got " +
                           std::to_string(image.channels()));
    if (grey.depth() == CV_16U) {
        cv::Mat eight;
        grey.convertTo(eight, CV_8U, 255.0 / ((1 << std::clamp(bitDepth, 1, 16)) - 1));
        return eight;
    }
    if (grey.depth() != CV_8U) throw FormatError("findBoardCorners: an 8- or 16-bit image is required");
    return grey;
}

CameraIntrinsics intrinsicsOf(const cv::Mat& k, const cv::Mat& d) {
    CameraIntrinsics in;
    in.fc = {k.at<double>(0, 0), k.at<double>(1, 1)};
    in.cc = {k.at<double>(0, 2), k.at<double>(1, 2)};
    in.alphaC = k.at<double>(0, 1) / k.at<double>(0, 0);
    for (int i = 0; i < 5; ++i) in.kc[static_cast<std::size_t>(i)] = i < static_cast<int>(d.total()) ? d.at<double>(i) : 0.0;
    return in;
}

double rms(const std::vector<double>& squaredErrors) {
    if (squaredErrors.empty()) return 0.0;
    return std::sqrt(std::accumulate(squaredErrors.begin(), squaredErrors.end(), 0.0) /
                     static_cast<double>(squaredErrors.size()));
}

/// The corners of the right image in the left image's order: a board can be
/// found from either end, and only the same order in both images pairs them.
std::vector<cv::Point2f> alignedRight(const CalibrationPair& pair) {
    std::vector<cv::Point2f> right = pair.right;
    const cv::Point2f dl = pair.left.back() - pair.left.front();
    const cv::Point2f dr = right.back() - right.front();
    if (dl.dot(dr) < 0.0f) std::reverse(right.begin(), right.end());
    return right;
}

/// A camera's calibration on the given pairs (views of that camera).
struct Mono {
    cv::Mat k, d;
    std::vector<cv::Mat> rvecs, tvecs;
    cv::Mat stdIntrinsics, perView;
    double rms{0.0};
};

Mono calibrateMono(const std::vector<std::vector<cv::Point3f>>& object,
                   const std::vector<std::vector<cv::Point2f>>& image, cv::Size size, bool estimateK3) {
    Mono m;
    cv::Mat stdExtrinsics;
    const int flags = estimateK3 ? 0 : cv::CALIB_FIX_K3;
    m.rms = cv::calibrateCamera(object, image, size, m.k, m.d, m.rvecs, m.tvecs, m.stdIntrinsics, stdExtrinsics,
                                m.perView, flags,
                                cv::TermCriteria(cv::TermCriteria::COUNT + cv::TermCriteria::EPS, 100, 1e-12));
    m.d = m.d.reshape(1, 1).colRange(0, 5).clone();
    return m;
}

/// Everything a stereo solution is: intrinsics of both cameras and right_T_left.
struct Stereo {
    cv::Mat kl, dl, kr, dr;
    cv::Mat r, t;  ///< 3x3, 3x1 (mm)
    cv::Mat perView;
    double rms{0.0};
};

Stereo calibrateBoth(const std::vector<std::vector<cv::Point3f>>& object,
                     const std::vector<std::vector<cv::Point2f>>& left,
                     const std::vector<std::vector<cv::Point2f>>& right, cv::Size size, const Mono& ml,
                     const Mono& mr, StereoStrategy strategy, bool estimateK3) {
    Stereo s;
    s.kl = ml.k.clone();
    s.dl = ml.d.clone();
    s.kr = mr.k.clone();
    s.dr = mr.d.clone();
    int flags = strategy == StereoStrategy::FixIntrinsics ? cv::CALIB_FIX_INTRINSIC : cv::CALIB_USE_INTRINSIC_GUESS;
    if (!estimateK3) flags |= cv::CALIB_FIX_K3;
    cv::Mat e, f;
    s.rms = cv::stereoCalibrate(object, left, right, s.kl, s.dl, s.kr, s.dr, size, s.r, s.t, e, f, s.perView, flags,
                                cv::TermCriteria(cv::TermCriteria::COUNT + cv::TermCriteria::EPS, 200, 1e-12));
    s.dl = s.dl.reshape(1, 1).colRange(0, 5).clone();
    s.dr = s.dr.reshape(1, 1).colRange(0, 5).clone();
    return s;
}

StereoSystemConfig configOf(const Stereo& s) {
    StereoSystemConfig c;
    c.left = intrinsicsOf(s.kl, s.dl);
    c.right = intrinsicsOf(s.kr, s.dr);
    cv::Vec3d om;
    cv::Rodrigues(s.r, om);
    c.om = {om[0], om[1], om[2]};
    c.translationMm = {s.t.at<double>(0), s.t.at<double>(1), s.t.at<double>(2)};
    return c;
}

/// RMS (px) of the corners of the held-back pairs as the stereo calibration
/// predicts them from the other image: the board's pose from one image
/// (solvePnP), then projected into the other through right_T_left.
double heldOutRms(const Stereo& s, const std::vector<cv::Point3f>& object,
                  const std::vector<std::vector<cv::Point2f>>& left, const std::vector<std::vector<cv::Point2f>>& right) {
    std::vector<double> squared;
    cv::Mat rl;
    cv::Rodrigues(s.r, rl);
    for (std::size_t i = 0; i < left.size(); ++i) {
        cv::Vec3d rv, tv;
        cv::solvePnP(object, left[i], s.kl, s.dl, rv, tv);
        cv::Mat rb;
        cv::Rodrigues(rv, rb);
        cv::Mat rRight = s.r * rb, tRight = s.r * cv::Mat(tv) + s.t, rvRight;
        cv::Rodrigues(rRight, rvRight);
        std::vector<cv::Point2f> predicted;
        cv::projectPoints(object, rvRight, tRight, s.kr, s.dr, predicted);
        for (std::size_t k = 0; k < predicted.size(); ++k) {
            const cv::Point2f d = predicted[k] - right[i][k];
            squared.push_back(d.dot(d));
        }
        // and from the right image into the left one
        cv::solvePnP(object, right[i], s.kr, s.dr, rv, tv);
        cv::Rodrigues(rv, rb);
        cv::Mat rLeft = s.r.t() * rb, tLeft = s.r.t() * (cv::Mat(tv) - s.t), rvLeft;
        cv::Rodrigues(rLeft, rvLeft);
        cv::projectPoints(object, rvLeft, tLeft, s.kl, s.dl, predicted);
        for (std::size_t k = 0; k < predicted.size(); ++k) {
            const cv::Point2f d = predicted[k] - left[i][k];
            squared.push_back(d.dot(d));
        }
    }
    return rms(squared);
}

// ---------------------------------------------------------------------------
// Standard errors of the stereo solution: the covariance sigma^2 (J^T J)^-1 of
// the joint least-squares problem (both cameras' reprojection residuals over
// every pair) at the solution, J by central differences. Parameters: om, T,
// each pair's board pose and, when the stereo step refined them, both
// cameras' intrinsics (fx, fy, cx, cy, k1, k2, p1, p2 and k3 when estimated).

class JointProblem {
public:
    JointProblem(const Stereo& s, const std::vector<cv::Point3f>& object,
                 const std::vector<std::vector<cv::Point2f>>& left,
                 const std::vector<std::vector<cv::Point2f>>& right, bool intrinsics, bool k3)
        : object_(object.begin(), object.end()), left_(left), right_(right), intrinsics_(intrinsics), k3_(k3) {
        cv::Vec3d om;
        cv::Rodrigues(s.r, om);
        p_ = {om[0], om[1], om[2], s.t.at<double>(0), s.t.at<double>(1), s.t.at<double>(2)};
        for (std::size_t v = 0; v < left.size(); ++v) {
            cv::Vec3d rv, tv;
            cv::solvePnP(object, left[v], s.kl, s.dl, rv, tv);
            for (int k = 0; k < 3; ++k) p_.push_back(rv[k]);
            for (int k = 0; k < 3; ++k) p_.push_back(tv[k]);
        }
        intrinsicsAt_ = p_.size();
        for (const auto* km : {&s.kl, &s.kr}) {
            const cv::Mat& kk = *km;
            const cv::Mat& dd = km == &s.kl ? s.dl : s.dr;
            base_.push_back(kk.at<double>(0, 0));
            base_.push_back(kk.at<double>(1, 1));
            base_.push_back(kk.at<double>(0, 2));
            base_.push_back(kk.at<double>(1, 2));
            for (int i = 0; i < 5; ++i) base_.push_back(dd.at<double>(i));
        }
        if (intrinsics_)
            for (std::size_t cam = 0; cam < 2; ++cam)
                for (std::size_t i = 0; i < intrinsicCount(); ++i) p_.push_back(base_[cam * 9 + i]);
        refinePoses();
    }

    std::size_t intrinsicCount() const { return k3_ ? 9 : 8; }
    std::size_t size() const { return p_.size(); }
    const std::vector<double>& parameters() const { return p_; }
    std::size_t intrinsicsAt() const { return intrinsicsAt_; }

    /// Residuals (px) of every corner, left then right, pair by pair.
    std::vector<double> residuals(const std::vector<double>& p) const {
        std::vector<double> out;
        out.reserve(left_.size() * object_.size() * 4);
        for (std::size_t v = 0; v < left_.size(); ++v) appendView(p, v, out);
        return out;
    }

    /// The covariance of all parameters (numeric Jacobian at the solution).
    cv::Mat covariance(double& rssOut) const {
        const std::vector<double> r0 = residuals(p_);
        const std::size_t m = r0.size(), n = p_.size();
        cv::Mat jtj = cv::Mat::zeros(static_cast<int>(n), static_cast<int>(n), CV_64F);
        // J column by column; each parameter of a board pose touches only its pair.
        std::vector<std::vector<double>> columns(n);
        for (std::size_t j = 0; j < n; ++j) {
            const double h = step(j);
            std::vector<double> plus = p_, minus = p_;
            plus[j] += h;
            minus[j] -= h;
            const std::vector<double> rp = residuals(plus), rm = residuals(minus);
            columns[j].resize(m);
            for (std::size_t i = 0; i < m; ++i) columns[j][i] = (rp[i] - rm[i]) / (2.0 * h);
        }
        for (std::size_t a = 0; a < n; ++a)
            for (std::size_t b = a; b < n; ++b) {
                double sum = 0.0;
                for (std::size_t i = 0; i < m; ++i) sum += columns[a][i] * columns[b][i];
                jtj.at<double>(static_cast<int>(a), static_cast<int>(b)) = sum;
                jtj.at<double>(static_cast<int>(b), static_cast<int>(a)) = sum;
            }
        double rss = 0.0;
        for (const double r : r0) rss += r * r;
        rssOut = rss;
        const double sigma2 = rss / std::max(1.0, static_cast<double>(m) - static_cast<double>(n));
        // The parameters differ by orders of magnitude in scale (pixels,
        // millimetres, radians, distortion coefficients): invert the
        // equilibrated matrix D J^T J D (unit diagonal), not J^T J itself, or
        // the small directions that carry the large variances would be lost
        // to rounding.
        cv::Mat d(static_cast<int>(n), 1, CV_64F);
        for (int i = 0; i < static_cast<int>(n); ++i) d.at<double>(i) = 1.0 / std::sqrt(jtj.at<double>(i, i));
        const cv::Mat scaled = cv::Mat::diag(d) * jtj * cv::Mat::diag(d);
        cv::Mat inverse;
        if (!cv::invert(scaled, inverse, cv::DECOMP_CHOLESKY))
            throw InvalidArgument("calibrateStereo: the calibration problem is degenerate (the views do not "
                                  "determine every parameter); use more views at different tilts");
        return cv::Mat::diag(d) * inverse * cv::Mat::diag(d) * sigma2;
    }

private:
    double step(std::size_t j) const {
        const double scale = std::max(1.0, std::abs(p_[j]));
        return 1e-6 * scale;
    }

    void cameraOf(const std::vector<double>& p, std::size_t cam, cv::Mat& k, cv::Mat& d) const {
        std::vector<double> q(base_.begin() + static_cast<std::ptrdiff_t>(cam * 9),
                              base_.begin() + static_cast<std::ptrdiff_t>(cam * 9 + 9));
        if (intrinsics_)
            for (std::size_t i = 0; i < intrinsicCount(); ++i) q[i] = p[intrinsicsAt_ + cam * intrinsicCount() + i];
        k = (cv::Mat_<double>(3, 3) << q[0], 0, q[2], 0, q[1], q[3], 0, 0, 1);
        d = (cv::Mat_<double>(1, 5) << q[4], q[5], q[6], q[7], q[8]);
    }

    void appendView(const std::vector<double>& p, std::size_t v, std::vector<double>& out) const {
        cv::Mat kl, dl, kr, dr;
        cameraOf(p, 0, kl, dl);
        cameraOf(p, 1, kr, dr);
        const std::size_t at = 6 + 6 * v;
        const cv::Vec3d rv(p[at], p[at + 1], p[at + 2]), tv(p[at + 3], p[at + 4], p[at + 5]);
        // In double throughout: the Jacobian is taken by differences of 1e-6.
        std::vector<cv::Point2d> projected;
        cv::projectPoints(object_, rv, tv, kl, dl, projected);
        for (std::size_t k = 0; k < projected.size(); ++k) {
            out.push_back(projected[k].x - left_[v][k].x);
            out.push_back(projected[k].y - left_[v][k].y);
        }
        cv::Matx33d rBoard, rStereo;
        cv::Rodrigues(rv, rBoard);
        cv::Rodrigues(cv::Vec3d(p[0], p[1], p[2]), rStereo);
        const cv::Matx33d rRight = rStereo * rBoard;
        const cv::Vec3d tRight = rStereo * tv + cv::Vec3d(p[3], p[4], p[5]);
        cv::Vec3d rvRight;
        cv::Rodrigues(rRight, rvRight);
        cv::projectPoints(object_, rvRight, tRight, kr, dr, projected);
        for (std::size_t k = 0; k < projected.size(); ++k) {
            out.push_back(projected[k].x - right_[v][k].x);
            out.push_back(projected[k].y - right_[v][k].y);
        }
    }

    /// Gauss-Newton on each board pose alone (both images), the stereo
    /// parameters fixed: the poses OpenCV optimised but does not return.
    void refinePoses() {
        for (std::size_t v = 0; v < left_.size(); ++v) {
            for (int iteration = 0; iteration < 10; ++iteration) {
                std::vector<double> r0;
                appendView(p_, v, r0);
                cv::Mat j(static_cast<int>(r0.size()), 6, CV_64F);
                for (int c = 0; c < 6; ++c) {
                    const std::size_t idx = 6 + 6 * v + static_cast<std::size_t>(c);
                    const double h = step(idx);
                    std::vector<double> plus = p_, minus = p_;
                    plus[idx] += h;
                    minus[idx] -= h;
                    std::vector<double> rp, rm;
                    appendView(plus, v, rp);
                    appendView(minus, v, rm);
                    for (std::size_t i = 0; i < r0.size(); ++i)
                        j.at<double>(static_cast<int>(i), c) = (rp[i] - rm[i]) / (2.0 * h);
                }
                cv::Mat delta;
                cv::solve(j, -cv::Mat(r0), delta, cv::DECOMP_SVD);
                for (int c = 0; c < 6; ++c) p_[6 + 6 * v + static_cast<std::size_t>(c)] += delta.at<double>(c);
                if (cv::norm(delta) < 1e-10) break;
            }
        }
    }

    const std::vector<cv::Point3d> object_;
    const std::vector<std::vector<cv::Point2f>>& left_;
    const std::vector<std::vector<cv::Point2f>>& right_;
    bool intrinsics_;
    bool k3_;
    std::vector<double> p_;
    std::vector<double> base_;  ///< both cameras' fx fy cx cy k1..k3 as solved
    std::size_t intrinsicsAt_{0};
};

IntrinsicsUncertainty monoUncertainty(const cv::Mat& std) {
    // calibrateCamera's order: fx, fy, cx, cy, k1, k2, p1, p2, k3, ...
    IntrinsicsUncertainty u;
    const auto at = [&](int i) { return i < static_cast<int>(std.total()) ? std.at<double>(i) : 0.0; };
    u.fc = {at(0), at(1)};
    u.cc = {at(2), at(3)};
    u.kc = {at(4), at(5), at(6), at(7), at(8)};
    return u;
}

}  // namespace

std::vector<cv::Point3f> BoardGeometry::objectPoints() const {
    std::vector<cv::Point3f> points;
    for (int y = 0; y < innerCorners.height; ++y)
        for (int x = 0; x < innerCorners.width; ++x)
            points.emplace_back(static_cast<float>(x * squareMm), static_cast<float>(y * squareMm), 0.0f);
    return points;
}

void BoardGeometry::validate() const {
    if (innerCorners.width < 2 || innerCorners.height < 2)
        throw InvalidArgument("checkerboard: " + std::to_string(innerCorners.width) + "x" +
                              std::to_string(innerCorners.height) + " inner corners; each count must be at least 2");
    if (!(squareMm > 0.0) || !std::isfinite(squareMm))
        throw InvalidArgument("checkerboard: the square size must be > 0 mm, got " + std::to_string(squareMm));
}

const char* toString(StereoStrategy strategy) {
    switch (strategy) {
        case StereoStrategy::Best: return "best";
        case StereoStrategy::FixIntrinsics: return "fix-intrinsics";
        case StereoStrategy::RefineAll: return "refine-all";
    }
    return "?";
}

std::optional<std::vector<cv::Point2f>> findBoardCorners(const cv::Mat& image, cv::Size innerCorners, int bitDepth) {
    if (image.empty()) throw FormatError("findBoardCorners: empty image");
    const cv::Mat grey = grey8(image, bitDepth);
    std::vector<cv::Point2f> corners;
    if (!cv::findChessboardCorners(grey, innerCorners, corners,
                                   cv::CALIB_CB_ADAPTIVE_THRESH | cv::CALIB_CB_NORMALIZE_IMAGE))
        return std::nullopt;
    if (static_cast<int>(corners.size()) != innerCorners.area()) return std::nullopt;
    // The refinement window: a third of the square's size in pixels, so it
    // sees the corner's two edges and no neighbouring corner.
    double spacing = 0.0;
    int count = 0;
    for (int y = 0; y < innerCorners.height; ++y)
        for (int x = 0; x + 1 < innerCorners.width; ++x, ++count) {
            const cv::Point2f d = corners[static_cast<std::size_t>(y * innerCorners.width + x + 1)] -
                                  corners[static_cast<std::size_t>(y * innerCorners.width + x)];
            spacing += std::hypot(d.x, d.y);
        }
    spacing /= std::max(1, count);
    const int half = std::clamp(static_cast<int>(std::lround(spacing / 3.0)), 2, 11);
    cv::cornerSubPix(grey, corners, cv::Size(half, half), cv::Size(-1, -1),
                     cv::TermCriteria(cv::TermCriteria::COUNT + cv::TermCriteria::EPS, 100, 1e-4));
    return corners;
}

double epipolarRmsPx(const StereoSystemConfig& stereo, const std::vector<CalibrationPair>& pairs) {
    const StereoGeometry g = stereoGeometry(stereo);
    const cv::Matx33d f = fundamentalMatrix(g);
    std::vector<double> squared;
    const auto ideal = [](const CameraIntrinsics& c, const cv::Point2f& p) {
        const cv::Point2d u = normalizedToPixel(c, normalizePixel(c, p));
        return cv::Vec3d(u.x, u.y, 1.0);
    };
    for (const CalibrationPair& pair : pairs) {
        const std::vector<cv::Point2f> right = alignedRight(pair);
        for (std::size_t k = 0; k < pair.left.size() && k < right.size(); ++k) {
            const cv::Vec3d pl = ideal(stereo.left, pair.left[k]), pr = ideal(stereo.right, right[k]);
            const cv::Vec3d lr = f * pl, ll = f.t() * pr;
            const double dr = pr.dot(lr) / std::hypot(lr[0], lr[1]);
            const double dl = pl.dot(ll) / std::hypot(ll[0], ll[1]);
            squared.push_back(dr * dr);
            squared.push_back(dl * dl);
        }
    }
    return rms(squared);
}

StereoCalibration calibrateStereo(const std::vector<CalibrationPair>& pairs, const BoardGeometry& board,
                                  cv::Size imageSize, const StereoCalibrationOptions& options) {
    board.validate();
    if (imageSize.width <= 0 || imageSize.height <= 0) throw InvalidArgument("calibrateStereo: empty image size");
    if (pairs.size() < 3)
        throw InvalidArgument("calibrateStereo: " + std::to_string(pairs.size()) +
                              " pairs with the whole board in both images; at least 3 are needed (10 to 20 recommended)");
    const std::size_t corners = static_cast<std::size_t>(board.innerCorners.area());
    for (const CalibrationPair& p : pairs)
        if (p.left.size() != corners || p.right.size() != corners)
            throw InvalidArgument("calibrateStereo: pair " + p.name + " has " + std::to_string(p.left.size()) + " and " +
                                  std::to_string(p.right.size()) + " corners; the board has " + std::to_string(corners));
    const std::vector<cv::Point3f> object = board.objectPoints();

    struct Split {
        std::vector<std::vector<cv::Point3f>> object;
        std::vector<std::vector<cv::Point2f>> left, right;
        std::vector<std::string> names;
    };
    const auto split = [&](const std::function<bool(std::size_t)>& take) {
        Split s;
        for (std::size_t i = 0; i < pairs.size(); ++i)
            if (take(i)) {
                s.object.push_back(object);
                s.left.push_back(pairs[i].left);
                s.right.push_back(alignedRight(pairs[i]));
                s.names.push_back(pairs[i].name);
            }
        return s;
    };

    StereoCalibration out;
    StereoStrategy strategy = options.strategy;
    if (strategy == StereoStrategy::Best) {
        strategy = StereoStrategy::RefineAll;
        if (pairs.size() >= 6) {
            // Every k-th pair held back, spread over the sequence.
            const std::size_t held = std::max<std::size_t>(
                1, static_cast<std::size_t>(std::lround(options.holdOutFraction * static_cast<double>(pairs.size()))));
            const std::size_t every = std::max<std::size_t>(2, pairs.size() / held);
            const auto isHeld = [&](std::size_t i) { return i % every == every / 2; };
            const Split train = split([&](std::size_t i) { return !isHeld(i); });
            const Split test = split(isHeld);
            const Mono ml = calibrateMono(train.object, train.left, imageSize, options.estimateK3);
            const Mono mr = calibrateMono(train.object, train.right, imageSize, options.estimateK3);
            const Stereo fixed = calibrateBoth(train.object, train.left, train.right, imageSize, ml, mr,
                                               StereoStrategy::FixIntrinsics, options.estimateK3);
            const Stereo refined = calibrateBoth(train.object, train.left, train.right, imageSize, ml, mr,
                                                 StereoStrategy::RefineAll, options.estimateK3);
            out.heldOutFixedPx = heldOutRms(fixed, object, test.left, test.right);
            out.heldOutRefinedPx = heldOutRms(refined, object, test.left, test.right);
            out.heldOutPairs = test.names;
            strategy = *out.heldOutFixedPx < *out.heldOutRefinedPx ? StereoStrategy::FixIntrinsics
                                                                    : StereoStrategy::RefineAll;
            logger().info("stereo calibration: held-back RMS %.4f px with fixed intrinsics, %.4f px refining all: %s",
                          *out.heldOutFixedPx, *out.heldOutRefinedPx, toString(strategy));
        }
    }
    out.strategy = strategy;

    const Split all = split([](std::size_t) { return true; });
    const Mono ml = calibrateMono(all.object, all.left, imageSize, options.estimateK3);
    const Mono mr = calibrateMono(all.object, all.right, imageSize, options.estimateK3);
    const Stereo s = calibrateBoth(all.object, all.left, all.right, imageSize, ml, mr, strategy, options.estimateK3);

    out.left = {intrinsicsOf(ml.k, ml.d), monoUncertainty(ml.stdIntrinsics), ml.rms, {}};
    out.right = {intrinsicsOf(mr.k, mr.d), monoUncertainty(mr.stdIntrinsics), mr.rms, {}};
    for (int i = 0; i < ml.perView.rows; ++i) out.left.perViewRmsPx.push_back(ml.perView.at<double>(i));
    for (int i = 0; i < mr.perView.rows; ++i) out.right.perViewRmsPx.push_back(mr.perView.at<double>(i));
    out.rmsPx = s.rms;
    double sumLeft = 0.0, sumRight = 0.0;
    for (int i = 0; i < s.perView.rows; ++i) {
        const double a = s.perView.at<double>(i, 0), b = s.perView.at<double>(i, 1);
        out.perPairRmsPx.push_back(std::sqrt(0.5 * (a * a + b * b)));
        out.perPairLeftRmsPx.push_back(a);
        out.perPairRightRmsPx.push_back(b);
        sumLeft += a * a;
        sumRight += b * b;
    }
    out.leftRmsPx = std::sqrt(sumLeft / std::max(1, s.perView.rows));
    out.rightRmsPx = std::sqrt(sumRight / std::max(1, s.perView.rows));
    out.stereo = configOf(s);

    // Standard errors: of om and T from the joint problem; of the intrinsics
    // from it too when the stereo step refined them, else each camera's own.
    const bool refined = strategy == StereoStrategy::RefineAll;
    const JointProblem problem(s, object, all.left, all.right, refined, options.estimateK3);
    double rss = 0.0;
    const cv::Mat cov = problem.covariance(rss);
    const auto sd = [&](std::size_t i) { return std::sqrt(std::max(0.0, cov.at<double>(static_cast<int>(i), static_cast<int>(i)))); };
    CalibrationUncertainty u;
    u.om = {sd(0), sd(1), sd(2)};
    u.translationMm = {sd(3), sd(4), sd(5)};
    if (refined) {
        for (std::size_t cam = 0; cam < 2; ++cam) {
            IntrinsicsUncertainty& in = cam == 0 ? u.left : u.right;
            const std::size_t at = problem.intrinsicsAt() + cam * problem.intrinsicCount();
            in.fc = {sd(at), sd(at + 1)};
            in.cc = {sd(at + 2), sd(at + 3)};
            in.kc = {sd(at + 4), sd(at + 5), sd(at + 6), sd(at + 7), options.estimateK3 ? sd(at + 8) : 0.0};
        }
    } else {
        u.left = out.left.uncertainty;
        u.right = out.right.uncertainty;
    }
    if (!options.estimateK3) u.left.kc[4] = u.right.kc[4] = 0.0;
    out.stereo.uncertainty = u;
    out.epipolarRmsPx = epipolarRmsPx(out.stereo, pairs);
    logger().notice("stereo calibration from %zu pairs (%s): RMS %.4f px, epipolar RMS %.4f px", pairs.size(),
                    toString(strategy), out.rmsPx, out.epipolarRmsPx);
    return out;
}

}  // namespace avatar
