// lamp_bias_report: how far the lamp's position moves a sphere's measured
// centre (docs/accuracy.md "What limits accuracy now": the spheres' depth
// bias). A grid of 15 yellow spheres (25 mm, 3 x 5, spread over the image at
// one range, each jittered by up to 8 mm across and 20 mm in depth per
// repeat, so that the edges fall at every sub-pixel phase) is rendered with
// the lamp at each of four places and analysed with scorpion.xml, every
// type declared a sphere and then without a model:
//   ambient  no lamp (ambient light only: the limb as bright as the face)
//   left     at the left camera (the scene sets' default)
//   right    at the right camera
//   above    400 mm above the middle of the baseline
// Per placement: the median error of the sphere model's centre against the
// projection of the true centre (x and y per view, px), of the sub-pixel
// silhouette's centroid without a model against the true silhouette's, of the
// silhouette's equivalent radius sqrt(area / pi), and the median signed
// depth error of the sphere model (mm). Noise-free by default, so that what
// is left is the estimator's own bias.
//
//   lamp_bias_report [--range MM] [--repeats N] [--noise DN] [--bgr] [--edge-aware]
//                    (--bgr: colour pixels rendered directly, no Bayer mosaic or demosaic;
//                     --edge-aware: the analysis's edge-aware demosaic instead of the bilinear)

#include "../analyze/AccuracyHarness.h"

#include <avatar/analyze/AnalyzeStereoImagePair.h>
#include <avatar/common/CameraModel.h>
#include <avatar/common/RigidTransform.h>
#include <avatar/config/ConfigXml.h>
#include <avatar/render/Renderer.h>

#include <opencv2/core.hpp>

#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <exception>
#include <string>
#include <vector>

using namespace avatar;
using namespace avatar::accuracy;

