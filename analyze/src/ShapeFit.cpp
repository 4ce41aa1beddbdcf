#include "ShapeFit.h"

#include <opencv2/core.hpp>
#include <opencv2/imgproc.hpp>

#include <algorithm>
#include <cmath>

namespace avatar::detail {

namespace {

/// Signed distance of @p p from ellipse @p e along the ray from its centre
/// (positive outside), and the point's angle parameter.
struct EllipsePosition {
    double distance;
    double angle;
};
EllipsePosition positionOn(const cv::RotatedRect& e, const cv::Point2f& p) {
    const double th = e.angle * CV_PI / 180.0, ct = std::cos(th), st = std::sin(th);
    const double a = 0.5 * e.size.width, b = 0.5 * e.size.height;
    const double dx = p.x - e.center.x, dy = p.y - e.center.y;
    const double u = ct * dx + st * dy, v = -st * dx + ct * dy;
    const double rho = std::hypot(u / a, v / b);
    const double r = std::hypot(dx, dy);
    return {rho > 0.0 ? r * (1.0 - 1.0 / rho) : -std::min(a, b), std::atan2(v / b, u / a)};
}

/// The point of @p e at angle parameter @p t, moved @p inwardPx towards the centre.
cv::Point2d pointOn(const cv::RotatedRect& e, double t, double inwardPx) {
    const double th = e.angle * CV_PI / 180.0, ct = std::cos(th), st = std::sin(th);
    const double a = std::max(0.5 * e.size.width - inwardPx, 0.0), b = std::max(0.5 * e.size.height - inwardPx, 0.0);
    const double u = a * std::cos(t), v = b * std::sin(t);
    return {e.center.x + ct * u - st * v, e.center.y + st * u + ct * v};
}


/// Eigenvalues (descending) and eigenvectors (rows) of a symmetric 3x3 matrix.
void eigen3(const cv::Matx33d& m, cv::Vec3d& values, cv::Matx33d& vectors) {
    cv::Mat vals, vecs;
    cv::eigen(cv::Mat(m), vals, vecs);
    for (int i = 0; i < 3; ++i) {
        values[i] = vals.at<double>(i);
        for (int j = 0; j < 3; ++j) vectors(i, j) = vecs.at<double>(i, j);
    }
}

}  // namespace

namespace {

/// The conic of the ellipse of centre (cx, cy), semi-axes a, b and angle
/// theta (rad), all in normalised coordinates.
cv::Matx33d conicOf(double cx, double cy, double a, double b, double theta) {
    const double ct = std::cos(theta), st = std::sin(theta);
    const cv::Matx22d R(ct, -st, st, ct);
    const cv::Matx22d D(1.0 / (a * a), 0, 0, 1.0 / (b * b));
    const cv::Matx22d A = R * D * R.t();
    const cv::Vec2d c(cx, cy);
    const cv::Vec2d Ac = A * c;
    const double k = c.dot(Ac) - 1.0;
    return {A(0, 0), A(0, 1), -Ac[0], A(1, 0), A(1, 1), -Ac[1], -Ac[0], -Ac[1], k};
}

}  // namespace

cv::Matx33d ellipseConic(const cv::RotatedRect& e, double f, const cv::Point2d& offset) {
    return conicOf(e.center.x / f + offset.x, e.center.y / f + offset.y, 0.5 * e.size.width / f,
                   0.5 * e.size.height / f, e.angle * CV_PI / 180.0);
}

namespace {

/// The weighted least-squares covariance of the parameters of ellipse @p e
/// fitted to @p points with position variances @p variances along the
/// ellipse's normal: (J^T W J)^-1, J the derivatives of each point's distance
/// from the ellipse (at the ellipse point of the same angle parameter) with
/// respect to centre, semi-axes and angle. Zero when singular.
cv::Matx<double, 5, 5> parameterCovariance(const cv::RotatedRect& e, const std::vector<cv::Point2f>& points,
                                           const std::vector<double>& variances) {
    const double th = e.angle * CV_PI / 180.0, ct = std::cos(th), st = std::sin(th);
    const double a = 0.5 * e.size.width, b = 0.5 * e.size.height;
    const cv::Vec2d u(ct, st), v(-st, ct);
    cv::Matx<double, 5, 5> information = cv::Matx<double, 5, 5>::zeros();
    for (std::size_t i = 0; i < points.size(); ++i) {
        const double t = positionOn(e, points[i]).angle;
        const double c = std::cos(t), s = std::sin(t);
        cv::Vec2d n = u * (c / a) + v * (s / b);  // outward normal at the ellipse point
        n *= 1.0 / cv::norm(n);
        // How the ellipse point moves with each parameter; the distance changes by minus its normal part.
        const cv::Vec2d moves[5] = {{1.0, 0.0}, {0.0, 1.0}, u * c, v * s, v * (a * c) - u * (b * s)};
        cv::Vec<double, 5> j;
        for (int k = 0; k < 5; ++k) j[k] = -n.dot(moves[k]);
        information += (j * j.t()) * (1.0 / std::max(variances[i], 1e-4));
    }
    bool ok = false;
    const cv::Matx<double, 5, 5> covariance = information.inv(cv::DECOMP_CHOLESKY, &ok);
    return ok ? covariance : cv::Matx<double, 5, 5>::zeros();
}

}  // namespace

std::optional<cv::Matx22d> modelPointCovariance(
    const EllipseFit& fit, double f, const std::function<std::optional<cv::Point2d>(const cv::Matx33d&)>& modelPoint) {
    if (!fit.ok) return std::nullopt;
    const double p0[5] = {fit.ideal.center.x / f, fit.ideal.center.y / f, 0.5 * fit.ideal.size.width / f,
                          0.5 * fit.ideal.size.height / f, fit.ideal.angle * CV_PI / 180.0};
    // Parameter scales: the covariance is in ideal pixels (and rad).
    const double scale[5] = {1.0 / f, 1.0 / f, 1.0 / f, 1.0 / f, 1.0};
    const double step[5] = {0.01, 0.01, 0.01, 0.01, 1e-4};  // px, px, px, px, rad
    cv::Matx<double, 2, 5> g;
    for (int k = 0; k < 5; ++k) {
        double plus[5], minus[5];
        std::copy(p0, p0 + 5, plus);
        std::copy(p0, p0 + 5, minus);
        plus[k] += step[k] * scale[k];
        minus[k] -= step[k] * scale[k];
        const auto hi = modelPoint(conicOf(plus[0], plus[1], plus[2], plus[3], plus[4]));
        const auto lo = modelPoint(conicOf(minus[0], minus[1], minus[2], minus[3], minus[4]));
        if (!hi || !lo) return std::nullopt;
        g(0, k) = (hi->x - lo->x) / (2.0 * step[k]);
        g(1, k) = (hi->y - lo->y) / (2.0 * step[k]);
    }
    return g * fit.parameterCovariance * g.t();
}

EllipseFit fitEllipse(const CameraIntrinsics& camera, const std::vector<OutlinePoint>& outline,
                      double minThresholdPx) {
    EllipseFit fit;
    const double f = camera.fc[0];
    std::vector<cv::Point2d> normalised;
    std::vector<double> variances;  // of each point's position, px^2
    for (const OutlinePoint& p : outline)
        if (p.kind == EdgeKind::Free) {
            normalised.push_back(normalizePixel(camera, p.px));
            variances.push_back(p.sigmaPx * p.sigmaPx);
        }
    fit.points = static_cast<int>(normalised.size());
    if (fit.points < 10) return fit;
    cv::Point2d mean(0, 0);
    for (const auto& n : normalised) mean += n;
    mean *= 1.0 / static_cast<double>(normalised.size());
    std::vector<cv::Point2f> ideal;
    ideal.reserve(normalised.size());
    for (const auto& n : normalised)
        ideal.emplace_back(static_cast<float>((n.x - mean.x) * f), static_cast<float>((n.y - mean.y) * f));

    std::vector<cv::Point2f> use = ideal;
    cv::RotatedRect e;
    std::vector<double> r(ideal.size());
    double threshold = minThresholdPx;
    for (int round = 0; round < 4; ++round) {
        if (use.size() < 10) return fit;
        e = cv::fitEllipseDirect(use);
        if (!(e.size.width > 0.0f && e.size.height > 0.0f) || !std::isfinite(e.center.x) ||
            !std::isfinite(e.center.y))
            return fit;
        std::vector<double> absolute;
        absolute.reserve(ideal.size());
        for (std::size_t i = 0; i < ideal.size(); ++i) {
            r[i] = positionOn(e, ideal[i]).distance;
            absolute.push_back(std::abs(r[i]));
        }
        std::nth_element(absolute.begin(), absolute.begin() + static_cast<std::ptrdiff_t>(absolute.size() / 2),
                         absolute.end());
        const double sigma = 1.4826 * absolute[absolute.size() / 2];
        threshold = std::max(3.0 * sigma, minThresholdPx);
        std::vector<cv::Point2f> next;
        for (std::size_t i = 0; i < ideal.size(); ++i)
            if (std::abs(r[i]) <= threshold) next.push_back(ideal[i]);
        if (next.size() == use.size()) break;
        use = std::move(next);
    }
    fit.ok = true;
    fit.thresholdPx = threshold;
    double sum = 0.0;
    std::vector<cv::Point2f> inliers;
    std::vector<double> inlierVariances;
    for (std::size_t i = 0; i < ideal.size(); ++i) {
        r[i] = positionOn(e, ideal[i]).distance;
        if (std::abs(r[i]) <= threshold) {
            ++fit.inliers;
            sum += r[i] * r[i];
            inliers.push_back(ideal[i]);
            inlierVariances.push_back(variances[i]);
        } else if (r[i] > 0.0) {
            ++fit.excessPoints;
        } else {
            ++fit.deficitPoints;
        }
    }
    fit.rmsPx = fit.inliers > 0 ? std::sqrt(sum / fit.inliers) : 0.0;
    fit.ideal = cv::RotatedRect(cv::Point2f(e.center.x + static_cast<float>(mean.x * f),
                                            e.center.y + static_cast<float>(mean.y * f)),
                                e.size, e.angle);
    fit.conic = ellipseConic(e, f, mean);
    fit.parameterCovariance = parameterCovariance(e, inliers, inlierVariances);
    return fit;
}

RoundCompleteness roundCompleteness(const CameraIntrinsics& camera, const EllipseFit& fit,
                                    const std::vector<OutlinePoint>& outline, const PixelProbe& probe) {
    RoundCompleteness c;
    if (!fit.ok) return c;
    const double f = camera.fc[0];
    // One bin per 2 px of perimeter, 16..128.
    const double a = 0.5 * fit.ideal.size.width, b = 0.5 * fit.ideal.size.height;
    const double perimeter = CV_PI * (3.0 * (a + b) - std::sqrt((3.0 * a + b) * (a + 3.0 * b)));
    c.bins = std::clamp(static_cast<int>(perimeter / 2.0), 16, 128);
    std::vector<bool> supported(static_cast<std::size_t>(c.bins), false);
    const auto binOf = [&](double t) {
        int k = static_cast<int>(std::floor((t + CV_PI) / (2.0 * CV_PI) * c.bins));
        return std::clamp(k, 0, c.bins - 1);
    };
    for (const OutlinePoint& p : outline) {
        if (p.kind != EdgeKind::Free) continue;
        const cv::Point2d n = normalizePixel(camera, p.px);
        const cv::Point2f ideal(static_cast<float>(n.x * f), static_cast<float>(n.y * f));
        const EllipsePosition pos = positionOn(fit.ideal, ideal);
        if (std::abs(pos.distance) <= fit.thresholdPx) supported[static_cast<std::size_t>(binOf(pos.angle))] = true;
    }
    const auto toPixel = [&](const cv::Point2d& idealPx) {
        return normalizedToPixel(camera, distortNormalized(camera, idealPx * (1.0 / f)));
    };
    for (int k = 0; k < c.bins; ++k) {
        if (supported[static_cast<std::size_t>(k)]) {
            ++c.supported;
            continue;
        }
        const double t = -CV_PI + (k + 0.5) * 2.0 * CV_PI / c.bins;
        // Where the silhouette meets another target, it is complete if it
        // is the nearer of the two and hidden if not: only the depths can
        // tell (the caller judges; erosion and the mixed pixels between the
        // two masks put the boundary up to two pixels either side).
        bool ownOn = false, ownIn = false, ownDeep = false;
        const EdgeKind on = probe(toPixel(pointOn(fit.ideal, t, 0.0)), ownOn);
        const EdgeKind in = probe(toPixel(pointOn(fit.ideal, t, 0.75)), ownIn);
        const EdgeKind deep = probe(toPixel(pointOn(fit.ideal, t, 1.75)), ownDeep);
        if (on == EdgeKind::ImageEdge || on == EdgeKind::WindowEdge) ++c.cut;
        // At another target, the mixed pixels of the seam pass neither
        // filter: the nearer one's own pixels may begin a pixel further in.
        else if (ownIn) ++c.present;
        else if (ownDeep && (on == EdgeKind::Contact || in == EdgeKind::Contact)) ++c.seam;
        else if (on == EdgeKind::Contact || in == EdgeKind::Contact || deep == EdgeKind::Contact) ++c.hidden;
        else ++c.missing;
    }
    c.excess = fit.excessPoints >= std::max(3, fit.points / 50);
    return c;
}

int freeConcavities(const Silhouette& silhouette, double minDepthPx) {
    if (silhouette.labels.empty()) return 0;
    const cv::Mat own = silhouette.labels == 1;  // Silhouette's kFeature
    std::vector<std::vector<cv::Point>> contours;
    cv::findContours(own, contours, cv::RETR_EXTERNAL, cv::CHAIN_APPROX_NONE);
    if (contours.empty()) return 0;
    const auto& contour = *std::max_element(contours.begin(), contours.end(), [](const auto& a, const auto& b) {
        return a.size() < b.size();
    });
    if (contour.size() < 8) return 0;
    std::vector<int> hull;
    cv::convexHull(contour, hull, true, false);
    if (hull.size() < 3) return 0;
    std::vector<cv::Vec4i> defects;
    try {
        cv::convexityDefects(contour, hull, defects);
    } catch (const cv::Exception&) {
        return 0;  // a self-intersecting hull order on degenerate outlines
    }
    const cv::Mat& labels = silhouette.labels;
    int count = 0;
    for (const cv::Vec4i& d : defects) {
        if (d[3] / 256.0 < minDepthPx) continue;
        const cv::Point deepest = contour[static_cast<std::size_t>(d[2])];
        bool free = true;
        for (int dy = -2; dy <= 2 && free; ++dy)
            for (int dx = -2; dx <= 2 && free; ++dx) {
                const int x = deepest.x + dx, y = deepest.y + dy;
                if (x < 0 || y < 0 || x >= labels.cols || y >= labels.rows) {
                    free = false;  // at the region's edge: the image's or the window's
                    continue;
                }
                free = labels.at<std::uint8_t>(y, x) != 2;  // Silhouette's kOther
            }
        count += free;
    }
    return count;
}

std::optional<SphereCone> sphereCone(const cv::Matx33d& conic) {
    cv::Vec3d l;
    cv::Matx33d v;
    eigen3(conic, l, v);
    // A real cone has signature (+, +, -) up to sign: the odd one out is the
    // eigenvalue whose sign differs from the other two.
    int odd = -1;
    if (l[0] > 0 && l[1] > 0 && l[2] < 0) odd = 2;
    else if (l[0] > 0 && l[1] < 0 && l[2] < 0) odd = 0;
    if (odd < 0) return std::nullopt;
    const double vz = v(odd, 2);
    if (std::abs(vz) < 1e-12) return std::nullopt;
    const double la = odd == 2 ? l[0] : l[1], lb = odd == 2 ? l[1] : l[2];
    const double mean = 0.5 * (la + lb);
    SphereCone s;
    s.axis = {v(odd, 0) / vz, v(odd, 1) / vz};
    s.anisotropy = std::abs(la - lb) / std::abs(mean);
    s.halfAngle = std::atan(std::sqrt(std::abs(l[odd] / mean)));
    return s;
}

std::optional<std::array<cv::Vec3d, 2>> circleNormals(const cv::Matx33d& conic) {
    cv::Vec3d l;
    cv::Matx33d v;
    eigen3(conic, l, v);
    // Two positive eigenvalues and one negative, l1 >= l2 > 0 > l3.
    if (l[0] > 0 && l[1] < 0 && l[2] < 0) {
        eigen3(conic * -1.0, l, v);
    } else if (!(l[0] > 0 && l[1] > 0 && l[2] < 0)) {
        return std::nullopt;
    }
    const double l1 = l[0], l2 = l[1], l3 = l[2];
    const cv::Vec3d v1(v(0, 0), v(0, 1), v(0, 2)), v3(v(2, 0), v(2, 1), v(2, 2));
    const double p = std::sqrt(std::max(0.0, (l1 - l2) / (l1 - l3)));
    const double q = std::sqrt(std::max(0.0, (l2 - l3) / (l1 - l3)));
    const cv::Vec3d axis = v3[2] >= 0 ? v3 : -v3;  // the cone's axis, in front of the camera
    std::array<cv::Vec3d, 2> out{p * v1 + q * v3, p * v1 - q * v3};
    for (cv::Vec3d& n : out) {
        n /= cv::norm(n);
        if (n.dot(axis) > 0) n = -n;  // towards the camera
    }
    return out;
}

std::optional<cv::Point2d> circleCentre(const cv::Matx33d& conic, const cv::Vec3d& n) {
    bool ok = false;
    const cv::Matx33d inverse = conic.inv(cv::DECOMP_LU, &ok);
    if (!ok) return std::nullopt;
    const cv::Vec3d x = inverse * n;
    if (std::abs(x[2]) < 1e-15 * cv::norm(x)) return std::nullopt;
    return cv::Point2d(x[0] / x[2], x[1] / x[2]);
}

std::optional<DiscPair> discPair(const cv::Matx33d& conicLeft, const cv::Matx33d& conicRight,
                                 const cv::Matx33d& rightRLeft) {
    const auto nl = circleNormals(conicLeft), nr = circleNormals(conicRight);
    if (!nl || !nr) return std::nullopt;
    double best = -1.0;
    cv::Vec3d normal;
    for (const cv::Vec3d& a : *nl)
        for (const cv::Vec3d& bRight : *nr) {
            const cv::Vec3d b = rightRLeft.t() * bRight;
            const double d = a.dot(b);
            if (std::abs(d) > best) {
                best = std::abs(d);
                normal = a + (d >= 0 ? b : -b);
            }
        }
    normal /= cv::norm(normal);
    DiscPair out;
    out.normalLeft = normal;
    out.disagreementRad = std::acos(std::clamp(best, -1.0, 1.0));
    const auto cl = circleCentre(conicLeft, normal);
    const auto cr = circleCentre(conicRight, rightRLeft * normal);
    if (!cl || !cr) return std::nullopt;
    out.centreLeft = *cl;
    out.centreRight = *cr;
    return out;
}

}  // namespace avatar::detail
