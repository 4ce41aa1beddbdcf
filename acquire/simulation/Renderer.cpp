#include <avatar/common/ImageUtils.h>
#include <avatar/render/Renderer.h>

#include "RayTracer.h"

#include <avatar/common/CameraModel.h>
#include <avatar/common/Error.h>
#include <avatar/common/Logging.h>

#include <log4cpp/Category.hh>
#include <opencv2/core.hpp>
#include <opencv2/core/utility.hpp>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <limits>
#include <random>

namespace avatar::render {

SensorFormat sensorFormatFrom(const CameraHardwareConfig& camera) {
    SensorFormat f;
    f.width = camera.width;
    f.height = camera.height;
    f.bitDepth = camera.bitDepth;
    f.format = camera.channels == 3 ? PixelFormat::Bgr : camera.bayer ? PixelFormat::Bayer : PixelFormat::Mono;
    f.bayerPattern = camera.bayerPattern;
    f.fileByteOrder = camera.endianSwap ? ByteOrder::Big : ByteOrder::Little;
    return f;
}

void RenderOptions::validate() const {
    auto fail = [](const std::string& field, const std::string& problem) {
        throw InvalidArgument("RenderOptions." + field + ": " + problem);
    };
    if (sensor.width < 2 || sensor.width > 16384)
        fail("sensor.width", "expected 2..16384, got " + std::to_string(sensor.width));
    if (sensor.height < 2 || sensor.height > 16384)
        fail("sensor.height", "expected 2..16384, got " + std::to_string(sensor.height));
    if (sensor.bitDepth < 1 || sensor.bitDepth > 16)
        fail("sensor.bitDepth", "expected 1..16, got " + std::to_string(sensor.bitDepth));
    if (sensor.format != PixelFormat::Bayer && sensor.format != PixelFormat::Bgr && sensor.format != PixelFormat::Mono)
        fail("sensor.format", "expected bayer, bgr or mono, got " + std::string(avatar::toString(sensor.format)));
    if (supersampling < 1 || supersampling > 16)
        fail("supersampling", "expected 1..16, got " + std::to_string(supersampling));
}

std::string_view toString(TargetVisibility visibility) {
    switch (visibility) {
        case TargetVisibility::Full: return "full";
        case TargetVisibility::Partial: return "partial";
        case TargetVisibility::None: return "none";
    }
    return "?";
}

const TargetTruth& GroundTruth::target(const std::string& name) const {
    for (const auto& t : targets)
        if (t.name == name) return t;
    throw InvalidArgument("GroundTruth::target: no target named '" + name + "' in scene '" + sceneName + "'");
}

namespace {

using detail::buildWorld;
using detail::CameraRig;
using detail::PrimKind;
using detail::Sample;
using detail::Signature;
using detail::Tracer;
using detail::World;

log4cpp::Category& logger() { return logging::category("render"); }

/// Per-target sums of one image row.
struct TargetAccumulator {
    double visible{0.0};
    double sumX{0.0};
    double sumY{0.0};
    double potential{0.0};
    bool atBorder{false};
    bool cut{false};  ///< a ray just outside the image passes through it
    double outside{0.0};  ///< its silhouette's area beyond the outer pixel edges (kOutsideBandPx deep; inf beyond)
};

/// How far beyond the image's outer pixel edges a cut silhouette's area is
/// measured, px.
constexpr double kOutsideBandPx = 2.0;

struct CameraRender {
    cv::Mat radiance;  ///< CV_64FC3, linear R, G, B per pixel (before strobe and sensor)
    std::vector<TargetAccumulator> targets;
    std::uint64_t supersampled{0};
    std::uint64_t rays{0};
    std::uint64_t noInverse{0};
};

CameraRender renderCamera(const World& world, const CameraRig& rig, const RenderOptions& options) {
    const int width = options.sensor.width, height = options.sensor.height;
    const int n = options.supersampling;
    const bool adaptive = options.adaptive && n > 1;
    const Tracer tracer(world, rig);
    const auto nTargets = static_cast<std::size_t>(world.targetCount);

    // Pass 1 (adaptive): what the pixel corners see.
    std::vector<Signature> corners;
    if (adaptive) {
        corners.resize(static_cast<std::size_t>(width + 1) * static_cast<std::size_t>(height + 1));
        cv::parallel_for_(cv::Range(0, height + 1), [&](const cv::Range& rows) {
            for (int j = rows.start; j < rows.end; ++j)
                for (int i = 0; i <= width; ++i)
                    corners[static_cast<std::size_t>(j) * static_cast<std::size_t>(width + 1) +
                            static_cast<std::size_t>(i)] = tracer.trace(i - 0.5, j - 0.5, false).sig;
        });
    }

    // Pass 2: every pixel, row by row; sums are kept per row and reduced in
    // row order, so the result does not depend on the threads.
    CameraRender out;
    out.radiance.create(height, width, CV_64FC3);
    std::vector<TargetAccumulator> rowSums(static_cast<std::size_t>(height) * nTargets);
    std::vector<std::uint64_t> rowSupersampled(static_cast<std::size_t>(height), 0);
    std::vector<std::uint64_t> rowNoInverse(static_cast<std::size_t>(height), 0);
    cv::parallel_for_(cv::Range(0, height), [&](const cv::Range& rows) {
        for (int j = rows.start; j < rows.end; ++j) {
            TargetAccumulator* acc = rowSums.data() + static_cast<std::size_t>(j) * nTargets;
            auto* pixels = out.radiance.ptr<cv::Vec3d>(j);
            for (int i = 0; i < width; ++i) {
                const bool border = i == 0 || j == 0 || i == width - 1 || j == height - 1;
                auto add = [&](const Sample& s, double x, double y, double weight) {
                    if (s.sig.object == -2) ++rowNoInverse[static_cast<std::size_t>(j)];
                    if (s.sig.object >= 0 && s.sig.object < world.targetCount) {
                        TargetAccumulator& a = acc[s.sig.object];
                        a.visible += weight;
                        a.sumX += weight * x;
                        a.sumY += weight * y;
                    }
                    for (std::uint64_t m = s.sig.targets; m; m &= m - 1) {
                        TargetAccumulator& a = acc[__builtin_ctzll(m)];
                        a.potential += weight;
                        a.atBorder = a.atBorder || border;
                    }
                };
                const Sample centre = tracer.trace(i, j, true);
                bool uniform = n == 1;
                if (adaptive) {
                    const std::size_t stride = static_cast<std::size_t>(width + 1);
                    const std::size_t k = static_cast<std::size_t>(j) * stride + static_cast<std::size_t>(i);
                    uniform = corners[k] == centre.sig && corners[k + 1] == centre.sig &&
                              corners[k + stride] == centre.sig && corners[k + stride + 1] == centre.sig;
                }
                if (uniform) {
                    add(centre, i, j, 1.0);
                    pixels[i] = cv::Vec3d(centre.radiance[0], centre.radiance[1], centre.radiance[2]);
                    continue;
                }
                ++rowSupersampled[static_cast<std::size_t>(j)];
                const double weight = 1.0 / (n * n);
                cv::Vec3d sum(0, 0, 0);
                for (int sy = 0; sy < n; ++sy)
                    for (int sx = 0; sx < n; ++sx) {
                        const double x = i - 0.5 + (sx + 0.5) / n;
                        const double y = j - 0.5 + (sy + 0.5) / n;
                        const Sample s = tracer.trace(x, y, true);
                        add(s, x, y, weight);
                        sum += cv::Vec3d(s.radiance[0], s.radiance[1], s.radiance[2]);
                    }
                pixels[i] = sum * weight;
            }
        }
    });

    // Cut or only touching: rays through points just outside the outer pixel
    // edges, every quarter pixel around the image, tell whether a target's
    // silhouette continues beyond the image.
    std::vector<std::uint64_t> outside;
    {
        const double eps = 1e-3, left = -0.5 - eps, right = width - 0.5 + eps, top = -0.5 - eps,
                     bottom = height - 0.5 + eps;
        std::vector<cv::Point2d> points;
        for (int k = 0; k <= 4 * width; ++k) {
            const double x = -0.5 + k / 4.0;
            points.emplace_back(x, top);
            points.emplace_back(x, bottom);
        }
        for (int k = 0; k <= 4 * height; ++k) {
            const double y = -0.5 + k / 4.0;
            points.emplace_back(left, y);
            points.emplace_back(right, y);
        }
        outside.assign(points.size(), 0);
        cv::parallel_for_(cv::Range(0, static_cast<int>(points.size())), [&](const cv::Range& r) {
            for (int k = r.start; k < r.end; ++k)
                outside[static_cast<std::size_t>(k)] =
                    tracer.trace(points[static_cast<std::size_t>(k)].x, points[static_cast<std::size_t>(k)].y, false)
                        .sig.targets;
        });
    }
    std::uint64_t cutTargets = 0;
    for (const std::uint64_t m : outside) cutTargets |= m;

    out.targets.assign(nTargets, {});
    for (std::size_t t = 0; t < nTargets; ++t) out.targets[t].cut = (cutTargets >> t) & 1u;
    // How much of a cut silhouette lies beyond the image: a band of
    // kOutsideBandPx along each edge, sampled every quarter pixel both ways
    // (each sample 1/16 px^2; the corners' squares are left out), and one
    // row of rays just beyond it: a silhouette reaching that far has an
    // area beyond the image without a bound here (infinity).
    if (cutTargets != 0) {
        const int depthSteps = static_cast<int>(4 * kOutsideBandPx);
        std::vector<cv::Point2d> points;  // (along-edge position, depth) per edge, then mapped
        const auto edgePoint = [&](int edge, double along, double depth) {
            switch (edge) {
                case 0: return cv::Point2d(along, -0.5 - depth);            // above the top
                case 1: return cv::Point2d(along, height - 0.5 + depth);    // below the bottom
                case 2: return cv::Point2d(-0.5 - depth, along);            // left of the left
                default: return cv::Point2d(width - 0.5 + depth, along);    // right of the right
            }
        };
        std::vector<char> deep;  // 1: beyond the band
        for (int edge = 0; edge < 4; ++edge) {
            const int length = edge < 2 ? width : height;
            for (int k = 0; k < 4 * length; ++k) {
                const double along = -0.5 + (k + 0.5) / 4.0;
                for (int d = 0; d <= depthSteps; ++d) {
                    points.push_back(edgePoint(edge, along, d < depthSteps ? (d + 0.5) / 4.0 : kOutsideBandPx + 1e-3));
                    deep.push_back(d == depthSteps);
                }
            }
        }
        std::vector<std::uint64_t> hits(points.size(), 0);
        cv::parallel_for_(cv::Range(0, static_cast<int>(points.size())), [&](const cv::Range& r) {
            for (int k = r.start; k < r.end; ++k)
                hits[static_cast<std::size_t>(k)] =
                    tracer.trace(points[static_cast<std::size_t>(k)].x, points[static_cast<std::size_t>(k)].y, false)
                        .sig.targets & cutTargets;
        });
        for (std::size_t k = 0; k < points.size(); ++k)
            for (std::uint64_t m = hits[k]; m != 0; m &= m - 1) {
                TargetAccumulator& a = out.targets[static_cast<std::size_t>(__builtin_ctzll(m))];
                a.outside = deep[k] ? std::numeric_limits<double>::infinity() : a.outside + 1.0 / 16.0;
            }
    }
    for (int j = 0; j < height; ++j) {
        for (std::size_t t = 0; t < nTargets; ++t) {
            const TargetAccumulator& r = rowSums[static_cast<std::size_t>(j) * nTargets + t];
            TargetAccumulator& a = out.targets[t];
            a.visible += r.visible;
            a.sumX += r.sumX;
            a.sumY += r.sumY;
            a.potential += r.potential;
            a.atBorder = a.atBorder || r.atBorder;
        }
        out.supersampled += rowSupersampled[static_cast<std::size_t>(j)];
        out.noInverse += rowNoInverse[static_cast<std::size_t>(j)];
    }
    const auto pixels = static_cast<std::uint64_t>(width) * static_cast<std::uint64_t>(height);
    out.rays = pixels + out.supersampled * static_cast<std::uint64_t>(n * n) +
               (adaptive ? static_cast<std::uint64_t>(width + 1) * static_cast<std::uint64_t>(height + 1) : 0);
    return out;
}

/// The radiance channel (0 red, 1 green, 2 blue: RGB) of the mosaic site (x, y).
int bayerChannel(BayerPattern pattern, int x, int y) { return 2 - bayerSiteColour(pattern, x, y); }

/// Strobe falloff, the sensor response and noise: radiance -> digital numbers.
cv::Mat digitize(const cv::Mat& radiance, const Scene& scene, const RenderOptions& options,
                 std::mt19937_64& rng) {
    const SensorFormat& f = options.sensor;
    const SensorNoise& sn = scene.sensor;
    const Strobe& strobe = scene.lighting.strobe;
    const double maxDn = std::ldexp(1.0, f.bitDepth) - 1.0;
    const bool readNoise = options.noise && sn.readNoiseDn > 0.0;
    const bool shotNoise = options.noise && sn.shotNoise;
    std::normal_distribution<double> gauss(0.0, 1.0);
    const int depth = f.bitDepth > 8 ? CV_16U : CV_8U;
    const bool colour = f.format == PixelFormat::Bgr;
    cv::Mat image(radiance.size(), CV_MAKETYPE(depth, colour ? 3 : 1));

    // Light reaching the pixel (strobe falloff included), relative to full well.
    auto signal = [&](double r, int channel, int x, int y) {
        double s = r * sn.exposure;
        if (strobe.enabled) {
            const double d = std::hypot(x - strobe.centrePx[0], y - strobe.centrePx[1]);
            const auto& ch = strobe.rgb[static_cast<std::size_t>(channel)];
            s *= ch.coefficient * std::exp(ch.exponent * d);
        }
        return s;
    };
    auto digital = [&](double s) {
        double electrons = s * sn.fullWellElectrons;
        if (shotNoise) electrons += std::sqrt(std::max(electrons, 0.0)) * gauss(rng);
        double dn = electrons / sn.fullWellElectrons * maxDn + sn.blackLevelDn;
        if (readNoise) dn += sn.readNoiseDn * gauss(rng);
        return std::clamp(std::round(dn), 0.0, maxDn);
    };
    auto store1 = [&](int x, int y, double v) {
        if (depth == CV_16U) image.at<std::uint16_t>(y, x) = static_cast<std::uint16_t>(v);
        else image.at<std::uint8_t>(y, x) = static_cast<std::uint8_t>(v);
    };
    for (int y = 0; y < radiance.rows; ++y) {
        const auto* in = radiance.ptr<cv::Vec3d>(y);
        for (int x = 0; x < radiance.cols; ++x) {
            switch (f.format) {
                case PixelFormat::Bayer: {
                    const int c = bayerChannel(f.bayerPattern, x, y);
                    store1(x, y, digital(signal(in[x][c], c, x, y)));
                    break;
                }
                case PixelFormat::Mono:  // a panchromatic pixel: the mean of the three bands
                    store1(x, y, digital((signal(in[x][0], 0, x, y) + signal(in[x][1], 1, x, y) +
                                          signal(in[x][2], 2, x, y)) / 3.0));
                    break;
                case PixelFormat::Bgr:
                    for (int c = 0; c < 3; ++c) {  // BGR order in the image
                        const double v = digital(signal(in[x][c], c, x, y));
                        if (depth == CV_16U) image.at<cv::Vec3w>(y, x)[2 - c] = static_cast<std::uint16_t>(v);
                        else image.at<cv::Vec3b>(y, x)[2 - c] = static_cast<std::uint8_t>(v);
                    }
                    break;
            }
        }
    }
    return image;
}

TargetView viewOf(const TargetAccumulator& a, const std::optional<cv::Point2d>& projected) {
    TargetView v;
    v.projectedCentrePx = projected;
    v.areaPx = a.visible;
    if (a.visible > 0.0) v.silhouetteCentroidPx = cv::Point2d(a.sumX / a.visible, a.sumY / a.visible);
    v.potentialAreaPx = a.potential;
    v.occluded = a.potential - a.visible > 1e-9 * std::max(1.0, a.potential);
    v.atBorder = a.atBorder;
    v.cut = a.cut;
    v.outsideAreaPx = a.outside;
    v.visibility = a.visible <= 0.0 ? TargetVisibility::None
                   : (v.occluded || v.cut) ? TargetVisibility::Partial
                                           : TargetVisibility::Full;
    return v;
}

}  // namespace

RenderResult render(const Scene& scene, const StereoSystemConfig& stereo, const RenderOptions& options) {
    const auto start = std::chrono::steady_clock::now();
    options.validate();
    validateScene(scene);

    const std::optional<RigidTransform> baseTVision = stereo.baseTVision ? stereo.baseTVision : scene.baseTVision;
    if (stereo.baseTVision && scene.baseTVision && !(*stereo.baseTVision == *scene.baseTVision))
        logger().notice("scene '%s': the stereo configuration's registration replaces the scene's",
                        scene.name.c_str());

    GroundTruth truth;
    truth.sceneName = scene.name;
    truth.seed = options.seed;
    truth.width = options.sensor.width;
    truth.height = options.sensor.height;
    truth.supersampling = options.supersampling;
    truth.adaptive = options.adaptive;
    truth.baseTVision = baseTVision;
    const World world = buildWorld(scene, baseTVision, truth.targets);

    const RigidTransform rTl = rightTLeft(stereo);
    const CameraRig leftRig{stereo.left, cv::Matx33d::eye(), cv::Vec3d(0, 0, 0)};
    const cv::Matx33d lRr = rotationMatrix(rTl).t();
    const cv::Vec3d t(rTl.translationMm[0], rTl.translationMm[1], rTl.translationMm[2]);
    const CameraRig rightRig{stereo.right, lRr, -(lRr * t)};

    const CameraRender left = renderCamera(world, leftRig, options);
    const CameraRender right = renderCamera(world, rightRig, options);

    for (std::size_t i = 0; i < truth.targets.size(); ++i) {
        TargetTruth& tt = truth.targets[i];
        tt.centreRightMm = transformPoint(rTl, tt.centreLeftMm);
        if (baseTVision) tt.centreBaseMm = transformPoint(*baseTVision, tt.centreLeftMm);
        tt.left = viewOf(left.targets[i], projectPoint(stereo.left, tt.centreLeftMm));
        tt.right = viewOf(right.targets[i], projectPoint(stereo.right, tt.centreRightMm));
    }
    if (world.board) {
        const Checkerboard& b = *world.board;
        CheckerboardTruth cb;
        cb.cornersX = b.squaresX - 1;
        cb.cornersY = b.squaresY - 1;
        cb.squareMm = b.squareMm;
        const RigidTransform leftTBoard = makeRigidTransform(rodrigues(b.om), b.positionMm);
        for (int y = 0; y < cb.cornersY; ++y)
            for (int x = 0; x < cb.cornersX; ++x) {
                const cv::Point3d p = transformPoint(leftTBoard, {x * b.squareMm, y * b.squareMm, 0.0});
                cb.cornersLeftMm.push_back(p);
                const auto l = projectPoint(stereo.left, p);
                const auto r = projectPoint(stereo.right, transformPoint(rTl, p));
                const cv::Point2d nan(std::nan(""), std::nan(""));
                cb.cornersLeftPx.push_back(l.value_or(nan));
                cb.cornersRightPx.push_back(r.value_or(nan));
            }
        truth.checkerboard = cb;
    }

    std::mt19937_64 rng(options.seed);
    cv::Mat leftImage = digitize(left.radiance, scene, options, rng);
    cv::Mat rightImage = digitize(right.radiance, scene, options, rng);
    PairLayout layout;
    layout.format = options.sensor.format;
    layout.bayerPattern = options.sensor.bayerPattern;
    layout.bitDepth = options.sensor.bitDepth;
    RenderResult result{StereoImagePair(leftImage, rightImage, layout), std::move(truth)};

    RenderStats& stats = result.truth.stats;
    stats.pixels = 2ull * static_cast<std::uint64_t>(options.sensor.width) *
                   static_cast<std::uint64_t>(options.sensor.height);
    stats.supersampledPixels = left.supersampled + right.supersampled;
    stats.rays = left.rays + right.rays;
    stats.raysWithoutInverse = left.noInverse + right.noInverse;
    stats.milliseconds =
        std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start).count();
    if (stats.raysWithoutInverse > 0)
        logger().warn("scene '%s': %llu samples fall outside the invertible lens distortion and are black",
                      scene.name.c_str(), static_cast<unsigned long long>(stats.raysWithoutInverse));
    logger().info("rendered scene '%s' %dx%d: %.1f ms, %llu of %llu pixels supersampled %dx%d, %llu rays",
                  scene.name.c_str(), options.sensor.width, options.sensor.height, stats.milliseconds,
                  static_cast<unsigned long long>(stats.supersampledPixels),
                  static_cast<unsigned long long>(stats.pixels), options.supersampling,
                  options.supersampling, static_cast<unsigned long long>(stats.rays));
    return result;
}

}  // namespace avatar::render
