// Accuracy regression on rendered scenes with exact ground truth (the floors
// of docs/accuracy.md on a few seeded scenes; the full report is
// tests/bench/accuracy_report). Scorpion calibration, 1280x960 16-bit Bayer BG
// with read and shot noise, data/config/scorpion.xml and seabed.xml as shipped.

#include "AccuracyHarness.h"

#include <avatar/analyze/AnalyzeStereoImagePair.h>
#include <avatar/config/ConfigXml.h>
#include <avatar/render/Renderer.h>

#include <gtest/gtest.h>

#include <array>

using namespace avatar;
using namespace avatar::accuracy;

namespace {

struct Fixture {
    AvatarConfig scorpion = readConfigFile(dataDir() / "config/scorpion.xml");
    render::SensorFormat sensor = render::sensorFormatFrom(scorpion.camera);
    SetConfigs configs = makeConfigs(standardSets().front());

    render::RenderResult renderScene(const render::Scene& scene, std::uint64_t seed) const {
        render::RenderOptions options;
        options.sensor = sensor;
        options.seed = seed;
        return render::render(scene, scorpion.stereo, options);
    }
};

}  // namespace

// Six lab scenes (0.5-1.0 m, spheres and discs, distractors, occluders, targets
// at the border): every isolated fully visible target found, no wrong match,
// and the 3-D error of the shape-known measurement within the floors
// (median <= 1.5 mm, p95 <= 4 mm). Measured: median ~0.5 mm, p95 ~1.4 mm.
TEST(Accuracy, LabScenesMeetTheFloors) {
    const Fixture f;
    const SetDefinition lab = standardSets().front();
    ASSERT_EQ(lab.name, "lab");
    const auto scenes = makeScenes(lab, 6, 1, f.scorpion.stereo, f.sensor);
    AnalyzeStereoImagePair centroid(f.configs.centroid), sphere(f.configs.sphere);
    std::vector<TargetRecord> known;
    std::vector<double> sphereCentroidBias, sphereCorrectedBias;
    int full = 0, found = 0, wrong = 0;
    for (std::size_t k = 0; k < scenes.size(); ++k) {
        const auto rr = f.renderScene(scenes[k], 1000 + k);
        const auto c = judge(centroid.analyze(rr.pair, k), rr.truth, &scenes[k], &f.scorpion.stereo);
        const auto s = judge(sphere.analyze(rr.pair, k), rr.truth, &scenes[k], &f.scorpion.stereo);
        wrong += c.wrongMatches + s.wrongMatches;
        for (std::size_t i = 0; i < c.targets.size(); ++i) {
            const bool isSphere = c.targets[i].shape == render::Shape::Sphere;
            const TargetRecord& t = isSphere ? s.targets[i] : c.targets[i];
            if (!t.fullyVisible || t.crowded) continue;
            ++full;
            if (!t.detected) {
                ADD_FAILURE() << "missed " << t.scene << "/" << t.name << " at " << t.rangeMm << " mm";
                continue;
            }
            ++found;
            known.push_back(t);
            if (isSphere && c.targets[i].detected) {
                EXPECT_TRUE(t.shapeCorrected) << t.scene << "/" << t.name;
                sphereCentroidBias.push_back(c.targets[i].radialErrorMm() / t.rangeMm);
                sphereCorrectedBias.push_back(t.radialErrorMm() / t.rangeMm);
            }
        }
    }
    EXPECT_EQ(wrong, 0);
    ASSERT_GE(full, 15);
    EXPECT_EQ(found, full);
    const ErrorStats e = errorStats(known);
    RecordProperty("median_mm", std::to_string(e.medianMm));
    EXPECT_LE(e.medianMm, 1.5);
    EXPECT_LE(e.p95Mm, 4.0);
    EXPECT_LE(e.medianPercent, 0.3);
    // Centroid triangulation pulls spheres towards the camera (measured
    // -0.25% of range on average here); the shape correction removes most of it.
    ASSERT_GE(sphereCentroidBias.size(), 5u);
    double meanCentroid = 0, meanCorrected = 0;
    for (std::size_t i = 0; i < sphereCentroidBias.size(); ++i) {
        meanCentroid += sphereCentroidBias[i] / static_cast<double>(sphereCentroidBias.size());
        meanCorrected += sphereCorrectedBias[i] / static_cast<double>(sphereCorrectedBias.size());
    }
    EXPECT_LT(meanCentroid, -0.0015);
    EXPECT_LT(std::abs(meanCorrected), 0.5 * std::abs(meanCentroid));
}

