// The shape models and completeness judgement of the target assembly
// (analyze/src/Silhouette.h, ShapeFit.h, TargetAssembly.h) on rendered
// scenes with exact ground truth: what each kind of silhouette is reported
// as (whole, touching the border, cut, hidden, merged, split between two
// filters), by which model, and how far from the true centre.
#include "ShapeFit.h"
#include "Silhouette.h"
#include "TargetAssembly.h"

#include <avatar/analyze/AnalyzeStereoImagePair.h>
#include <avatar/common/CameraModel.h>
#include <avatar/common/RigidTransform.h>
#include <avatar/config/ConfigXml.h>
#include <avatar/config/StereoSystemConfig.h>
#include <avatar/render/Renderer.h>
#include <avatar/render/Scene.h>

#include <gtest/gtest.h>

#include <opencv2/core.hpp>
#include <opencv2/imgproc.hpp>

#include <algorithm>
#include <array>
#include <cmath>
#include <map>
#include <optional>
#include <random>
#include <string>
#include <tuple>

namespace avatar {
namespace {

constexpr render::Rgb kYellow{0.92, 0.72, 0.04};  // scorpion.xml "sample"
constexpr render::Rgb kGold{0.85, 0.46, 0.28};    // scorpion.xml "arm_marker"

/// scorpion.xml with both types declared @p shape.
AvatarConfig config(TargetShape shape) {
    AvatarConfig c = readConfigFile(std::string(AVATAR_DATA_DIR) + "/config/scorpion.xml");
    for (TargetType& t : c.targets.targets) t.shape = shape;
    return c;
}

/// The lab's light and noise, a flat seabed far behind, nothing else.
render::Scene emptyLab() {
    render::Scene s = render::readSceneFile(std::string(AVATAR_DATA_DIR) + "/scenes/lab.xml");
    s.targets.clear();
    s.armMarkers.clear();
    s.occluders.clear();
    s.seabed.tiltDeg = 0;
    s.seabed.distanceMm = 2500;
    return s;
}

render::TargetSpec target(const std::string& name, render::Shape shape, cv::Vec3d centre, double radius,
                          const render::Rgb& albedo = kYellow, const std::string& type = "sample") {
    render::TargetSpec t;
    t.name = name;
    t.type = type;
    t.shape = shape;
    t.centreMm = centre;
    t.radiusMm = radius;
    t.albedo = albedo;
    return t;
}

/// A grey sphere that is not a target (a rock, a speck of silt).
render::Occluder occluder(const std::string& name, cv::Vec3d centre, double radius, double grey) {
    render::Occluder o;
    o.name = name;
    o.centreMm = centre;
    o.radiusMm = radius;
    o.albedo = {grey, grey, grey};
    return o;
}

struct Outcome {
    render::GroundTruth truth;
    VisionTargets result;
    AnalysisFrame frame;

