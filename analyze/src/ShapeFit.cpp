#include "ShapeFit.h"

#include <opencv2/core.hpp>
#include <opencv2/imgproc.hpp>

#include <algorithm>
#include <cmath>
#include <iterator>
#include <limits>
#include <numeric>

namespace avatar::detail {

namespace {

/// Signed distance of a point from an ellipse along the ray from its centre
/// (positive outside), and the point's angle parameter. The ellipse's
/// rotation is taken once, not per point.
struct EllipsePosition {
    double distance;
    double angle;
};
class EllipseFrame {
public:
    explicit EllipseFrame(const cv::RotatedRect& e)
        : cx_(e.center.x), cy_(e.center.y), a_(0.5 * e.size.width), b_(0.5 * e.size.height) {
        const double th = e.angle * CV_PI / 180.0;
        ct_ = std::cos(th);
        st_ = std::sin(th);
    }
    double distance(const cv::Point2f& p) const {
        double u, v;
        const double r = local(p, u, v);
        const double rho = std::hypot(u / a_, v / b_);
        return rho > 0.0 ? r * (1.0 - 1.0 / rho) : -std::min(a_, b_);
    }
    EllipsePosition position(const cv::Point2f& p) const {
        double u, v;
        local(p, u, v);
        return {distance(p), std::atan2(v / b_, u / a_)};
    }

private:
    /// The point in the ellipse's axes (u, v) and its distance from the centre.
    double local(const cv::Point2f& p, double& u, double& v) const {
        const double dx = p.x - cx_, dy = p.y - cy_;
        u = ct_ * dx + st_ * dy;
        v = -st_ * dx + ct_ * dy;
        return std::hypot(dx, dy);
    }
    double cx_, cy_, a_, b_, ct_{1.0}, st_{0.0};
};

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
    const EllipseFrame frame(e);
    for (std::size_t i = 0; i < points.size(); ++i) {
        const double t = frame.position(points[i]).angle;
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

/// The least distance outside the ellipse at which a free outline point is
/// evidence of another object in the silhouette (px), when the fit's inlier
/// limit is less. A second object lies its own size outside; the limit is
/// three times the fit's scatter, which for a clean outline is a tenth of a
/// pixel or less, and a pixel's worth of the demosaic's false colour or a
/// notch's floor is not another object.
constexpr double kExcessPx = 1.0;

EllipseFit fitEllipse(const CameraIntrinsics& camera, const std::vector<OutlinePoint>& outline,
                      double minThresholdPx) {
    EllipseFit fit;
    const double f = camera.fc[0];
    std::vector<cv::Point2d> normalised;
    std::vector<double> variances;  // of each point's position, px^2
    // A notch's walls lie inside the outline by the notch's depth: on a
    // sphere's limb in shadow, where the filter leaves notches a pixel or
    // two deep, they pulled the ellipse towards the lamp (docs/accuracy.md,
    // "The thirteenth round").
    std::vector<bool> rim;  // no second object beyond the ellipse (OutlinePoint::rim)
    for (const OutlinePoint& p : outline)
        if (p.kind == EdgeKind::Free && !p.wall) {
            normalised.push_back(normalizePixel(camera, p.px));
            variances.push_back(p.sigmaPx * p.sigmaPx);
            rim.push_back(p.rim);
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
        const EllipseFrame frame(e);
        for (std::size_t i = 0; i < ideal.size(); ++i) {
            r[i] = frame.distance(ideal[i]);
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
    const EllipseFrame frame(e);
    for (std::size_t i = 0; i < ideal.size(); ++i) {
        r[i] = frame.distance(ideal[i]);
        if (std::abs(r[i]) <= threshold) {
            ++fit.inliers;
            sum += r[i] * r[i];
            inliers.push_back(ideal[i]);
            inlierVariances.push_back(variances[i]);
        } else if (r[i] > 0.0) {
            ++fit.excessPoints;
            fit.farExcessPoints += r[i] > kExcessPx && !rim[i];
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

/// How far from another target's pixels a silhouette's outline still
/// belongs to the seam between the two (px).
constexpr double kSeamPx = 3.0;
/// Where a seam ends (the other target's outline leaves this one's), the
/// mixed pixels of the two colours and the background blur along it: an
/// outline point this close to the other target (px) and at most
/// kSeamBulgePx outside the ellipse is still the seam. A second object
/// in the silhouette lies its own size outside the ellipse, not a pixel
/// or two (the bilinear demosaic's pixel of mixing and the erosion's).
constexpr double kSeamEndPx = 8.0;
constexpr double kSeamBulgePx = 2.5;

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
    const EllipseFrame frame(fit.ideal);
    for (const OutlinePoint& p : outline) {
        if (p.kind != EdgeKind::Free) continue;
        const cv::Point2d n = normalizePixel(camera, p.px);
        const cv::Point2f ideal(static_cast<float>(n.x * f), static_cast<float>(n.y * f));
        const EllipsePosition pos = frame.position(ideal);
        if (std::abs(pos.distance) <= fit.thresholdPx) supported[static_cast<std::size_t>(binOf(pos.angle))] = true;
    }
    const auto toPixel = [&](const cv::Point2d& idealPx) {
        return normalizedToPixel(camera, distortNormalized(camera, idealPx * (1.0 / f)));
    };
    std::vector<cv::Point2d> contacts;
    for (const OutlinePoint& p : outline)
        if (p.kind == EdgeKind::Contact) contacts.push_back(p.px);
    const auto nearContact = [&](const cv::Point2d& px, double reachPx = kSeamPx) {
        for (const cv::Point2d& q : contacts)
            if (cv::norm(q - px) <= reachPx) return true;
        return false;
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
        const cv::Point2d onPx = toPixel(pointOn(fit.ideal, t, 0.0));
        const cv::Point2d inPx = toPixel(pointOn(fit.ideal, t, 0.75));
        const cv::Point2d deepPx = toPixel(pointOn(fit.ideal, t, 1.75));
        const EdgeKind on = probe(onPx, ownOn);
        const EdgeKind in = probe(inPx, ownIn);
        const EdgeKind deep = probe(deepPx, ownDeep);
        if (on == EdgeKind::ImageEdge || on == EdgeKind::WindowEdge) ++c.cut;
        // At another target, the mixed pixels of the seam pass neither
        // filter: the nearer one's own pixels may begin a pixel further in.
        else if (ownIn) ++c.present;
        else if (ownDeep && (on == EdgeKind::Contact || in == EdgeKind::Contact)) ++c.seam;
        // Where the seam's mixed pixels pass neither filter, the gap between
        // the two masks is background: still the seam when the outline's own
        // contact points lie this close.
        else if (ownDeep && nearContact(onPx)) ++c.seam;
        else if (on == EdgeKind::Contact || in == EdgeKind::Contact || deep == EdgeKind::Contact) {
            ++c.hidden;
            c.hiddenPx.push_back(onPx);
        }
        // Where the seam ends, the mixed pixels of the two colours and the
        // background blur along it and the filter passes neither side: a
        // bin short there is at the other target too, hidden only if that
        // one is the nearer.
        else if (nearContact(onPx, kSeamEndPx)) {
            ++c.hidden;
            c.hiddenPx.push_back(onPx);
        }
        else {
            ++c.missing;
            c.shallow += ownDeep;
            c.missingBins.push_back(k);
            if (ownDeep) c.shallowBins.push_back(k);
            // Where the probes meet a fragment: on the ellipse, inside it
            // (the probes above) or within 2 px outside it.
            const std::size_t before = c.fragmentPx.size();
            if (deep == EdgeKind::Fragment) c.fragmentPx.push_back(deepPx);
            if (in == EdgeKind::Fragment) c.fragmentPx.push_back(inPx);
            if (on == EdgeKind::Fragment) c.fragmentPx.push_back(onPx);
            for (const double d : {1.0, 2.0}) {
                const cv::Point2d px = toPixel(pointOn(fit.ideal, t, -d));
                bool own = false;
                if (probe(px, own) == EdgeKind::Fragment) c.fragmentPx.push_back(px);
            }
            if (c.fragmentPx.size() > before) {
                c.fragmentBins.push_back(k);
                c.fragmentShallow += ownDeep;
            }
        }
    }
    // Points well outside the ellipse (beyond its inlier limit and
    // kExcessPx) are another object, except at the seam with a target it
    // touches: mixed pixels of two colours may pass this filter there
    // (orange beside yellow), a bulge of a pixel or two.
    int excess = fit.farExcessPoints;
    const double excessFrom = std::max(fit.thresholdPx, kExcessPx);
    if (!contacts.empty() && excess > 0) {
        excess = 0;
        for (const OutlinePoint& p : outline) {
            if (p.kind != EdgeKind::Free || p.wall || p.rim) continue;  // the points fitEllipse() counted
            const cv::Point2d n = normalizePixel(camera, p.px);
            const cv::Point2f ideal(static_cast<float>(n.x * f), static_cast<float>(n.y * f));
            const double outside = frame.distance(ideal);
            if (outside <= excessFrom) continue;
            const double reach = outside <= kSeamBulgePx ? kSeamEndPx : kSeamPx;
            bool seam = false;
            for (const cv::Point2d& q : contacts) seam = seam || cv::norm(q - p.px) <= reach;
            excess += !seam;
        }
    }
    c.excess = excess >= std::max(3, fit.points / 50);
    return c;
}

RoundCompleteness withoutFragments(const RoundCompleteness& c) {
    RoundCompleteness rest = c;
    rest.missing -= static_cast<int>(c.fragmentBins.size());
    rest.shallow -= c.fragmentShallow;
    rest.fragmentShallow = 0;
    rest.fragmentPx.clear();
    const auto atFragment = [&](int k) {
        return std::find(c.fragmentBins.begin(), c.fragmentBins.end(), k) != c.fragmentBins.end();
    };
    rest.missingBins.clear();
    for (const int k : c.missingBins)
        if (!atFragment(k)) rest.missingBins.push_back(k);
    rest.shallowBins.clear();
    for (const int k : c.shallowBins)
        if (!atFragment(k)) rest.shallowBins.push_back(k);
    return rest;
}

bool foreignAtMissing(const CameraIntrinsics& camera, const EllipseFit& fit, const RoundCompleteness& c,
                      const std::function<cv::Vec3d(const cv::Point2d&)>& colourAt, const PixelProbe& probe,
                      double factor, double minLog, const std::optional<cv::Vec3d>& target, double insideLog,
                      bool deepOnly) {
    if (!fit.ok || c.missingBins.empty() || c.bins <= 0) return false;
    std::vector<int> judged;
    for (const int k : c.missingBins)
        if (!deepOnly || std::find(c.shallowBins.begin(), c.shallowBins.end(), k) == c.shallowBins.end())
            judged.push_back(k);
    if (judged.empty()) return false;
    const auto angleOf = [&](int k) { return -CV_PI + (k + 0.5) * 2.0 * CV_PI / c.bins; };
    const double f = camera.fc[0];
    const auto toPixel = [&](const cv::Point2d& idealPx) {
        return normalizedToPixel(camera, distortNormalized(camera, idealPx * (1.0 / f)));
    };
    // Brightness: the mean of the channels' logs.
    const auto meanLog = [](const cv::Vec3d& v) {
        return (std::log1p(std::max(v[0], 0.0)) + std::log1p(std::max(v[1], 0.0)) + std::log1p(std::max(v[2], 0.0))) /
               3.0;
    };
    // The mean log colour of the free background 1.5, 2.5 and 3.5 px
    // outside the ellipse at angle t; none where any of them is not free.
    const auto outside = [&](double t) -> std::optional<cv::Vec3d> {
        cv::Vec3d sum(0, 0, 0);
        for (const double d : {1.5, 2.5, 3.5}) {
            const cv::Point2d px = toPixel(pointOn(fit.ideal, t, -d));
            bool own = false;
            // A fragment's pixels are read as what lies there.
            const EdgeKind kind = probe(px, own);
            if ((kind != EdgeKind::Free && kind != EdgeKind::Fragment) || own) return std::nullopt;
            const cv::Vec3d v = colourAt(px);
            const double lb = std::log1p(std::max(v[0], 0.0)), lg = std::log1p(std::max(v[1], 0.0)),
                         lr = std::log1p(std::max(v[2], 0.0));
            // Chromaticity (B/G, R/G) and brightness: a shadow on the
            // background changes only the brightness, and only downwards.
            sum += cv::Vec3d(lb - lg, lr - lg, meanLog(v));
        }
        return sum * (1.0 / 3.0);
    };
    std::vector<double> channels[3];
    for (int k = 0; k < c.bins; ++k) {
        if (std::find(c.missingBins.begin(), c.missingBins.end(), k) != c.missingBins.end() ||
            std::find(c.fragmentBins.begin(), c.fragmentBins.end(), k) != c.fragmentBins.end())
            continue;
        if (const auto v = outside(angleOf(k)))
            for (int ch = 0; ch < 3; ++ch) channels[ch].push_back((*v)[ch]);
    }
    if (channels[0].size() < 8) return false;  // too little free background to know it
    cv::Vec3d median, spread;
    for (int ch = 0; ch < 3; ++ch) {
        std::vector<double>& v = channels[ch];
        std::nth_element(v.begin(), v.begin() + static_cast<std::ptrdiff_t>(v.size() / 2), v.end());
        median[ch] = v[v.size() / 2];
        for (double& x : v) x = std::abs(x - median[ch]);
        std::nth_element(v.begin(), v.begin() + static_cast<std::ptrdiff_t>(v.size() / 2), v.end());
        spread[ch] = 1.4826 * v[v.size() / 2];
    }
    for (const int k : judged) {
        if (const auto v = outside(angleOf(k)))
            for (int ch = 0; ch < 3; ++ch) {
                // Chromaticity either way; brightness only above the background's.
                const double d = ch < 2 ? std::abs((*v)[ch] - median[ch]) : (*v)[ch] - median[ch];
                if (d >= minLog && d > factor * spread[ch]) return true;
            }
    }
    if (!target) return false;
    const double above = std::max(median[2], meanLog(*target)) + std::max(insideLog, factor * spread[2]);
    for (const int k : judged) {
        int bright = 0;
        for (const double d : {0.5, 1.5, 2.5, 3.5, 4.5}) {
            const cv::Point2d px = toPixel(pointOn(fit.ideal, angleOf(k), d));
            bool own = false;
            const EdgeKind kind = probe(px, own);
            if ((kind != EdgeKind::Free && kind != EdgeKind::Fragment) || own) continue;
            if (meanLog(colourAt(px)) >= above && ++bright == 2) return true;
        }
    }
    return false;
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

std::optional<std::pair<double, double>> conicRowRange(const cv::Matx33d& conic, const cv::Matx33d& rect) {
    bool invertible = false;
    const cv::Matx33d dual = conic.inv(cv::DECOMP_LU, &invertible);
    if (!invertible) return std::nullopt;
    const cv::Vec3d a = rect.t() * cv::Vec3d(0.0, 1.0, 0.0), b = rect.t() * cv::Vec3d(0.0, 0.0, 1.0);
    // (a - v b)^T Q^-1 (a - v b) = 0
    const double qa = b.dot(dual * b), qb = -2.0 * a.dot(dual * b), qc = a.dot(dual * a);
    const double disc = qb * qb - 4.0 * qa * qc;
    if (!(qa != 0.0) || !(disc > 0.0) || !std::isfinite(disc)) return std::nullopt;
    const double r1 = (-qb - std::sqrt(disc)) / (2.0 * qa), r2 = (-qb + std::sqrt(disc)) / (2.0 * qa);
    return std::make_pair(std::min(r1, r2), std::max(r1, r2));
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

namespace {

/// A circular cone about the unit @p axis: the rays whose unit vectors u
/// have axis . u == cosAngle (a sphere's silhouette).
struct Cone {
    cv::Vec3d axis;
    double cosAngle{1.0};
};

/// The cone through three unit rays: their tips lie in a plane whose normal
/// is the axis.
std::optional<Cone> coneThrough(const cv::Vec3d& a, const cv::Vec3d& b, const cv::Vec3d& c) {
    cv::Vec3d n = (b - a).cross(c - a);
    const double length = cv::norm(n);
    if (!(length > 1e-15)) return std::nullopt;
    n *= 1.0 / length;
    if (n[2] < 0.0) n = -n;  // in front of the camera
    const double k = n.dot(a);
    if (!(k > 0.0 && k < 1.0)) return std::nullopt;
    return Cone{n, k};
}

/// The least-squares plane through the tips of @p rays[i] for i in @p use:
/// the smallest principal axis of their scatter.
std::optional<Cone> coneFit(const std::vector<cv::Vec3d>& rays, const std::vector<std::size_t>& use) {
    if (use.size() < 3) return std::nullopt;
    cv::Vec3d mean(0, 0, 0);
    for (std::size_t i : use) mean += rays[i];
    mean *= 1.0 / static_cast<double>(use.size());
    cv::Matx33d scatter = cv::Matx33d::zeros();
    for (std::size_t i : use) {
        const cv::Vec3d d = rays[i] - mean;
        scatter += d * d.t();
    }
    cv::Vec3d values;
    cv::Matx33d vectors;
    eigen3(scatter, values, vectors);
    cv::Vec3d n(vectors(2, 0), vectors(2, 1), vectors(2, 2));
    if (n[2] < 0.0) n = -n;
    const double k = n.dot(mean);
    if (!(k > 0.0 && k < 1.0)) return std::nullopt;
    return Cone{n, k};
}

/// The indices in @p candidates of the rays within @p tolerance (rad, of the
/// cone's half-angle) of @p cone: a band of cosines, so no arc cosine per ray.
std::vector<std::size_t> coneInliers(const Cone& cone, const std::vector<cv::Vec3d>& rays,
                                     const std::vector<std::size_t>& candidates, double tolerance) {
    const double angle = std::acos(std::clamp(cone.cosAngle, -1.0, 1.0));
    const double hi = std::cos(std::max(angle - tolerance, 0.0)), lo = std::cos(angle + tolerance);
    std::vector<std::size_t> out;
    for (std::size_t i : candidates) {
        const double c = cone.axis.dot(rays[i]);
        if (c >= lo && c <= hi) out.push_back(i);
    }
    return out;
}

/// A cone as an ellipse fit (ideal pixels, conic), with the RMS distance of
/// @p rays[i], i in @p use, from it: a part is a sphere's image, so its
/// ellipse is fixed by three parameters and a short arc of it is enough.
EllipseFit coneEllipse(const Cone& cone, const std::vector<cv::Vec3d>& rays, const std::vector<std::size_t>& use,
                       double f, double thresholdPx) {
    EllipseFit fit;
    const double c = cone.cosAngle;
    // The cone (axis . x)^2 = c^2 |x|^2 for x = (u, v, 1) is the conic
    // Q = axis axis^T - c^2 I; an ellipse when the axis is more than the
    // half-angle in front of the image plane.
    const cv::Vec3d& n = cone.axis;
    const cv::Matx33d q = n * n.t() - cv::Matx33d::eye() * (c * c);
    const cv::Matx22d a2(q(0, 0), q(0, 1), q(1, 0), q(1, 1));
    const double det = cv::determinant(a2);
    if (!(det > 0.0)) return fit;
    const cv::Vec2d centre = -(a2.inv() * cv::Vec2d(q(0, 2), q(1, 2)));
    const double k = -(q(2, 2) + q(0, 2) * centre[0] + q(1, 2) * centre[1]);
    // (x - centre)^T A (x - centre) = k: semi-axis sqrt(k / l) along each
    // eigenvector of A; the width along the first's direction.
    const double tr = a2(0, 0) + a2(1, 1), disc = std::sqrt(std::max(0.0, 0.25 * tr * tr - det));
    const double l1 = 0.5 * tr - disc, l2 = 0.5 * tr + disc;
    if (!(l1 * k > 0.0 && l2 * k > 0.0)) return fit;
    const double angle = std::abs(a2(0, 1)) > 1e-300 ? std::atan2(l1 - a2(0, 0), a2(0, 1))
                                                     : (a2(0, 0) <= a2(1, 1) ? 0.0 : CV_PI / 2);
    const double axis1 = std::sqrt(k / l1) * f, axis2 = std::sqrt(k / l2) * f;
    fit.ok = true;
    fit.ideal = cv::RotatedRect(cv::Point2f(static_cast<float>(centre[0] * f), static_cast<float>(centre[1] * f)),
                                cv::Size2f(static_cast<float>(2.0 * axis1), static_cast<float>(2.0 * axis2)),
                                static_cast<float>(angle * 180.0 / CV_PI));
    fit.conic = q;
    fit.thresholdPx = thresholdPx;
    fit.points = fit.inliers = static_cast<int>(use.size());
    const double halfAngle = std::acos(std::clamp(c, -1.0, 1.0));
    double sum = 0.0;
    for (std::size_t i : use) {
        const double d = (std::acos(std::clamp(cone.axis.dot(rays[i]), -1.0, 1.0)) - halfAngle) * f;
        sum += d * d;
    }
    fit.rmsPx = use.empty() ? 0.0 : std::sqrt(sum / static_cast<double>(use.size()));
    return fit;
}

/// The pixels of @p silhouette's region inside ellipse @p fit (ideal
/// pixels) grown by @p growPx, as a mask of the region.
cv::Mat partMask(const CameraIntrinsics& camera, const EllipseFit& fit, const Silhouette& silhouette, double growPx) {
    cv::Mat inside = cv::Mat::zeros(silhouette.labels.size(), CV_8UC1);
    const double f = camera.fc[0];
    constexpr int kSides = 72;
    std::vector<cv::Point> polygon;
    polygon.reserve(kSides);
    for (int k = 0; k < kSides; ++k) {
        const cv::Point2d ideal = pointOn(fit.ideal, 2.0 * CV_PI * k / kSides, -growPx);
        const cv::Point2d px = normalizedToPixel(camera, distortNormalized(camera, ideal * (1.0 / f)));
        // fillPoly's fixed point: 1/16 px.
        polygon.emplace_back(static_cast<int>(std::lround((px.x - silhouette.region.x) * 16.0)),
                             static_cast<int>(std::lround((px.y - silhouette.region.y) * 16.0)));
    }
    cv::fillPoly(inside, std::vector<std::vector<cv::Point>>{polygon}, cv::Scalar(255), cv::LINE_8, 4);
    return inside;
}

}  // namespace

PartsFit fitRoundParts(const CameraIntrinsics& camera, const Silhouette& silhouette, double minThresholdPx,
                       double partThresholdPx, int maxParts, double minPartSided) {
    PartsFit out;
    const std::vector<OutlinePoint>& outline = silhouette.outline;
    std::vector<cv::Vec3d> rays;
    std::vector<const OutlinePoint*> source;
    for (const OutlinePoint& p : outline)
        if (p.kind == EdgeKind::Free || p.kind == EdgeKind::Contact) {
            const cv::Point2d n = normalizePixel(camera, p.px);
            const cv::Vec3d r(n.x, n.y, 1.0);
            rays.push_back(r * (1.0 / cv::norm(r)));
            source.push_back(&p);
        }
    out.points = static_cast<int>(rays.size());
    // A pixel is about 1/f rad near the axis; the outline's rays are
    // nearly parallel, so one tolerance serves the whole silhouette.
    const double tolerance = partThresholdPx / camera.fc[0];
    std::vector<std::size_t> left(rays.size());
    std::iota(left.begin(), left.end(), std::size_t{0});
    std::vector<Cone> cones;
    // A fixed seed: the same outline always gives the same parts.
    cv::RNG rng(0x5eedu);
    constexpr std::size_t kMinPartPoints = 6;
    std::vector<std::size_t> refused;  // points of a consensus that was not a part
    for (int attempt = 0; attempt < maxParts + 2 && static_cast<int>(cones.size()) < maxParts &&
                          left.size() >= kMinPartPoints;
         ++attempt) {
        // Candidates are scored on at most 128 of the points (a long
        // outline has far more than a consensus needs); the best one's
        // inliers are then taken from all of them.
        const std::size_t stride = std::max<std::size_t>(1, (left.size() + 127) / 128);
        std::vector<std::size_t> sample;
        for (std::size_t i = 0; i < left.size(); i += stride) sample.push_back(left[i]);
        std::vector<std::size_t> best;
        std::optional<Cone> bestCone;
        const double n = static_cast<double>(sample.size());
        int needed = 400;
        for (int it = 0; it < needed; ++it) {
            const std::size_t a = left[static_cast<std::size_t>(rng.uniform(0, static_cast<int>(left.size())))];
            const std::size_t b = left[static_cast<std::size_t>(rng.uniform(0, static_cast<int>(left.size())))];
            const std::size_t c = left[static_cast<std::size_t>(rng.uniform(0, static_cast<int>(left.size())))];
            if (a == b || b == c || a == c) continue;
            const auto cone = coneThrough(rays[a], rays[b], rays[c]);
            if (!cone) continue;
            std::vector<std::size_t> in = coneInliers(*cone, rays, sample, tolerance);
            if (in.size() > best.size()) {
                best = std::move(in);
                bestCone = cone;
                // Enough samples to draw three of the best's points at once
                // with 99.9 % probability.
                const double w = static_cast<double>(best.size()) / n;
                const double miss = 1.0 - w * w * w;
                if (miss <= 1e-9) needed = it + 1;
                else needed = std::min(400, static_cast<int>(std::ceil(std::log(1e-3) / std::log(miss))));
            }
        }
        if (!bestCone) break;
        best = coneInliers(*bestCone, rays, left, tolerance);
        if (best.size() < kMinPartPoints) break;
        std::optional<Cone> cone;
        for (int round = 0; round < 3; ++round) {
            const auto refined = coneFit(rays, best);
            if (!refined) break;
            cone = refined;
            std::vector<std::size_t> in = coneInliers(*cone, rays, left, tolerance);
            if (in.size() < kMinPartPoints || in == best) break;
            best = std::move(in);
        }
        if (!cone) break;
        std::vector<std::size_t> rest;
        std::set_difference(left.begin(), left.end(), best.begin(), best.end(), std::back_inserter(rest));
        left = std::move(rest);
        // A part is a piece of the object: the silhouette lies inside its
        // arc, nothing of it beyond. Points along a neighbour in front of
        // it follow the neighbour's circle, with the silhouette beyond it.
        // (Only the outer side is asked: the filter may lose the dim pixels
        // just inside a shaded edge.)
        EllipseFit part = coneEllipse(*cone, rays, best, camera.fc[0], std::max(minThresholdPx, partThresholdPx));
        if (!part.ok) break;
        if (!silhouette.labels.empty()) {
            const cv::Point2d centre = normalizedToPixel(
                camera, distortNormalized(camera, cv::Point2d(part.ideal.center) * (1.0 / camera.fc[0])));
            const auto own = [&](const cv::Point2d& px) {
                const int x = static_cast<int>(std::lround(px.x)) - silhouette.region.x;
                const int y = static_cast<int>(std::lround(px.y)) - silhouette.region.y;
                return x >= 0 && y >= 0 && x < silhouette.labels.cols && y < silhouette.labels.rows &&
                       silhouette.labels.at<std::uint8_t>(y, x) == 1;  // Silhouette's kFeature
            };
            std::size_t sided = 0;
            for (std::size_t i : best) {
                const cv::Point2d p = source[i]->px, towards = centre - p;
                const double length = cv::norm(towards);
                if (!(length > 0.0)) continue;
                sided += !own(p - towards * (1.5 / length));
            }
            if (static_cast<double>(sided) < minPartSided * static_cast<double>(best.size())) {
                refused.insert(refused.end(), best.begin(), best.end());
                continue;
            }
        }
        cones.push_back(*cone);
        std::vector<OutlinePoint> points;
        for (std::size_t i : best) points.push_back(*source[i]);
        out.parts.push_back(part);
        out.outlines.push_back(std::move(points));
    }
    left.insert(left.end(), refused.begin(), refused.end());
    for (std::size_t i : left) {
        bool in = false;
        for (const Cone& c : cones) in = in || c.axis.dot(rays[i]) > c.cosAngle;
        ++(in ? out.inside : out.outside);
    }
    return out;
}

std::optional<cv::Matx22d> coneAxisCovariance(const CameraIntrinsics& camera, const EllipseFit& part,
                                              const std::vector<OutlinePoint>& outline) {
    const auto cone = part.ok ? sphereCone(part.conic) : std::nullopt;
    if (!cone || outline.size() < 3) return std::nullopt;
    cv::Vec3d n(cone->axis.x, cone->axis.y, 1.0);
    n *= 1.0 / cv::norm(n);
    const double f = camera.fc[0], across = std::sin(cone->halfAngle);
    // Weighted scatter of the rays' tips (weight: 1 / variance of the tip's
    // distance from the plane).
    double total = 0.0;
    cv::Vec3d mean(0, 0, 0);
    std::vector<std::pair<cv::Vec3d, double>> tips;
    tips.reserve(outline.size());
    for (const OutlinePoint& p : outline) {
        const cv::Point2d q = normalizePixel(camera, p.px);
        cv::Vec3d u(q.x, q.y, 1.0);
        u *= 1.0 / cv::norm(u);
        const double sd = across * std::max(p.sigmaPx, 1e-3) / f;
        const double w = 1.0 / (sd * sd);
        tips.emplace_back(u, w);
        mean += u * w;
        total += w;
    }
    mean *= 1.0 / total;
    cv::Matx33d scatter = cv::Matx33d::zeros();
    for (const auto& [u, w] : tips) {
        const cv::Vec3d d = u - mean;
        scatter += (d * d.t()) * w;
    }
    // In the plane: two directions perpendicular to n.
    cv::Vec3d e1 = std::abs(n[0]) < 0.9 ? cv::Vec3d(1, 0, 0) : cv::Vec3d(0, 1, 0);
    e1 -= n * n.dot(e1);
    e1 *= 1.0 / cv::norm(e1);
    const cv::Vec3d e2 = n.cross(e1);
    const cv::Matx<double, 3, 2> basis(e1[0], e2[0], e1[1], e2[1], e1[2], e2[2]);
    const cv::Matx22d inPlane = basis.t() * scatter * basis;
    if (!(cv::determinant(inPlane) > 0.0)) return std::nullopt;
    const cv::Matx33d normalCov = basis * inPlane.inv() * basis.t();
    // The axis image (n_x / n_z, n_y / n_z).
    const cv::Matx23d j(1.0 / n[2], 0.0, -n[0] / (n[2] * n[2]), 0.0, 1.0 / n[2], -n[1] / (n[2] * n[2]));
    return j * normalCov * j.t();
}

namespace {

/// Image pixel @p px in ideal pixels (undistorted normalised x fc[0]), as
/// the parts' ellipses are given.
cv::Point2f idealPixel(const CameraIntrinsics& camera, const cv::Point2d& px) {
    const double f = camera.fc[0];
    const cv::Point2d n = normalizePixel(camera, px);
    return {static_cast<float>(n.x * f), static_cast<float>(n.y * f)};
}

}  // namespace

int nearestPart(const CameraIntrinsics& camera, const PartsFit& parts, const cv::Point2d& px) {
    const cv::Point2f ideal = idealPixel(camera, px);
    int best = -1;
    double bestDistance = 0.0;
    for (std::size_t i = 0; i < parts.parts.size(); ++i) {
        if (!parts.parts[i].ok) continue;
        const double d = std::abs(EllipseFrame(parts.parts[i].ideal).distance(ideal));
        if (best < 0 || d < bestDistance) {
            best = static_cast<int>(i);
            bestDistance = d;
        }
    }
    return best;
}

bool withinParts(const CameraIntrinsics& camera, const PartsFit& parts, const cv::Point2d& px, double thresholdPx) {
    const cv::Point2f ideal = idealPixel(camera, px);
    for (const EllipseFit& part : parts.parts)
        if (part.ok && EllipseFrame(part.ideal).distance(ideal) <= thresholdPx) return true;
    return false;
}

std::optional<cv::Rect2d> partsExtent(const CameraIntrinsics& camera, const PartsFit& parts,
                                      const Silhouette& silhouette, double thresholdPx) {
    double x0 = std::numeric_limits<double>::infinity(), y0 = x0, x1 = -x0, y1 = -x0;
    for (const OutlinePoint& p : silhouette.outline) {
        if (!withinParts(camera, parts, p.px, thresholdPx)) continue;
        x0 = std::min(x0, p.px.x);
        x1 = std::max(x1, p.px.x);
        y0 = std::min(y0, p.px.y);
        y1 = std::max(y1, p.px.y);
    }
    if (!(x0 <= x1)) return std::nullopt;
    return cv::Rect2d(x0, y0, x1 - x0, y1 - y0);
}

double shareOutsideParts(const CameraIntrinsics& camera, const PartsFit& parts, const Silhouette& silhouette,
                         double growPx) {
    if (silhouette.labels.empty()) return 0.0;
    const cv::Mat own = silhouette.labels == 1;  // Silhouette's kFeature
    const int total = cv::countNonZero(own);
    if (total == 0) return 0.0;
    cv::Mat inside = cv::Mat::zeros(own.size(), CV_8UC1);
    for (const EllipseFit& part : parts.parts)
        if (part.ok) inside |= partMask(camera, part, silhouette, growPx);
    return static_cast<double>(cv::countNonZero(own & ~inside)) / total;
}

}  // namespace avatar::detail