// Eight seabed scenes (1.0-2.5 m, strobe falloff, blue-green water, sand,
// rocks; data/config/seabed.xml with its strobe correction): every isolated
// fully visible sand dollar found, no wrong match, no more spurious reports
// than the scenes hold distractor boxes (the target's colour by design; grey
// rocks must not pass the filter), and the 3-D error within the wide-range
// floor (median <= 0.3% of range). Measured: 32 of 32 found, 1 spurious
// (5 distractor boxes), median 0.11% (1.8 mm), p95 0.44% of range. Before the
// scene's exposure was lowered so that near sand dollars no longer clip (and
// the filter no longer had to admit white, hence grey rocks): 6 spurious.
// Without the strobe correction the sand dollars away from the image centre
// fail the filter (the strobe takes red away fastest there): 12 of 32 found.
TEST(Accuracy, SeabedScenesMeetTheFloors) {
    const Fixture f;
    SetDefinition seabed;
    for (const SetDefinition& s : standardSets())
        if (s.name == "seabed") seabed = s;
    ASSERT_EQ(seabed.name, "seabed");
    const SetConfigs configs = makeConfigs(seabed);
    ASSERT_TRUE(configs.centroid.lighting.patternEnabled);
    ASSERT_FALSE(configs.uncorrected.lighting.patternEnabled);
    const auto scenes = makeScenes(seabed, 8, 1, f.scorpion.stereo, f.sensor);
    AnalyzeStereoImagePair centroid(configs.centroid), sphere(configs.sphere), uncorrected(configs.uncorrected);
    std::vector<TargetRecord> known;
    int full = 0, found = 0, foundUncorrected = 0, wrong = 0, spurious = 0, distractors = 0;
    for (std::size_t k = 0; k < scenes.size(); ++k) {
        for (const auto& o : scenes[k].occluders) distractors += o.name.rfind("distractor_", 0) == 0;
        const auto rr = f.renderScene(scenes[k], 2000 + k);
        const auto c = judge(centroid.analyze(rr.pair, k), rr.truth, &scenes[k], &f.scorpion.stereo);
        const auto s = judge(sphere.analyze(rr.pair, k), rr.truth, &scenes[k], &f.scorpion.stereo);
        const auto u = judge(uncorrected.analyze(rr.pair, k), rr.truth, &scenes[k], &f.scorpion.stereo);
        wrong += c.wrongMatches + s.wrongMatches + u.wrongMatches;
        spurious += c.spurious;
        for (std::size_t i = 0; i < c.targets.size(); ++i) {
            const TargetRecord& t = c.targets[i].shape == render::Shape::Sphere ? s.targets[i] : c.targets[i];
            if (!t.fullyVisible || t.crowded) continue;
            ++full;
            foundUncorrected += u.targets[i].detected;
            if (!t.detected) {
                ADD_FAILURE() << "missed " << t.scene << "/" << t.name << " at " << t.rangeMm << " mm";
                continue;
            }
            ++found;
            known.push_back(t);
        }
    }
    EXPECT_EQ(wrong, 0);
    EXPECT_LE(spurious, distractors);
    ASSERT_GE(full, 25);
    EXPECT_EQ(found, full);
    EXPECT_LT(foundUncorrected, found);
    const ErrorStats e = errorStats(known);
    RecordProperty("found", std::to_string(found) + "/" + std::to_string(full));
    RecordProperty("found_without_lighting_correction", std::to_string(foundUncorrected));
    RecordProperty("spurious", std::to_string(spurious) + " (" + std::to_string(distractors) + " distractor boxes)");
    RecordProperty("median_mm", std::to_string(e.medianMm));
    RecordProperty("median_percent", std::to_string(e.medianPercent));
    RecordProperty("p95_percent", std::to_string(e.p95Percent));
    EXPECT_LE(e.medianPercent, 0.3);
    EXPECT_LE(e.p95Percent, 0.8);
}