    /// The stereo target whose left centroid lies on truth target @p name's
    /// left silhouette (within its equivalent radius); nullopt if none.
    std::optional<VisionTarget> of(const std::string& name) const {
        const render::TargetTruth& t = truth.target(name);
        if (!t.left.silhouetteCentroidPx) return std::nullopt;
        const double gate = std::sqrt(t.left.areaPx / M_PI);
        std::optional<VisionTarget> best;
        double bestD = gate;
        for (const VisionTarget& v : result.targets) {
            if (!(v.flags & kTargetStereo) || !v.centroidLeftPx) continue;
            const double d = cv::norm(*v.centroidLeftPx - *t.left.silhouetteCentroidPx);
            if (d < bestD) {
                bestD = d;
                best = v;
            }
        }
        return best;
    }
    double errorMm(const std::string& name) const {
        const auto v = of(name);
        return v && v->positionVisionMm ? cv::norm(*v->positionVisionMm - truth.target(name).centreLeftMm) : 1e9;
    }
    int stereoCount() const {
        int n = 0;
        for (const VisionTarget& v : result.targets) n += (v.flags & kTargetStereo) != 0;
        return n;
    }
};

Outcome run(const render::Scene& scene, const AvatarConfig& cfg, std::uint64_t seed = 3) {
    render::RenderOptions options;
    options.seed = seed;
    render::RenderResult r = render::render(scene, cfg.stereo, options);
    AnalyzeStereoImagePair analysis(cfg);
    Outcome o{r.truth, analysis.analyze(r.pair, 1), {}};
    o.frame = analysis.lastFrame();
    return o;
}

std::string flagsOf(const std::optional<VisionTarget>& v) { return v ? targetFlagsText(v->flags) : "not found"; }

/// @p mask as the one mask of @p w and its one feature (all of it), which is returned.
Feature soleFeature(ImageWork& w, const cv::Mat& mask) {
    w.masks = {mask};
    Feature feature;
    feature.area = cv::countNonZero(mask);
    feature.box = cv::boundingRect(mask);
    for (int x = feature.box.x; x < feature.box.br().x; ++x)
        if (mask.at<std::uint8_t>(feature.box.y, x) != 0) {
            feature.boundary[kTopLeft] = {x, feature.box.y};
            break;
        }
    w.features = {{feature}};
    return feature;
}

// A 160x160 16-bit image of a circle of @p target's colour (B, G, R) on
// @p seabed's: each pixel's exact coverage (8x8 samples), blurred over three
// pixels as the demosaic and optics blur an edge.
cv::Mat blurredCircle(const cv::Point2d& centre, double radius, const cv::Vec3d& target, const cv::Vec3d& seabed) {
    cv::Mat exact(160, 160, CV_64FC3);
    for (int y = 0; y < exact.rows; ++y)
        for (int x = 0; x < exact.cols; ++x) {
            int inside = 0;
            for (int sy = 0; sy < 8; ++sy)
                for (int sx = 0; sx < 8; ++sx)
                    inside += cv::norm(cv::Point2d(x - 0.5 + (sx + 0.5) / 8, y - 0.5 + (sy + 0.5) / 8) - centre) < radius;
            const double a = inside / 64.0;
            exact.at<cv::Vec3d>(y, x) = target * a + seabed * (1.0 - a);
        }
    cv::Mat mixed, out;
    cv::blur(exact, mixed, cv::Size(3, 3), cv::Point(-1, -1), cv::BORDER_REPLICATE);
    mixed.convertTo(out, CV_16UC3);
    return out;
}

// The silhouette's fills against cv::floodFill (no tolerance, no mask) as a
// brute-force reference: random blobs of four labels, views into a larger
// image, both connectivities, seeds anywhere (on the value filled or not).
TEST(Silhouette, FillComponentEqualsOpenCVsFloodFill) {
    std::mt19937 rng(11);
    std::vector<cv::Point> stack;
    int filled = 0;
    for (int trial = 0; trial < 300; ++trial) {
        const int w = 5 + static_cast<int>(rng() % 60), h = 5 + static_cast<int>(rng() % 60);
        cv::Mat big(h + 4, w + 6, CV_8UC1);
        // Blobs: random labels smoothed by taking a neighbour's now and then.
        for (int y = 0; y < big.rows; ++y)
            for (int x = 0; x < big.cols; ++x) {
                std::uint8_t v = static_cast<std::uint8_t>(rng() % 4);
                if (x > 0 && rng() % 3 != 0) v = big.at<std::uint8_t>(y, x - 1);
                if (y > 0 && rng() % 3 == 0) v = big.at<std::uint8_t>(y - 1, x);
                big.at<std::uint8_t>(y, x) = v;
            }
        const cv::Rect view(3, 2, w, h);
        const cv::Point seed(static_cast<int>(rng() % static_cast<unsigned>(w)),
                             static_cast<int>(rng() % static_cast<unsigned>(h)));
        const bool eight = trial % 2 == 0;
        const std::uint8_t from = static_cast<std::uint8_t>(rng() % 4), to = 7;
        cv::Mat ours = big.clone(), theirs = big.clone();
        cv::Mat oursView = ours(view), theirsView = theirs(view);
        detail::fillComponent(oursView, seed, from, to, eight, stack);
        if (theirsView.at<std::uint8_t>(seed) == from)
            cv::floodFill(theirsView, seed, cv::Scalar(to), nullptr, cv::Scalar(), cv::Scalar(), eight ? 8 : 4);
        filled += cv::countNonZero(theirs == to) > 0;
        ASSERT_EQ(cv::countNonZero(ours != theirs), 0) << "trial " << trial << ", " << (eight ? 8 : 4) << "-connected";
    }
    EXPECT_GT(filled, 50) << "the seeds must often lie on the value filled";
}

// A sphere and a disc tilted by 34 degrees, both in a type declared sphere:
// each is whole and located by the model its silhouettes fit. The disc's
// silhouettes are ellipses too, but not a sphere's (their cone is not
// circular): the sphere correction would put it 2 px off in each image.
TEST(ShapeModel, SphereAndTiltedDiscAreWholeAndLocatedByTheirModels) {
    render::Scene scene = emptyLab();
    auto disc = target("disc", render::Shape::Disc, {-150, -100, 600}, 35);
    disc.normal = {std::sin(0.6), 0.0, -std::cos(0.6)};
    scene.targets = {target("ball", render::Shape::Sphere, {180, 120, 650}, 40), disc};
    const Outcome o = run(scene, config(TargetShape::Sphere));
    const auto ball = o.of("ball"), d = o.of("disc");
    ASSERT_TRUE(ball && d);
    EXPECT_TRUE(ball->flags & kTargetWhole) << flagsOf(ball);
    EXPECT_EQ(ball->model, ShapeModel::Sphere);
    EXPECT_TRUE(d->flags & kTargetWhole) << flagsOf(d);
    EXPECT_EQ(d->model, ShapeModel::Disc);
    EXPECT_LT(o.errorMm("ball"), 0.5);
    EXPECT_LT(o.errorMm("disc"), 0.5);
}

// The image of a flat circle's centre is the pole of its plane's vanishing
// line, not the centre of its elliptical image: for this disc of 35 mm at
// 0.6 m, tilted 34 degrees, they are 2 px apart.
TEST(ShapeModel, DiscCentreIsThePoleOfTheVanishingLineNotTheEllipseCentre) {
    render::Scene scene = emptyLab();
    auto disc = target("disc", render::Shape::Disc, {-150, -100, 600}, 35);
    disc.normal = {std::sin(0.6), 0.0, -std::cos(0.6)};
    scene.targets = {disc};
    const AvatarConfig cfg = config(TargetShape::Disc);
    const Outcome o = run(scene, cfg);
    detail::EllipseFit fits[2];
    for (int s = 0; s < 2; ++s) {
        const ImageWork& w = o.frame.at(s == 0 ? Side::Left : Side::Right);
        ASSERT_EQ(w.features[0].size(), 1u);
        const auto sil = detail::measureSilhouette(w, 0, w.features[0][0], {0, 0, 1280, 960}, 1.0);
        EXPECT_TRUE(sil.subPixel);
        fits[s] = detail::fitEllipse(s == 0 ? cfg.stereo.left : cfg.stereo.right, sil.outline, 0.5);
        ASSERT_TRUE(fits[s].ok);
        EXPECT_LT(fits[s].rmsPx, 0.3);
    }
    const auto pair = detail::discPair(fits[0].conic, fits[1].conic, rotationMatrix(rightTLeft(cfg.stereo)));
    ASSERT_TRUE(pair);
    const cv::Vec3d truthNormal = -disc.normal / cv::norm(disc.normal);  // towards the camera
    EXPECT_LT(std::acos(std::abs(pair->normalLeft.dot(truthNormal))), 0.02);
    const render::TargetTruth& t = o.truth.target("disc");
    const cv::Point2d centreL = normalizedToPixel(cfg.stereo.left, distortNormalized(cfg.stereo.left, pair->centreLeft));
    const cv::Point2d centreR = normalizedToPixel(cfg.stereo.right, distortNormalized(cfg.stereo.right, pair->centreRight));
    EXPECT_LT(cv::norm(centreL - *t.left.projectedCentrePx), 0.05);
    EXPECT_LT(cv::norm(centreR - *t.right.projectedCentrePx), 0.05);
    const cv::Point2d ellipseCentreL(fits[0].ideal.center.x / cfg.stereo.left.fc[0],
                                     fits[0].ideal.center.y / cfg.stereo.left.fc[0]);
    EXPECT_GT(cv::norm(normalizedToPixel(cfg.stereo.left, ellipseCentreL) - *t.left.projectedCentrePx), 1.0);
}

// The covariance propagated through the ellipse fit against Monte Carlo:
// outline points of a known ellipse, each moved along its normal by noise of
// the sigma it states, fitted 400 times. The spread of the fitted centre and
// of a sphere model's cone axis must be what parameterCovariance and
// modelPointCovariance predict (400 trials measure a sigma to about 4 %).
// Outline points well outside a round silhouette's ellipse are a second
// object (excess, merged), except within the seam of a target it touches:
// mixed pixels of two colours may pass this filter there (an orange sphere
// beside a yellow duck bulges by a pixel or two towards it).
/// The round completeness of a circle of radius @p r around @p centre seen
/// through a camera without distortion: 150 outline points (1.7 px apart),
/// the point k positions from the rightmost one (either way round) lying
/// bulgePx(k) outside the circle, a contact point when contact(k). The
/// silhouette's own pixels are the circle's, less a negative bulge (a dent).
template <typename Bulge, typename Contact>
detail::RoundCompleteness circleVerdict(const cv::Point2d& centre, double r, Bulge bulgePx, Contact contact) {
    CameraIntrinsics camera = config(TargetShape::Sphere).stereo.left;
    camera.kc = {0, 0, 0, 0, 0};
    const int n = 150;
    const auto kAt = [&](const cv::Point2d& px) {
        const cv::Point2d d = px - centre;
        const double t = std::atan2(d.y, d.x);
        const int i = static_cast<int>(std::lround((t < 0.0 ? t + 2.0 * CV_PI : t) / (2.0 * CV_PI) * n)) % n;
        return std::min(i, n - i);
    };
    std::vector<detail::OutlinePoint> outline;
    for (int i = 0; i < n; ++i) {
        const double t = 2.0 * CV_PI * i / n;
        const int k = std::min(i, n - i);
        outline.push_back({centre + cv::Point2d(std::cos(t), std::sin(t)) * (r + bulgePx(k)),
                           contact(k) ? detail::EdgeKind::Contact : detail::EdgeKind::Free, 0.2});
    }
    const detail::EllipseFit fit = detail::fitEllipse(camera, outline, 0.5);
    EXPECT_TRUE(fit.ok);
    return detail::roundCompleteness(camera, fit, outline, [&](const cv::Point2d& px, bool& own) {
        own = cv::norm(px - centre) < r + std::min(0.0, static_cast<double>(bulgePx(kAt(px))));
        return detail::EdgeKind::Free;
    });
}

TEST(ShapeModel, ABulgeAtTheSeamWithANeighbourIsNotASecondObject) {
    // A bulge of 2 px over 9 points at the right; beside a neighbour its
    // middle 5 are contact (the neighbour's pixels within 2 px), and only
    // its two ends are free.
    const auto verdict = [](bool contactBeside) {
        return circleVerdict({700.0, 500.0}, 40.0, [](int k) { return k <= 4 ? 2.0 : 0.0; },
                             [&](int k) { return contactBeside && k <= 2; });
    };
    EXPECT_TRUE(verdict(false).excess) << "a bulge in the open is another object";
    EXPECT_FALSE(verdict(true).excess) << "a bulge at the seam with a neighbour is the seam";
}

// Where the seam with a target of another colour ends (its outline leaves
// this one's), the mixed pixels of the two colours and the background
// smear along this outline a few pixels past the last contact point: a
// pixel or two outside the ellipse there is the seam's end; a second
// object of this colour lies its size outside, and a bulge far from any
// contact is another object too.
TEST(ShapeModel, TheSeamsEndIsNotASecondObjectButASecondObjectBesideItIs) {
    // Contact over points k <= 6; a bulge of @p bulgePx over k in [from, to].
    const auto verdict = [](int from, int to, double bulgePx) {
        return circleVerdict({640.0, 420.0}, 40.0, [&](int k) { return k >= from && k <= to ? bulgePx : 0.0; },
                             [](int k) { return k <= 6; });
    };
    // Points 7-10 each side: 1.7-6.8 px past the last contact point.
    EXPECT_FALSE(verdict(7, 10, 2.0).excess) << "2 px outside at the seam's end";
    EXPECT_TRUE(verdict(7, 10, 6.0).excess) << "6 px outside beside the seam: an object";
    EXPECT_TRUE(verdict(16, 19, 2.0).excess) << "2 px outside 17-22 px from the seam: an object";
}

// Where the seam's mixed pixels pass neither filter (an orange sphere in
// front of a magenta disc, seed 33 of the trust report), the mask stops a
// pixel short of the circle just past the last contact point, with
// background between the two masks: bins there are the seam (judged by
// depth: complete when this target is the nearer one), not missing. The same
// dent 30 px from any contact is missing: something hides it.
TEST(ShapeModel, AGapOfMixedPixelsAtTheSeamIsTheSeamNotMissing) {
    // A dent of 1.2 px over points k in [from, to]; contact over k <= 2.
    const auto verdict = [](int from, int to) {
        return circleVerdict({700.0, 500.0}, 40.0, [&](int k) { return k >= from && k <= to ? -1.2 : 0.0; },
                             [](int k) { return k <= 2; });
    };
    const detail::RoundCompleteness atSeam = verdict(3, 4);
    EXPECT_LE(atSeam.missing, 1) << "within the tolerance of one bin (3 before)";
    EXPECT_GE(atSeam.seam, 2);
    const detail::RoundCompleteness apart = verdict(18, 19);
    EXPECT_GE(apart.missing, 2);
}

// A bin is missing where the silhouette stops short of the circle; it is
// shallow where the silhouette's own pixels still lie 1.75 px inside it, as
// they do along a circle fitted a pixel or two too large on a short arc (a
// duck's head, which TargetAssembly checks on its deep misses only). A bite
// 2.5 px deep is missing and not shallow.
TEST(ShapeModel, AMissingBinIsShallowWhereTheSilhouetteStopsWithinTwoPixels) {
    const auto verdict = [](double depthPx) {
        return circleVerdict({700.0, 500.0}, 40.0, [&](int k) { return k >= 18 && k <= 21 ? -depthPx : 0.0; },
                             [](int) { return false; });
    };
    const detail::RoundCompleteness shallow = verdict(1.2);
    EXPECT_GE(shallow.missing, 2);
    EXPECT_EQ(shallow.shallow, shallow.missing);
    const detail::RoundCompleteness deep = verdict(2.5);
    EXPECT_GE(deep.missing, 2);
    EXPECT_EQ(deep.shallow, 0);
    EXPECT_EQ(verdict(0.0).missing, 0);
}

// Where the seam ends, the mixed pixels of the two colours and the
// background may pass neither filter over a pixel or two of depth, a few
// pixels past the last contact point (an orange sphere just touching a red
// one behind it, seed 11 of the trust report: 4.5 px from the contact, and
// the whole sphere had been called hidden). Such a notch is at the other
// target (judged by depth: hidden only if that one is nearer); the same
// notch in the open is missing: something in front of it.
TEST(ShapeModel, ANotchWhereTheSeamEndsIsAtTheNeighbourNotMissing) {
    // A dent of 2.5 px (deeper than the seam's own test) over points k in
    // [from, to]; contact over k <= 2.
    const auto verdict = [](int from, int to) {
        return circleVerdict({700.0, 500.0}, 40.0, [&](int k) { return k >= from && k <= to ? -2.5 : 0.0; },
                             [](int k) { return k <= 2; });
    };
    const detail::RoundCompleteness atSeamsEnd = verdict(4, 5);  // 3.4-5.1 px past the last contact point
    EXPECT_EQ(atSeamsEnd.missing, 0);
    EXPECT_GE(atSeamsEnd.hidden, 1);
    const detail::RoundCompleteness apart = verdict(18, 19);  // 27 px past it
    EXPECT_GE(apart.missing, 2);
    EXPECT_EQ(apart.hidden, 0);
}

// The rectified rows an ellipse spans (the epipolar tangency of a round
// target whose end is a contact): the rows of the two lines of the
// rectified pencil that touch it, against 20,000 points along it.
TEST(ShapeModel, AConicsRectifiedRowsAreItsTangentRows) {
    // A rectifying rotation of a few degrees about each axis.
    const double ax = 0.02, ay = -0.03, az = 0.05;
    const cv::Matx33d rx(1, 0, 0, 0, std::cos(ax), -std::sin(ax), 0, std::sin(ax), std::cos(ax));
    const cv::Matx33d ry(std::cos(ay), 0, std::sin(ay), 0, 1, 0, -std::sin(ay), 0, std::cos(ay));
    const cv::Matx33d rz(std::cos(az), -std::sin(az), 0, std::sin(az), std::cos(az), 0, 0, 0, 1);
    const cv::Matx33d rect = rz * ry * rx;
    for (const cv::RotatedRect& e : {cv::RotatedRect({0.1f, -0.05f}, {0.16f, 0.10f}, 30.f),
                                     cv::RotatedRect({-0.3f, 0.25f}, {0.04f, 0.05f}, -70.f),
                                     cv::RotatedRect({0.0f, 0.0f}, {0.3f, 0.3f}, 0.f)}) {
        const auto range = detail::conicRowRange(detail::ellipseConic(e, 1.0, {0.0, 0.0}), rect);
        ASSERT_TRUE(range.has_value());
        const double th = e.angle * CV_PI / 180.0;
        const cv::Vec2d u(std::cos(th), std::sin(th)), v(-std::sin(th), std::cos(th));
        double lo = 1e300, hi = -1e300;
        for (int i = 0; i < 20000; ++i) {
            const double t = 2.0 * CV_PI * i / 20000.0;
            const cv::Vec2d x = cv::Vec2d(e.center.x, e.center.y) + 0.5 * e.size.width * std::cos(t) * u +
                                0.5 * e.size.height * std::sin(t) * v;
            const cv::Vec3d q = rect * cv::Vec3d(x[0], x[1], 1.0);
            lo = std::min(lo, q[1] / q[2]);
            hi = std::max(hi, q[1] / q[2]);
        }
        EXPECT_NEAR(range->first, lo, 1e-7);
        EXPECT_NEAR(range->second, hi, 1e-7);
    }
    EXPECT_FALSE(detail::conicRowRange(cv::Matx33d::zeros(), rect).has_value());
}

TEST(ShapeModel, FitCovarianceMatchesTheSpreadOfNoisyOutlines) {
    const AvatarConfig cfg = config(TargetShape::Sphere);
    CameraIntrinsics camera = cfg.stereo.left;
    camera.kc = {0, 0, 0, 0, 0};
    const double f = camera.fc[0];
    const cv::Point2d centre(820.0, 430.0);
    const double a = 42.0, b = 31.0, theta = 0.5, sigma = 0.25;
    std::mt19937 rng(12);
    std::normal_distribution<double> noise(0.0, sigma);
    const auto axis = [](const cv::Matx33d& conic) -> std::optional<cv::Point2d> {
        const auto cone = detail::sphereCone(conic);
        if (!cone) return std::nullopt;
        return cone->axis;
    };
    std::vector<cv::Point2d> centres, axes;
    cv::Matx22d predictedCentre(0, 0, 0, 0), predictedAxis(0, 0, 0, 0);
    const int trials = 400;
    for (int k = 0; k < trials; ++k) {
        std::vector<detail::OutlinePoint> outline;
        for (int i = 0; i < 240; ++i) {
            const double t = 2.0 * CV_PI * i / 240.0;
            const cv::Vec2d u(std::cos(theta), std::sin(theta)), v(-std::sin(theta), std::cos(theta));
            const cv::Vec2d p = u * (a * std::cos(t)) + v * (b * std::sin(t));
            cv::Vec2d n = u * (std::cos(t) / a) + v * (std::sin(t) / b);
            n *= 1.0 / cv::norm(n);
            const cv::Vec2d q = p + n * noise(rng);
            outline.push_back({{centre.x + q[0], centre.y + q[1]}, detail::EdgeKind::Free, sigma});
        }
        const detail::EllipseFit fit = detail::fitEllipse(camera, outline, 0.5);
        ASSERT_TRUE(fit.ok);
        ASSERT_GE(fit.inliers, 234);  // a point beyond 3 sigma now and then
        centres.emplace_back(fit.ideal.center.x, fit.ideal.center.y);
        const auto ax = axis(fit.conic);
        ASSERT_TRUE(ax);
        axes.push_back(*ax * f);
        predictedCentre += cv::Matx22d(fit.parameterCovariance(0, 0), fit.parameterCovariance(0, 1),
                                       fit.parameterCovariance(1, 0), fit.parameterCovariance(1, 1));
        const auto c = detail::modelPointCovariance(fit, f, axis);
        ASSERT_TRUE(c);
        predictedAxis += *c * (f * f);
    }
    predictedCentre *= 1.0 / trials;
    predictedAxis *= 1.0 / trials;
    const auto measured = [](const std::vector<cv::Point2d>& p) {
        cv::Point2d mean(0, 0);
        for (const auto& q : p) mean += q;
        mean *= 1.0 / static_cast<double>(p.size());
        cv::Point2d var(0, 0);
        for (const auto& q : p) var += cv::Point2d((q - mean).x * (q - mean).x, (q - mean).y * (q - mean).y);
        var *= 1.0 / static_cast<double>(p.size() - 1);
        return cv::Point2d(std::sqrt(var.x), std::sqrt(var.y));
    };
    const cv::Point2d mc = measured(centres), ma = measured(axes);
    // About sigma / sqrt(points / 2): a few hundredths of a pixel.
    EXPECT_GT(mc.x, 0.01);
    EXPECT_LT(mc.x, 0.05);
    EXPECT_NEAR(mc.x / std::sqrt(predictedCentre(0, 0)), 1.0, 0.12);
    EXPECT_NEAR(mc.y / std::sqrt(predictedCentre(1, 1)), 1.0, 0.12);
    EXPECT_NEAR(ma.x / std::sqrt(predictedAxis(0, 0)), 1.0, 0.12);
    EXPECT_NEAR(ma.y / std::sqrt(predictedAxis(1, 1)), 1.0, 0.12);
}

// 16-bit samples are read in place with integer sums; any other depth goes
// through a float copy. Both must give the same silhouette to the last bit,
// also where neighbouring samples differ by more than 4096, whose float
// squares (above 2^24) the definition rounds.
TEST(Silhouette, SixteenBitSamplesGiveWhatTheirFloatCopyGives) {
    render::Scene scene = emptyLab();
    scene.targets = {target("disc", render::Shape::Disc, {-150, -100, 600}, 35),
                     target("sphere", render::Shape::Sphere, {120, 60, 750}, 30)};
    const Outcome o = run(scene, config(TargetShape::Disc));
    int compared = 0;
    const auto compare = [&](const ImageWork& w) {
        ASSERT_EQ(w.image.type(), CV_16UC3);
        ImageWork f = w;
        w.image.convertTo(f.image, CV_32FC3);
        for (const Feature& feature : w.features[0]) {
            const auto a = detail::measureSilhouette(w, 0, feature, {0, 0, 1280, 960}, 1.0);
            const auto b = detail::measureSilhouette(f, 0, feature, {0, 0, 1280, 960}, 1.0);
            EXPECT_EQ(a.area, b.area);
            EXPECT_EQ(a.centroid, b.centroid);
            EXPECT_EQ(a.coverageNoise, b.coverageNoise);
            for (int i = 0; i < 4; ++i) EXPECT_EQ(a.centroidCovariance.val[i], b.centroidCovariance.val[i]);
            ASSERT_EQ(a.outline.size(), b.outline.size());
            for (std::size_t i = 0; i < a.outline.size(); ++i) {
                EXPECT_EQ(a.outline[i].px, b.outline[i].px);
                EXPECT_EQ(a.outline[i].sigmaPx, b.outline[i].sigmaPx);
            }
            ++compared;
        }
    };
    for (int s = 0; s < 2; ++s) {
        const ImageWork& w = o.frame.at(s == 0 ? Side::Left : Side::Right);
        compare(w);
        for (const Feature& feature : w.features[0])
            EXPECT_TRUE(detail::measureSilhouette(w, 0, feature, {0, 0, 1280, 960}, 1.0).subPixel);
        // The same masks over a grainy image: samples two apart differ by up
        // to 9000, so many squares are above 2^24.
        ImageWork grainy = w;
        grainy.image = w.image.clone();
        int big = 0;
        for (int y = 0; y < grainy.image.rows; ++y) {
            cv::Vec3w* row = grainy.image.ptr<cv::Vec3w>(y);
            for (int x = 0; x < grainy.image.cols; ++x)
                for (int c = 0; c < 3; ++c) {
                    const int grain = (x * 7919 + y * 104729 + c * 31) % 9001;
                    row[x][c] = cv::saturate_cast<std::uint16_t>(row[x][c] + grain);
                    if (x >= 2 && std::abs(int(row[x][c]) - int(row[x - 2][c])) > 4096) ++big;
                }
        }
        ASSERT_GT(big, 100000);
        compare(grainy);
    }
    EXPECT_GE(compared, 4);
}

// A sphere whose silhouette touches the last row is whole (border flag
// only); one that continues past the edge is cut; one hidden in part behind
// a grey rock in the left image only is occluded there; the sphere in front
// of another target is whole, the one behind occluded in that view.
TEST(Completeness, BorderCutAndHidden) {
    const auto bottomY = [](double bottomPx, double x, double z, double r) {
        double lo = 0, hi = 800;
        const double f = 1050.38, cy = 564.45;
        for (int i = 0; i < 60; ++i) {
            const double y = 0.5 * (lo + hi);
            const double v = cy + f * std::tan(std::asin(r / std::hypot(y, z)) + std::atan2(y, z));
            (v < bottomPx ? lo : hi) = y;
        }
        (void)x;
        return 0.5 * (lo + hi);
    };
    render::Scene scene = emptyLab();
    scene.targets = {target("touching", render::Shape::Sphere, {-250, bottomY(958.8, -250, 900, 35), 900}, 35),
                     target("cut", render::Shape::Sphere, {150, bottomY(966.0, 150, 900, 35), 900}, 35),
                     target("rocked", render::Shape::Sphere, {-200, -150, 800}, 35),
                     target("behind", render::Shape::Sphere, {200, -150, 900}, 40),
                     target("front", render::Shape::Sphere, {0, 0, 0}, 22, kGold, "arm_marker")};
    // The front sphere 40 % of the way from the left camera to "behind",
    // overlapping its left edge in the left image only.
    scene.targets[4].centreMm = cv::Vec3d(200, -150, 900) * 0.6 + cv::Vec3d(-38, 0, 0);
    scene.occluders = {occluder("rock", cv::Vec3d(-200, -150, 800) * 0.35 + cv::Vec3d(-12, 0, 0), 8, 0.35)};
    const Outcome o = run(scene, config(TargetShape::Sphere));
    const render::TargetTruth& touching = o.truth.target("touching");
    ASSERT_TRUE(touching.left.atBorder && !touching.left.cut) << "the scene must touch the border";
    ASSERT_TRUE(o.truth.target("cut").left.cut);
    ASSERT_TRUE(o.truth.target("rocked").left.occluded && !o.truth.target("rocked").right.occluded);
    ASSERT_TRUE(o.truth.target("behind").left.occluded && !o.truth.target("behind").right.occluded);
    ASSERT_FALSE(o.truth.target("front").left.occluded);

    const auto t = o.of("touching");
    EXPECT_TRUE(t && (t->flags & kTargetWhole) && (t->flags & kTargetAtBorder) && !(t->flags & kTargetCut))
        << flagsOf(t);
    // Its fit lacks the outline along the last row, and it lies where the
    // lens distorts most: 1 mm at 0.9 m, where a free sphere is within 0.5.
    EXPECT_LT(o.errorMm("touching"), 1.5);
    const auto c = o.of("cut");
    EXPECT_TRUE(c && (c->flags & kTargetCut) && !(c->flags & kTargetWhole)) << flagsOf(c);
    const auto r = o.of("rocked");
    EXPECT_TRUE(r && (r->flags & kTargetOccludedLeft) && !(r->flags & kTargetWhole)) << flagsOf(r);
    const auto b = o.of("behind");
    EXPECT_TRUE(b && (b->flags & kTargetOccludedLeft) && !(b->flags & kTargetWhole)) << flagsOf(b);
    const auto f = o.of("front");
    EXPECT_TRUE(f && (f->flags & kTargetWhole)) << flagsOf(f);
    EXPECT_LT(o.errorMm("front"), 1.0);
}

// A yellow sphere in front of a gold one, over its top in the left image,
// so that its lowest outline there is the contact: it stays whole, and the
// one behind is occluded. (These two colours leave no mixed pixels beyond
// the edge; the ellipse's rows at such an end are tested above, and the
// orange-against-yellow case is measured by trust_report, docs/accuracy.md.)
TEST(Completeness, ATargetInFrontKeepsItsEndsWhereItTouchesAnother) {
    render::Scene scene = emptyLab();
    scene.targets = {target("behind", render::Shape::Sphere, {200, -150, 900}, 40, kGold, "arm_marker"),
                     target("front", render::Shape::Sphere, {0, 0, 0}, 22)};
    scene.targets[1].centreMm = cv::Vec3d(200, -150, 900) * 0.6 + cv::Vec3d(0, -36, 0);
    const Outcome o = run(scene, config(TargetShape::Sphere));
    ASSERT_TRUE(o.truth.target("behind").left.occluded);
    ASSERT_FALSE(o.truth.target("front").left.occluded || o.truth.target("front").right.occluded);
    const auto f = o.of("front");
    EXPECT_TRUE(f && (f->flags & kTargetWhole)) << flagsOf(f);
    EXPECT_LT(o.errorMm("front"), 1.0);
    const auto b = o.of("behind");
    EXPECT_TRUE(b && (b->flags & kTargetOccludedLeft) && !(b->flags & kTargetWhole)) << flagsOf(b);
}

// Two spheres of one colour that touch make one feature in each view. Its
// outline is two sphere cones there, paired across the views: two targets,
// each placed by its cones as a sphere alone is. One that a view shows in
// part behind the other, even by a sliver of a few pixels, is occluded there
// (with its best estimate); the one in front stays whole.
TEST(Completeness, TouchingSpheresOfOneColourAreTwoTargets) {
    render::Scene side = emptyLab();
    side.targets = {target("a", render::Shape::Sphere, {-60, 0, 800}, 30),
                    target("b", render::Shape::Sphere, {-60 + 60.5, 0, 800}, 30)};
    const Outcome o = run(side, config(TargetShape::Sphere));
    ASSERT_EQ(o.frame.at(Side::Left).features[0].size(), 1u) << "the two spheres must make one feature";
    ASSERT_EQ(o.stereoCount(), 2);
    // 0.5 mm apart at the same depth: the left camera sees them side by
    // side; the right one, 106 mm to the right, looks past b's edge onto
    // a's and hides 2.7 px of a there (the renderer's truth). So b is whole
    // and a occluded in the right view only.
    for (const char* name : {"a", "b"}) {
        const auto v = o.of(name);
        ASSERT_TRUE(v) << name;
        const auto& truth = o.truth.target(name);
        const bool hiddenRight = std::string(name) == "a";
        ASSERT_FALSE(truth.left.occluded) << name;
        ASSERT_EQ(truth.right.occluded, hiddenRight) << name;
        if (hiddenRight) {
            ASSERT_GT(truth.right.potentialAreaPx - truth.right.areaPx, 1.0);
        }
        EXPECT_FALSE(v->flags & (kTargetMerged | kTargetOccludedLeft)) << name << ": " << flagsOf(v);
        EXPECT_EQ(static_cast<bool>(v->flags & kTargetOccludedRight), hiddenRight) << name << ": " << flagsOf(v);
        EXPECT_EQ(static_cast<bool>(v->flags & kTargetWhole), !hiddenRight) << name << ": " << flagsOf(v);
        EXPECT_EQ(v->model, ShapeModel::Sphere) << name;
        EXPECT_LT(o.errorMm(name), 1.0) << name;
        EXPECT_TRUE(v->covarianceVisionMm2.has_value()) << name;
    }

    render::Scene stacked = emptyLab();
    stacked.targets = {target("front", render::Shape::Sphere, {-40, 0, 780}, 30),
                       target("back", render::Shape::Sphere, {-40 + 40, -10, 860}, 30)};
    const Outcome s = run(stacked, config(TargetShape::Sphere));
    ASSERT_TRUE(s.truth.target("back").left.occluded && s.truth.target("back").right.occluded);
    ASSERT_EQ(s.frame.at(Side::Left).features[0].size(), 1u) << "the two spheres must make one feature";
    const auto f = s.of("front");
    const auto k = s.of("back");
    ASSERT_TRUE(f && k);
    EXPECT_TRUE(f->flags & kTargetWhole) << flagsOf(f);
    EXPECT_LT(s.errorMm("front"), 1.0);
    EXPECT_TRUE((k->flags & kTargetOccludedLeft) && (k->flags & kTargetOccludedRight) && !(k->flags & kTargetWhole))
        << flagsOf(k);
    EXPECT_LT(s.errorMm("back"), 3.0) << "its best estimate, from the arc it shows";
}

/// Eight pairs of touching spheres (a, b), seeded: radii 20-40 mm, a at
/// 0.6-1.4 m, b beside it mostly sideways, tilted up to 40 degrees towards or
/// away from the cameras, 0.01 mm apart (the renderer does not intersect them).
struct TouchingPair {
    cv::Vec3d a, b;
    double ra, rb;
};
std::vector<TouchingPair> touchingPairs() {
    cv::RNG rng(11);
    std::vector<TouchingPair> pairs;
    for (int k = 0; k < 8; ++k) {
        TouchingPair p;
        p.ra = rng.uniform(20.0, 40.0);
        p.rb = rng.uniform(20.0, 40.0);
        p.a = cv::Vec3d(rng.uniform(-150.0, 150.0), rng.uniform(-100.0, 100.0), rng.uniform(600.0, 1400.0));
        const double around = rng.uniform(0.0, 2.0 * M_PI), tilt = rng.uniform(-0.7, 0.7);
        const cv::Vec3d direction(std::cos(around) * std::cos(tilt), std::sin(around) * std::cos(tilt), std::sin(tilt));
        p.b = p.a + direction * (p.ra + p.rb + 0.01);
        pairs.push_back(p);
    }
    return pairs;
}

/// One sphere of a rendered pair in one view: where both are, the view's
/// camera, and what the renderer hides of it.
struct PairView {
    std::size_t pair{0};
    int side{0};
    const char* name{""};
    cv::Point3d own, other;
    double ownR{0.0}, otherR{0.0};
    cv::Point3d camera;
    double focalPx{0.0};
    double potentialPx{0.0}, hiddenPx{0.0};
    std::string what() const {
        return std::string(name) + (side == 0 ? " left" : " right") + ", pair " + std::to_string(pair);
    }
};

/// Renders each pair (a, and b in gold) in the empty lab and calls @p visit
/// for each sphere in each view that shows some of it.
template <class Visit>
void forEachPairView(const std::vector<TouchingPair>& pairs, Visit visit) {
    const AvatarConfig cfg = config(TargetShape::Sphere);
    const std::array<cv::Point3d, 2> cameras{cv::Point3d(0, 0, 0),
                                             transformPoint(inverse(rightTLeft(cfg.stereo)), {0, 0, 0})};
    for (std::size_t k = 0; k < pairs.size(); ++k) {
        const auto [a, b, ra, rb] = pairs[k];
        render::Scene scene = emptyLab();
        scene.targets = {target("a", render::Shape::Sphere, a, ra), target("b", render::Shape::Sphere, b, rb, kGold)};
        render::RenderOptions options;
        options.seed = 1;
        const render::GroundTruth truth = render::render(scene, cfg.stereo, options).truth;
        for (int s = 0; s < 2; ++s)
            for (const auto& [name, own, ownR, other, otherR] :
                 {std::tuple("a", a, ra, b, rb), std::tuple("b", b, rb, a, ra)}) {
                const render::TargetView& view = s == 0 ? truth.target(name).left : truth.target(name).right;
                if (view.potentialAreaPx <= 0.0) continue;
                PairView v;
                v.pair = k;
                v.side = s;
                v.name = name;
                v.own = cv::Point3d(own);
                v.other = cv::Point3d(other);
                v.ownR = ownR;
                v.otherR = otherR;
                v.camera = cameras[static_cast<std::size_t>(s)];
                v.focalPx = s == 0 ? cfg.stereo.left.fc[0] : cfg.stereo.right.fc[0];
                v.potentialPx = view.potentialAreaPx;
                v.hiddenPx = view.potentialAreaPx - view.areaPx;
                visit(v);
            }
    }
}

// The sliver of a sphere that a touching one hides (hiddenAtContactPx(),
// the rule by which a sphere touching another is occluded in a view) against
// the renderer's truth: touching pairs of random sizes and directions at
// 0.6-1.4 m, each sphere in each view. Where the truth hides 2 px or more
// the model says at least the 0.5 px that flags it (and its area is within
// 15 % from 5 px on: 5.4 -> 5.4, 75 -> 75, 918 -> 886 px when written); where
// nothing is hidden it stays below that.
TEST(Completeness, TheSliverBehindAContactIsWhatTheRendererHides) {
    int hiddenChecked = 0, wholeChecked = 0;
    forEachPairView(touchingPairs(), [&](const PairView& v) {
        const double model = detail::hiddenAtContactPx(v.own, v.ownR, v.other, v.otherR, v.camera, v.focalPx);
        const std::string what = v.what() + ": hidden " + std::to_string(v.hiddenPx) + " px, model " +
                                 std::to_string(model) + " px";
        if (v.hiddenPx >= 2.0) {
            ++hiddenChecked;
            EXPECT_GE(model, 0.5) << what;
            if (v.hiddenPx >= 5.0) {
                EXPECT_GT(model, 0.85 * v.hiddenPx) << what;
                EXPECT_LT(model, 1.15 * v.hiddenPx) << what;
            }
        } else if (v.hiddenPx <= 0.0) {
            ++wholeChecked;
            EXPECT_LT(model, 0.5) << what;
        }
    });
    EXPECT_GE(hiddenChecked, 4) << "the poses must hide slivers";
    EXPECT_GE(wholeChecked, 8) << "and leave spheres whole";
}

/// Each pair of @p pairs rendered as a yellow sample and a gold arm marker
/// and analysed: every view in which the renderer hides 2 px or more of
/// either sphere must flag it occluded there and not whole. Returns how
/// many such views there were, and counts in @p nearerChecked those of the
/// sphere whose centre is nearer the left camera.
int expectHiddenViewsOccluded(const std::vector<TouchingPair>& pairs, int& nearerChecked) {
    const AvatarConfig cfg = config(TargetShape::Sphere);
    int checked = 0;
    for (std::size_t k = 0; k < pairs.size(); ++k) {
        const auto [a, b, ra, rb] = pairs[k];
        render::Scene scene = emptyLab();
        scene.targets = {target("a", render::Shape::Sphere, a, ra),
                         target("b", render::Shape::Sphere, b, rb, kGold, "arm_marker")};
        const Outcome o = run(scene, cfg, 5);
        for (const char* name : {"a", "b"}) {
            const render::TargetTruth& truth = o.truth.target(name);
            const auto v = o.of(name);
            const bool nearer = cv::norm(std::string(name) == "a" ? a : b) < cv::norm(std::string(name) == "a" ? b : a);
            for (int s = 0; s < 2; ++s) {
                const render::TargetView& view = s == 0 ? truth.left : truth.right;
                if (view.potentialAreaPx - view.areaPx < 2.0) continue;
                ++checked;
                nearerChecked += nearer;
                if (!v) {
                    ADD_FAILURE() << name << ", pair " << k << " not found";
                    continue;
                }
                const std::uint32_t occluded = s == 0 ? kTargetOccludedLeft : kTargetOccludedRight;
                EXPECT_TRUE((v->flags & occluded) && !(v->flags & kTargetWhole))
                    << name << (s == 0 ? " left" : " right") << ", pair " << k << ": "
                    << view.potentialAreaPx - view.areaPx << " px hidden, flags " << flagsOf(v);
            }
        }
    }
    return checked;
}

// The same poses as above, a yellow sample touching a gold arm marker
// (two features, two types), analysed: a sphere the renderer hides by 2 px
// or more in a view is never reported whole, and is flagged occluded in
// that view, whether or not that view's outline shows the contact.
TEST(Completeness, ASphereBehindATouchingOneOfAnotherColourIsNotWhole) {
    int nearer = 0;
    EXPECT_GE(expectHiddenViewsOccluded(touchingPairs(), nearer), 4) << "the poses must hide slivers";
}

/// The pairs of touchingPairs() passed into each other by 15 % of the sum
/// of their radii (a target half sunk into another: more than the touch's
/// tolerance of 5 %).
std::vector<TouchingPair> pairsIntoEachOther() {
    std::vector<TouchingPair> pairs = touchingPairs();
    for (TouchingPair& p : pairs) {
        const cv::Vec3d direction = (p.b - p.a) / cv::norm(p.b - p.a);
        p.b = p.a + direction * (0.85 * (p.ra + p.rb));
    }
    return pairs;
}

// The share of a sphere's image that another hides (hiddenShareBySphere())
// against the renderer's truth, for spheres passed into each other, which
// hide each other in turn: within 15 % of the truth, or 3 px, in every view
// of either sphere; and in some view both are hidden at once (the nearer
// centre too, which the sliver model of touching spheres calls whole).
TEST(Completeness, TheShareTwoSpheresIntoEachOtherHideIsWhatTheRendererHides) {
    int checked = 0;
    std::map<std::pair<std::size_t, int>, int> hiddenInView;  // (pair, side) -> spheres hidden there
    forEachPairView(pairsIntoEachOther(), [&](const PairView& v) {
        const double model = detail::hiddenShareBySphere(v.own, v.ownR, v.other, v.otherR, v.camera) * v.potentialPx;
        ++checked;
        EXPECT_NEAR(model, v.hiddenPx, std::max(3.0, 0.15 * v.hiddenPx)) << v.what();
        hiddenInView[{v.pair, v.side}] += v.hiddenPx >= 5.0 && model >= 5.0;
    });
    EXPECT_EQ(checked, 32);
    const auto mutual = std::count_if(hiddenInView.begin(), hiddenInView.end(), [](const auto& e) { return e.second == 2; });
    EXPECT_GE(mutual, 2) << "the poses must show spheres hiding each other";
}

// Spheres of two colours passed into each other: every view in which the
// renderer hides 2 px or more of either flags it occluded there, the one
// with the nearer centre too. (The sliver model alone called the nearer whole: 3.8 % of a
// magenta sphere hidden by a red one it was 8.7 mm into, trust_report seed 46.)
TEST(Completeness, SpheresIntoEachOtherAreBothOccluded) {
    int nearerChecked = 0;
    EXPECT_GE(expectHiddenViewsOccluded(pairsIntoEachOther(), nearerChecked), 8) << "the poses must hide parts";
    EXPECT_GE(nearerChecked, 2) << "of the nearer spheres too";
}

// Spheres of two colours apart in space, one partly in front of the other
// in the image at nearly its depth (3-20 mm between their surfaces, the
// nearer centre closer than both radii together): the one in front is
// whole, the one behind is occluded where the renderer hides 2 px or more
// of it. Judged by the order along a ray through the cones' overlap; a
// margin of both radii called the one in front hidden too.
TEST(Completeness, OfTwoSpheresApartTheOneInFrontIsWholeTheOneBehindIsNot) {
    const AvatarConfig cfg = config(TargetShape::Sphere);
    cv::RNG rng(23);
    int front = 0, behind = 0;
    for (int k = 0; k < 6; ++k) {
        const double ra = rng.uniform(20.0, 40.0), rb = rng.uniform(20.0, 40.0);
        const cv::Vec3d a(rng.uniform(-120.0, 120.0), rng.uniform(-80.0, 80.0), rng.uniform(600.0, 1200.0));
        const double around = rng.uniform(0.0, 2.0 * M_PI);
        const double sideways = (ra + rb) * rng.uniform(0.5, 0.85), gap = rng.uniform(3.0, 20.0);
        const double deeper = std::sqrt(std::pow(ra + rb + gap, 2) - sideways * sideways);
        const cv::Vec3d b = a + cv::Vec3d(std::cos(around) * sideways, std::sin(around) * sideways, deeper);
        render::Scene scene = emptyLab();
        const bool goldInFront = k % 2 == 1;
        scene.targets = {target("a", render::Shape::Sphere, a, ra, goldInFront ? kGold : kYellow,
                                goldInFront ? "arm_marker" : "sample"),
                         target("b", render::Shape::Sphere, b, rb, goldInFront ? kYellow : kGold,
                                goldInFront ? "sample" : "arm_marker")};
        const Outcome o = run(scene, cfg, 7);
        const auto va = o.of("a"), vb = o.of("b");
        ASSERT_TRUE(va && vb) << "pair " << k;
        const render::TargetTruth& ta = o.truth.target("a");
        const render::TargetTruth& tb = o.truth.target("b");
        ASSERT_EQ(ta.left.potentialAreaPx - ta.left.areaPx, 0.0) << "pair " << k;
        ASSERT_EQ(ta.right.potentialAreaPx - ta.right.areaPx, 0.0) << "pair " << k;
        if (!ta.left.cut && !ta.right.cut) {
            ++front;
            EXPECT_TRUE(va->flags & kTargetWhole) << "pair " << k << ": " << flagsOf(va);
            EXPECT_LT(o.errorMm("a"), 1.0) << "pair " << k;
        }
        for (int s = 0; s < 2; ++s) {
            const render::TargetView& view = s == 0 ? tb.left : tb.right;
            if (view.potentialAreaPx - view.areaPx < 2.0) continue;
            ++behind;
            EXPECT_TRUE(vb->flags & (s == 0 ? kTargetOccludedLeft : kTargetOccludedRight))
                << "pair " << k << (s == 0 ? " left" : " right") << ": " << flagsOf(vb);
            EXPECT_FALSE(vb->flags & kTargetWhole) << "pair " << k;
        }
    }
    EXPECT_GE(front, 5);
    EXPECT_GE(behind, 6);
}

// A far sphere whose cone grazes a near one's (of another colour, 1.1 m
// behind it): a sliver of it hidden in a view, its chord shallower than
// the outline fit's tolerance, so every bin of its circle is supported and
// only outline points at the near sphere show the contact. Where the
// renderer hides 2 px or more of it in a view it is occluded there and not
// whole; the near sphere stays whole. (Judged by depth only where bins
// showed the contact, the far sphere was whole at 4-15 px hidden, and so
// was an orange sphere 12.6 px behind a magenta one, trust_report seed 31.)
TEST(Completeness, AFarSphereGrazingANearOneIsHiddenByItsSliver) {
    const AvatarConfig cfg = config(TargetShape::Sphere);
    const cv::Vec3d a(-60.0, 20.0, 700.0);
    const double ra = 30.0, rb = 35.0, rangeB = 1800.0;
    const cv::Vec3d toA = a / cv::norm(a);
    int slivers = 0;
    for (const double overlap : {0.0004, 0.0007, 0.001, 0.0013, 0.0016}) {
        // b's direction: a's, turned in the plane of a's ray and the image's
        // x axis by the two cones' half angles less the overlap (rad).
        const double angle = std::asin(ra / cv::norm(a)) + std::asin(rb / rangeB) - overlap;
        const cv::Vec3d side = cv::normalize(cv::Vec3d(1, 0, 0) - toA * toA[0]);
        const cv::Vec3d b = (toA * std::cos(angle) + side * std::sin(angle)) * rangeB;
        render::Scene scene = emptyLab();
        scene.targets = {target("a", render::Shape::Sphere, a, ra, kGold, "arm_marker"),
                         target("b", render::Shape::Sphere, b, rb)};
        const Outcome o = run(scene, cfg, 11);
        const auto va = o.of("a"), vb = o.of("b");
        ASSERT_TRUE(va && vb) << "overlap " << overlap;
        EXPECT_TRUE(va->flags & kTargetWhole) << "overlap " << overlap << ": " << flagsOf(va);
        const render::TargetTruth& tb = o.truth.target("b");
        for (int s = 0; s < 2; ++s) {
            const render::TargetView& view = s == 0 ? tb.left : tb.right;
            const double hidden = view.potentialAreaPx - view.areaPx;
            if (hidden < 2.0) continue;
            slivers += hidden <= 20.0;
            EXPECT_TRUE(vb->flags & (s == 0 ? kTargetOccludedLeft : kTargetOccludedRight))
                << "overlap " << overlap << (s == 0 ? " left" : " right") << ": " << hidden << " px hidden, "
                << flagsOf(vb);
            EXPECT_FALSE(vb->flags & kTargetWhole) << "overlap " << overlap;
        }
    }
    EXPECT_GE(slivers, 2) << "the poses must hide slivers of 2-20 px";
}

// A sphere in front of two touching discs of another colour far behind it
// (one feature no model fits: merged, placed by a blend of the two): the
// sphere is still judged nearer, by the doubt such a position has (half its
// radius in one image's centroid), and is whole; the discs never are. (When
// nothing was judged nearer than a merged neighbour, the sphere was flagged
// hidden at the offset of 25 mm, where its outline touches the discs.)
TEST(Completeness, ASphereInFrontOfAMergedPairFarBehindIsWhole) {
    const AvatarConfig cfg = config(TargetShape::Sphere);
    int checked = 0;
    for (const double offset : {20.0, 22.0, 25.0, 28.0}) {
        render::Scene scene = emptyLab();
        const double x = -40 + offset * 1300.0 / 700.0;
        scene.targets = {target("front", render::Shape::Sphere, {-40, 10, 700}, 30),
                         target("disc1", render::Shape::Disc, {x, 10, 1300}, 35, kGold, "arm_marker"),
                         target("disc2", render::Shape::Disc, {x + 70.5, 10, 1300}, 35, kGold, "arm_marker")};
        const Outcome o = run(scene, cfg, 9);
        std::optional<VisionTarget> front, discs;
        for (const VisionTarget& v : o.result.targets)
            if (v.flags & kTargetStereo) (v.type == "sample" ? front : discs) = v;
        ASSERT_TRUE(front) << offset;
        SCOPED_TRACE("offset " + std::to_string(offset) + ": front " + flagsOf(front) + ", discs " + flagsOf(discs));
        ASSERT_EQ(o.truth.target("front").left.hiddenFraction(), 0.0);
        ASSERT_EQ(o.truth.target("front").right.hiddenFraction(), 0.0);
        if (!discs || !(discs->flags & (kTargetMerged | kTargetAmbiguous))) continue;
        ++checked;
        EXPECT_TRUE(front->flags & kTargetWhole) << offset << ": " << flagsOf(front);
        EXPECT_FALSE(discs->flags & kTargetWhole) << offset;
    }
    EXPECT_GE(checked, 2);
}

// A yellow sphere 200 mm in front of a larger gold one, their types
// declaring no shape (placed by their centroids, every contact judged by
// depth), hiding the gold one's side in the left view or both: the gold
// one is partial, and its centroids' depth was doubted by half its radius
// in one image's centroid (150-170 mm there), so the sphere in front,
// nearer by less than both radii and that doubt, was flagged hidden where
// it hides most. The gold one's outlines give its depth where they are
// their own in both views (the rows of its far side), and the sphere in
// front is whole at every overlap; with that depth left out (more rows
// asked for than there are) it is hidden, as before.
TEST(Completeness, ASphereInFrontOfAPartialNeighbourIsJudgedByTheNeighboursOutlineDepth) {
    const AvatarConfig cfg = config(TargetShape::None);
    detail::CompletenessLimits withoutOutline;
    withoutOutline.minOutlineDisparityRows = 100000;
    const detail::TargetAssembler centroidsOnly(cfg, withoutOutline);
    int checked = 0, hiddenWithout = 0;
    for (const double overlap : {8.0, 12.0, 16.0, 20.0, 24.0, 28.0}) {
        render::Scene scene = emptyLab();
        // The gold sphere's left limb that far (mm at the front one's
        // depth) inside the front one's right limb, seen from the left camera.
        const double x = 40 - (10 + overlap) * 900.0 / 700.0;
        scene.targets = {target("front", render::Shape::Sphere, {-40, 10, 700}, 30),
                         target("gold", render::Shape::Sphere, {x, 10, 900}, 40, kGold, "arm_marker")};
        Outcome o = run(scene, cfg, 9);
        const auto front = o.of("front"), gold = o.of("gold");
        ASSERT_TRUE(front && gold) << overlap;
        SCOPED_TRACE("overlap " + std::to_string(overlap) + ": front " + flagsOf(front) + ", gold " + flagsOf(gold));
        ASSERT_EQ(o.truth.target("front").left.hiddenFraction(), 0.0);
        ASSERT_EQ(o.truth.target("front").right.hiddenFraction(), 0.0);
        ASSERT_GT(o.truth.target("gold").left.hiddenFraction() + o.truth.target("gold").right.hiddenFraction(), 0.0);
        EXPECT_FALSE(gold->flags & kTargetWhole);
        if (!(gold->flags & (kTargetOccludedLeft | kTargetOccludedRight))) continue;
        ++checked;
        EXPECT_TRUE(front->flags & kTargetWhole);
        EXPECT_LT(o.errorMm("front"), 4.0);  // its centroids' (no shape declared): a sphere's silhouette bias
        // The same frame judged without the outlines' depth.
        o.frame.result.targets.clear();
        centroidsOnly.assemble(o.frame);
        for (const VisionTarget& v : o.frame.result.targets)
            if ((v.flags & kTargetStereo) && v.type == "sample")
                hiddenWithout += (v.flags & (kTargetOccludedLeft | kTargetOccludedRight)) != 0;
    }
    EXPECT_GE(checked, 5);
    EXPECT_GE(hiddenWithout, 3) << "the centroids' doubt must have hidden the sphere";
}

// One sphere whose halves pass two filters (yellow "sample", gold
// "arm_marker") is reported once, never as two targets: ambiguous when the
// halves are even, of the type holding most of it when one dominates.
TEST(Completeness, OneTargetSplitBetweenTwoFiltersIsReportedOnce) {
    render::Scene scene = emptyLab();
    auto even = target("even", render::Shape::Sphere, {-150, 0, 800}, 35);
    even.secondAlbedo = kGold;
    even.splitNormal = {1, 0, 0};
    auto mostly = target("mostly", render::Shape::Sphere, {180, 60, 800}, 35);
    mostly.secondAlbedo = kGold;
    mostly.splitNormal = {1, 0, 0};
    // Gold beyond x = centre.x + 0.75 r: about 6 % of the silhouette.
    mostly.splitOffsetMm = 0.75 * 35;
    scene.targets = {even, mostly};
    AvatarConfig cfg = config(TargetShape::Sphere);
    const Outcome o = run(scene, cfg);
    EXPECT_EQ(o.stereoCount(), 2);
    const auto e = o.of("even");
    ASSERT_TRUE(e);
    EXPECT_TRUE((e->flags & kTargetAmbiguous) && !(e->flags & kTargetWhole)) << flagsOf(e);
    EXPECT_LT(o.errorMm("even"), 2.0);
    // The gold sliver of "mostly" is too small to be a feature; the yellow
    // rest is the sample, which touches other-coloured pixels: not whole
    // (something may hide it), but placed by its sphere model all the same.
    const auto m = o.of("mostly");
    ASSERT_TRUE(m);
    EXPECT_EQ(m->type, "sample");
    EXPECT_EQ(m->model, ShapeModel::Sphere);
    EXPECT_LT(o.errorMm("mostly"), 1.0);
}

// A yellow duck facing away from a gold disc 15 mm behind its body's
// centre, over the disc's side: the depths cannot order them (their
// centroids' difference is well inside both radii), and the duck's contact
// is judged by depth (a composite's). The seam does order them: the disc's
// ellipse runs on under the duck, whose parts' bins there are their own.
// The duck is whole wherever the disc's model shows two bins or more under
// it (it was flagged hidden: minSeamOrderBins 0); the disc is never whole, a
// sliver of a pixel or two hidden included.
TEST(Completeness, AtASeamTheOutlineThatRunsOnUnderTheOtherIsBehind) {
    AvatarConfig cfg = config(TargetShape::Composite);
    cfg.targets.targets[1].shape = TargetShape::Disc;  // the arm marker
    const double f = cfg.stereo.left.fc[0];
    detail::CompletenessLimits depthsOnly;
    depthsOnly.minSeamOrderBins = 0;
    const detail::TargetAssembler byDepths(cfg, depthsOnly);
    const cv::Vec3d body(-40, 10, 800);
    const double radius = 30.0, discRadius = 25.0, discDepth = 815.0;
    int wholeDuck = 0, wholeDuckByDepths = 0, deep = 0;
    for (const double overlapPx : {1.0, 2.0, 6.0, 10.0, 14.0, 18.0}) {
        render::Scene scene = emptyLab();
        auto duck = target("duck", render::Shape::Duck, body, radius);
        duck.om = {0.0, M_PI, 0.0};  // facing left: its head and beak away from the disc
        // The disc's left rim that far inside the body's right limb in the
        // left image.
        const double limbPx = f * body[0] / body[2] + f * radius / std::sqrt(body[2] * body[2] - radius * radius);
        const double discX = (limbPx - overlapPx) / f * discDepth + discRadius;
        scene.targets = {duck, target("disc", render::Shape::Disc, {discX, body[1], discDepth}, discRadius, kGold,
                                      "arm_marker")};
        Outcome o = run(scene, cfg, 7);
        const auto d = o.of("duck"), disc = o.of("disc");
        ASSERT_TRUE(d && disc) << overlapPx;
        SCOPED_TRACE("overlap " + std::to_string(overlapPx) + " px: duck " + flagsOf(d) + ", disc " + flagsOf(disc));
        ASSERT_FALSE(o.truth.target("duck").left.occluded || o.truth.target("duck").right.occluded);
        ASSERT_TRUE(o.truth.target("disc").left.occluded);
        EXPECT_FALSE(disc->flags & kTargetWhole);
        EXPECT_TRUE(disc->flags & kTargetOccludedLeft);
        wholeDuck += (d->flags & kTargetWhole) != 0;
        if (d->flags & kTargetWhole) {
            EXPECT_LT(o.errorMm("duck"), 2.0);
        }
        deep += overlapPx >= 6.0;
        // The same frame judged by the depths alone.
        o.frame.result.targets.clear();
        byDepths.assemble(o.frame);
        for (const VisionTarget& v : o.frame.result.targets)
            if ((v.flags & kTargetStereo) && v.type == "sample") wholeDuckByDepths += (v.flags & kTargetWhole) != 0;
    }
    EXPECT_GE(wholeDuck, deep) << "the duck is whole wherever the disc runs on under it";
    EXPECT_EQ(wholeDuckByDepths, 0) << "the depths alone cannot order them";
}

// A duck at the top edge of the images, its beak up, beyond the edge where
// its head touches the edge; a beak of a colour no filter passes stands for
// one the filter loses in dark water. Every round part's circle is whole,
// yet it is cut: the head reaches the edge, and the beak beside it may lie
// beyond (it was whole: trust_report seed 92, a duck at the right image's
// edge). Moved 30 px down, nothing of it lies beyond the edge: whole.
TEST(Completeness, ADuckWhoseHeadReachesTheEdgeIsCutItsBeakMayLieBeyond) {
    const AvatarConfig cfg = config(TargetShape::Composite);
    const double radius = 30.0, z = 900.0, f = cfg.stereo.left.fc[1];
    const RigidTransform rTl = rightTLeft(cfg.stereo);
    // The smallest row of a sphere's silhouette (centre in the left camera's
    // frame) in either image.
    const auto topmostIn = [&](const cv::Vec3d& centreLeft, double r, bool right) {
        const cv::Point3d p = right ? transformPoint(rTl, cv::Point3d(centreLeft[0], centreLeft[1], centreLeft[2]))
                                    : cv::Point3d(centreLeft[0], centreLeft[1], centreLeft[2]);
        const cv::Vec3d c(p.x, p.y, p.z);
        const double d = cv::norm(c);
        const cv::Vec3d axis = c / d, e1 = cv::normalize(axis.cross(cv::Vec3d(1, 0, 0))), e2 = axis.cross(e1);
        const cv::Vec3d centre = c - axis * (r * r / d);  // the circle the camera's tangent rays touch
        const double rho = r * std::sqrt(1.0 - r * r / (d * d));
        double v = 1e9;
        for (int k = 0; k < 720; ++k) {
            const double a = 2.0 * M_PI * k / 720.0;
            const cv::Vec3d q = centre + rho * (std::cos(a) * e1 + std::sin(a) * e2);
            if (const auto px = projectPoint(right ? cfg.stereo.right : cfg.stereo.left, cv::Point3d(q[0], q[1], q[2])))
                v = std::min(v, px->y);
        }
        return v;
    };
    const auto topmost = [&](const cv::Vec3d& c, double r) { return std::min(topmostIn(c, r, false), topmostIn(c, r, true)); };
    // Its own frame: x forward, y down; the head at (0.55, -0.75) radius.
    // x turned to -y: the head up and to the left, the beak above it.
    const cv::Vec3d om(0.0, 0.0, -M_PI / 2);
    const cv::Vec3d headOffset = rodrigues({om[0], om[1], om[2]}) * cv::Vec3d(0.55 * radius, -0.75 * radius, 0.0);
    // The body's height where the head comes within 0.2 px of the image's
    // outer edge (-0.5).
    double lo = -2000.0, hi = 0.0;
    for (int i = 0; i < 60; ++i)
        (topmost(cv::Vec3d(60.0, 0.5 * (lo + hi), z) + headOffset, 0.55 * radius) < -0.3 ? lo : hi) = 0.5 * (lo + hi);
    for (const double downPx : {0.0, 30.0}) {
        const cv::Vec3d body(60.0, 0.5 * (lo + hi) + downPx * z / f, z);
        ASSERT_LT(topmost(body + headOffset, 0.55 * radius), topmost(body, radius) - 1.0) << "the head is the highest part";
        render::Scene scene = emptyLab();
        auto duck = target("duck", render::Shape::Duck, body, radius);
        duck.om = {om[0], om[1], om[2]};
        duck.beakAlbedo = {0.3, 0.3, 0.3};
        scene.targets = {duck};
        const Outcome o = run(scene, cfg);
        const render::TargetTruth& truth = o.truth.target("duck");
        const bool beyond = downPx == 0.0;
        ASSERT_EQ(truth.left.cut || truth.right.cut, beyond) << downPx;
        const auto d = o.of("duck");
        ASSERT_TRUE(d);
        if (beyond) {
            EXPECT_TRUE((d->flags & kTargetCut) && !(d->flags & kTargetWhole)) << flagsOf(d);
        } else {
            EXPECT_TRUE((d->flags & kTargetWhole) && !(d->flags & kTargetCut)) << flagsOf(d);
            EXPECT_LT(o.errorMm("duck"), 1.0);
        }
    }
}

// A porous mask: where haze brings a target's colour near its filter's
// edge, the filter passes it in part, and channels cut in from the rim put
// their walls on the outline (trust_report: 19 of the 52 targets the 28
// studied seeds missed as "merged, not split" in the twenty-eighth round).
// A whole sphere's masks in both views are cut here by ten channels five
// pixels deep, three pixels wide (wider than a pocket's mouth,
// Silhouette.cpp), and eight single pixels inside are dropped (holes of its
// own colour). Its outline fits no ellipse (merged with the code before);
// measured closed, it is whole and where it is. Channels five pixels wide
// are more than the closing shuts (a bite that something in front may
// make): not whole.
TEST(Completeness, APorousMaskIsMeasuredClosed) {
    const AvatarConfig cfg = config(TargetShape::Sphere);
    render::Scene scene = emptyLab();
    scene.targets = {target("ball", render::Shape::Sphere, {30, -20, 900}, 30)};
    const detail::TargetAssembler assembler(cfg);
    for (const int widthPx : {3, 5}) {
        SCOPED_TRACE("channels " + std::to_string(widthPx) + " px wide");
        Outcome o = run(scene, cfg);
        ASSERT_TRUE(o.of("ball") && (o.of("ball")->flags & kTargetWhole)) << flagsOf(o.of("ball"));
        for (const Side side : {Side::Left, Side::Right}) {
            ImageWork& w = o.frame.at(side);
            ASSERT_EQ(w.features[0].size(), 1u);
            Feature& f = w.features[0][0];
            cv::Mat& mask = w.masks[0];
            cv::Mat inside;  // each pixel's distance to the nearest pixel off the mask
            cv::distanceTransform(mask, inside, cv::DIST_L2, 5);
            const double radius = std::sqrt(f.area / M_PI);
            for (int y = f.box.y; y < f.box.br().y; ++y)
                for (int x = f.box.x; x < f.box.br().x; ++x) {
                    const cv::Point2d d = cv::Point2d(x, y) - f.centroid;
                    const float depth = inside.at<float>(y, x);
                    for (int k = 0; k < 12; ++k) {
                        if (k == 8 || k == 9) continue;  // none at the top row, where the flood's seed is
                        const double a = (15.0 + 30.0 * k) * M_PI / 180.0;
                        const double along = d.x * std::cos(a) + d.y * std::sin(a);
                        const double across = -d.x * std::sin(a) + d.y * std::cos(a);
                        if (depth > 0.f && depth <= 5.f && along > 0.0 && std::abs(across) < 0.5 * widthPx)
                            mask.at<std::uint8_t>(y, x) = 0;
                    }
                }
            for (int k = 0; k < 8; ++k) {  // eight pixels on a circle at half the radius
                const cv::Point p(static_cast<int>(std::lround(f.centroid.x + 0.5 * radius * std::cos(k * M_PI / 4))),
                                  static_cast<int>(std::lround(f.centroid.y + 0.5 * radius * std::sin(k * M_PI / 4))));
                ASSERT_NE(mask.at<std::uint8_t>(p), 0);
                mask.at<std::uint8_t>(p) = 0;
            }
            f.area = cv::countNonZero(mask(f.box));
            ASSERT_NE(mask.at<std::uint8_t>(f.boundary[kTopLeft]), 0) << "the flood's seed is kept";
        }
        o.frame.result.targets.clear();
        assembler.assemble(o.frame);
        o.result = o.frame.result;
        const auto ball = o.of("ball");
        ASSERT_TRUE(ball);
        if (widthPx == 3) {
            EXPECT_TRUE(ball->flags & kTargetWhole) << flagsOf(ball);
            EXPECT_EQ(ball->model, ShapeModel::Sphere);
            EXPECT_LT(o.errorMm("ball"), 1.0);
        } else {
            EXPECT_FALSE(ball->flags & kTargetWhole) << flagsOf(ball);
        }
    }
}

// A yellow sphere touching a gold one far behind it (judged nearer by
// depth), with a second gold sphere nearer than it diagonally off its
// corner: their boxes overlap, their outlines do not touch. Its contact is
// judged against the target its outline touches only, and it is whole;
// judged against every box within 3 px (touchedOnly false), the nearer
// sphere it never touches hid it.
TEST(Completeness, AContactIsJudgedAgainstTheTargetItTouchesNotABoxNearIt) {
    const AvatarConfig cfg = config(TargetShape::None);
    const double f = cfg.stereo.left.fc[0];
    detail::CompletenessLimits anyBox;
    anyBox.touchedOnly = false;
    const detail::TargetAssembler byBoxes(cfg, anyBox);
    const cv::Vec3d centre(0, 0, 800);
    const double radius = 30.0, cornerRadius = 20.0, cornerDepth = 790.0;
    int checked = 0;
    for (const double apart : {1.15, 1.25}) {
        render::Scene scene = emptyLab();
        // Diagonally up-left: centres (apart x the radii's sum) apart in the left image.
        const double sumPx = f * radius / centre[2] + f * cornerRadius / cornerDepth;
        const double offsetPx = apart * sumPx / std::sqrt(2.0);
        const cv::Vec3d corner(-offsetPx / f * cornerDepth, -offsetPx / f * cornerDepth, cornerDepth);
        scene.targets = {target("sphere", render::Shape::Sphere, centre, radius),
                         target("behind", render::Shape::Sphere, {60.0 / f * 1200.0, 0, 1200}, 40, kGold,
                                "arm_marker"),
                         target("corner", render::Shape::Sphere, corner, cornerRadius, kGold, "arm_marker")};
        Outcome o = run(scene, cfg, 11);
        SCOPED_TRACE("apart " + std::to_string(apart));
        ASSERT_FALSE(o.truth.target("sphere").left.occluded || o.truth.target("sphere").right.occluded);
        ASSERT_TRUE(o.truth.target("behind").left.occluded);
        ASSERT_FALSE(o.truth.target("corner").left.occluded || o.truth.target("corner").right.occluded);
        const auto v = o.of("sphere");
        ASSERT_TRUE(v);
        EXPECT_TRUE(v->flags & kTargetWhole) << flagsOf(v);
        EXPECT_LT(o.errorMm("sphere"), 4.0);  // its centroids' (no shape declared)
        // The same frame judged against every box near it.
        o.frame.result.targets.clear();
        byBoxes.assemble(o.frame);
        for (const VisionTarget& t : o.frame.result.targets)
            if ((t.flags & kTargetStereo) && t.type == "sample") {
                EXPECT_FALSE(t.flags & kTargetWhole) << "the nearer box must have hidden it";
                ++checked;
            }
    }
    EXPECT_EQ(checked, 2);
}

// A speck of silt in front of a sphere, inside its outline in the left image
// only, leaves a hole the filter does not pass: the sphere is hidden there in
// part (not whole), though its outline is complete and its model still places
// it. The same sphere without the speck is whole.
TEST(Completeness, ASpeckInsideTheOutlineHidesPartOfTheTarget) {
    render::Scene scene = emptyLab();
    scene.targets = {target("specked", render::Shape::Sphere, {-150, 0, 800}, 35),
                     target("clear", render::Shape::Sphere, {180, 60, 800}, 35)};
    scene.occluders = {occluder("silt", cv::Vec3d(-150, 0, 800) * 0.35 + cv::Vec3d(0, 3, 0), 2.0, 0.75)};
    const Outcome o = run(scene, config(TargetShape::Sphere));
    const render::TargetTruth& truth = o.truth.target("specked");
    ASSERT_TRUE(truth.left.occluded && !truth.right.occluded) << "the speck must be in front in the left image only";
    ASSERT_GT(truth.left.hiddenFraction(), 0.01);
    const auto s = o.of("specked");
    ASSERT_TRUE(s);
    EXPECT_TRUE((s->flags & kTargetOccludedLeft) && !(s->flags & kTargetOccludedRight) && !(s->flags & kTargetWhole))
        << flagsOf(s);
    EXPECT_EQ(s->model, ShapeModel::Sphere);
    EXPECT_LT(o.errorMm("specked"), 1.0);
    const auto c = o.of("clear");
    EXPECT_TRUE(c && (c->flags & kTargetWhole)) << flagsOf(c);
}

// Where the filter stops short of the edge (a limb in shadow, whose mixed
// pixels the demosaic gives false colours) and where it cuts a notch into
// it, the sub-pixel outline must still be the edge. A disc of 30 px whose
// colours are mixed over a pixel either side of its edge (a 3x3 box blur of
// the exact coverage, as the bilinear demosaic mixes them), noise-free; its
// mask two pixels short of the edge over a sixth of the outline, and cut by a
// notch two pixels wide and two deep at its top. Three pixels beyond the
// short mask are within the mixed pixels: a background taken there pulled
// that sixth 0.3-0.5 px in, and the notch's walls, looked across, gave
// points 1.3-2.4 px inside; they are now marked as walls.
TEST(Silhouette, TheOutlineIsTheEdgeWhereTheMaskStopsShortOrIsNotched) {
    const cv::Point2d centre(80.3, 79.6);
    const double radius = 30.0;
    const cv::Vec3d target(2000, 18000, 40000), seabed(9000, 10000, 9000);  // B, G, R
    ImageWork w;
    w.image = blurredCircle(centre, radius, target, seabed);
    cv::Mat mask(w.image.size(), CV_8UC1, cv::Scalar(0));
    for (int y = 0; y < mask.rows; ++y)
        for (int x = 0; x < mask.cols; ++x) {
            const cv::Point2d d = cv::Point2d(x, y) - centre;
            const double theta = std::atan2(d.y, d.x);
            const double shortBy = std::abs(theta) < M_PI / 6 ? 2.0 * std::pow(std::cos(3.0 * theta), 2) : 0.0;
            const bool notch = (x == 79 || x == 80) && y < centre.y - radius + 2.0;
            if (cv::norm(d) < radius - shortBy && !notch) mask.at<std::uint8_t>(y, x) = 255;
        }
    const Feature feature = soleFeature(w, mask);
    const detail::Silhouette s = detail::measureSilhouette(w, 0, feature, {0, 0, 160, 160}, 1.0);
    ASSERT_TRUE(s.subPixel);
    int onShortSide = 0, atNotch = 0, walls = 0;
    for (const detail::OutlinePoint& p : s.outline) {
        ASSERT_EQ(p.kind, detail::EdgeKind::Free);
        const cv::Point2d d = p.px - centre;
        const double error = cv::norm(d) - radius;
        if (p.wall) {  // kept at its pixel edge, left out of the fit
            ++walls;
            EXPECT_TRUE(std::abs(d.x) < 2.0 && d.y < 0.0) << "a wall away from the notch, at " << p.px;
        } else if (std::abs(std::atan2(d.y, d.x)) < M_PI / 12) {  // the mask 1-2 px short
            ++onShortSide;
            EXPECT_NEAR(error, 0.0, 0.1) << "where the mask stops short, at " << p.px;
        } else if (std::abs(d.x) < 3.0 && d.y < 0.0) {
            ++atNotch;
            EXPECT_NEAR(error, 0.0, 0.1) << "at the notch, at " << p.px;
        } else {
            // Where the shortfall tapers off, its steps look along the
            // outline through unmasked pixels of the target (0.33 px).
            EXPECT_NEAR(error, 0.0, 0.35) << "at " << p.px;
        }
    }
    EXPECT_GE(onShortSide, 12);
    EXPECT_GE(atNotch, 4);
    EXPECT_EQ(walls, 4);  // two rows on either side
}

// A target's edge pixels, mixed with the background, may pass another
// type's filter: a yellow duck's edge over a green seabed under water passes
// an orange filter whose R/G the water's side was lowered for (trust_report
// seeds 32, 34, 42, 50, 57, 58: ducks ringed by such a rim were occluded).
// A rim of at most two pixels with background beyond is the outline's own
// edge, placed there as at a free edge; a fragment thicker than that (here
// a 6-px tab of the other colour) is still what it was: unknown. A circle of
// 30 px, its edge blurred over three pixels, its mask stopping a pixel short
// of the edge, the other filter's mask the two pixels beyond.
TEST(Silhouette, ARimOfMixedPixelsThatPassAnotherFilterIsTheOutlinesEdge) {
    const cv::Point2d centre(80.3, 79.6);
    const double radius = 30.0;
    const cv::Vec3d target(2000, 18000, 20000), seabed(9000, 16000, 7000);  // B, G, R
    ImageWork w;
    w.image = blurredCircle(centre, radius, target, seabed);
    cv::Mat own(w.image.size(), CV_8UC1, cv::Scalar(0)), other(w.image.size(), CV_8UC1, cv::Scalar(0));
    const auto inTab = [&](const cv::Point2d& d) { return d.x > 0.0 && std::abs(d.y) < 3.0; };
    for (int y = 0; y < own.rows; ++y)
        for (int x = 0; x < own.cols; ++x) {
            const cv::Point2d d = cv::Point2d(x, y) - centre;
            const double r = cv::norm(d);
            if (r < radius - 1.0) own.at<std::uint8_t>(y, x) = 255;
            else if (r < radius + 1.0 || (inTab(d) && r < radius + 6.0)) other.at<std::uint8_t>(y, x) = 255;
        }
    const Feature feature = soleFeature(w, own);
    w.masks.push_back(other);  // the other type's mask: no feature of it, so fragment pixels
    w.features.emplace_back();
    const detail::Silhouette s = detail::measureSilhouette(w, 0, feature, {0, 0, 160, 160}, 1.0);
    ASSERT_TRUE(s.subPixel);
    int free = 0, atTab = 0;
    std::vector<double> errors;
    for (const detail::OutlinePoint& p : s.outline) {
        const cv::Point2d d = p.px - centre;
        if (inTab(d) && std::abs(d.y) < 2.0) {  // the tab's rows, away from its corners
            EXPECT_EQ(p.kind, detail::EdgeKind::Fragment) << "at the tab, at " << p.px;
            atTab += p.kind == detail::EdgeKind::Fragment;
            continue;
        }
        if (inTab(d)) continue;  // its corners: either
        ASSERT_EQ(p.kind, detail::EdgeKind::Free) << "at " << p.px;
        EXPECT_TRUE(p.rim) << "found through the rim, at " << p.px;  // no second object beyond the ellipse
        ++free;
        // Where the pixel edges step along a steep outline they look along
        // the rim (as where a mask stops short without one: 0.35 px above).
        if (!p.wall) {
            EXPECT_NEAR(cv::norm(d) - radius, 0.0, 0.7) << "at " << p.px;
            errors.push_back(std::abs(cv::norm(d) - radius));
        }
    }
    std::nth_element(errors.begin(), errors.begin() + errors.size() / 2, errors.end());
    EXPECT_LT(errors[errors.size() / 2], 0.1) << "the median point is at the edge";
    EXPECT_GE(free, 150);
    EXPECT_GE(atTab, 3);
}

// A speck of silt just inside a target's outline whose mixed rim the filter
// cut open: its pixels reach the background only through a mouth one pixel
// wide, so the outline runs round it and no bin of it is missing. It is a
// hole all the same (a pocket), of the speck's colour; through a mouth three
// pixels wide it is a notch, which the outline shows, and no hole. A circle of
// 30 px, orange on the seabed, a white speck of 5 px 22 px from its centre.
TEST(Silhouette, ASpeckOpenedToTheBackgroundByAOnePixelMouthIsAHole) {
    const cv::Point2d centre(80.3, 79.6), speck = centre + cv::Point2d(22.0, 0.0);
    const double radius = 30.0, speckRadius = 5.0;
    const cv::Vec3d target(2000, 18000, 40000), seabed(9000, 10000, 9000), white(30000, 30000, 30000);  // B, G, R
    const auto judge = [&](int mouthRows) {
        ImageWork w;
        w.image.create(160, 160, CV_16UC3);
        cv::Mat mask(w.image.size(), CV_8UC1, cv::Scalar(0));
        for (int y = 0; y < mask.rows; ++y)
            for (int x = 0; x < mask.cols; ++x) {
                const cv::Point2d p(x, y);
                const bool inTarget = cv::norm(p - centre) < radius, inSpeck = cv::norm(p - speck) < speckRadius;
                const cv::Vec3d c = inSpeck ? white : inTarget ? target : seabed;
                w.image.at<cv::Vec3w>(y, x) = cv::Vec3w(cv::saturate_cast<std::uint16_t>(c[0]),
                                                        cv::saturate_cast<std::uint16_t>(c[1]),
                                                        cv::saturate_cast<std::uint16_t>(c[2]));
                // The filter leaves out the speck and its mixed rim, and the
                // mouth from the speck to the background.
                const bool mouth = std::abs(y - static_cast<int>(std::lround(speck.y))) <= (mouthRows - 1) / 2 &&
                                   x > speck.x;
                if (inTarget && cv::norm(p - speck) >= speckRadius + 1.0 && !mouth) mask.at<std::uint8_t>(y, x) = 255;
            }
        const Feature feature = soleFeature(w, mask);
        return detail::measureSilhouette(w, 0, feature, {0, 0, 160, 160}, 1.0);
    };
    const detail::Silhouette pocket = judge(1);
    ASSERT_EQ(pocket.holes.size(), 1u) << "the speck behind a mouth of one pixel";
    EXPECT_GE(pocket.holes[0].areaPx, 40);
    EXPECT_LE(pocket.holes[0].areaPx, static_cast<int>(M_PI * speckRadius * speckRadius));
    EXPECT_GT(pocket.holes[0].colourLog, 1.0) << "white against orange";
    const detail::Silhouette notch = judge(3);
    EXPECT_TRUE(notch.holes.empty()) << "a mouth of three pixels: a notch";
}

// A hole's noise is the noise of the target's pixels around it, and a hole
// something in front makes lies past the filter's edge by more than that
// noise. In a dark frame a sphere's dim limb holds few blue electrons under
// an orange target, and the pixels the filter leaves out there are the
// noise's tail: a hole whose colour strays 0.55 in log B/G, 0.25 past the
// filter's edge, is noise at the limb, where one pixel strays 0.24, and
// something in front in the bright middle, where one pixel strays 0.03. A
// circle of 40 px, its right third at an eighth of the light, read noise of
// 60 in every sample; a hole of 3x2 px in each part, its pixels of the
// target's colour there with blue raised by 0.55 in log; the filter's B/G
// reaches 0.3 above the target's.
TEST(Silhouette, AHolesNoiseIsTheNoiseAroundIt) {
    const cv::Point2d centre(100.0, 100.0);
    const double radius = 40.0, readNoise = 60.0;
    const cv::Vec3d bright(2000, 18000, 40000), seabed(9000, 10000, 9000);  // B, G, R
    const cv::Vec3d dim = bright * (1.0 / 8.0);
    const cv::Rect brightHole(80, 95, 3, 2), dimHole(124, 95, 3, 2);
    ImageWork w;
    w.image.create(200, 200, CV_16UC3);
    cv::Mat mask(w.image.size(), CV_8UC1, cv::Scalar(0));
    std::mt19937 rng(7);
    std::normal_distribution<double> noise(0.0, readNoise);
    for (int y = 0; y < mask.rows; ++y)
        for (int x = 0; x < mask.cols; ++x) {
            const bool inTarget = cv::norm(cv::Point2d(x, y) - centre) < radius;
            const bool inHole = brightHole.contains({x, y}) || dimHole.contains({x, y});
            cv::Vec3d c = !inTarget ? seabed : x > centre.x + radius / 3.0 ? dim : bright;
            if (inHole) c[0] *= std::exp(0.55);
            cv::Vec3w& p = w.image.at<cv::Vec3w>(y, x);
            for (int ch = 0; ch < 3; ++ch) p[ch] = cv::saturate_cast<std::uint16_t>(c[ch] + noise(rng));
            if (inTarget && !inHole) mask.at<std::uint8_t>(y, x) = 255;
        }
    const Feature feature = soleFeature(w, mask);
    const detail::Silhouette sil = detail::measureSilhouette(w, 0, feature, {0, 0, 200, 200}, 1.0);
    ASSERT_EQ(sil.holes.size(), 2u);
    const detail::Silhouette::Hole& inBright = sil.holes[0];  // raster order: the bright one's first pixel comes first
    const detail::Silhouette::Hole& inDim = sil.holes[1];
    EXPECT_EQ(inBright.areaPx, 6);
    EXPECT_EQ(inDim.areaPx, 6);
    // The colours: 0.55 from the target's, give or take the noise of six pixels.
    EXPECT_NEAR(inBright.colourLog, 0.55, 0.05);
    EXPECT_NEAR(inDim.colourLog, 0.55, 0.25);
    EXPECT_NEAR(inBright.ratiosLog[1], std::log(bright[0] / bright[1]) + 0.55, 0.05);
    // Its mean's noise: one pixel's B/G noise (readNoise over blue; G's adds
    // little) twice over the root of six (the mosaic's factor).
    const double brightNoise = 2.0 * readNoise / bright[0] / std::sqrt(6.0);
    const double dimNoise = 2.0 * readNoise / dim[0] / std::sqrt(6.0);
    EXPECT_NEAR(inBright.noiseLog, brightNoise, 0.3 * brightNoise);
    EXPECT_NEAR(inDim.noiseLog, dimNoise, 0.3 * dimNoise);
    TargetType orange;
    orange.name = "orange";
    orange.redGreen = {bright[2] / bright[1] * std::exp(-0.3), bright[2] / bright[1] * std::exp(0.3)};
    orange.blueGreen = {bright[0] / bright[1] * std::exp(-0.3), bright[0] / bright[1] * std::exp(0.3)};
    const auto brightPast = detail::outsideFilterLog(orange, inBright.ratiosLog);
    const auto dimPast = detail::outsideFilterLog(orange, inDim.ratiosLog);
    ASSERT_TRUE(brightPast && dimPast);
    EXPECT_NEAR((*brightPast)[1], 0.25, 0.05) << "past B/G's maximum";
    EXPECT_EQ((*brightPast)[0], 0.0) << "R/G within its range";
    // Against the target's colour around it: 0.55 in B/G, nothing in R/G.
    EXPECT_NEAR(inBright.offsetLog[1], 0.55, 0.05);
    EXPECT_NEAR(inBright.offsetLog[0], 0.0, 4.0 * inBright.axisNoiseLog[0]);
    EXPECT_NEAR(inDim.offsetLog[0], 0.0, 4.0 * inDim.axisNoiseLog[0]);
    // Cut by B/G: only how far past the edge counts there.
    EXPECT_GT(detail::holeEvidence(inBright.offsetLog, inBright.axisNoiseLog, brightPast), 4.0) << "something in front";
    EXPECT_LT(detail::holeEvidence(inDim.offsetLog, inDim.axisNoiseLog, dimPast), 4.0) << "the noise's tail";
    // Without the filter's ranges, its 0.55 from the target's colour tells both from it.
    EXPECT_GT(detail::holeEvidence(inDim.offsetLog, inDim.axisNoiseLog, std::nullopt), 1.0);
}

// How far a colour lies outside a type's ratio ranges: 0 inside, the
// largest excess over R/G, B/G and R/B outside; none for a filter that is
// no box of ratios.
TEST(Completeness, HowFarAColourLiesOutsideTheFilter) {
    TargetType t;
    t.name = "orange";
    t.redGreen = {1.5, 3.0};
    t.blueGreen = {0.05, 0.2};
    const auto at = [&](double rg, double bg) { return *detail::outsideFilterLog(t, {std::log(rg), std::log(bg)}); };
    EXPECT_EQ(at(2.0, 0.1), cv::Vec3d(0, 0, 0));
    EXPECT_NEAR(at(1.5 * std::exp(-0.1), 0.1)[0], 0.1, 1e-12);
    const cv::Vec3d both = at(3.0 * std::exp(0.2), 0.05 * std::exp(-0.05));
    EXPECT_NEAR(both[0], 0.2, 1e-12);
    EXPECT_NEAR(both[1], 0.05, 1e-12);
    EXPECT_NEAR(at(1.0, 1.0)[1], std::log(1.0 / 0.2), 1e-12) << "grey: far past B/G's maximum";
    t.redBlue = {20.0, 40.0};
    EXPECT_NEAR(at(2.0, 0.2)[2], std::log(20.0 / 10.0), 1e-12) << "R/B 10 against a minimum of 20";
    TargetType banded = t;
    banded.brightnessBands.push_back({{0.0, 1000.0}, {1.0, 4.0}, {0.0, 1e9}, {0.0, 1.0}});
    EXPECT_FALSE(detail::outsideFilterLog(banded, {0.0, 0.0}));
    TargetType hsv = t;
    hsv.filter = ColorFilterMethod::Hsv;
    EXPECT_FALSE(detail::outsideFilterLog(hsv, {0.0, 0.0}));
}

// A hole's evidence: on a ratio the filter cut its pixels by, how far past
// the edge (in noise); on the other, how far from the target's colour. A
// grey speck on an orange target strays in both: past B/G's edge by little
// where the filter reaches far, but its R/G, inside a range grown for the
// water, is far from the target's. Noise strays in B/G alone.
TEST(Completeness, AHoleIsJudgedPastTheFilterOnTheRatioThatCutIt) {
    const cv::Vec2d noise(0.02, 0.1);
    const cv::Vec3d pastBlue(0.0, 0.3, 0.0);
    EXPECT_NEAR(detail::holeEvidence({0.01, 0.6}, noise, pastBlue), 3.0, 1e-12) << "noise: 0.3 past, 3 of its noise";
    EXPECT_NEAR(detail::holeEvidence({-0.8, 1.3}, noise, pastBlue), 40.0, 1e-12) << "grey: R/G 0.8 off";
    EXPECT_NEAR(detail::holeEvidence({0.01, 0.6}, noise, std::nullopt), 6.0, 1e-12) << "no ranges: the distances";
    EXPECT_NEAR(detail::holeEvidence({0.01, 0.6}, noise, cv::Vec3d(0.0, 0.0, 0.2)), 0.2 / std::hypot(0.02, 0.1),
                1e-12)
        << "cut by R/B: both ratios chosen, R/B's excess over its noise";

    // Holes judged in full (size, colour, evidence) against a filter whose
    // B/G reaches 0.3 above the target's (B/G 0.12) and whose R/G reaches
    // 0.2 below it (R/G 1.2).
    TargetType orange;
    orange.name = "orange";
    orange.redGreen = {1.2 * std::exp(-0.2), 1.2 * std::exp(0.5)};
    orange.blueGreen = {0.12 * std::exp(-0.5), 0.12 * std::exp(0.3)};
    const detail::CompletenessLimits limits;
    const auto hole = [&](int area, double offsetRg, double offsetBg, double noiseRg, double noiseBg) {
        detail::Silhouette::Hole h;
        h.areaPx = area;
        h.offsetLog = {offsetRg, offsetBg};
        h.ratiosLog = cv::Vec2d(std::log(1.2), std::log(0.12)) + h.offsetLog;
        h.colourLog = std::max(std::abs(offsetRg), std::abs(offsetBg));
        h.axisNoiseLog = {noiseRg, noiseBg};
        h.noiseLog = std::max(noiseRg, noiseBg);
        return detail::foreignHole(h, orange, limits);
    };
    EXPECT_FALSE(hole(6, 0.0, 0.55, 0.02, 0.1)) << "noise: 0.25 past B/G's edge, 2.5 of its noise";
    EXPECT_TRUE(hole(6, 0.0, 0.55, 0.02, 0.05)) << "5 of its noise past the edge";
    EXPECT_TRUE(hole(6, -0.25, 1.0, 0.05, 0.2))
        << "a speck mixed with the target: cut by R/G and B/G, 0.05 and 0.7 past (1 and 3.5 of the noise), but 1.0 off";
    EXPECT_FALSE(hole(6, -0.25, 1.0, 0.05, 0.3)) << "as far, but within four times its noise";
    EXPECT_FALSE(hole(4, 0.0, 1.3, 0.02, 0.05)) << "too small";
    EXPECT_FALSE(hole(6, 0.0, 0.45, 0.02, 0.01)) << "too near the target's colour";
}

// The shape decides for a composite type (decideByShape(), decideForOwn())
// only where its head lies as a duck's does: seen in both views, its centre
// 0.6 of the two radii from the body's. A second part at the body's centre
// (0.09: a far orange sphere's ragged outline fitted twice, taken for a whole
// yellow duck in a trial) is no head, nor is one beside the body (1: two
// touching spheres).
TEST(Completeness, ACompositesHeadLiesWhereADucksDoes) {
    const detail::CompletenessLimits limits;
    EXPECT_TRUE(detail::headSunk(0.6, limits)) << "a duck's";
    EXPECT_TRUE(detail::headSunk(0.41, limits)) << "the nearest seen on the trust report's seeds";
    EXPECT_TRUE(detail::headSunk(0.73, limits)) << "the farthest seen";
    EXPECT_FALSE(detail::headSunk(0.09, limits)) << "the body fitted twice";
    EXPECT_FALSE(detail::headSunk(1.0, limits)) << "two spheres that touch";
    EXPECT_FALSE(detail::headSunk(std::nullopt, limits)) << "not seen in both views";
}

// A duck found in haze by a round type's filter has its holes judged as
// that filter's round targets' are, but one of its own parts of another
// colour is no speck in front: ownPartHole() tells them by the side of the
// target's colour the hole lies on, against the duck's veil (0.7 : 1 : 1,
// log R/G -0.36, log B/G 0). The offsets are the trust report's (hazy
// yellow ducks at log R/G 0.1, log B/G -1.2): silt specks -0.1 to -0.2 in
// R/G and +1.2 to +2.0 in B/G, beaks +0.5 to +0.7 in R/G, +0.4 to +0.5 in
// B/G.
TEST(Completeness, AHoleRedderThanAHazyDuckIsItsBeakNotASpeckInFront) {
    TargetType duck;
    duck.name = "yellow";
    duck.shape = TargetShape::Composite;
    duck.veil = Veil{{0.7, 1.0, 1.0}, 0.5, std::nullopt, std::nullopt};
    const detail::CompletenessLimits limits;
    const auto own = [&](const TargetType& type, double offsetRg, double offsetBg, double noise) {
        detail::Silhouette::Hole h;
        h.areaPx = 10;
        h.offsetLog = {offsetRg, offsetBg};
        h.ratiosLog = cv::Vec2d(0.1, -1.2) + h.offsetLog;
        h.colourLog = std::max(std::abs(offsetRg), std::abs(offsetBg));
        h.axisNoiseLog = {noise, noise};
        h.noiseLog = noise;
        return detail::ownPartHole(h, type, limits);
    };
    EXPECT_TRUE(own(duck, 0.6, 0.45, 0.03)) << "a beak: redder, 20 times the noise";
    EXPECT_FALSE(own(duck, 0.6, 0.45, 0.2)) << "as red, within four times the noise";
    EXPECT_FALSE(own(duck, -0.15, 1.6, 0.03)) << "a speck of silt: towards the veil on both ratios";
    EXPECT_FALSE(own(duck, -0.9, 1.7, 0.03)) << "a grey speck beyond the veil's R/G";
    EXPECT_TRUE(own(duck, 0.0, -0.5, 0.03)) << "less blue than the duck, away from the veil";
    TargetType clear = duck;
    clear.veil.reset();
    EXPECT_FALSE(own(clear, 0.6, 0.45, 0.03)) << "without a veil the side of a speck is unknown";
    TargetType grey = duck;
    grey.veil->colourRgb = {1.105, 1.0, 0.301};  // the veil's log ratios the duck's: no side on either
    EXPECT_FALSE(own(grey, 0.6, 0.45, 0.03)) << "a veil of the duck's colour tells no side";
}

// What lies just beyond a bin of the outline that no point supports tells
// something in front of the target (a grey stone, silt: no filter passes
// it) from a limb the filter left a bin short: foreignAtMissing() against the
// free background all around; given the target's colour, inside it too (a
// speck brighter than both in a notch the outline runs round). A circle of
// 30 px on a seabed of one colour with 2 % noise; a patch beyond the missing
// bin, or within it.
TEST(Completeness, WhatLiesBeyondAMissingBinTellsAStoneFromTheBackground) {
    const CameraIntrinsics camera;  // no distortion: ideal pixels are pixels less the principal point
    const cv::Point2d centre(camera.cc[0], camera.cc[1]);
    const double radius = 30.0;
    std::vector<detail::OutlinePoint> outline;
    for (int k = 0; k < 180; ++k) {
        const double a = 2.0 * M_PI * k / 180.0;
        outline.push_back({centre + radius * cv::Point2d(std::cos(a), std::sin(a)), detail::EdgeKind::Free, 0.1});
    }
    const detail::EllipseFit fit = detail::fitEllipse(camera, outline, 0.5);
    ASSERT_TRUE(fit.ok);
    detail::RoundCompleteness c;
    c.bins = 64;
    const auto angleOf = [&](int bin) { return -M_PI + (bin + 0.5) * 2.0 * M_PI / c.bins; };
    c.missing = 1;
    c.missingBins = {10};
    // The point at the ellipse's angle parameter t, @p out px outside it (a circle: its radius grows).
    const auto beyond = [&](double t, double out) {
        const double th = fit.ideal.angle * M_PI / 180.0;
        const double a = 0.5 * fit.ideal.size.width + out, b = 0.5 * fit.ideal.size.height + out;
        const double u = a * std::cos(t), v = b * std::sin(t);
        return cv::Point2d(fit.ideal.center.x + std::cos(th) * u - std::sin(th) * v + camera.cc[0],
                           fit.ideal.center.y + std::sin(th) * u + std::cos(th) * v + camera.cc[1]);
    };
    const cv::Vec3d seabed(3000, 4000, 5000);
    // @p target: the target's colour, and the patch is a notch inside it
    // (not its pixels).
    const auto judge = [&](const std::optional<std::pair<cv::Point2d, cv::Vec3d>>& patch,
                           const std::optional<cv::Vec3d>& target = std::nullopt) {
        cv::Mat image(960, 1280, CV_16UC3);
        cv::RNG rng(7);
        for (int y = 0; y < image.rows; ++y)
            for (int x = 0; x < image.cols; ++x) {
                const double n = 1.0 + 0.02 * rng.gaussian(1.0);
                cv::Vec3d v = seabed * n;
                if (patch && cv::norm(cv::Point2d(x, y) - patch->first) <= 3.0) v = patch->second * n;
                image.at<cv::Vec3w>(y, x) = cv::Vec3w(cv::saturate_cast<std::uint16_t>(v[0]),
                                                      cv::saturate_cast<std::uint16_t>(v[1]),
                                                      cv::saturate_cast<std::uint16_t>(v[2]));
            }
        const auto colourAt = [&](const cv::Point2d& px) {
            return cv::Vec3d(image.at<cv::Vec3w>(static_cast<int>(std::lround(px.y)), static_cast<int>(std::lround(px.x))));
        };
        const auto probe = [&](const cv::Point2d& px, bool& own) {
            own = cv::norm(px - centre) < radius && !(target && patch && cv::norm(px - patch->first) <= 3.0);
            return detail::EdgeKind::Free;
        };
        return detail::foreignAtMissing(camera, fit, c, colourAt, probe, 4.0, 0.1, target, 0.5);
    };
    EXPECT_FALSE(judge(std::nullopt)) << "the seabed alone";
    const cv::Vec3d stone(6000, 6000, 6000);
    EXPECT_TRUE(judge(std::make_pair(beyond(angleOf(10), 2.5), stone))) << "a grey stone beyond the missing bin";
    EXPECT_FALSE(judge(std::make_pair(beyond(angleOf(30), 2.5), stone))) << "the stone beyond a supported bin";
    EXPECT_FALSE(judge(std::make_pair(beyond(angleOf(10), 2.5), seabed * 0.6)))
        << "a shadow: the seabed's colour, darker";
    EXPECT_TRUE(judge(std::make_pair(beyond(angleOf(10), 2.5), seabed * 1.6))) << "the seabed's colour, brighter";
    // Inside the outline at the missing bin, in a notch the outline runs round.
    const cv::Vec3d orange(2000, 18000, 40000), silt(25000, 25000, 25000);
    EXPECT_TRUE(judge(std::make_pair(beyond(angleOf(10), -2.5), silt), orange)) << "a speck of silt in the notch";
    EXPECT_FALSE(judge(std::make_pair(beyond(angleOf(30), -2.5), silt), orange)) << "the speck at a supported bin";
    EXPECT_FALSE(judge(std::make_pair(beyond(angleOf(10), -2.5), (orange + seabed) * 0.5), orange))
        << "the target's colour mixed with the background's";
    EXPECT_FALSE(judge(std::make_pair(beyond(angleOf(10), -2.5), orange * 0.6), orange)) << "a dim limb";
    EXPECT_FALSE(judge(std::make_pair(beyond(angleOf(10), -2.5), silt))) << "not looked at without the target's colour";
    c.missingBins.clear();
    c.missing = 0;
    EXPECT_FALSE(judge(std::make_pair(beyond(angleOf(10), 2.5), stone))) << "no missing bin: nothing is judged";
}

// A round outline short of its ellipse over two arcs, one beyond which lies
// the background and one beyond which lies a fragment (pixels of a filter
// that make no feature: an object behind the target that shows too little
// to be a target, or one in front). roundCompleteness() lists the bins at
// the fragment among the missing ones and apart (fragmentBins), which the
// other view may explain (withoutFragments()); foreignAtMissing() reads the
// fragment's pixels as what lies there, as before fragments were told apart,
// and leaves them out of the background it judges against. A circle of 30
// px, its silhouette 6 px short over each arc.
TEST(Completeness, BinsShortAtAFragmentAreMissingAndListedApart) {
    const CameraIntrinsics camera;  // no distortion
    const cv::Point2d centre(camera.cc[0], camera.cc[1]);
    const double radius = 30.0, kShort = 6.0;
    // The arcs: around angle 0 (the fragment beyond) and around pi / 2 (background).
    const auto inArc = [](double a, double middle) { return std::abs(std::remainder(a - middle, 2.0 * M_PI)) < 0.2; };
    std::vector<detail::OutlinePoint> outline;
    for (int k = 0; k < 180; ++k) {
        const double a = 2.0 * M_PI * k / 180.0;
        const bool short_ = inArc(a, 0.0) || inArc(a, M_PI / 2);
        outline.push_back({centre + (short_ ? radius - kShort : radius) * cv::Point2d(std::cos(a), std::sin(a)),
                           detail::EdgeKind::Free, 0.1});
    }
    const detail::EllipseFit fit = detail::fitEllipse(camera, outline, 0.5);
    ASSERT_TRUE(fit.ok);
    const auto angle = [&](const cv::Point2d& px) { return std::atan2(px.y - centre.y, px.x - centre.x); };
    const auto ownAt = [&](const cv::Point2d& px) {
        const double r = cv::norm(px - centre), a = angle(px);
        return r < ((inArc(a, 0.0) || inArc(a, M_PI / 2)) ? radius - kShort : radius);
    };
    const auto fragmentAt = [&](const cv::Point2d& px) {
        const double r = cv::norm(px - centre);
        return inArc(angle(px), 0.0) && r >= radius - kShort && r < radius + 6.0;
    };
    const auto probe = [&](const cv::Point2d& px, bool& own) {
        own = ownAt(px);
        return !own && fragmentAt(px) ? detail::EdgeKind::Fragment : detail::EdgeKind::Free;
    };
    const detail::RoundCompleteness c = detail::roundCompleteness(camera, fit, outline, probe);
    ASSERT_GT(c.missing, 4);
    ASSERT_FALSE(c.fragmentBins.empty());
    // Bin k's angle about the centre in the image (its ellipse parameter
    // turned by the ellipse's orientation: the fit is a circle).
    const auto binAngle = [&](int k) {
        return -M_PI + (k + 0.5) * 2.0 * M_PI / c.bins + fit.ideal.angle * M_PI / 180.0;
    };
    for (const int k : c.missingBins) {
        const bool listed = std::find(c.fragmentBins.begin(), c.fragmentBins.end(), k) != c.fragmentBins.end();
        EXPECT_EQ(listed, inArc(binAngle(k), 0.0)) << "bin " << k << " at " << binAngle(k) << " rad";
    }
    for (const int k : c.fragmentBins)
        EXPECT_NE(std::find(c.missingBins.begin(), c.missingBins.end(), k), c.missingBins.end()) << "bin " << k;
    const detail::RoundCompleteness rest = detail::withoutFragments(c);
    EXPECT_EQ(rest.missing, c.missing - static_cast<int>(c.fragmentBins.size()));
    EXPECT_EQ(rest.missingBins.size(), c.missingBins.size() - c.fragmentBins.size());
    EXPECT_EQ(rest.shallow, c.shallow - c.fragmentShallow);
    for (const int k : rest.missingBins) EXPECT_FALSE(inArc(binAngle(k), 0.0)) << "bin " << k;

    // The seabed of one colour with 2 % noise; the fragment blue.
    const cv::Vec3d seabed(3000, 4000, 5000), blue(40000, 15000, 7000);
    cv::Mat image(960, 1280, CV_16UC3);
    cv::RNG rng(7);
    for (int y = 0; y < image.rows; ++y)
        for (int x = 0; x < image.cols; ++x) {
            const double n = 1.0 + 0.02 * rng.gaussian(1.0);
            const cv::Vec3d v = (fragmentAt(cv::Point2d(x, y)) ? blue : seabed) * n;
            image.at<cv::Vec3w>(y, x) = cv::Vec3w(cv::saturate_cast<std::uint16_t>(v[0]),
                                                  cv::saturate_cast<std::uint16_t>(v[1]),
                                                  cv::saturate_cast<std::uint16_t>(v[2]));
        }
    const auto colourAt = [&](const cv::Point2d& px) {
        return cv::Vec3d(image.at<cv::Vec3w>(static_cast<int>(std::lround(px.y)), static_cast<int>(std::lround(px.x))));
    };
    EXPECT_TRUE(detail::foreignAtMissing(camera, fit, c, colourAt, probe, 4.0, 0.1, std::nullopt, 0.5))
        << "the fragment's colour beyond its bins";
    EXPECT_FALSE(detail::foreignAtMissing(camera, fit, rest, colourAt, probe, 4.0, 0.1, std::nullopt, 0.5))
        << "its bins explained: the background beyond the other arc";
}

// A duck's extent is its parts': a few pixels of the beak's edge that pass
// the body's filter in one view only (another colour's mixed pixels) widen
// its mask's box by 15-21 % at 2 m, which read as a part hidden in the other
// view (whole ducks at 1.8-2.4 m, trust_report seeds 30, 31, 45, 46, 54 and
// 59). The outline the round parts explain ends where the head does, with or
// without the stub.
TEST(ShapeModel, ADucksExtentIsWhatItsPartsExplainNotItsBeaksEdge) {
    const CameraIntrinsics camera;  // no distortion
    const cv::Point2d body(camera.cc[0] + 0.3, camera.cc[1] - 0.2), head = body + cv::Point2d(10.5, -9.0);
    const double bodyRadius = 14.0, headRadius = 0.55 * bodyRadius;
    const cv::Rect2d stub(head.x + headRadius - 1.0, head.y - 1.0, 6.0, 2.0);  // the beak's edge, 5 px beyond the head
    const cv::Vec3d target(2000, 18000, 40000), seabed(9000, 10000, 9000);     // B, G, R
    const cv::Rect region(static_cast<int>(body.x) - 40, static_cast<int>(body.y) - 40, 80, 80);
    const auto silhouette = [&](bool withStub, cv::Rect& maskBox) {
        ImageWork w;
        cv::Mat exact(static_cast<int>(2 * camera.cc[1]), static_cast<int>(2 * camera.cc[0]), CV_64FC3,
                      cv::Scalar(seabed[0], seabed[1], seabed[2]));
        cv::Mat mask(exact.size(), CV_8UC1, cv::Scalar(0));
        for (int y = region.y; y < region.br().y; ++y)
            for (int x = region.x; x < region.br().x; ++x) {
                int inside = 0;
                for (int sy = 0; sy < 8; ++sy)
                    for (int sx = 0; sx < 8; ++sx) {
                        const cv::Point2d q(x - 0.5 + (sx + 0.5) / 8, y - 0.5 + (sy + 0.5) / 8);
                        inside += cv::norm(q - body) < bodyRadius || cv::norm(q - head) < headRadius ||
                                  (withStub && stub.contains(q));
                    }
                const double a = inside / 64.0;
                exact.at<cv::Vec3d>(y, x) = target * a + seabed * (1.0 - a);
                if (a >= 0.5) mask.at<std::uint8_t>(y, x) = 255;
            }
        cv::Mat mixed;
        cv::blur(exact, mixed, cv::Size(3, 3), cv::Point(-1, -1), cv::BORDER_REPLICATE);
        mixed.convertTo(w.image, CV_16UC3);
        const Feature feature = soleFeature(w, mask);
        maskBox = feature.box;
        return detail::measureSilhouette(w, 0, feature, {0, 0, w.image.cols, w.image.rows}, 1.0);
    };
    const detail::CompletenessLimits limits;
    const auto extentOf = [&](bool withStub, cv::Rect& maskBox, int& stray) {
        const detail::Silhouette s = silhouette(withStub, maskBox);
        const detail::PartsFit parts = detail::fitRoundParts(camera, s, limits.minFitThresholdPx,
                                                             limits.partThresholdPx, limits.compositeParts,
                                                             limits.minPartSided);
        stray = parts.outside;
        EXPECT_EQ(std::count_if(parts.parts.begin(), parts.parts.end(), [](const auto& p) { return p.ok; }), 2)
            << "a body and a head";
        return detail::partsExtent(camera, parts, s, limits.partThresholdPx);
    };
    cv::Rect plainBox, stubBox;
    int plainStray = 0, stubStray = 0;
    const auto plain = extentOf(false, plainBox, plainStray);
    const auto withStub = extentOf(true, stubBox, stubStray);
    ASSERT_TRUE(plain && withStub);
    ASSERT_GE(stubBox.width - plainBox.width, 4) << "the stub must widen the mask's box";
    EXPECT_GT(stubStray, plainStray) << "the stub's outline is no part's";
    // The parts' extent: the body's and the head's edges (with the stub,
    // its root within the parts' threshold outside the head too).
    EXPECT_NEAR(withStub->width, plain->width, limits.partThresholdPx);
    EXPECT_NEAR(withStub->height, plain->height, limits.partThresholdPx);
    EXPECT_NEAR(plain->x, body.x - bodyRadius, 0.5);
    EXPECT_NEAR(plain->br().x, head.x + headRadius, 0.5);
    EXPECT_NEAR(plain->y, head.y - headRadius, 0.5);
    EXPECT_NEAR(plain->br().y, body.y + bodyRadius, 0.5);
}

// A yellow duck (a composite type: no model can check a union) with a gold
// sphere in front of its edge in the right image: two colours well inside their
// own filters are two targets, not one object split between filters. The
// sphere is whole; the duck, hidden in part, is reported as its own type and
// occluded, not ambiguous.
TEST(Completeness, ADuckBehindASphereOfAnotherColourAreTwoTargets) {
    render::Scene scene = emptyLab();
    auto duck = target("duck", render::Shape::Duck, {0, 0, 900}, 40);
    duck.om = {0.0, M_PI, 0.0};  // facing left: its beak away from the ball
    auto ball = target("ball", render::Shape::Sphere, {0, 0, 0}, 22, kGold, "arm_marker");
    // 400 mm nearer than the duck, beside it in the left image and in front
    // of its edge in the right.
    ball.centreMm = cv::Vec3d(0, 0, 900) * (500.0 / 900.0) + cv::Vec3d(61, 0, 0);
    scene.targets = {duck, ball};
    AvatarConfig cfg = config(TargetShape::Sphere);
    cfg.targets.targets[0].shape = TargetShape::Composite;  // "sample": the duck
    const Outcome o = run(scene, cfg);
    ASSERT_TRUE(!o.truth.target("duck").left.occluded && o.truth.target("duck").right.occluded)
        << "the ball must hide part of the duck in the right image only";
    EXPECT_EQ(o.stereoCount(), 2);
    const auto b = o.of("ball");
    ASSERT_TRUE(b);
    EXPECT_EQ(b->type, "arm_marker");
    EXPECT_TRUE(b->flags & kTargetWhole) << flagsOf(b);
    EXPECT_LT(o.errorMm("ball"), 2.0);  // its right outline meets the duck: a seam of mixed pixels
    const auto d = o.of("duck");
    ASSERT_TRUE(d);
    EXPECT_EQ(d->type, "sample");
    EXPECT_TRUE(!(d->flags & kTargetWhole) && !(d->flags & kTargetAmbiguous) && (d->flags & kTargetOccludedRight) &&
                !(d->flags & kTargetOccludedLeft))
        << flagsOf(d);
}

// A gold sphere lying in front of a larger yellow disc, seen within the
// disc's outline in both views (in three places: well inside it, and near
// its rim, where the two outlines come within a few pixels): the union of
// the two colours fits the disc's ellipse, and was taken for one object
// split between the filters, the sphere lost in it (trust_report seed 36:
// a red disc lying on a green one, not reported at all). Two colours
// neither near the other's filter, one seen within the other's hull, are
// two targets; the sphere is in front, its outline at the disc its own:
// whole, within a millimetre. The disc is hidden by it in both views.
TEST(Completeness, ATargetSeenWithinALargerOneOfAnotherColourIsATargetInFrontOfIt) {
    const std::array<cv::Vec2d, 3> offsets{cv::Vec2d(0, 0), cv::Vec2d(-36, -8), cv::Vec2d(20, 33)};
    for (std::size_t k = 0; k < offsets.size(); ++k) {
        render::Scene scene = emptyLab();
        const auto disc = target("disc", render::Shape::Disc, {0, 0, 800}, 60);
        const auto ball = target("ball", render::Shape::Sphere, {offsets[k][0], offsets[k][1], 750}, 16, kGold,
                                 "arm_marker");
        scene.targets = {disc, ball};
        AvatarConfig cfg = config(TargetShape::Sphere);
        cfg.targets.targets[0].shape = TargetShape::Disc;  // "sample": the disc
        const Outcome o = run(scene, cfg);
        const render::TargetTruth& b = o.truth.target("ball");
        ASSERT_EQ(b.left.potentialAreaPx - b.left.areaPx, 0.0) << "pose " << k;
        ASSERT_EQ(b.right.potentialAreaPx - b.right.areaPx, 0.0) << "pose " << k;
        ASSERT_TRUE(o.truth.target("disc").left.occluded && o.truth.target("disc").right.occluded) << "pose " << k;
        // By type: in the first pose both centroids lie at the image's centre.
        std::map<std::string, VisionTarget> byType;
        for (const VisionTarget& v : o.result.targets)
            if (v.flags & kTargetStereo) byType.emplace(v.type, v);
        EXPECT_EQ(o.stereoCount(), 2) << "pose " << k;
        ASSERT_EQ(byType.count("arm_marker"), 1u) << "pose " << k << ": the ball is not found";
        const VisionTarget& vb = byType.at("arm_marker");
        EXPECT_TRUE(vb.flags & kTargetWhole) << "pose " << k << ": " << targetFlagsText(vb.flags);
        EXPECT_EQ(vb.model, ShapeModel::Sphere) << "pose " << k;
        ASSERT_TRUE(vb.positionVisionMm) << "pose " << k;
        EXPECT_LT(cv::norm(*vb.positionVisionMm - b.centreLeftMm), 1.0) << "pose " << k;
        ASSERT_EQ(byType.count("sample"), 1u) << "pose " << k;
        const VisionTarget& vd = byType.at("sample");
        EXPECT_TRUE(!(vd.flags & kTargetWhole) && (vd.flags & kTargetOccludedLeft) &&
                    (vd.flags & kTargetOccludedRight))
            << "pose " << k << ": " << targetFlagsText(vd.flags);
    }
}

// The type margin: a colour is near a filter it fails only by less than the
// margin in R/G or B/G; windows do not matter; 8- and 16-bit colours agree.
TEST(Completeness, AColourWithinTheMarginOfAnotherFilterIsNearIt) {
    TargetType low, high;
    low.name = "low";
    low.redGreen = {1.0, 2.0};
    high.name = "high";
    high.redGreen = {2.3, 4.0};
    high.window = {0, 0, 1, 1};  // a window the test colours are not in
    const std::vector<TargetType> types{low, high};
    const double margin = 0.1;  // 10.5 %
    // R/G 1.9: passes low; 1.9 x 1.105 = 2.10 < 2.3, so not near high.
    auto near = detail::typesNear(types, cv::Vec3f(20.f, 100.f, 190.f), CV_8U, 8, margin);
    EXPECT_TRUE(near[0]);
    EXPECT_FALSE(near[1]);
    // R/G 2.1: passes low's margin (2.1 / 1.105 = 1.90) and high's (2.1 x 1.105 = 2.32).
    near = detail::typesNear(types, cv::Vec3f(20.f, 100.f, 210.f), CV_8U, 8, margin);
    EXPECT_TRUE(near[0]);
    EXPECT_TRUE(near[1]);
    const auto wide = detail::typesNear(types, cv::Vec3f(20.f * 256, 100.f * 256, 210.f * 256), CV_16U, 16, margin);
    EXPECT_EQ(wide, near);
    // R/G 2.6: high only; a black pixel is near nothing.
    near = detail::typesNear(types, cv::Vec3f(20.f, 100.f, 255.f), CV_8U, 8, margin);
    EXPECT_FALSE(near[0]);
    EXPECT_TRUE(near[1]);
    near = detail::typesNear(types, cv::Vec3f(0.f, 0.f, 0.f), CV_8U, 8, margin);
    EXPECT_EQ(near, std::vector<bool>({false, false}));
}

// The composite model (the duck: a body and a head sphere). Its outline is
// explained by the round parts it fits: a duck is whole and placed by its
// body's cone axes (its centre; the centroids, pulled towards the head, are
// millimetres off); a box of the duck's colour leaves corners no round part
// explains, and two touching ducks one duck's worth of outline: neither is
// whole, without any size range.
TEST(ShapeModel, ADuckIsPlacedByItsBodyAndABoxOrTwoDucksOfItsColourAreNotWhole) {
    const double r = 35.0;
    render::Scene scene = emptyLab();
    auto duck = target("duck", render::Shape::Duck, {-150, 20, 800}, r);
    duck.om = {0.0, 0.0, 0.3};  // seen from the side, its head raised a little
    auto box = target("box", render::Shape::Box, {160, -30, 850}, r);
    box.halfSizeMm = {32, 24, 20};
    box.om = {0.4, 0.6, 0.2};
    scene.targets = {duck, box};
    AvatarConfig cfg = config(TargetShape::Composite);
    const Outcome o = run(scene, cfg);
    const auto d = o.of("duck");
    ASSERT_TRUE(d);
    EXPECT_TRUE(d->flags & kTargetWhole) << flagsOf(d);
    EXPECT_EQ(d->model, ShapeModel::Composite);
    EXPECT_TRUE(d->flags & kTargetShapeCorrected) << flagsOf(d);
    EXPECT_LT(o.errorMm("duck"), 0.5);
    // The same duck without a model: its centroids.
    const Outcome none = run(scene, config(TargetShape::None));
    EXPECT_GT(none.errorMm("duck"), 3.0 * std::max(o.errorMm("duck"), 0.3));
    const auto b = o.of("box");
    ASSERT_TRUE(b) << "the box passes the duck's filter";
    EXPECT_TRUE((b->flags & kTargetStereo) && !(b->flags & kTargetWhole)) << flagsOf(b);
    EXPECT_EQ(b->model, ShapeModel::None);
    EXPECT_TRUE(none.of("box") && (none.of("box")->flags & kTargetWhole))
        << "without a model nothing tells the box from a target";

    render::Scene two = emptyLab();
    two.targets = {duck, target("neighbour", render::Shape::Duck, duck.centreMm + cv::Vec3d(1.7 * r, 0, 0), r)};
    two.targets[1].om = duck.om;
    const Outcome pair = run(two, cfg);
    ASSERT_EQ(pair.stereoCount(), 1) << "the two ducks must make one feature";
    for (const VisionTarget& v : pair.result.targets) {
        if (v.flags & kTargetStereo) {
            EXPECT_TRUE((v.flags & kTargetMerged) && !(v.flags & kTargetWhole)) << targetFlagsText(v.flags);
        }
    }
}

// Two small ducks touching at 2 m, the one behind hidden in part: their
// outline is one's body and the other's (two parts of the type's two), and
// the heads left over are too little of the silhouette for the stray share.
// The heads' circles are a part more than the type has, as large as a part
// of it: `merged`, what the feature is (without that, the other duck read
// as what hides this one: `occluded` only; seed 49 had such a pair whole).
TEST(ShapeModel, TwoSmallTouchingDucksAreMergedByThePartTheyHaveMore) {
    const double r = 22.0;
    const AvatarConfig cfg = config(TargetShape::Composite);
    for (const double yaw : {M_PI / 2, M_PI}) {
        render::Scene two = emptyLab();
        auto front = target("front", render::Shape::Duck, {-40, 20, 2000}, r);
        front.om = {0.0, yaw, 0.0};
        auto behind = target("behind", render::Shape::Duck, front.centreMm + cv::Vec3d(1.1 * r, 0.2 * r, 40.0), r);
        behind.om = front.om;
        two.targets = {front, behind};
        const Outcome o = run(two, cfg);
        ASSERT_TRUE(o.truth.target("front").left.visibility == render::TargetVisibility::Full &&
                    o.truth.target("behind").left.occluded)
            << "the front duck must hide part of the other in the left view";
        ASSERT_EQ(o.stereoCount(), 1) << "the two ducks must make one feature";
        for (const VisionTarget& v : o.result.targets) {
            if (v.flags & kTargetStereo) {
                EXPECT_TRUE((v.flags & kTargetMerged) && !(v.flags & kTargetWhole))
                    << "yaw " << yaw << ": " << targetFlagsText(v.flags);
            }
        }
    }
}

// Small spheres far away (23 mm at 1.95-2.15 m: about 12 px of radius) are
// placed by their model, not by their centroids: the filter loses up to a
// pixel of a lit sphere's dim limb, which elongates so small a cone by more
// than a large one's limit (two of these four were placed by their
// centroids without the allowance; seed 30 of the trust report had one so
// 21 mm off). Their error stays within 0.4 % of the range.
TEST(ShapeModel, SmallFarSpheresArePlacedByTheirCones) {
    render::Scene scene = emptyLab();
    scene.seabed.distanceMm = 3000;
    const std::array<cv::Vec3d, 4> centres{cv::Vec3d(-450, -280, 1950), cv::Vec3d(-50, 0, 2050),
                                           cv::Vec3d(350, 280, 2150), cv::Vec3d(450, -200, 2000)};
    for (std::size_t i = 0; i < centres.size(); ++i)
        scene.targets.push_back(target("s" + std::to_string(i), render::Shape::Sphere, centres[i], 23.0));
    const Outcome o = run(scene, config(TargetShape::Sphere));
    for (std::size_t i = 0; i < centres.size(); ++i) {
        const std::string name = "s" + std::to_string(i);
        const auto s = o.of(name);
        if (!s) {
            ADD_FAILURE() << name << " not found";
            continue;
        }
        EXPECT_TRUE(s->flags & kTargetWhole) << name << ": " << flagsOf(s);
        EXPECT_EQ(s->model, ShapeModel::Sphere) << name;
        EXPECT_LT(o.errorMm(name), 8.0) << name;
    }
}

// A composite type's silhouette that is one round part in both views, and no
// sphere's, is not the duck: its type cannot be decided, and it is never
// whole. A disc of the duck's colour at 2 m tilted 14 degrees (one ellipse of
// about 20 px radius) was whole before, placed by its centroids; tilted
// further, or nearer, its outline leaves the duck's part checks (occluded);
// tilted less than about 9 degrees it is a sphere's cone to the image (no
// shape tells them apart). A duck beside it stays whole, by its model, and
// one facing the camera (its head in front of its body) is not ambiguous.
TEST(Completeness, ACompositesColourInOneEllipseThatNoSphereMakesIsNotWhole) {
    const double r = 35.0;
    render::Scene scene = emptyLab();
    auto disc = target("disc", render::Shape::Disc, {150, -40, 2000}, r);
    disc.normal = {std::sin(0.25), 0.0, -std::cos(0.25)};
    auto duck = target("duck", render::Shape::Duck, {-160, 30, 800}, r);
    duck.om = {0.0, 0.0, 0.3};
    scene.targets = {disc, duck};
    const AvatarConfig cfg = config(TargetShape::Composite);
    const Outcome o = run(scene, cfg);
    const auto d = o.of("disc");
    ASSERT_TRUE(d) << "the disc passes the duck's filter";
    EXPECT_TRUE((d->flags & kTargetStereo) && (d->flags & kTargetAmbiguous) && !(d->flags & kTargetWhole))
        << flagsOf(d);
    const auto k = o.of("duck");
    ASSERT_TRUE(k);
    EXPECT_TRUE(k->flags & kTargetWhole) << flagsOf(k);
    EXPECT_EQ(k->model, ShapeModel::Composite);

    // The duck turned towards the camera: its head in front of its body.
    render::Scene front = emptyLab();
    auto facing = duck;
    facing.om = {0.0, M_PI / 2, 0.0};
    front.targets = {facing};
    const Outcome f = run(front, cfg);
    const auto fk = f.of("duck");
    ASSERT_TRUE(fk);
    EXPECT_FALSE(fk->flags & kTargetAmbiguous) << flagsOf(fk);
}

// A duck and a sphere touching side by side at nearly one depth (as the
// trust report's scenes place touching pairs). The duck counts as its
// body's sphere where all its contact is on its body's outline, so the pair
// is judged as two spheres in space: the duck, in front at the contact in
// both views, is whole, and the ball, a sliver of which passes behind it in
// one view (the renderer's truth), is occluded there. Before, the duck was
// judged by the margin of both radii that a contact at its head needs and
// flagged occluded (seeds 31 and 33: four such ducks). The body is an arc
// beside the head, placed by its cone. With the ball in front of the duck's
// head instead, the duck is hidden in part and not whole.
TEST(Completeness, ADuckBesideASphereIsJudgedByItsBodysSphere) {
    const double s = 40.0, r = 25.0;
    const cv::Vec3d centre(-60, 60, 900);
    auto duck = target("duck", render::Shape::Duck, centre, s);
    duck.om = {0.0, M_PI, 0.0};  // facing left: its head and beak away from the ball
    AvatarConfig cfg = config(TargetShape::Sphere);
    cfg.targets.targets[0].shape = TargetShape::Composite;  // "sample": the duck
    // Touching, the line of their centres across the ray from the middle of
    // the baseline: each camera sees the pair a little obliquely.
    const cv::Point3d mid = transformPoint(inverse(rightTLeft(cfg.stereo)), {0, 0, 0}) * 0.5;
    cv::Vec3d across(centre[2] - mid.z, 0.0, -(centre[0] - mid.x));
    across *= (s + r) / cv::norm(across);
    auto ball = target("ball", render::Shape::Sphere, centre + across, r, kGold, "arm_marker");
    render::Scene scene = emptyLab();
    scene.targets = {duck, ball};
    const Outcome o = run(scene, cfg);
    const auto hiddenPx = [](const render::TargetView& v) { return v.potentialAreaPx - v.areaPx; };
    const render::TargetTruth& dt = o.truth.target("duck");
    const render::TargetTruth& bt = o.truth.target("ball");
    ASSERT_LT(hiddenPx(dt.left) + hiddenPx(dt.right), 1.0) << "the duck must be whole in both views";
    ASSERT_LT(hiddenPx(bt.right), 1.0);
    ASSERT_GE(hiddenPx(bt.left), 1.0) << "a sliver of the ball must pass behind the duck in the left view";
    const auto d = o.of("duck"), b = o.of("ball");
    ASSERT_TRUE(d && b);
    EXPECT_TRUE(d->flags & kTargetWhole) << flagsOf(d);
    EXPECT_EQ(d->model, ShapeModel::Composite);
    EXPECT_LT(o.errorMm("duck"), 1.0);
    EXPECT_TRUE((b->flags & kTargetOccludedLeft) && !(b->flags & kTargetOccludedRight)) << flagsOf(b);
    EXPECT_EQ(b->model, ShapeModel::Sphere);
    EXPECT_LT(o.errorMm("ball"), 1.0);

    // The ball 30 mm in front of the duck's head (up and to its right),
    // hiding part of it in both views: the contact is at the head, which its
    // body's sphere cannot judge.
    render::Scene head = emptyLab();
    auto facing = duck;
    facing.om = {0.0, 0.0, 0.0};  // head to the right, up
    const cv::Vec3d headCentre = centre + cv::Vec3d(0.55 * s, -0.75 * s, 0.0);
    auto front = ball;
    front.centreMm = headCentre + cv::Vec3d(0.55 * s + r - 12.0, -10.0, -30.0);
    head.targets = {facing, front};
    const Outcome h = run(head, cfg);
    ASSERT_TRUE(h.truth.target("duck").left.occluded && h.truth.target("duck").right.occluded)
        << "the ball must hide part of the duck's head";
    const auto hd = h.of("duck");
    ASSERT_TRUE(hd);
    EXPECT_TRUE((hd->flags & kTargetOccludedLeft) && (hd->flags & kTargetOccludedRight) &&
                !(hd->flags & kTargetWhole))
        << flagsOf(hd);
}

// A duck moved across the right image's left edge 1 mm at a time: cut
// while any of it lies beyond the edge (the renderer's truth), whole and
// `border` while its body's circle only touches it, whole inside. Edge
// points outside every round part make a composite cut (seed 35 of the
// trust report: a duck 2 px across the edge where its parts' circles did
// not reach was whole); those within a pixel of a part's circle, the mixed
// column at the edge, leave it to the part's bins.
TEST(Completeness, ADuckAtTheEdgeIsCutOnlyWhenItCrossesIt) {
    const AvatarConfig cfg = config(TargetShape::Composite);
    int cut = 0, touching = 0, inside = 0;
    for (double x = -466; x <= -455; x += 1.0) {
        render::Scene scene = emptyLab();
        scene.targets = {target("duck", render::Shape::Duck, {x, 0, 900}, 35)};
        const Outcome o = run(scene, cfg);
        const render::TargetTruth& t = o.truth.target("duck");
        ASSERT_EQ(o.stereoCount(), 1) << "x " << x;
        const VisionTarget* d = nullptr;
        for (const VisionTarget& v : o.result.targets)
            if (v.flags & kTargetStereo) d = &v;
        const std::string flags = targetFlagsText(d->flags);
        if (t.right.cut) {
            ++cut;
            EXPECT_TRUE((d->flags & kTargetCut) && !(d->flags & kTargetWhole)) << "x " << x << ": " << flags;
        } else {
            touching += t.right.atBorder;
            inside += !t.right.atBorder;
            EXPECT_TRUE((d->flags & kTargetWhole) && !(d->flags & kTargetCut)) << "x " << x << ": " << flags;
        }
    }
    EXPECT_GE(cut, 4);
    EXPECT_GE(touching, 1);
    EXPECT_GE(inside, 4);
}

// imageScale(): a sphere's image off the axis and through a distorting lens.
// Its silhouette's area (the renderer's exact coverage) over the scale, times
// the range squared, is its cross-section pi R^2 at every angle (within
// 0.1 %); the plain scale (f^2 over the range squared) over-states it off the
// axis, by 1/cos^3 of the ray's angle without distortion.
TEST(ShapeModel, ImageScaleGivesASpheresSizeAtAnyAngleThroughTheLens) {
    const double r = 30.0;
    for (const bool distorted : {false, true}) {
        AvatarConfig cfg = config(TargetShape::Sphere);
        if (distorted) cfg.stereo.left.kc = {-0.25, 0.08, 0.001, -0.001, 0.0};
        double worstPlain = 0.0;
        for (const cv::Vec3d& c : {cv::Vec3d(-70, -60, 900), cv::Vec3d(-380, 0, 900), cv::Vec3d(230, 230, 800),
                                   cv::Vec3d(-400, -300, 900)}) {
            render::Scene scene = emptyLab();
            scene.targets = {target("ball", render::Shape::Sphere, c, r)};
            render::RenderOptions options;
            options.seed = 5;
            const render::RenderResult rendered = render::render(scene, cfg.stereo, options);
            const render::TargetTruth& t = rendered.truth.target("ball");
            ASSERT_EQ(t.left.visibility, render::TargetVisibility::Full);
            const double d = cv::norm(c);
            const detail::ImageScale scale = detail::imageScale(cfg.stereo.left, cv::Point3d(c));
            EXPECT_NEAR(std::sqrt(t.left.areaPx / (M_PI * scale.area)) * d / r, 1.0, 0.01)
                << "at x " << c[0] << " y " << c[1] << (distorted ? ", distorted" : "");
            const double plain = std::sqrt(t.left.areaPx / M_PI) / cfg.stereo.left.fc[0] * d / r;
            worstPlain = std::max(worstPlain, std::abs(plain - 1.0));
        }
        // 1.22 at 29 degrees without distortion; the barrel distortion shrinks it back to 1.06.
        EXPECT_GT(worstPlain, distorted ? 0.04 : 0.15) << "the plain scale should be off at 29 degrees";
    }
}

// The type's physical size (sizeMm): two ducks of one colour side by side
// are one feature whose views agree with each other; for a type without a
// shape model only the size tells them from one duck (the composite model
// does too: see above). Within the range a duck stays whole, above it the
// pair is merged, below it a duck is ambiguous.
TEST(Completeness, TheTypesSizeTellsTwoTouchingDucksFromOne) {
    const double r = 35.0;
    const cv::Vec3d centre(-60, 20, 800);
    render::Scene one = emptyLab();
    one.targets = {target("duck", render::Shape::Duck, centre, r)};
    AvatarConfig cfg = config(TargetShape::None);  // the size alone
    const Outcome alone = run(one, cfg);
    // Its size from the truth: the diameter of the circle of its silhouette's area at its range.
    const render::TargetTruth& truth = alone.truth.target("duck");
    const double size = 2.0 * std::sqrt(truth.left.areaPx / M_PI) * cv::norm(truth.centreLeftMm) / cfg.stereo.left.fc[0];
    ASSERT_GT(size, 1.5 * r);
    ASSERT_LT(size, 3.0 * r);
    auto d = alone.of("duck");
    ASSERT_TRUE(d && (d->flags & kTargetWhole)) << flagsOf(d);

    cfg.targets.targets[0].sizeMm = Range{0.9 * size, 1.1 * size};  // "sample", the yellow type
    d = run(one, cfg).of("duck");
    EXPECT_TRUE(d && (d->flags & kTargetWhole)) << flagsOf(d);

    render::Scene two = one;
    two.targets.push_back(target("neighbour", render::Shape::Duck, centre + cv::Vec3d(1.7 * r, 0, 0), r));
    const Outcome pair = run(two, cfg);
    ASSERT_EQ(pair.stereoCount(), 1) << "the two ducks must make one feature";
    for (const VisionTarget& v : pair.result.targets) {
        if (v.flags & kTargetStereo) {
            EXPECT_TRUE((v.flags & kTargetMerged) && !(v.flags & kTargetWhole)) << targetFlagsText(v.flags);
        }
    }

    cfg.targets.targets[0].sizeMm = Range{1.2 * size, 2.0 * size};
    d = run(one, cfg).of("duck");
    EXPECT_TRUE(d && (d->flags & kTargetAmbiguous) && !(d->flags & kTargetWhole)) << flagsOf(d);
}

// behindByAbsence() on masks drawn by hand: an object 40x40 px seen in the
// left view alone, its box's left edge at x, behind a target of disparity
// 100 px if the right view, between 100 and 300 px of disparity (rows
// within 5 px), shows no 800 px of its colour in a box of its size. Near the
// left edge the stretch leaves the right image: a box the image cuts still
// counts for what it shows, down to a quarter of itself (before, any part
// beyond the image left the object undecided, and a whole duck at 0.54 m
// touching such an object was occluded; trust_report seed 58).
TEST(Completeness, AnObjectOneViewAloneShowsIsBehindWhereTheOtherViewLacksItsColour) {
    AnalysisFrame frame;
    ImageWork& right = frame.at(Side::Right);
    right.image = cv::Mat(480, 640, CV_8UC3, cv::Scalar(0, 0, 0));
    right.masks = {cv::Mat::zeros(480, 640, CV_8UC1)};
    TargetType type;
    type.name = "orange";
    const std::vector<TargetType> types{type};
    MatchConfig match;
    match.boxDxMin = 10.0;
    match.boxDxMax = 300.0;
    match.boxDyMin = -5.0;
    match.boxDyMax = 5.0;
    const auto behind = [&](int x, double minPx) {
        return detail::behindByAbsence(frame, match, types, cv::Rect(x, 200, 40, 40), {0}, Side::Left, 100.0, minPx);
    };
    EXPECT_TRUE(behind(400, 800.0)) << "nothing in the right view, the stretch inside it";
    EXPECT_TRUE(behind(290, 800.0)) << "the box 10 px beyond the right image at 300 px: three quarters show";
    EXPECT_TRUE(behind(270, 800.0)) << "30 px beyond: a quarter shows";
    EXPECT_FALSE(behind(269, 800.0)) << "31 px beyond: less than a quarter shows, it may lie there unseen";
    EXPECT_FALSE(behind(290, 0.0)) << "a fragment, counted by any pixel: any part beyond the image leaves it unseen";
    EXPECT_TRUE(behind(400, 0.0)) << "a fragment whose stretch lies inside the image";

    // Its colour at a disparity of 200 px, a blob of its size: there.
    right.masks[0](cv::Rect(200, 200, 40, 40)).setTo(255);
    EXPECT_FALSE(behind(400, 800.0));
    EXPECT_FALSE(behind(400, 0.0));
    // Only its colour in a column at the image's edge, where the box 10 px
    // beyond the image at 300 px shows 30 of its 40 columns: 15 columns of
    // 40 rows (600 px) hold its share of 800 px there, 10 columns do not.
    right.masks[0].setTo(0);
    right.masks[0](cv::Rect(0, 195, 15, 50)).setTo(255);
    EXPECT_FALSE(behind(290, 800.0)) << "600 px of its colour where three quarters of its box show";
    right.masks[0].setTo(0);
    right.masks[0](cv::Rect(0, 195, 10, 50)).setTo(255);
    EXPECT_TRUE(behind(290, 800.0)) << "400 px: fewer than its share there";
    // A type's search window cuts the stretch as the image's edge does.
    right.masks[0].setTo(0);
    TargetType windowed = type;
    windowed.window = SearchWindow{150, 0, 490, 480};
    EXPECT_TRUE(behind(380, 800.0)) << "the image alone holds the box at every disparity";
    EXPECT_FALSE(detail::behindByAbsence(frame, match, {windowed}, cv::Rect(380, 200, 40, 40), {0}, Side::Left,
                                         100.0, 800.0))
        << "the window starts at x 150: at 300 px the box lies wholly beyond it";
}

// A duck (a composite: any contact is judged by depth) in front of a gold
// disc that it hides whole in the left view and in part in the right, where
// the disc touches its body: the disc is seen in the right view alone, so no
// depth judges the contact. Were the disc nearer than the duck, the left
// view would show it at a larger disparity than the duck's, where nothing
// gold is: it is behind, and the duck is whole (it was occluded-right; a
// red sphere in front of a magenta disc so, trust_report seed 50). With a
// gold disc in that stretch of the left view nothing can be told, and the
// duck stays occluded there; with a speck of gold there, too small to be
// the disc, it is whole.
TEST(Completeness, ATargetTouchingOnlyAnObjectBehindItThatTheOtherViewLacksIsWhole) {
    render::Scene scene = emptyLab();
    auto duck = target("duck", render::Shape::Duck, {0, 0, 800}, 40);
    duck.om = {0.0, M_PI, 0.0};  // facing left: its head and beak away from the disc
    // 13 px right of the duck's centre in the left image, 1200 mm away.
    scene.targets = {duck, target("disc", render::Shape::Disc, {1200.0 * 13.0 / 1049.0, 0, 1200}, 15, kGold,
                                  "arm_marker")};
    const AvatarConfig cfg = config(TargetShape::Composite);
    const Outcome o = run(scene, cfg);
    const render::TargetTruth& d = o.truth.target("disc");
    ASSERT_TRUE(d.left.visibility == render::TargetVisibility::None && d.right.areaPx > 150.0 && d.right.occluded)
        << "the duck must hide the disc whole in the left view and in part in the right";
    ASSERT_FALSE(o.truth.target("duck").left.occluded || o.truth.target("duck").right.occluded);
    const auto k = o.of("duck");
    ASSERT_TRUE(k);
    EXPECT_TRUE(k->flags & kTargetWhole) << flagsOf(k);
    int rightOnly = 0;
    for (const VisionTarget& v : o.result.targets) rightOnly += (v.flags & kTargetRightOnly) && v.type == "arm_marker";
    EXPECT_EQ(rightOnly, 1) << "the disc is seen in the right view alone";

    // Another gold disc where the first would show in the left view were it
    // nearer than the duck (175 px right of the image's centre there).
    scene.targets.push_back(target("other", render::Shape::Disc, {200, 0, 1200}, 15, kGold, "arm_marker"));
    const Outcome with = run(scene, cfg);
    ASSERT_FALSE(with.truth.target("other").left.occluded);
    const auto k2 = with.of("duck");
    ASSERT_TRUE(k2);
    EXPECT_TRUE((k2->flags & kTargetOccludedRight) && !(k2->flags & kTargetWhole)) << flagsOf(k2);

    // A small gold sphere there instead, of less than half the area the
    // disc shows in the right view: the disc, were it nearer, would show
    // there whole, so the sphere does not stand for it. The duck is whole.
    scene.targets.back() = target("speck", render::Shape::Sphere, {200, 0, 1200}, 4, kGold, "arm_marker");
    const Outcome speck = run(scene, cfg);
    const render::TargetTruth& st = speck.truth.target("speck");
    ASSERT_TRUE(st.left.visibility == render::TargetVisibility::Full && st.left.areaPx >= 20.0 &&
                st.left.areaPx < 0.5 * speck.truth.target("disc").right.areaPx)
        << st.left.areaPx;
    const auto k3 = speck.of("duck");
    ASSERT_TRUE(k3);
    EXPECT_TRUE(k3->flags & kTargetWhole) << flagsOf(k3);
}

// A duck (a composite type: no model checks its outline) whose head is
// topped by a grey sphere in front of it in the left image only: little of
// its area is lost, but its silhouette there ends lower than in the right
// image, which a rigid object seen from two nearby viewpoints cannot do.
TEST(Completeness, ADuckLosingItsTopInOneViewIsNotWhole) {
    render::Scene scene = emptyLab();
    const double s = 40.0, z = 900.0;
    const cv::Vec3d centre(-100, 0, z);
    scene.targets = {target("duck", render::Shape::Duck, centre, s)};
    // 35 % of the way from the left camera to a point above the head, its
    // image's lower edge 1.05 s above the duck's centre: the top of its
    // head (1.3 s up), about 4 % of its silhouette, hidden.
    scene.occluders = {occluder("cap", (centre + cv::Vec3d(0.55 * s, -(1.05 + 1.0) * s, 0)) * 0.35, 0.35 * s, 0.35)};
    const Outcome o = run(scene, config(TargetShape::Composite));
    const render::TargetTruth& truth = o.truth.target("duck");
    ASSERT_TRUE(truth.left.occluded && !truth.right.occluded) << "the cap must hide the head in the left image only";
    ASSERT_GT(truth.left.hiddenFraction(), 0.02);
    ASSERT_LT(truth.left.hiddenFraction(), 0.06) << "too little for the area check to see";
    const auto d = o.of("duck");
    ASSERT_TRUE(d);
    EXPECT_TRUE((d->flags & kTargetOccludedLeft) && !(d->flags & kTargetWhole)) << flagsOf(d);
}

}  // namespace
}  // namespace avatar
