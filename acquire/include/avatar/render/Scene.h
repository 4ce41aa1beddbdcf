#pragma once
/// @file Scene.h
/// The description of a synthetic scene for avatar-render: seabed, targets,
/// the arm marker, occluders, an optional checkerboard, light, water and sensor
/// noise. Geometry is in millimetres in the left camera (vision) frame (x right,
/// y down, z forward) unless a name says otherwise (…BaseMm: manipulator base
/// frame). Colours are linear RGB albedos in [0, 1]. File format: see
/// docs/tools/avatar-render.md.

#include <avatar/common/Error.h>
#include <avatar/config/StereoSystemConfig.h>

#include <opencv2/core/matx.hpp>

#include <array>
#include <cstdint>
#include <filesystem>
#include <optional>
#include <string>
#include <vector>

namespace avatar::render {

/// Linear red, green, blue.
using Rgb = std::array<double, 3>;

/// A scene description that cannot be accepted. what() reads
///   "<source>:<line>: <element path>: <problem>"
/// e.g. "lab.xml:12: /scene/target[2]@radiusMm: expected a number > 0, got '-3'".
class SceneError : public DocumentError<FormatError> {
public:
    using DocumentError::DocumentError;
};

/// The seabed: an infinite plane with a procedural sand texture. With tilt 0
/// it faces the camera at z = distanceMm; a positive tilt (rotation about the
/// camera x axis) moves the upper part of the image further away, as for a
/// camera looking obliquely down at the floor.
struct Seabed {
    bool enabled{true};
    double distanceMm{2000.0};   ///< along the left optical axis
    double tiltDeg{0.0};         ///< -80..80
    Rgb albedo{0.55, 0.50, 0.40};
    double textureContrast{0.3}; ///< 0..1: relative amplitude of the texture
    double textureScaleMm{40.0}; ///< size of the coarsest texture feature
    std::uint64_t textureSeed{1};
};

enum class Shape { Sphere, Disc, Duck, Box };

/// A coloured target (what the vision system looks for).
/// - sphere: centre, radius.
/// - disc: a flat, two-sided disc of the radius, facing along `normal`.
/// - duck: a body sphere of the radius at the centre, a head sphere of 0.55 radius
///   at (0.55, -0.75, 0) radius and an orange box beak in front of the head,
///   in the duck's own frame (x forward, y down) rotated by `om`. The centre of
///   the target is the body's centre.
/// - box: half sizes, rotated by `om`.
struct TargetSpec {
    std::string name;
    std::string type{"sample"};  ///< the TargetType the analysis should report
    Shape shape{Shape::Sphere};
    cv::Vec3d centreMm{0.0, 0.0, 1000.0};
    double radiusMm{25.0};
    cv::Vec3d halfSizeMm{10.0, 10.0, 10.0};  ///< box only
    cv::Vec3d normal{0.0, 0.0, -1.0};        ///< disc only; need not be unit length
    std::array<double, 3> om{0.0, 0.0, 0.0}; ///< duck and box orientation (Rodrigues, rad)
    Rgb albedo{0.9, 0.75, 0.05};
    Rgb beakAlbedo{0.95, 0.35, 0.02};        ///< duck only
    /// Sphere and disc: a second colour where splitNormal . (x - centre) >
    /// splitOffsetMm (|splitNormal| = 1): a target split between two filters.
    std::optional<Rgb> secondAlbedo;
    cv::Vec3d splitNormal{1.0, 0.0, 0.0};
    double splitOffsetMm{0.0};
};

/// The arm marker (e.g. the gold box on the Ranger end effector). Its pose is
/// in the manipulator base frame; it is placed in the scene with base_T_vision
/// (from the StereoSystemConfig, or else the scene's <registration>).
struct ArmMarker {
    std::string name{"arm"};
    std::string type{"arm_marker"};
    cv::Vec3d positionBaseMm{0.0, 0.0, 0.0};
    std::array<double, 3> omBase{0.0, 0.0, 0.0};  ///< orientation in the base frame
    cv::Vec3d halfSizeMm{20.0, 15.0, 10.0};
    Rgb albedo{0.85, 0.46, 0.28};  ///< gold (fits data/config/scorpion.xml's arm_marker filter)
};

/// Anything that is not a target: occluders, rocks, similar-coloured distractors.
struct Occluder {
    std::string name;
    Shape shape{Shape::Sphere};  ///< sphere or box
    cv::Vec3d centreMm{0.0, 0.0, 800.0};
    double radiusMm{30.0};
    cv::Vec3d halfSizeMm{30.0, 30.0, 30.0};
    std::array<double, 3> om{0.0, 0.0, 0.0};
    Rgb albedo{0.4, 0.4, 0.4};
};

/// A planar calibration checkerboard of squaresX x squaresY squares (so
/// (squaresX-1) x (squaresY-1) inner corners) with a light margin around it.
/// Board frame: origin at the first inner corner, x along squaresX, y along
/// squaresY, z into the board (the printed side faces -z); left_T_board =
/// (rodrigues(om), positionMm) places it in the scene.
struct Checkerboard {
    int squaresX{9};
    int squaresY{7};
    double squareMm{30.0};
    double marginSquares{1.0};
    std::array<double, 3> om{0.0, 0.0, 0.0};
    cv::Vec3d positionMm{0.0, 0.0, 1000.0};
    Rgb dark{0.03, 0.03, 0.03};
    Rgb light{0.85, 0.85, 0.85};
};

/// Strobe falloff in the image: each channel is multiplied by c * exp(e * d),
/// d the pixel distance from centrePx. The strobe darkens away from its centre,
/// so e <= 0 (thesis 3.2.2 fits the inverse, a correction factor growing with d:
/// the matching LightingConfig has coefficient 1/c and exponent -e).
struct StrobeChannel {
    double coefficient{1.0};
    double exponent{0.0};
};
struct Strobe {
    bool enabled{false};
    cv::Vec2d centrePx{640.0, 480.0};
    std::array<StrobeChannel, 3> rgb;  ///< red, green, blue
};

/// Light: ambient plus one Lambertian point light (no shadows), water and darkness.
struct Lighting {
    Rgb ambient{0.25, 0.25, 0.25};
    Rgb lightIntensity{0.75, 0.75, 0.75};
    cv::Vec3d lightPositionMm{0.0, 0.0, 0.0};  ///< default: at the left camera
    /// When true the light falls off as (referenceDistanceMm / distance)^2.
    bool inverseSquare{false};
    double referenceDistanceMm{1000.0};
    /// Global factor on all light, 1 = normal, e.g. 0.1 for the lights-off laboratory.
    double darknessFactor{1.0};
    Strobe strobe;
    /// Water: each channel decays as exp(-attenuationPerM * path / 1000 mm), the path
    /// being light -> surface -> camera. Blue-green water: red largest.
    Rgb attenuationPerM{0.0, 0.0, 0.0};
    /// Radiance of rays that hit nothing (open water).
    Rgb background{0.0, 0.0, 0.0};
    /// Haze: light scattered towards the camera by suspended particles, the
    /// radiance of an infinitely long column of water. A surface at distance
    /// d from the camera is seen as L exp(-k d) + backscatter (1 - exp(-k d)),
    /// k = attenuationPerM + turbidityPerM per metre; open water as
    /// background + backscatter.
    Rgb backscatter{0.0, 0.0, 0.0};
    /// Extinction by the particles (all channels, per metre of light path),
    /// on top of attenuationPerM.
    double turbidityPerM{0.0};
};

/// Sensor response and noise. A radiance of 1 with exposure 1 is full scale.
struct SensorNoise {
    double exposure{1.0};
    double readNoiseDn{0.0};   ///< Gaussian read noise, standard deviation in output counts
    bool shotNoise{false};     ///< photon noise from fullWellElectrons (Gaussian approximation)
    double fullWellElectrons{20000.0};
    double blackLevelDn{0.0};
};

struct Scene {
    std::string name{"scene"};
    Seabed seabed;
    Lighting lighting;
    SensorNoise sensor;
    std::vector<TargetSpec> targets;
    std::vector<ArmMarker> armMarkers;
    std::vector<Occluder> occluders;
    std::optional<Checkerboard> checkerboard;
    /// base_T_vision used for the arm markers when the StereoSystemConfig has none.
    std::optional<RigidTransform> baseTVision;
};

/// At most this many targets plus arm markers per scene.
constexpr std::size_t kMaxSceneTargets = 64;

/// Parses a scene document held in memory; @p sourceName appears in errors.
/// Throws SceneError naming the line, element path and value of the first problem.
Scene readSceneString(const std::string& xml, const std::string& sourceName = "<string>");
/// Reads a scene file; a missing file is an avatar::IoError.
Scene readSceneFile(const std::filesystem::path& path);
/// Serialises a scene (every field; doubles round-trip exactly).
std::string writeSceneString(const Scene& scene);
/// Writes a scene file; throws avatar::IoError on failure.
void writeSceneFile(const Scene& scene, const std::filesystem::path& path);

/// Checks a scene built in code; throws SceneError (source "<memory>") naming the bad field.
void validateScene(const Scene& scene);

std::string_view toString(Shape shape);

}  // namespace avatar::render