// A sphere of 45 mm radius 0.5 m away, 27 degrees off axis: its silhouette
// centroid is ~6 px from the projection of its centre. Centroid triangulation
// puts it ~4.7 mm (0.8% of range) towards the camera; the silhouette-cone
// correction brings it within ~0.2 mm.
TEST(Accuracy, ShapeCorrectionRemovesTheSphereSilhouetteBias) {
    const Fixture f;
    const render::Scene scene = sphereBiasScene(500.0, 45.0);
    AnalyzeStereoImagePair centroid(f.configs.centroid), sphere(f.configs.sphere);
    for (std::uint64_t seed : {11u}) {
        const auto rr = f.renderScene(scene, seed);
        const auto& truth = rr.truth.targets.at(0);
        ASSERT_EQ(truth.left.visibility, render::TargetVisibility::Full);
        ASSERT_EQ(truth.right.visibility, render::TargetVisibility::Full);
        // The physics: the silhouette centroid is not the projected centre.
        EXPECT_GT(cv::norm(*truth.left.silhouetteCentroidPx - *truth.left.projectedCentrePx), 4.0);

        const auto c = judge(centroid.analyze(rr.pair, 0), rr.truth);
        const auto s = judge(sphere.analyze(rr.pair, 0), rr.truth);
        ASSERT_TRUE(c.targets[0].detected);
        ASSERT_TRUE(s.targets[0].detected);
        EXPECT_FALSE(c.targets[0].shapeCorrected);
        EXPECT_TRUE(s.targets[0].shapeCorrected);
        EXPECT_GT(c.targets[0].errorMm, 3.0);
        EXPECT_LT(c.targets[0].radialErrorMm(), -3.0);  // towards the camera
        EXPECT_LT(s.targets[0].errorMm, 0.5);
    }
}

// Issue 10: every stereo target carries the covariance of its position, the
// edge noise propagated through its model (centroid, or the ellipse fit of a
// sphere or disc) and the triangulation. Against the spread over 30 noise
// seeds of the precision scene (seeds not used to choose the models' variance
// factors, which came from trust_report --covariance 40 --seed 21): each
// target's predicted sigma (the three axes together) within 30 % of the
// measured one, no single axis off by half. 30 seeds measure a sigma to
// about 13 %.
TEST(Accuracy, PredictedSigmaMatchesTheSpreadOverNoiseSeeds) {
    std::vector<std::uint64_t> seeds;
    for (std::uint64_t k = 0; k < 30; ++k) seeds.push_back(7000 + k);
    const std::vector<SigmaCheck> checks = sigmaOverNoiseSeeds(seeds);
    ASSERT_EQ(checks.size(), 6u);
    int spheres = 0, discs = 0;
    for (const SigmaCheck& c : checks) {
        spheres += c.shape == render::Shape::Sphere ? 1 : 0;
        discs += c.shape == render::Shape::Disc ? 1 : 0;
        EXPECT_GE(c.n, 28u) << c.name << " was not found whole often enough";
        const double ratio = cv::norm(c.measuredMm) / cv::norm(c.predictedMm);
        EXPECT_NEAR(ratio, 1.0, 0.3) << c.name << " measured " << c.measuredMm << " predicted " << c.predictedMm;
        const cv::Point3d r = c.ratio();
        for (double v : {r.x, r.y, r.z}) EXPECT_NEAR(v, 1.0, 0.5) << c.name;
    }
    EXPECT_EQ(spheres, 4);
    EXPECT_EQ(discs, 2);
}

