#pragma once
/// @file SceneSet.h
/// Generated scene collections: random evaluation scenes and checkerboard
/// views for calibration tests. Generation is deterministic for a seed; scene k
/// of a set depends only on the seed and k (not on the set's size).

#include <avatar/config/StereoSystemConfig.h>
#include <avatar/render/Renderer.h>
#include <avatar/render/Scene.h>

#include <cstdint>
#include <string>
#include <vector>

namespace avatar::render {

/// A target colour of a scene set; the name becomes the target type.
struct TargetColour {
    std::string name;
    Rgb albedo;
};

/// What a random scene set contains. Probabilities are per scene.
struct SceneSetSpec {
    int count{10};
    std::uint64_t seed{1};
    int minTargets{1};
    int maxTargets{8};
    double minRangeMm{500.0};   ///< distance of a target centre from the left camera
    double maxRangeMm{2500.0};
    double minRadiusMm{20.0};
    double maxRadiusMm{45.0};
    std::vector<TargetColour> colours{{"yellow", {0.92, 0.72, 0.04}},
                                      {"red", {0.8, 0.08, 0.06}},
                                      {"orange", {0.95, 0.42, 0.05}},
                                      {"green", {0.12, 0.6, 0.15}},
                                      {"white", {0.85, 0.83, 0.78}}};
    double nearBorderProbability{0.3};          ///< one target within 25 px of a border (maybe cut)
    double occludedInOneCameraProbability{0.3}; ///< an occluder hides part of one target in one camera
    double touchingProbability{0.3};            ///< two targets (spheres) touching side by side
    double distractorProbability{0.4};          ///< a box of nearly a target colour that is not a target
    // The variations below are drawn from a stream of their own: with them
    // all 0 (the defaults), a seed gives the same scenes as before they existed.
    /// Another target in front of one target, overlapping it in one camera
    /// only (the other camera sees the two apart).
    double targetOcclusionProbability{0.0};
    /// Blue-green water: red attenuated 0.05-0.3 per metre, green 0.01-0.05,
    /// blue 0.02-0.12 (coastal water: at 2.5 m a target's red/green falls to
    /// 40-90 %), ambient light tinted blue-green, so that colours move (and
    /// may cross from one filter to another).
    double waterProbability{0.0};
    /// Lights low: everything x 0.1-0.25, read noise 20-40 DN.
    double darkProbability{0.0};
    /// A target whose albedo lies between two of the colours (mixed 35-65 %);
    /// its name starts with "mix_" and its type is the nearer colour's.
    double mixedColourProbability{0.0};
    /// Silt: 60-200 small bright particles (spheres of 0.7-3 mm, named
    /// "silt...") between 150 mm and the far range, and haze (backscatter and
    /// turbidity) with it.
    double siltProbability{0.0};
    /// Throws avatar::InvalidArgument naming the bad field.
    void validate() const;
};

/// Generates spec.count scenes named "<prefix>NNNN" seen by @p stereo with an
/// image of @p sensor's size. Targets float at their ranges in front of a
/// seabed placed behind them all.
std::vector<Scene> makeSceneSet(const SceneSetSpec& spec, const StereoSystemConfig& stereo,
                                const SensorFormat& sensor, const std::string& prefix = "set");

struct CheckerboardSpec {
    int views{10};
    std::uint64_t seed{1};
    int squaresX{10};     ///< squares, so squaresX-1 inner corners
    int squaresY{7};
    double squareMm{30.0};
    double minRangeMm{600.0};
    double maxRangeMm{1500.0};
    double maxTiltDeg{40.0};  ///< of the board normal from the optical axis
    double marginPx{10.0};    ///< the board, margin included, stays this far inside both images
    void validate() const;
};

/// Random board poses entirely visible (with its margin) in both cameras.
/// Throws avatar::InvalidArgument when no such pose is found (board too big
/// for the range and field of view).
std::vector<Scene> makeCheckerboardViews(const CheckerboardSpec& spec, const StereoSystemConfig& stereo,
                                         const SensorFormat& sensor);

}  // namespace avatar::render
