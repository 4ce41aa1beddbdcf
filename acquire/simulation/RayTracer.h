#pragma once
/// @file RayTracer.h
/// Internal to the renderer (Renderer.cpp): the scene as primitive surfaces
/// and the ray tracer that tells what one ray of a camera sees.

#include <avatar/common/CameraModel.h>
#include <avatar/common/RigidTransform.h>
#include <avatar/render/Renderer.h>
#include <avatar/render/Scene.h>

#include <opencv2/core/matx.hpp>

#include <cstdint>
#include <optional>
#include <vector>

namespace avatar::render::detail {

enum class PrimKind { Sphere, Disc, Box, Plane, Board };

/// One primitive surface. `object` is the target index (< number of targets) or
/// a larger id for scenery; `part` separates differently coloured parts.
struct Prim {
    PrimKind kind{PrimKind::Sphere};
    int object{0};
    int part{0};
    cv::Vec3d centre;
    double radius{0.0};
    cv::Vec3d normal;      ///< disc, plane (unit, facing the camera side for the plane)
    cv::Matx33d rotation;  ///< box, board: local -> left
    cv::Vec3d half;        ///< box half sizes; board: x/y extent (min in half, max in extentMax)
    cv::Vec3d extentMax;
    Rgb albedo{0, 0, 0};
    /// Two-tone sphere or disc: albedo2 (part 1) where split . (x - centre) > 0.
    bool twoTone{false};
    cv::Vec3d split;       ///< unit
    double splitOffset{0.0};
    Rgb albedo2{0, 0, 0};
};

/// Signature of what a sample sees; pixels whose samples agree are not supersampled.
struct Signature {
    int object{-1};  ///< -1 background, -2 no ray (outside the invertible distortion)
    int part{0};
    std::uint64_t targets{0};  ///< every target the ray passes through, visible or not
    bool operator==(const Signature& o) const {
        return object == o.object && part == o.part && targets == o.targets;
    }
};

struct Sample {
    Signature sig;
    Rgb radiance{0, 0, 0};
};

/// The scene as the tracer sees it.
struct World {
    std::vector<Prim> prims;
    int targetCount{0};
    int seabedObject{-1};
    int boardObject{-1};
    // seabed
    cv::Vec3d seabedPoint, seabedE1, seabedE2;
    Seabed seabed;
    // checkerboard
    std::optional<Checkerboard> board;
    Lighting lighting;
};

/// The scene's targets, arm markers, seabed and checkerboard as primitives, in
/// the left camera frame (arm markers placed through @p baseTVision); appends
/// the truth of every target (its centre in both camera frames) to @p truths.
World buildWorld(const Scene& scene, const std::optional<RigidTransform>& baseTVision,
                 std::vector<TargetTruth>& truths);

/// One camera as the renderer needs it: its intrinsics and its pose in the left frame.
struct CameraRig {
    CameraIntrinsics intrinsics;
    cv::Matx33d leftRCamera;
    cv::Vec3d centreLeftMm;
};

class Tracer {
public:
    Tracer(const World& world, const CameraRig& rig) : w_(world), rig_(rig) {}

    /// What the ray through pixel position (u, v) of this camera sees: the
    /// object and part it hits first (a target wins a tie with scenery) and,
    /// when @p shade, the radiance it carries.
    Sample trace(double u, double v, bool shade) const;

private:
    Rgb shadeAt(const cv::Vec3d& x, const cv::Vec3d& n, const Rgb& albedo, double viewMm) const;

    const World& w_;
    const CameraRig& rig_;
};

}  // namespace avatar::render::detail