// The same for ducks (a composite type): the body's position is its part's
// cone axis, whose covariance is propagated from the body's outline points
// through the cone's plane fit (coneAxisCovariance()), times the factor for
// correlated edge noise measured for it (compositeFitCorrelation, on noise
// seeds 7100-7129; these are others). Three ducks turned so that their
// heads take different arcs from their bodies, at 0.7-0.9 m.
TEST(Accuracy, ADucksPredictedSigmaMatchesItsSpread) {
    render::Scene scene = precisionScene();
    scene.targets.clear();
    const std::array<std::pair<cv::Vec3d, double>, 3> ducks{{{{-200, -80, 700}, 0.0},
                                                             {{60, 120, 800}, M_PI},
                                                             {{260, -60, 900}, 0.6}}};
    for (const auto& [centre, yaw] : ducks) {
        render::TargetSpec t;
        t.name = "duck" + std::to_string(scene.targets.size() + 1);
        t.type = "sample";
        t.shape = render::Shape::Duck;
        t.centreMm = centre;
        t.radiusMm = 35.0;
        t.om = {0.0, yaw, 0.0};
        t.albedo = kYellow;
        scene.targets.push_back(t);
    }
    std::vector<std::uint64_t> seeds;
    for (std::uint64_t k = 0; k < 30; ++k) seeds.push_back(7200 + k);
    const std::vector<SigmaCheck> checks = sigmaOverNoiseSeeds(seeds, scene, TargetShape::Composite);
    ASSERT_EQ(checks.size(), 3u);
    for (const SigmaCheck& c : checks) {
        EXPECT_GE(c.n, 28u) << c.name << " was not found whole often enough";
        const double ratio = cv::norm(c.measuredMm) / cv::norm(c.predictedMm);
        EXPECT_NEAR(ratio, 1.0, 0.3) << c.name << " measured " << c.measuredMm << " predicted " << c.predictedMm;
    }
}

// Thesis 6.1.3: the same scene measured again with independent noise. Ten
// noise seeds; every target at 0.65-0.95 m must scatter by at most 0.5 mm
// (sigma magnitude; the thesis reported 2.6-3.8 mm). Measured: <= ~0.2 mm.
TEST(Accuracy, PrecisionOverNoiseSeeds) {
    const Fixture f;
    const render::Scene scene = precisionScene();
    AnalyzeStereoImagePair centroid(f.configs.centroid), sphere(f.configs.sphere);
    std::vector<std::vector<cv::Point3d>> points(scene.targets.size());
    for (std::uint64_t seed = 1; seed <= 10; ++seed) {
        const auto rr = f.renderScene(scene, 500 + seed);
        const auto c = judge(centroid.analyze(rr.pair, seed), rr.truth);
        const auto s = judge(sphere.analyze(rr.pair, seed), rr.truth);
        for (std::size_t i = 0; i < c.targets.size(); ++i) {
            const TargetRecord& t = c.targets[i].shape == render::Shape::Sphere ? s.targets[i] : c.targets[i];
            ASSERT_TRUE(t.detected) << t.name << " seed " << seed;
            EXPECT_LT(t.errorMm, 3.0) << t.name << " seed " << seed;
            points[i].push_back(t.measuredMm);
        }
    }
    for (std::size_t i = 0; i < points.size(); ++i) {
        const Spread sp = spread(points[i]);
        const double range = cv::norm(cv::Point3d(scene.targets[i].centreMm));
        EXPECT_GE(range, 650.0 - 30.0);
        EXPECT_LE(range, 950.0 + 60.0);
        EXPECT_LE(sp.magnitudeMm(), 0.5) << scene.targets[i].name << " at " << range << " mm";
        EXPECT_GT(sp.magnitudeMm(), 0.0) << "noise must change the measurement";
    }
}
