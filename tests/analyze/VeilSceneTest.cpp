// The haze's veil (TargetConfig.h, Veil) on a rendered scene: a green sphere
// 1 m away in haze whose backscatter moves its colour out of its clear
// colour's ranges. Without the veil the filter loses it; with it the sphere
// is found whole and placed where it is (0.35-0.45 mm off over three render
// seeds), and the hazy seabed is not taken.
#include <avatar/analyze/AnalyzeStereoImagePair.h>
#include <avatar/config/ConfigXml.h>
#include <avatar/render/Renderer.h>
#include <avatar/render/Scene.h>

#include <gtest/gtest.h>

#include <optional>
#include <string>

namespace avatar {
namespace {

constexpr double kRadiusMm = 30.0;
const cv::Point3d kCentreMm(40.0, -30.0, 1000.0);

render::Scene hazyGreenSphere(double thicker = 1.0) {
    render::Scene s = render::readSceneFile(std::string(AVATAR_DATA_DIR) + "/scenes/lab.xml");
    s.targets.clear();
    s.armMarkers.clear();
    s.occluders.clear();
    s.seabed.distanceMm = 2500.0;
    s.seabed.tiltDeg = 10.0;
    render::TargetSpec t;
    t.name = "ball";
    t.type = "green";
    t.shape = render::Shape::Sphere;
    t.centreMm = {kCentreMm.x, kCentreMm.y, kCentreMm.z};
    t.radiusMm = kRadiusMm;
    t.albedo = {0.12, 0.6, 0.15};
    s.targets.push_back(t);
    // The scene sets' haze (acquire/simulation/SceneSet.cpp): backscatter
    // 0.7 : 1 : 1, here strong enough to take the sphere's B/G from 0.25 to
    // about 0.35.
    s.lighting.backscatter = {0.105 * thicker, 0.15 * thicker, 0.15 * thicker};
    s.lighting.turbidityPerM = 0.4 * thicker;
    return s;
}

/// scorpion.xml with one type: green spheres, its ranges those of the
/// colour in clear water.
AvatarConfig greenConfig(bool veil) {
    AvatarConfig c = readConfigFile(std::string(AVATAR_DATA_DIR) + "/config/scorpion.xml");
    TargetType green = c.targets.targets[0];
    green.name = "green";
    green.redGreen = {0.13, 0.3};
    green.redBlue = {0.0, 1e9};
    green.blueGreen = {0.18, 0.3};
    green.shape = TargetShape::Sphere;
    green.area = {150.0, 400000.0};
    if (veil) green.veil = Veil{{0.7, 1.0, 1.0}, 0.35, std::nullopt, std::nullopt};
    c.targets.targets = {green};
    return c;
}

/// @p scene rendered (noise seed 3) and analysed with @p config.
VisionTargets renderAndAnalyse(const render::Scene& scene, const AvatarConfig& config) {
    render::RenderOptions options;
    options.seed = 3;
    const render::RenderResult r = render::render(scene, config.stereo, options);
    AnalyzeStereoImagePair analysis(config);
    return analysis.analyze(r.pair, 1);
}

VisionTargets analyse(bool veil) {
    const AvatarConfig config = greenConfig(veil);
    return renderAndAnalyse(hazyGreenSphere(), config);
}

TEST(VeilScene, WithoutTheVeilTheHazySphereIsNotWhole) {
    for (const VisionTarget& v : analyse(false).targets) EXPECT_FALSE(v.flags & kTargetWhole);
}

TEST(VeilScene, WithTheVeilItIsWholeWhereItIsAndNothingElseIsReported) {
    const VisionTargets result = analyse(true);
    int stereo = 0;
    for (const VisionTarget& v : result.targets) {
        if (!(v.flags & kTargetStereo)) continue;
        ++stereo;
        EXPECT_TRUE(v.flags & kTargetWhole) << v.flags;
        EXPECT_EQ(v.model, ShapeModel::Sphere);
        ASSERT_TRUE(v.positionVisionMm);
        EXPECT_LT(cv::norm(*v.positionVisionMm - kCentreMm), 1.0)
            << v.positionVisionMm->x << " " << v.positionVisionMm->y << " " << v.positionVisionMm->z;
    }
    EXPECT_EQ(stereo, 1);
}

// A colour that one type's veil explains as that type's in thicker haze
// than its filter passes, and that another type's ranges take, cannot be
// told by colour (a yellow duck in haze where orange's ranges reach, taken
// for a whole orange sphere in the trust report): the target is ambiguous,
// not whole. Here a "teal" type's ranges take the green sphere in haze
// twice as thick as above (R/G ~0.33, B/G ~0.45: a share of ~0.25 of the
// veil) while green's own veil stops at a share of 0.05, and its filter's
// margin (0.1 in log) at B/G 0.32.
/// Green (of @p greenShape, with a veil up to a share of 0.05 when
/// @p greenHasVeil) and a "teal" sphere type whose ranges take green in the
/// thick haze of hazyGreenSphere(2.0).
AvatarConfig greenAndTeal(bool greenHasVeil, TargetShape greenShape) {
    AvatarConfig config = greenConfig(false);
    TargetType teal = config.targets.targets[0];
    teal.name = "teal";
    teal.redGreen = {0.25, 0.5};
    teal.blueGreen = {0.36, 0.7};
    TargetType& green = config.targets.targets[0];
    green.shape = greenShape;
    if (greenHasVeil) green.veil = Veil{{0.7, 1.0, 1.0}, 0.05, std::nullopt, std::nullopt};
    config.targets.targets.push_back(teal);
    validateConfig(config);
    return config;
}

VisionTargets analyseAsTeal(bool greenHasVeil) {
    const AvatarConfig config = greenAndTeal(greenHasVeil, TargetShape::Sphere);
    return renderAndAnalyse(hazyGreenSphere(2.0), config);
}

TEST(VeilScene, AnotherTypesColourInThickerHazeThanItsFilterPassesIsAmbiguous) {
    for (const bool greenHasVeil : {false, true}) {
        const VisionTargets result = analyseAsTeal(greenHasVeil);
        int stereo = 0;
        for (const VisionTarget& v : result.targets) {
            if (!(v.flags & kTargetStereo)) continue;
            ++stereo;
            EXPECT_EQ(v.type, "teal");
            ASSERT_TRUE(v.positionVisionMm);
            EXPECT_LT(cv::norm(*v.positionVisionMm - kCentreMm), 5.0);  // the thick haze's edges: 3.3 mm
            if (greenHasVeil) {
                EXPECT_TRUE(v.flags & kTargetAmbiguous) << v.flags;
                EXPECT_FALSE(v.flags & kTargetWhole) << v.flags;
            } else {
                // Nothing says it is another type's: teal as configured.
                EXPECT_FALSE(v.flags & kTargetAmbiguous) << v.flags;
                EXPECT_TRUE(v.flags & kTargetWhole) << v.flags;
            }
        }
        EXPECT_EQ(stereo, 1) << (greenHasVeil ? "green with a veil" : "green without");
    }
}

// The same with a second hazy green sphere touching the first side by
// side: both in teal's box, one feature in each view, which splits into
// two spheres. The split's parts are each tested as a lone target's colour
// is, so both are ambiguous, never whole; before, the split made two whole
// teal spheres whatever their colour (a hazy yellow duck beside an orange
// sphere, both in orange's box, became two whole orange spheres;
// trust_report seed 51).
TEST(VeilScene, TheSpheresATouchingPairSplitsIntoHaveTheirColoursJudged) {
    AvatarConfig config = greenConfig(false);
    TargetType teal = config.targets.targets[0];
    teal.name = "teal";
    teal.redGreen = {0.2, 0.5};
    teal.blueGreen = {0.32, 0.7};
    config.targets.targets[0].veil = Veil{{0.7, 1.0, 1.0}, 0.05, std::nullopt, std::nullopt};
    config.targets.targets.push_back(teal);
    validateConfig(config);
    render::Scene scene = hazyGreenSphere();
    render::TargetSpec other = scene.targets[0];
    other.name = "ball2";
    other.radiusMm = 25.0;
    other.centreMm = {kCentreMm.x + kRadiusMm + other.radiusMm + 0.01, kCentreMm.y, kCentreMm.z};
    scene.targets.push_back(other);
    const VisionTargets result = renderAndAnalyse(scene, config);
    const cv::Point3d otherCentre(other.centreMm[0], other.centreMm[1], other.centreMm[2]);
    int first = 0, second = 0;
    for (const VisionTarget& v : result.targets) {
        if (!(v.flags & kTargetStereo)) continue;
        EXPECT_EQ(v.type, "teal");
        EXPECT_EQ(v.model, ShapeModel::Sphere) << "each placed by its own cone";
        ASSERT_TRUE(v.positionVisionMm);
        first += cv::norm(*v.positionVisionMm - kCentreMm) < 5.0;
        second += cv::norm(*v.positionVisionMm - otherCentre) < 5.0;
        EXPECT_TRUE(v.flags & kTargetAmbiguous) << v.flags;
        EXPECT_FALSE(v.flags & kTargetWhole) << v.flags;
    }
    EXPECT_EQ(first, 1) << "the pair must split into its two spheres";
    EXPECT_EQ(second, 1);
}

// An undecided colour leaves the type to the shape: a green duck (type
// composite) in the thick haze that puts its colour in teal's box, teal's
// type a sphere. Teal's model finds no sphere there, green's finds its
// whole duck: reported once, as a whole green duck placed by its body,
// where green's veil explains the colour. Without that veil nothing says
// it is green: teal's, and not whole. A hazy green sphere there stays
// teal's and ambiguous: teal's model fits it, and a duck facing the camera
// shows a sphere's outline too, so the shape decides nothing. A hazy green
// disc seen aslant, which teal's disc model finds whole, stays ambiguous
// too where green's model raises no objection of its own (it finds two
// parts, most of each circle missing: a duck's outline hidden in part
// looks so too); where green's ducks are larger than the disc (green's
// size range), it is no green duck, and it is teal's disc, whole.
// A speck of silt in front of the duck, inside its outline, hides it in
// part: green's model does not find it whole either, and it stays teal's,
// undecided. (Found by a round type's filter, a duck's holes are judged as
// that filter's are: hazy ducks 5-6 % hidden by specks were whole green
// ducks in the trust report's first run of the rule, seeds 42, 55 and 59.
// Here the speck's hole also leaves its mark on the outline, which green's
// parts do not explain.)
VisionTargets analyseHazy(render::Shape shape, bool greenHasVeil, bool speck = false,
                          std::optional<Range> greenSizeMm = std::nullopt) {
    AvatarConfig config = greenAndTeal(greenHasVeil, TargetShape::Composite);
    config.targets.targets[0].sizeMm = greenSizeMm;
    render::Scene scene = hazyGreenSphere(2.0);
    render::TargetSpec& t = scene.targets[0];
    t.shape = shape;
    t.om = {0.0, 0.0, 0.3};
    t.normal = {1.0, 0.3, -1.0};  // a disc seen aslant (45 degrees): an ellipse no sphere makes
    t.beakAlbedo = t.albedo;  // green all over: the duck's shape alone differs
    if (speck) {
        render::Occluder silt;
        silt.name = "silt";
        silt.centreMm = (kCentreMm + cv::Point3d(0, 8, 0)) * 0.35;
        silt.radiusMm = 2.0;
        silt.albedo = {0.75, 0.75, 0.75};
        scene.occluders = {silt};
    }
    return renderAndAnalyse(scene, config);
}

TEST(VeilScene, AnUndecidedColourIsTheTypeWhoseModelItsShapeFits) {
    struct Case {
        render::Shape shape;
        bool veil;
        bool speck;
        const char* type;
        bool whole;
        ShapeModel model;
        std::optional<Range> greenSizeMm;
    };
    for (const Case& c : {Case{render::Shape::Duck, true, false, "green", true, ShapeModel::Composite, {}},
                          Case{render::Shape::Duck, false, false, "teal", false, ShapeModel::None, {}},
                          Case{render::Shape::Sphere, true, false, "teal", false, ShapeModel::Sphere, {}},
                          Case{render::Shape::Disc, true, false, "teal", false, ShapeModel::Disc, {}},
                          Case{render::Shape::Disc, true, false, "teal", true, ShapeModel::Disc, Range{80.0, 200.0}},
                          Case{render::Shape::Duck, true, true, "teal", false, ShapeModel::None, {}}}) {
        const std::string what = std::string(c.shape == render::Shape::Duck     ? "duck"
                                             : c.shape == render::Shape::Disc ? "disc"
                                                                              : "sphere") +
                                 (c.veil ? ", green with a veil" : ", green without") + (c.speck ? ", a speck" : "") +
                                 (c.greenSizeMm ? ", green's ducks 80 mm or more" : "");
        int stereo = 0;
        for (const VisionTarget& v : analyseHazy(c.shape, c.veil, c.speck, c.greenSizeMm).targets) {
            if (!(v.flags & kTargetStereo)) continue;
            ++stereo;
            EXPECT_EQ(v.type, c.type) << what;
            EXPECT_EQ(static_cast<bool>(v.flags & kTargetWhole), c.whole) << what << ": flags " << v.flags;
            if (c.whole) {
                EXPECT_EQ(v.model, c.model) << what;
                EXPECT_FALSE(v.flags & kTargetAmbiguous) << what;
                ASSERT_TRUE(v.positionVisionMm);
                EXPECT_LT(cv::norm(*v.positionVisionMm - kCentreMm), 5.0) << what;  // the body's centre
            } else {
                EXPECT_TRUE(v.flags & (kTargetAmbiguous | kTargetMerged | kTargetOccludedLeft | kTargetOccludedRight))
                    << what << ": flags " << v.flags;
                if (c.shape != render::Shape::Duck) {
                    EXPECT_EQ(v.model, c.model) << what;
                }
                if (c.speck) {
                    EXPECT_TRUE(v.flags & kTargetAmbiguous) << what << ": its shape decides nothing";
                }
            }
        }
        EXPECT_EQ(stereo, 1) << what;
    }
}


// Thinner haze: a green duck's colour just beyond green's veil (a share of
// 0.01) lies in teal's box and is not undecided (within minHazeShare of
// green's colour, where other colours under water lie too). Teal's sphere
// model does not find it whole; green's veil explains the colour, and
// green's model finds a whole duck whose head sinks into its body: a whole
// green duck. Two touching green spheres there, the smaller of a duck
// head's size, are no duck (trust_report: hazy yellow ducks in orange's
// box at shares under 0.1, 36 on 28 seeds, were never whole).
VisionTargets analyseLightHaze(bool twoSpheres, double thicker) {
    AvatarConfig config = greenConfig(false);
    TargetType& green = config.targets.targets[0];
    green.blueGreen = {0.18, 0.26};
    green.shape = TargetShape::Composite;
    green.veil = Veil{{0.7, 1.0, 1.0}, 0.01, std::nullopt, std::nullopt};
    TargetType teal = green;
    teal.name = "teal";
    teal.shape = TargetShape::Sphere;
    teal.veil.reset();
    teal.redGreen = {0.13, 0.5};
    teal.blueGreen = {0.27, 0.7};
    config.targets.targets.push_back(teal);
    validateConfig(config);
    render::Scene scene = hazyGreenSphere(thicker);
    render::TargetSpec& t = scene.targets[0];
    if (twoSpheres) {
        render::TargetSpec head = t;
        head.name = "ball2";
        head.radiusMm = 0.55 * kRadiusMm;
        head.centreMm = {kCentreMm.x + 0.6 * (kRadiusMm + head.radiusMm) + 0.01,
                         kCentreMm.y - 0.8 * (kRadiusMm + head.radiusMm), kCentreMm.z};
        scene.targets.push_back(head);
    } else {
        t.shape = render::Shape::Duck;
        t.om = {0.0, 0.0, 0.3};
        t.beakAlbedo = t.albedo;
    }
    return renderAndAnalyse(scene, config);
}

TEST(VeilScene, ADuckInThinHazeInARoundTypesBoxIsItsOwnWhenItsHeadSinksIn) {
    // 0.6: undecided (its colour within 10 % of green's ranges); 0.8:
    // decided, teal's. Teal's model splits either duck into two spheres
    // sunk into each other, which the duck's shape is asked before.
    for (const double thicker : {0.6, 0.8}) {
        const std::string haze = "haze x" + std::to_string(thicker).substr(0, 3);
        int stereo = 0;
        for (const VisionTarget& v : analyseLightHaze(false, thicker).targets) {
            if (!(v.flags & kTargetStereo)) continue;
            ++stereo;
            EXPECT_EQ(v.type, "green") << haze;
            EXPECT_TRUE(v.flags & kTargetWhole) << haze << ": flags " << v.flags;
            EXPECT_FALSE(v.flags & kTargetAmbiguous) << haze;
            EXPECT_EQ(v.model, ShapeModel::Composite) << haze;
            ASSERT_TRUE(v.positionVisionMm);
            EXPECT_LT(cv::norm(*v.positionVisionMm - kCentreMm), 5.0) << haze;  // its body's centre: 0.2 mm
        }
        EXPECT_EQ(stereo, 1) << haze;
        // Green's model finds the two spheres a whole duck, but the head's
        // centre lies a radii's sum from the body's: no green target.
        stereo = 0;
        for (const VisionTarget& v : analyseLightHaze(true, thicker).targets) {
            if (!(v.flags & kTargetStereo)) continue;
            ++stereo;
            EXPECT_EQ(v.type, "teal") << haze << ": two spheres";
        }
        EXPECT_GE(stereo, 1) << haze << ": two spheres";
    }
}

}  // namespace
}  // namespace avatar