namespace {

struct Options {
    double rangeMm{1000.0};
    int repeats{20};
    double noiseDn{0.0};
    bool bgr{false};
    DemosaicAlgorithm demosaic{DemosaicAlgorithm::Bilinear};
};

struct Placement {
    const char* name;
    bool lamp;
    cv::Vec3d positionMm;
};

struct Errors {
    std::vector<double> modelXL, modelYL, modelXR, modelYR, dz;
    std::vector<double> centroidXL, centroidXR, radiusL, radiusR;
    std::vector<double> disparityByColumn[5];  ///< the sphere model's, per grid column (left to right)
};

cv::Point2d project(const CameraIntrinsics& c, const cv::Point3d& p) {
    return normalizedToPixel(c, distortNormalized(c, cv::Point2d(p.x / p.z, p.y / p.z)));
}

render::Scene gridScene(const render::Scene& lab, const Placement& lamp, const Options& o, std::uint64_t repeat) {
    render::Scene s;
    s.name = "lamp_bias";
    s.seabed = lab.seabed;
    s.seabed.tiltDeg = 0.0;
    s.seabed.distanceMm = o.rangeMm + 2500.0;
    s.sensor = lab.sensor;
    s.sensor.readNoiseDn = o.noiseDn;
    s.sensor.shotNoise = o.noiseDn > 0.0;
    if (lamp.lamp) {
        s.lighting.ambient = {0.3, 0.3, 0.3};
        s.lighting.lightIntensity = {0.5, 0.5, 0.5};
        s.lighting.lightPositionMm = lamp.positionMm;
    } else {
        s.lighting.ambient = {0.8, 0.8, 0.8};
        s.lighting.lightIntensity = {0.0, 0.0, 0.0};
    }
    cv::RNG jitter(repeat * 7919 + 1);
    int k = 0;
    for (int iy = -1; iy <= 1; ++iy)
        for (int ix = -2; ix <= 2; ++ix) {
            render::TargetSpec t;
            t.name = "ball" + std::to_string(++k);
            t.type = "sample";
            t.shape = render::Shape::Sphere;
            // About the baseline's middle, so both cameras see every one.
            t.centreMm = cv::Vec3d(ix * 0.18 * o.rangeMm + 53.0 + jitter.uniform(-8.0, 8.0),
                                   iy * 0.18 * o.rangeMm + jitter.uniform(-8.0, 8.0),
                                   o.rangeMm + jitter.uniform(-20.0, 20.0));
            t.radiusMm = 25.0;
            t.albedo = kYellow;
            s.targets.push_back(t);
        }
    return s;
}

/// Renders and analyses every repeat with @p declared; adds what it finds whole to @p e.
void measure(const Placement& lamp, const Options& o, TargetShape declared, Errors& e) {
    AvatarConfig config = readConfigFile(dataDir() / "config/scorpion.xml");
    if (o.bgr) {
        config.camera.channels = 3;
        config.camera.bayer = false;
    }
    config.analysis.demosaic = o.demosaic;
    // Without a model, the centroid of the sub-pixel silhouette (scorpion.xml
    // triangulates the mask's mean pixel position).
    config.analysis.centroid = CentroidMode::Coverage;
    for (auto& t : config.targets.targets) t.shape = declared;
    AnalyzeStereoImagePair analysis(config);
    render::RenderOptions options;
    options.sensor = render::sensorFormatFrom(config.camera);
    options.noise = o.noiseDn > 0.0;
    const render::Scene lab = render::readSceneFile(dataDir() / "scenes/lab.xml");
    for (int r = 0; r < o.repeats; ++r) {
        options.seed = static_cast<std::uint64_t>(r + 1);
        const render::RenderResult rr =
            render::render(gridScene(lab, lamp, o, static_cast<std::uint64_t>(r)), config.stereo, options);
        const VisionTargets result = analysis.analyze(rr.pair, static_cast<std::uint64_t>(r));
        for (const VisionTarget& v : result.targets) {
            if (!(v.flags & kTargetWhole) || !v.positionVisionMm || !v.centroidLeftPx || !v.centroidRightPx) continue;
            const int i = nearestTruth(rr.truth, Side::Left, *v.centroidLeftPx);
            if (i < 0) continue;
            const render::TargetTruth& t = rr.truth.targets[static_cast<std::size_t>(i)];
            if (!t.left.silhouetteCentroidPx || !t.right.silhouetteCentroidPx) continue;
            if (declared == TargetShape::Sphere) {
                if (v.model != ShapeModel::Sphere) continue;  // placed by its centroids: not the model's
                const cv::Point2d l = project(config.stereo.left, t.centreLeftMm);
                const cv::Point2d rt = project(config.stereo.right, t.centreRightMm);
                e.modelXL.push_back(v.centroidLeftPx->x - l.x);
                e.modelYL.push_back(v.centroidLeftPx->y - l.y);
                e.modelXR.push_back(v.centroidRightPx->x - rt.x);
                e.modelYR.push_back(v.centroidRightPx->y - rt.y);
                e.dz.push_back(v.positionVisionMm->z - t.centreLeftMm.z);
                const int column = (std::atoi(t.name.c_str() + 4) - 1) % 5;  // "ballN", row by row
                e.disparityByColumn[column].push_back((v.centroidLeftPx->x - l.x) - (v.centroidRightPx->x - rt.x));
            } else {
                e.centroidXL.push_back(v.centroidLeftPx->x - t.left.silhouetteCentroidPx->x);
                e.centroidXR.push_back(v.centroidRightPx->x - t.right.silhouetteCentroidPx->x);
                e.radiusL.push_back(std::sqrt(v.areaLeftPx / CV_PI) - std::sqrt(t.left.areaPx / CV_PI));
                e.radiusR.push_back(std::sqrt(v.areaRightPx / CV_PI) - std::sqrt(t.right.areaPx / CV_PI));
            }
        }
    }
}

void usage() {
    std::fprintf(stderr, "usage: lamp_bias_report [--range MM] [--repeats N] [--noise DN] [--bgr] [--edge-aware]\n");
}

}  // namespace

