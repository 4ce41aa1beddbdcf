#pragma once
// Accuracy measurement of the analysis pipeline on rendered scenes with exact
// ground truth: the scene sets, the association of reported targets with the
// truth, and the statistics. Shared by tests/analyze/AccuracyTest.cpp (a few
// scenes, asserted floors) and tests/bench/AccuracyReport.cpp (the full
// report). Method and results: docs/accuracy.md.

#include <avatar/analyze/AnalyzeStereoImagePair.h>
#include <avatar/common/CameraModel.h>
#include <avatar/common/VisionTargets.h>
#include <avatar/config/AvatarConfig.h>
#include <avatar/config/ConfigXml.h>
#include <avatar/render/Renderer.h>
#include <avatar/render/Scene.h>
#include <avatar/render/SceneSet.h>

#include <opencv2/core.hpp>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <filesystem>
#include <limits>
#include <optional>
#include <string>
#include <vector>

namespace avatar::accuracy {

/// Where lighting and noise of a set come from.
enum class Environment {
    Lab,     ///< lighted laboratory: makeSceneSet's random lamp, ambient and read noise (0-40 DN)
    Dark,    ///< lights off: lighting and sensor of data/scenes/darklab.xml
    Seabed,  ///< strobe, blue-green water: lighting, sensor and sand of data/scenes/seabed.xml
};

/// One evaluation set.
struct SetDefinition {
    std::string name;
    Environment environment{Environment::Lab};
    double minRangeMm{500.0};
    double maxRangeMm{1000.0};
    double minRadiusMm{20.0};
    double maxRadiusMm{45.0};
    std::string configFile;                  ///< relative to the data directory
    std::vector<render::TargetColour> colours;  ///< name = the config's target type
    /// Frame-average gains (R, G, B) that the "with lighting correction" run
    /// enables, on top of what the configuration already holds.
    std::optional<std::array<double, 3>> correctionGainsRgb;
    /// The configuration's own lighting correction is "with"; "without" turns it off.
    bool configHasCorrection{false};
};

inline const render::Rgb kYellow{0.92, 0.72, 0.04};   // the duck (scorpion.xml "sample")
inline const render::Rgb kGold{0.85, 0.46, 0.28};     // the arm marker's colour
inline const render::Rgb kSandDollar{0.8, 0.75, 0.62};

/// The standard sets of docs/accuracy.md.
inline std::vector<SetDefinition> standardSets() {
    std::vector<SetDefinition> sets;
    SetDefinition lab;
    lab.name = "lab";
    lab.configFile = "config/scorpion.xml";
    lab.colours = {{"sample", kYellow}, {"arm_marker", kGold}};
    sets.push_back(lab);

    SetDefinition wide = lab;
    wide.name = "wide";
    wide.maxRangeMm = 2500.0;
    sets.push_back(wide);

    SetDefinition dark = lab;
    dark.name = "dark";
    dark.environment = Environment::Dark;
    dark.maxRangeMm = 1500.0;
    dark.correctionGainsRgb = std::array<double, 3>{1.0 / 0.12, 1.0 / 0.12, 1.0 / 0.12};  // darknessFactor
    sets.push_back(dark);

    SetDefinition seabed;
    seabed.name = "seabed";
    seabed.environment = Environment::Seabed;
    seabed.minRangeMm = 1000.0;
    seabed.maxRangeMm = 2500.0;
    seabed.minRadiusMm = 30.0;
    seabed.maxRadiusMm = 50.0;
    seabed.configFile = "config/seabed.xml";
    seabed.colours = {{"sand_dollar", kSandDollar}};
    seabed.configHasCorrection = true;
    sets.push_back(seabed);
    return sets;
}

inline std::filesystem::path dataDir() { return AVATAR_DATA_DIR; }

/// The scenes of a set: makeSceneSet's layouts (1-8 targets, one near a
/// border, occluders in one camera, similar-colour distractor boxes, rocks),
/// without touching pairs (two touching same-colour spheres are one blob to
/// any colour segmentation), with every duck made a sphere or a disc so that
/// each target has a well-defined centre, and the set's lighting and noise.
inline std::vector<render::Scene> makeScenes(const SetDefinition& set, int count, std::uint64_t seed,
                                             const StereoSystemConfig& stereo, const render::SensorFormat& sensor) {
    render::SceneSetSpec spec;
    spec.count = count;
    spec.seed = seed;
    spec.minRangeMm = set.minRangeMm;
    spec.maxRangeMm = set.maxRangeMm;
    spec.minRadiusMm = set.minRadiusMm;
    spec.maxRadiusMm = set.maxRadiusMm;
    spec.colours = set.colours;
    spec.touchingProbability = 0.0;
    std::vector<render::Scene> scenes = render::makeSceneSet(spec, stereo, sensor, set.name);

    std::optional<render::Scene> environment;
    if (set.environment == Environment::Dark) environment = render::readSceneFile(dataDir() / "scenes/darklab.xml");
    if (set.environment == Environment::Seabed) environment = render::readSceneFile(dataDir() / "scenes/seabed.xml");
    for (std::size_t k = 0; k < scenes.size(); ++k) {
        render::Scene& s = scenes[k];
        for (std::size_t i = 0; i < s.targets.size(); ++i)
            if (s.targets[i].shape == render::Shape::Duck)
                s.targets[i].shape = (i + k) % 2 ? render::Shape::Sphere : render::Shape::Disc;
        if (environment) {
            s.lighting = environment->lighting;
            s.sensor = environment->sensor;
            if (set.environment == Environment::Seabed) {
                s.seabed.albedo = environment->seabed.albedo;
                s.seabed.textureContrast = environment->seabed.textureContrast;
            }
        }
    }
    return scenes;
}

/// The analysis configurations of a set.
struct SetConfigs {
    AvatarConfig centroid;       ///< as configured: every target's centroid triangulated
    AvatarConfig sphere;         ///< every type declared TargetShape::Sphere
    AvatarConfig uncorrected;    ///< centroid, lighting correction off
    bool hasCorrectionVariant{false};
};

inline SetConfigs makeConfigs(const SetDefinition& set) {
    SetConfigs c;
    c.centroid = readConfigFile(dataDir() / set.configFile);
    c.uncorrected = c.centroid;
    if (set.correctionGainsRgb) {
        c.centroid.lighting.frameAverageEnabled = true;
        c.centroid.lighting.gainsRgb = *set.correctionGainsRgb;
        c.hasCorrectionVariant = true;
    }
    if (set.configHasCorrection) {
        c.uncorrected.lighting.frameAverageEnabled = false;
        c.uncorrected.lighting.patternEnabled = false;
        c.hasCorrectionVariant = true;
    }
    c.sphere = c.centroid;
    for (auto& t : c.sphere.targets.targets) t.shape = TargetShape::Sphere;
    return c;
}

/// Smallest target counted in the recall: fully visible in both images and at
/// least 12 x 12 = 144 pixels in each.
constexpr double kMinRecallAreaPx = 144.0;

/// One ground-truth target and what the pipeline made of it.
struct TargetRecord {
    std::string scene;
    std::string name;
    std::string type;
    render::Shape shape{render::Shape::Sphere};
    double rangeMm{0.0};
    double areaLeftPx{0.0};
    bool fullyVisible{false};  ///< Full in both images, area >= kMinRecallAreaPx in both
    /// Its silhouette touches or overlaps, in either image, that of another
    /// target of its type or of a distractor of its colour: colour segmentation
    /// sees one blob. Counted apart from the recall.
    bool crowded{false};
    bool detected{false};      ///< a stereo target of its type associated with it in both images
    cv::Point3d truthMm;
    cv::Point3d measuredMm;
    double errorMm{0.0};
    bool shapeCorrected{false};
    double radialErrorMm() const {  // along the line of sight, + away from the camera
        const cv::Point3d u = truthMm * (1.0 / cv::norm(truthMm));
        return (measuredMm - truthMm).dot(u);
    }
};

/// What the pipeline reported on one scene, judged against the truth.
struct SceneOutcome {
    std::vector<TargetRecord> targets;  ///< one per truth target
    int stereoTargets{0};
    int wrongMatches{0};     ///< left and right centroids belong to different truth targets
    int spurious{0};         ///< a stereo target belonging to no truth target in one or both images
    int duplicates{0};       ///< a second stereo target on the same truth target
};

/// The truth target of @p type whose visible silhouette centroid is nearest to
/// @p px, within a gate of half its equivalent radius plus 2 px; -1 if none.
inline int associate(const render::GroundTruth& truth, const std::string& type, Side side, const cv::Point2d& px) {
    int best = -1;
    double bestDistance = std::numeric_limits<double>::infinity();
    for (std::size_t i = 0; i < truth.targets.size(); ++i) {
        const render::TargetTruth& t = truth.targets[i];
        const render::TargetView& view = side == Side::Left ? t.left : t.right;
        if (t.type != type || !view.silhouetteCentroidPx) continue;
        const double gate = 0.5 * std::sqrt(view.areaPx / M_PI) + 2.0;
        const double d = cv::norm(*view.silhouetteCentroidPx - px);
        if (d <= gate && d < bestDistance) {
            bestDistance = d;
            best = static_cast<int>(i);
        }
    }
    return best;
}

/// A disc in the image that holds the silhouette of a ball of @p radiusMm
/// centred at @p centreMm of a camera (generous: 1.25 x the on-axis radius + 2 px).
struct ImageDisc {
    cv::Point2d centrePx;
    double radiusPx{0.0};
};
inline std::optional<ImageDisc> imageDisc(const CameraIntrinsics& camera, const cv::Point3d& centreMm, double radiusMm) {
    if (centreMm.z <= radiusMm) return std::nullopt;
    const auto px = projectPoint(camera, centreMm);
    if (!px) return std::nullopt;
    return ImageDisc{*px, 1.25 * camera.fc[0] * radiusMm / centreMm.z + 2.0};
}

/// Marks the targets whose silhouettes may merge with another of their colour (see TargetRecord::crowded).
inline void markCrowded(std::vector<TargetRecord>& records, const render::Scene& scene, const StereoSystemConfig& stereo) {
    struct Blob {
        std::string colour;  // target type, or the colour a distractor imitates
        cv::Point3d centreMm;
        double radiusMm;
        int target;  // index into scene.targets, -1 for a distractor
    };
    std::vector<Blob> blobs;
    for (std::size_t i = 0; i < scene.targets.size(); ++i) {
        const auto& t = scene.targets[i];
        blobs.push_back({t.type, cv::Point3d(t.centreMm), t.radiusMm, static_cast<int>(i)});
    }
    const std::string prefix = "distractor_";
    for (const auto& o : scene.occluders)
        if (o.name.rfind(prefix, 0) == 0)
            blobs.push_back({o.name.substr(prefix.size()), cv::Point3d(o.centreMm), cv::norm(o.halfSizeMm), -1});
    const RigidTransform rTl = rightTLeft(stereo);
    for (const Blob& a : blobs) {
        if (a.target < 0 || static_cast<std::size_t>(a.target) >= records.size()) continue;
        for (const Blob& b : blobs) {
            if (&a == &b || a.colour != b.colour) continue;
            for (int side = 0; side < 2; ++side) {
                const CameraIntrinsics& cam = side == 0 ? stereo.left : stereo.right;
                const auto da = imageDisc(cam, side == 0 ? a.centreMm : transformPoint(rTl, a.centreMm), a.radiusMm);
                const auto db = imageDisc(cam, side == 0 ? b.centreMm : transformPoint(rTl, b.centreMm), b.radiusMm);
                if (da && db && cv::norm(da->centrePx - db->centrePx) < da->radiusPx + db->radiusPx)
                    records[static_cast<std::size_t>(a.target)].crowded = true;
            }
        }
    }
}

/// The record of truth target @p t of @p truth, nothing detected yet.
inline TargetRecord truthRecord(const render::GroundTruth& truth, const render::TargetTruth& t) {
    TargetRecord r;
    r.scene = truth.sceneName;
    r.name = t.name;
    r.type = t.type;
    r.shape = t.shape;
    r.truthMm = t.centreLeftMm;
    r.rangeMm = cv::norm(t.centreLeftMm);
    r.areaLeftPx = t.left.areaPx;
    r.fullyVisible = t.left.visibility == render::TargetVisibility::Full &&
                     t.right.visibility == render::TargetVisibility::Full && t.left.areaPx >= kMinRecallAreaPx &&
                     t.right.areaPx >= kMinRecallAreaPx;
    return r;
}

/// Judges what the pipeline reported on a rendered scene. @p scene (the one
/// rendered, targets in the truth's order) marks crowded targets when given.
inline SceneOutcome judge(const VisionTargets& result, const render::GroundTruth& truth,
                          const render::Scene* scene = nullptr, const StereoSystemConfig* stereo = nullptr) {
    SceneOutcome out;
    for (const auto& t : truth.targets) out.targets.push_back(truthRecord(truth, t));
    if (scene && stereo) markCrowded(out.targets, *scene, *stereo);
    for (const VisionTarget& v : result.targets) {
        if (!(v.flags & kTargetStereo) || !v.positionVisionMm) continue;
        ++out.stereoTargets;
        const int l = associate(truth, v.type, Side::Left, *v.centroidLeftPx);
        const int r = associate(truth, v.type, Side::Right, *v.centroidRightPx);
        if (l < 0 || r < 0) {
            ++out.spurious;
            continue;
        }
        if (l != r) {
            ++out.wrongMatches;
            continue;
        }
        TargetRecord& rec = out.targets[static_cast<std::size_t>(l)];
        if (rec.detected) {
            ++out.duplicates;
            continue;
        }
        rec.detected = true;
        rec.measuredMm = *v.positionVisionMm;
        rec.errorMm = cv::norm(rec.measuredMm - rec.truthMm);
        rec.shapeCorrected = (v.flags & kTargetShapeCorrected) != 0;
    }
    return out;
}

/// Quantile by linear interpolation (q in [0, 1]); NaN for no values.
inline double quantile(std::vector<double> v, double q) {
    if (v.empty()) return std::numeric_limits<double>::quiet_NaN();
    std::sort(v.begin(), v.end());
    const double pos = q * static_cast<double>(v.size() - 1);
    const auto i = static_cast<std::size_t>(pos);
    const double f = pos - static_cast<double>(i);
    return i + 1 < v.size() ? v[i] * (1.0 - f) + v[i + 1] * f : v[i];
}

struct ErrorStats {
    std::size_t n{0};
    double medianMm{NAN}, p95Mm{NAN}, maxMm{NAN};
    double medianPercent{NAN}, p95Percent{NAN};
    double meanRadialPercent{NAN};  ///< mean signed error along the line of sight, % of range
};

inline ErrorStats errorStats(const std::vector<TargetRecord>& records) {
    std::vector<double> mm, percent;
    double radial = 0.0;
    for (const auto& r : records) {
        mm.push_back(r.errorMm);
        percent.push_back(100.0 * r.errorMm / r.rangeMm);
        radial += 100.0 * r.radialErrorMm() / r.rangeMm;
    }
    ErrorStats s;
    s.n = mm.size();
    if (mm.empty()) return s;
    s.medianMm = quantile(mm, 0.5);
    s.p95Mm = quantile(mm, 0.95);
    s.maxMm = *std::max_element(mm.begin(), mm.end());
    s.medianPercent = quantile(percent, 0.5);
    s.p95Percent = quantile(percent, 0.95);
    s.meanRadialPercent = radial / static_cast<double>(mm.size());
    return s;
}

/// Spread of repeated measurements of one target.
struct Spread {
    std::size_t n{0};
    cv::Point3d sigmaMm;  ///< sample standard deviation per axis (x, y, z of the left camera)
    double magnitudeMm() const { return cv::norm(sigmaMm); }
};

inline Spread spread(const std::vector<cv::Point3d>& points) {
    Spread s;
    s.n = points.size();
    if (points.size() < 2) return s;
    cv::Point3d mean(0, 0, 0);
    for (const auto& p : points) mean += p;
    mean *= 1.0 / static_cast<double>(points.size());
    cv::Point3d var(0, 0, 0);
    for (const auto& p : points) {
        const cv::Point3d d = p - mean;
        var += cv::Point3d(d.x * d.x, d.y * d.y, d.z * d.z);
    }
    var *= 1.0 / static_cast<double>(points.size() - 1);
    s.sigmaMm = {std::sqrt(var.x), std::sqrt(var.y), std::sqrt(var.z)};
    return s;
}

/// The precision scene (thesis 6.1.3: a stationary target measured again and
/// again): lab lighting and noise of data/scenes/lab.xml, yellow spheres and
/// discs at 0.65-0.95 m spread over the image.
inline render::Scene precisionScene() {
    const render::Scene lab = render::readSceneFile(dataDir() / "scenes/lab.xml");
    render::Scene s;
    s.name = "precision";
    s.seabed = lab.seabed;
    s.lighting = lab.lighting;
    s.sensor = lab.sensor;
    struct Placement {
        render::Shape shape;
        cv::Vec3d centreMm;
        double radiusMm;
    };
    const Placement placements[] = {
        {render::Shape::Sphere, {-180, -120, 650}, 25}, {render::Shape::Disc, {120, -140, 700}, 25},
        {render::Shape::Sphere, {20, 20, 800}, 30},     {render::Shape::Disc, {-250, 150, 850}, 30},
        {render::Shape::Sphere, {200, 130, 900}, 35},   {render::Shape::Sphere, {-60, 240, 900}, 20},
    };
    int k = 0;
    for (const auto& p : placements) {
        render::TargetSpec t;
        t.name = "p" + std::to_string(++k);
        t.type = "sample";
        t.shape = p.shape;
        t.centreMm = p.centreMm;
        t.radiusMm = p.radiusMm;
        t.albedo = kYellow;
        s.targets.push_back(t);
    }
    return s;
}

/// The truth target (any type) whose visible silhouette centroid is nearest
/// to @p px within half its equivalent radius + 2 px; -1 if none.
inline int nearestTruth(const render::GroundTruth& truth, Side side, const cv::Point2d& px) {
    int best = -1;
    double bestD = std::numeric_limits<double>::max();
    for (std::size_t i = 0; i < truth.targets.size(); ++i) {
        const render::TargetView& v = side == Side::Left ? truth.targets[i].left : truth.targets[i].right;
        if (!v.silhouetteCentroidPx) continue;
        const double d = cv::norm(*v.silhouetteCentroidPx - px);
        if (d <= 0.5 * std::sqrt(v.areaPx / CV_PI) + 2.0 && d < bestD) {
            bestD = d;
            best = static_cast<int>(i);
        }
    }
    return best;
}

/// One target's predicted position sigma against its spread over noise seeds.
struct SigmaCheck {
    std::string name;
    render::Shape shape{render::Shape::Sphere};
    std::size_t n{0};          ///< noise seeds it was found whole in
    cv::Point3d measuredMm;    ///< standard deviation over the seeds per axis (left camera frame)
    cv::Point3d predictedMm;   ///< RMS of the predicted sigmas (covarianceVisionMm2's diagonal)
    cv::Point3d ratio() const {
        return {measuredMm.x / predictedMm.x, measuredMm.y / predictedMm.y, measuredMm.z / predictedMm.z};
    }
};

/// @p scene rendered with @p seeds' noise and analysed with scorpion.xml,
/// every type declared @p declared: per target found whole, the spread of
/// its positions against the covariance the analysis predicted.
inline std::vector<SigmaCheck> sigmaOverNoiseSeeds(const std::vector<std::uint64_t>& seeds,
                                                   const render::Scene& scene, TargetShape declared) {
    AvatarConfig config = readConfigFile(dataDir() / "config/scorpion.xml");
    for (auto& t : config.targets.targets) t.shape = declared;
    AnalyzeStereoImagePair analysis(config);
    render::RenderOptions options;
    options.sensor = render::sensorFormatFrom(config.camera);
    std::vector<std::vector<cv::Point3d>> points(scene.targets.size());
    std::vector<cv::Point3d> variance(scene.targets.size(), cv::Point3d(0, 0, 0));
    std::vector<render::Shape> shapes(scene.targets.size());
    for (std::size_t k = 0; k < seeds.size(); ++k) {
        options.seed = seeds[k];
        const render::RenderResult rr = render::render(scene, config.stereo, options);
        const VisionTargets result = analysis.analyze(rr.pair, k);
        for (const VisionTarget& v : result.targets) {
            if (!(v.flags & kTargetWhole) || !v.covarianceVisionMm2 || !v.positionVisionMm) continue;
            const int i = nearestTruth(rr.truth, Side::Left, *v.centroidLeftPx);
            if (i < 0) continue;
            const auto u = static_cast<std::size_t>(i);
            shapes[u] = rr.truth.targets[u].shape;
            points[u].push_back(*v.positionVisionMm);
            const auto& c = *v.covarianceVisionMm2;
            variance[u] += cv::Point3d(c(0, 0), c(1, 1), c(2, 2));
        }
    }
    std::vector<SigmaCheck> out;
    for (std::size_t i = 0; i < points.size(); ++i) {
        if (points[i].size() < 2) continue;
        SigmaCheck c;
        c.name = scene.targets[i].name;
        c.shape = shapes[i];
        c.n = points[i].size();
        c.measuredMm = spread(points[i]).sigmaMm;
        const cv::Point3d var = variance[i] * (1.0 / static_cast<double>(c.n));
        c.predictedMm = {std::sqrt(var.x), std::sqrt(var.y), std::sqrt(var.z)};
        out.push_back(c);
    }
    return out;
}

/// The precision scene's check (above), its targets @p rangeScale times as
/// far: declared a sphere, spheres take the sphere model and the tilted
/// discs the disc model; unknown, every target is placed by its centroids.
inline std::vector<SigmaCheck> sigmaOverNoiseSeeds(const std::vector<std::uint64_t>& seeds,
                                                   TargetShape declared = TargetShape::Sphere,
                                                   double rangeScale = 1.0) {
    render::Scene scene = precisionScene();
    for (auto& t : scene.targets) t.centreMm *= rangeScale;
    return sigmaOverNoiseSeeds(seeds, scene, declared);
}

/// The sphere-bias scene: one large sphere near and far off the optical axis
/// (towards the top-right corner of the left image, so that the right camera,
/// a baseline to the right, sees it whole too), the case where its silhouette
/// centroid is furthest from the projection of its centre.
inline render::Scene sphereBiasScene(double rangeMm = 500.0, double radiusMm = 45.0) {
    const render::Scene lab = render::readSceneFile(dataDir() / "scenes/lab.xml");
    render::Scene s;
    s.name = "sphere_bias";
    s.seabed = lab.seabed;
    s.seabed.tiltDeg = 0.0;
    s.seabed.distanceMm = 3000.0;  // behind the sphere at every range
    s.lighting = lab.lighting;
    s.sensor = lab.sensor;
    render::TargetSpec t;
    t.name = "ball";
    t.type = "sample";
    t.shape = render::Shape::Sphere;
    // Direction of pixel ~(1090, 185) of the left camera: 27 degrees off axis.
    const cv::Vec3d d(0.36, -0.36, 1.0);
    t.centreMm = d * (rangeMm / cv::norm(d));
    t.radiusMm = radiusMm;
    t.albedo = kYellow;
    s.targets.push_back(t);
    return s;
}

}  // namespace avatar::accuracy
