#include <avatar/common/Registration.h>

#include <avatar/common/Error.h>

#include <opencv2/core.hpp>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>
#include <random>
#include <string>

namespace avatar {

namespace {

cv::Vec3d vec(const cv::Point3d& p) { return {p.x, p.y, p.z}; }

cv::Vec3d centroid(const std::vector<cv::Point3d>& points) {
    cv::Vec3d sum(0, 0, 0);
    for (const cv::Point3d& p : points) sum += vec(p);
    return sum * (1.0 / static_cast<double>(points.size()));
}

/// The eigenvalues (descending) of the scatter matrix of @p points about their centroid.
cv::Vec3d spread(const std::vector<cv::Point3d>& points) {
    const cv::Vec3d c = centroid(points);
    cv::Matx33d scatter = cv::Matx33d::zeros();
    for (const cv::Point3d& p : points) {
        const cv::Vec3d d = vec(p) - c;
        scatter += d * d.t();
    }
    cv::Mat values;
    cv::eigen(cv::Mat(scatter), values);
    return {values.at<double>(0), values.at<double>(1), values.at<double>(2)};
}

/// Relative size below which the second spread of a cloud counts as none:
/// the points lie on one line (to rounding) and the rotation about it is free.
constexpr double kCollinear = 1e-12;

void checkInput(const std::vector<cv::Point3d>& vision, const std::vector<cv::Point3d>& base, const char* who) {
    const std::string name = who;
    if (vision.size() != base.size())
        throw InvalidArgument(name + ": " + std::to_string(vision.size()) + " vision points but " +
                              std::to_string(base.size()) + " base points; they must correspond one to one");
    if (vision.size() < 3)
        throw InvalidArgument(name + ": " + std::to_string(vision.size()) +
                              " point pairs; a rotation needs at least 3 that are not on one line");
    for (std::size_t i = 0; i < vision.size(); ++i)
        for (const cv::Point3d* p : {&vision[i], &base[i]})
            if (!std::isfinite(p->x) || !std::isfinite(p->y) || !std::isfinite(p->z))
                throw InvalidArgument(name + ": point pair " + std::to_string(i + 1) + " has a coordinate that is not finite");
    for (const auto* cloud : {&vision, &base}) {
        const cv::Vec3d s = spread(*cloud);
        const char* frame = cloud == &vision ? "vision" : "base";
        if (!(s[0] > 0.0))
            throw InvalidArgument(name + ": all " + frame + " points are in one place; they determine no rotation");
        if (!(s[1] > kCollinear * s[0]))
            throw InvalidArgument(name + ": the " + frame +
                                  " points lie on one line; the rotation about that line is undetermined "
                                  "(move the arm to points off the line)");
    }
}

/// The closed form without the input checks (used on checked data and on minimal sets).
RigidTransform closedForm(const std::vector<cv::Point3d>& vision, const std::vector<cv::Point3d>& base) {
    const cv::Vec3d cv_ = centroid(vision);
    const cv::Vec3d cb = centroid(base);
    cv::Matx33d h = cv::Matx33d::zeros();  // sum (v - cv)(b - cb)^T
    for (std::size_t i = 0; i < vision.size(); ++i) h += (vec(vision[i]) - cv_) * (vec(base[i]) - cb).t();
    cv::Mat w, u, vt;
    cv::SVD::compute(cv::Mat(h), w, u, vt, cv::SVD::FULL_UV);
    const cv::Matx33d U(u), Vt(vt);
    // R = V diag(1, 1, d) U^T with d = det(V U^T): the proper rotation nearest
    // to the best orthogonal one (a reflection when the data are noisy and planar).
    const double d = cv::determinant(Vt.t() * U.t()) < 0.0 ? -1.0 : 1.0;
    const cv::Matx33d r = Vt.t() * cv::Matx33d::diag({1.0, 1.0, d}) * U.t();
    return makeRigidTransform(r, cb - r * cv_);
}

}  // namespace

RigidTransform registerClosedForm(const std::vector<cv::Point3d>& vision, const std::vector<cv::Point3d>& base) {
    checkInput(vision, base, "registerClosedForm");
    return closedForm(vision, base);
}

RigidTransform registerIterative(const std::vector<cv::Point3d>& vision, const std::vector<cv::Point3d>& base,
                                 int maxIterations) {
    checkInput(vision, base, "registerIterative");
    if (maxIterations < 1) throw InvalidArgument("registerIterative: maxIterations must be at least 1");
    const cv::Vec3d cv_ = centroid(vision);
    const cv::Vec3d cb = centroid(base);
    std::vector<cv::Vec3d> v, m;
    for (std::size_t i = 0; i < vision.size(); ++i) {
        v.push_back(vec(vision[i]) - cv_);
        m.push_back(vec(base[i]) - cb);
    }
    cv::Matx33d r = cv::Matx33d::eye();
    // One best rotation about axis a (0 x, 1 y, 2 z) of the vision cloud onto
    // the base cloud; b and c are the other two axes in cyclic order. Returns
    // the angle (0 when the points have no spread about that axis).
    const auto step = [&](int a) {
        const int b = (a + 1) % 3, c = (a + 2) % 3;
        double cosSum = 0.0, sinSum = 0.0;
        for (std::size_t j = 0; j < v.size(); ++j) {
            cosSum += v[j][b] * m[j][b] + v[j][c] * m[j][c];
            sinSum += -(v[j][c] * m[j][b]) + v[j][b] * m[j][c];
        }
        const double magnitude = std::hypot(cosSum, sinSum);
        if (!(magnitude > 0.0)) return 0.0;
        const double cosA = cosSum / magnitude, sinA = sinSum / magnitude;
        cv::Matx33d rot = cv::Matx33d::eye();
        rot(b, b) = cosA;
        rot(b, c) = -sinA;
        rot(c, b) = sinA;
        rot(c, c) = cosA;
        r = rot * r;
        for (cv::Vec3d& p : v) p = rot * p;
        return std::atan2(sinA, cosA);
    };
    for (int i = 0; i < maxIterations; ++i) {
        // Figure 3-1: gamma about x, beta about y, alpha about z.
        const double gamma = step(0), beta = step(1), alpha = step(2);
        if (std::abs(gamma) < 1e-12 && std::abs(beta) < 1e-12 && std::abs(alpha) < 1e-12) break;
    }
    cv::Vec3d t(0, 0, 0);
    for (std::size_t i = 0; i < vision.size(); ++i) t += vec(base[i]) - r * vec(vision[i]);
    return makeRigidTransform(r, t * (1.0 / static_cast<double>(vision.size())));
}

std::vector<double> registrationResiduals(const RigidTransform& baseTVision, const std::vector<cv::Point3d>& vision,
                                          const std::vector<cv::Point3d>& base) {
    std::vector<double> out;
    out.reserve(vision.size());
    for (std::size_t i = 0; i < vision.size() && i < base.size(); ++i)
        out.push_back(cv::norm(vec(transformPoint(baseTVision, vision[i])) - vec(base[i])));
    return out;
}

RobustRegistration registerRobust(const std::vector<cv::Point3d>& vision, const std::vector<cv::Point3d>& base,
                                  const RobustRegistrationOptions& options) {
    checkInput(vision, base, "registerRobust");
    const std::size_t n = vision.size();
    const auto medianOfSquares = [](std::vector<double> r) {
        for (double& x : r) x *= x;
        std::nth_element(r.begin(), r.begin() + static_cast<std::ptrdiff_t>(r.size() / 2), r.end());
        return r[r.size() / 2];
    };

    RigidTransform best = closedForm(vision, base);
    double bestMedian = medianOfSquares(registrationResiduals(best, vision, base));
    std::mt19937_64 rng(options.seed);
    std::uniform_int_distribution<std::size_t> pick(0, n - 1);
    for (int s = 0; s < options.samples && n > 3; ++s) {
        std::size_t a = pick(rng), b = pick(rng), c = pick(rng);
        if (a == b || b == c || a == c) continue;
        const std::vector<cv::Point3d> sv{vision[a], vision[b], vision[c]};
        const std::vector<cv::Point3d> sb{base[a], base[b], base[c]};
        const cv::Vec3d spreadV = spread(sv), spreadB = spread(sb);
        if (!(spreadV[1] > 1e-6 * spreadV[0]) || !(spreadB[1] > 1e-6 * spreadB[0])) continue;  // a line
        const RigidTransform candidate = closedForm(sv, sb);
        const double median = medianOfSquares(registrationResiduals(candidate, vision, base));
        if (median < bestMedian) {
            bestMedian = median;
            best = candidate;
        }
    }

    // The robust per-axis scale: for 3-D Gaussian errors r^2 is sigma^2
    // chi^2_3, whose median is 2.366; (1 + 5 / (n - 6)) is Rousseeuw's
    // small-sample correction. A residual norm above 4.03 sigma (the 99.9 %
    // quantile of chi_3) marks an outlier.
    const double correction = n > 6 ? 1.0 + 5.0 / static_cast<double>(n - 6) : 2.0;
    double sigma = correction * std::sqrt(bestMedian / 2.366);
    RobustRegistration out;
    out.baseTVision = best;
    for (int round = 0; round < 3; ++round) {
        out.thresholdMm = std::max(options.thresholdSigmas * sigma, options.minThresholdMm);
        const std::vector<double> residuals = registrationResiduals(out.baseTVision, vision, base);
        std::vector<cv::Point3d> iv, ib;
        std::vector<bool> inliers(n);
        for (std::size_t i = 0; i < n; ++i) {
            inliers[i] = residuals[i] <= out.thresholdMm;
            if (inliers[i]) {
                iv.push_back(vision[i]);
                ib.push_back(base[i]);
            }
        }
        if (iv.size() < 3) throw InvalidArgument("registerRobust: fewer than 3 points agree with any registration");
        const cv::Vec3d s = spread(iv);
        if (!(s[1] > kCollinear * s[0]))
            throw InvalidArgument("registerRobust: the points that agree lie on one line; the rotation about it is undetermined");
        const RigidTransform refit = closedForm(iv, ib);
        const bool stable = inliers == out.inliers;
        out.baseTVision = refit;
        out.inliers = inliers;
        // The per-axis scale of the inliers' residuals about the refit: 3
        // coordinates per point, 6 parameters.
        double sum = 0.0;
        for (const double r : registrationResiduals(refit, iv, ib)) sum += r * r;
        const double dof = std::max(1.0, 3.0 * static_cast<double>(iv.size()) - 6.0);
        sigma = std::sqrt(sum / dof);
        if (stable) break;
    }
    out.residualsMm = registrationResiduals(out.baseTVision, vision, base);
    double sum = 0.0;
    std::size_t count = 0;
    for (std::size_t i = 0; i < n; ++i)
        if (out.inliers[i]) {
            sum += out.residualsMm[i] * out.residualsMm[i];
            ++count;
        }
    out.rmsMm = std::sqrt(sum / static_cast<double>(count));
    return out;
}

RegistrationUncertainty registrationUncertainty(const RigidTransform& baseTVision,
                                                const std::vector<cv::Point3d>& vision,
                                                const std::vector<cv::Point3d>& base, const std::vector<bool>& use) {
    std::vector<cv::Point3d> v, b;
    for (std::size_t i = 0; i < vision.size() && i < base.size(); ++i)
        if (use.empty() || (i < use.size() && use[i])) {
            v.push_back(vision[i]);
            b.push_back(base[i]);
        }
    if (v.size() < 3) throw InvalidArgument("registrationUncertainty: fewer than 3 points");
    RegistrationUncertainty u;
    double rss = 0.0;
    for (const double r : registrationResiduals(baseTVision, v, b)) rss += r * r;
    u.sigmaMm = std::sqrt(rss / std::max(1.0, 3.0 * static_cast<double>(v.size()) - 6.0));
    const cv::Vec3d c = centroid(v);
    cv::Matx33d scatter = cv::Matx33d::zeros();
    for (const cv::Point3d& p : v) {
        const cv::Vec3d d = vec(p) - c;
        scatter += d * d.t();
    }
    const double trace = scatter(0, 0) + scatter(1, 1) + scatter(2, 2);
    const cv::Matx33d information = trace * cv::Matx33d::eye() - scatter;
    cv::Mat values;
    cv::eigen(cv::Mat(information), values);
    const double smallest = values.at<double>(2);
    const double variance = u.sigmaMm * u.sigmaMm;
    if (!(smallest > 0.0)) {
        u.worstRotationStdRad = std::numeric_limits<double>::infinity();
        u.rotationStdRad.fill(std::numeric_limits<double>::infinity());
        u.translationStdMm.fill(std::numeric_limits<double>::infinity());
        return u;
    }
    // Rotation error (a small vector w, R_est = exp([w]x) R, in the base
    // frame): cov(w) = sigma^2 R (tr(S) I - S)^-1 R^T.
    const cv::Matx33d r = rotationMatrix(baseTVision);
    const cv::Matx33d covRotation = variance * (r * information.inv() * r.t());
    u.worstRotationStdRad = std::sqrt(variance / smallest);
    // t = mean(b) - R mean(v): the centroids' noise, plus the rotation error
    // moving the rotated vision centroid.
    const cv::Vec3d rc = r * c;
    const cv::Matx33d cross(0, -rc[2], rc[1], rc[2], 0, -rc[0], -rc[1], rc[0], 0);
    const cv::Matx33d covTranslation =
        (variance / static_cast<double>(v.size())) * cv::Matx33d::eye() + cross * covRotation * cross.t();
    const cv::Matx33d covRotationVision = variance * information.inv();
    for (int k = 0; k < 3; ++k) {
        u.rotationStdRad[static_cast<std::size_t>(k)] = std::sqrt(covRotationVision(k, k));
        u.translationStdMm[static_cast<std::size_t>(k)] = std::sqrt(covTranslation(k, k));
    }
    return u;
}

PointRegistration registerPoints(const std::vector<cv::Point3d>& vision, const std::vector<cv::Point3d>& base,
                                 const RegistrationOptions& options) {
    checkInput(vision, base, "registerPoints");
    PointRegistration out;
    out.inliers.assign(vision.size(), true);
    if (options.rejectOutliers) out.inliers = registerRobust(vision, base, options.robust).inliers;
    std::vector<cv::Point3d> iv, ib;
    for (std::size_t i = 0; i < vision.size(); ++i)
        if (out.inliers[i]) {
            iv.push_back(vision[i]);
            ib.push_back(base[i]);
        }
    out.baseTVision = options.method == RegistrationMethod::Iterative
                          ? registerIterative(iv, ib, options.maxIterations)
                          : registerClosedForm(iv, ib);
    out.residualsMm = registrationResiduals(out.baseTVision, vision, base);
    double sum = 0.0;
    for (std::size_t i = 0; i < vision.size(); ++i)
        if (out.inliers[i]) sum += out.residualsMm[i] * out.residualsMm[i];
    out.rmsMm = std::sqrt(sum / static_cast<double>(iv.size()));
    out.uncertainty = registrationUncertainty(out.baseTVision, vision, base, out.inliers);
    if (!(out.uncertainty.worstRotationStdRad <= options.maxRotationStdRad)) {
        char text[256];
        std::snprintf(text, sizeof text,
                      "registerPoints: the rotation is uncertain by %.3g degrees (one standard deviation) about the "
                      "worst axis, above the limit of %.3g: the %zu points lie too close to one line for their "
                      "%.3g mm noise; add points off that line",
                      out.uncertainty.worstRotationStdRad * 180.0 / M_PI, options.maxRotationStdRad * 180.0 / M_PI,
                      iv.size(), out.uncertainty.sigmaMm);
        throw InvalidArgument(text);
    }
    return out;
}

std::array<double, 3> eulerZyx(const cv::Matx33d& r) {
    const double alpha = std::atan2(r(1, 0), r(0, 0));
    const double beta = std::atan2(-r(2, 0), std::hypot(r(2, 1), r(2, 2)));
    const double gamma = std::atan2(r(2, 1), r(2, 2));
    return {alpha, beta, gamma};
}

double rotationAngleBetween(const cv::Matx33d& a, const cv::Matx33d& b) {
    const cv::Matx33d d = b * a.t();
    const double c = std::clamp((d(0, 0) + d(1, 1) + d(2, 2) - 1.0) / 2.0, -1.0, 1.0);
    // acos loses precision near 0; the skew part gives the sine.
    const double s = 0.5 * std::sqrt((d(2, 1) - d(1, 2)) * (d(2, 1) - d(1, 2)) + (d(0, 2) - d(2, 0)) * (d(0, 2) - d(2, 0)) +
                                     (d(1, 0) - d(0, 1)) * (d(1, 0) - d(0, 1)));
    return std::atan2(s, c);
}

}  // namespace avatar