int main(int argc, char** argv) {
    Options o;
    for (int i = 1; i < argc; ++i) {
        const std::string a = argv[i];
        const auto value = [&]() -> const char* {
            if (i + 1 >= argc) {
                usage();
                std::exit(2);
            }
            return argv[++i];
        };
        if (a == "--range") o.rangeMm = std::atof(value());
        else if (a == "--repeats") o.repeats = std::atoi(value());
        else if (a == "--noise") o.noiseDn = std::atof(value());
        else if (a == "--bgr") o.bgr = true;
        else if (a == "--edge-aware") o.demosaic = DemosaicAlgorithm::EdgeAware;
        else {
            usage();
            return a == "--help" || a == "-h" ? 0 : 2;
        }
    }
    if (!(o.rangeMm >= 400.0 && o.rangeMm <= 3000.0) || o.repeats < 1 || !(o.noiseDn >= 0.0)) {
        usage();
        return 2;
    }
    try {
        const StereoSystemConfig stereo = readConfigFile(dataDir() / "config/scorpion.xml").stereo;
        const cv::Point3d right = transformPoint(inverse(rightTLeft(stereo)), {0, 0, 0});  // left camera frame
        const Placement placements[] = {{"ambient", false, {0, 0, 0}},
                                        {"left", true, {0, 0, 0}},
                                        {"right", true, cv::Vec3d(right.x, right.y, right.z)},
                                        {"above", true, cv::Vec3d(0.5 * right.x, 0.5 * right.y - 400.0, 0.5 * right.z)}};
        std::printf("15 yellow spheres of 25 mm at %.0f mm, %d repeats, read noise %.1f DN, %s\n\n", o.rangeMm,
                    o.repeats, o.noiseDn, o.bgr ? "colour pixels (no mosaic)"
                    : o.demosaic == DemosaicAlgorithm::EdgeAware ? "Bayer mosaic, edge-aware demosaic"
                                                                 : "Bayer mosaic, bilinear demosaic");
        std::printf("Medians (px; depth mm). Sphere model: centre against the true centre's projection; "
                    "no model: silhouette centroid and equivalent radius against the true silhouette's.\n\n");
        std::printf("| lamp    |   n | model xL | model yL | model xR | model yR | depth mm |   n | centroid xL | "
                    "centroid xR | radius L | radius R |\n");
        std::printf("|---------|-----|----------|----------|----------|----------|----------|-----|-------------|"
                    "-------------|----------|----------|\n");
        const auto med = [](const std::vector<double>& v) { return quantile(v, 0.5); };
        std::vector<Errors> all;
        for (const Placement& p : placements) {
            Errors& e = all.emplace_back();
            measure(p, o, TargetShape::Sphere, e);
            measure(p, o, TargetShape::None, e);
            std::printf("| %-7s | %3zu | %8.4f | %8.4f | %8.4f | %8.4f | %8.3f | %3zu | %11.4f | %11.4f | %8.4f | "
                        "%8.4f |\n",
                        p.name, e.dz.size(), med(e.modelXL), med(e.modelYL), med(e.modelXR), med(e.modelYR),
                        med(e.dz), e.centroidXL.size(), med(e.centroidXL), med(e.centroidXR), med(e.radiusL),
                        med(e.radiusR));
        }
        std::printf("\nThe sphere model's disparity error (median, px) by the grid's column, left to right:\n\n");
        std::printf("| lamp    | column 1 | column 2 | column 3 | column 4 | column 5 |\n");
        std::printf("|---------|----------|----------|----------|----------|----------|\n");
        for (std::size_t k = 0; k < all.size(); ++k) {
            std::printf("| %-7s |", placements[k].name);
            for (const auto& column : all[k].disparityByColumn) std::printf(" %8.4f |", med(column));
            std::printf("\n");
        }
    } catch (const std::exception& e) {
        std::fprintf(stderr, "lamp_bias_report: %s\n", e.what());
        return 1;
    }
    return 0;
}
