#pragma once
/// @file VisionTargets.h
/// VisionTargets: everything one analysis iteration tells the outside world
/// (thesis 4.2.3). The only way results leave AVATAR; produced by analyze,
/// recorded by acquire's session log, served by TAUNet.

#include <avatar/common/StereoImagePair.h>

#include <opencv2/core/matx.hpp>
#include <opencv2/core/types.hpp>

#include <cstdint>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

namespace avatar {

/// Bit flags of one target. A manipulator may act on a target only when
/// kTargetWhole is set: every other stereo target is a best estimate whose
/// flags say why it is not whole.
enum TargetFlag : std::uint32_t {
    kTargetStereo = 1u << 0,        ///< matched in both images; a 3-D position was estimated
    kTargetLeftOnly = 1u << 1,      ///< seen in the left image only (occluded or out of view)
    kTargetRightOnly = 1u << 2,     ///< seen in the right image only
    kTargetAtBorder = 1u << 3,      ///< a silhouette touches the image or search-window edge
    kTargetShapeCorrected = 1u << 4,///< position from the shape model's fit (ShapeModel), not the centroids
    /// Stereo, both silhouettes complete (nothing cut, hidden or merged) and
    /// the type and match decided: the position is valid.
    kTargetWhole = 1u << 5,
    kTargetCut = 1u << 6,           ///< a silhouette crosses the image or search-window edge
    kTargetOccludedLeft = 1u << 7,  ///< part of it is hidden in the left image
    kTargetOccludedRight = 1u << 8, ///< part of it is hidden in the right image
    kTargetMerged = 1u << 9,        ///< its feature holds more than one object (touching targets)
    kTargetAmbiguous = 1u << 10,    ///< its type (a colour split between filters) or its match is undecided
    kTargetPoorVisibility = 1u << 11 ///< found while the visibility verdict is poor
};

/// Every bit of TargetFlag.
inline constexpr std::uint32_t kTargetFlagsAll = (1u << 12) - 1;

/// The names of the set flags, comma-separated in bit order
/// ("stereo,border,whole"); "-" when none is set. Unknown bits are written
/// as "bitN".
std::string targetFlagsText(std::uint32_t flags);

/// The shape model a target type declares and a target's position was
/// computed with (docs/config.md, <shape>).
enum class ShapeModel : std::uint8_t {
    None = 0,      ///< no model: the silhouette centroids are triangulated
    Sphere = 1,    ///< the silhouette-cone axis of each image
    Disc = 2,      ///< the image of the centre of a flat circle, from its fitted ellipse
    Composite = 3  ///< a rigid object of round parts (the duck): the silhouette-cone axes of its largest part
};

/// "none", "sphere", "disc", "composite".
std::string_view toString(ShapeModel model);

/// A 3x3 covariance, mm^2 (symmetric).
using Covariance3 = cv::Matx33d;

/// One target found in an image pair.
struct VisionTarget {
    std::string type;            ///< the TargetType name, e.g. "sample"
    std::uint32_t flags{0};      ///< TargetFlag bits
    /// Position in the left camera (vision) frame, mm; set when kTargetStereo
    /// (valid when kTargetWhole, a best estimate otherwise).
    std::optional<cv::Point3d> positionVisionMm;
    /// Position in the manipulator base frame, mm; set when stereo and a registration is known.
    std::optional<cv::Point3d> positionBaseMm;
    std::optional<cv::Point2d> centroidLeftPx;   ///< set when seen in the left image
    std::optional<cv::Point2d> centroidRightPx;  ///< set when seen in the right image
    double areaLeftPx{0.0};
    double areaRightPx{0.0};
    double matchError{0.0};      ///< shape difference of the match (0 for single-image targets)
    /// The model the position was computed with: the type's, unless its
    /// silhouettes do not fit it (then None, and the target is not whole).
    ShapeModel model{ShapeModel::None};
    /// Covariance of positionVisionMm from the image noise through the
    /// triangulation; set with the position.
    std::optional<Covariance3> covarianceVisionMm2;
    /// Covariance of positionBaseMm (R Cov R^T of the registration); set with it.
    std::optional<Covariance3> covarianceBaseMm2;
    double rayResidualMm{0.0};   ///< distance between the two viewing rays at their closest approach
    double rayResidualPx{0.0};   ///< RMS distance of the triangulated point's projections from the measured points

    bool operator==(const VisionTarget& o) const {
        return type == o.type && flags == o.flags && positionVisionMm == o.positionVisionMm &&
               positionBaseMm == o.positionBaseMm && centroidLeftPx == o.centroidLeftPx &&
               centroidRightPx == o.centroidRightPx && areaLeftPx == o.areaLeftPx &&
               areaRightPx == o.areaRightPx && matchError == o.matchError && model == o.model &&
               sameCovariance(covarianceVisionMm2, o.covarianceVisionMm2) &&
               sameCovariance(covarianceBaseMm2, o.covarianceBaseMm2) && rayResidualMm == o.rayResidualMm &&
               rayResidualPx == o.rayResidualPx;
    }

private:
    static bool sameCovariance(const std::optional<Covariance3>& a, const std::optional<Covariance3>& b) {
        if (a.has_value() != b.has_value()) return false;
        if (!a) return true;
        for (int i = 0; i < 9; ++i)
            if (a->val[i] != b->val[i]) return false;
        return true;
    }
};

/// Time taken by one analysis stage.
struct StageTiming {
    std::string stage;
    double milliseconds{0.0};
    bool operator==(const StageTiming& o) const {
        return stage == o.stage && milliseconds == o.milliseconds;
    }
};

/// Visibility verdict of an iteration (thesis 3.6.1).
enum class Visibility { Unknown, Good, Poor };

/// The result of analysing one stereo pair.
struct VisionTargets {
    std::uint64_t iteration{0};   ///< vision iteration counter
    AcquisitionId acquisition;    ///< the pair the result belongs to
    std::vector<VisionTarget> targets;
    std::vector<StageTiming> timings;
    Visibility visibility{Visibility::Unknown};
    std::string visibilityReason; ///< e.g. "left: contrast 0.02 below 0.05"

    bool operator==(const VisionTargets& o) const {
        return iteration == o.iteration && acquisition == o.acquisition && targets == o.targets &&
               timings == o.timings && visibility == o.visibility && visibilityReason == o.visibilityReason;
    }
    bool operator!=(const VisionTargets& o) const { return !(*this == o); }

    /// The targets of one type, in the order found.
    std::vector<VisionTarget> ofType(const std::string& type) const {
        std::vector<VisionTarget> out;
        for (const auto& t : targets)
            if (t.type == type) out.push_back(t);
        return out;
    }
};

}  // namespace avatar
