#pragma once
/// @file TargetAssembly.h
/// Internal: how matched and unmatched features become the targets of a
/// VisionTargets (thesis 3.4.2, 3.6.2), as targets an arm can trust:
/// - every stereo target's silhouettes are measured (Silhouette.h) and
///   checked for completeness: a round type's (sphere, disc) against its
///   fitted ellipse (ShapeFit.h), every type against the image and window
///   edges, other targets it touches and the other view;
/// - features of different types that touch are one object split between
///   two filters when their union is round (or their types have no model):
///   it is reported once, under the type that holds most of it, or as
///   ambiguous;
/// - the position comes from the shape model that fits (sphere cone axes,
///   disc centres), else the centroids; its covariance from the centroids'
///   through the triangulation;
/// - kTargetWhole only when nothing says otherwise.

#include <avatar/analyze/Feature.h>
#include <avatar/analyze/ProcessStereoImagePair.h>
#include <avatar/analyze/SIPFeatureMatcher.h>
#include <avatar/common/StereoCoordinateCalculator.h>
#include <avatar/common/VisionTargets.h>
#include <avatar/config/AvatarConfig.h>

#include <opencv2/core/mat.hpp>

#include <vector>

namespace avatar::detail {

/// The evidence thresholds of the completeness checks (docs/accuracy.md
/// says how they were chosen: on scene sets of one seed, reported on another).
struct CompletenessLimits {
    double minFitThresholdPx{0.5};  ///< smallest inlier limit of the ellipse fits
    int maxUnsupportedBins{1};      ///< ellipse bins without outline points that are tolerated
    double maxFitRmsPx{0.45};       ///< RMS of a round silhouette's inliers about its ellipse
    double maxSphereAnisotropy{0.04};  ///< of a sphere's cone (0 for a sphere)
    double maxSphereRadiusMismatch{0.03};  ///< relative, between the two views' radii
    double maxDiscNormalDisagreementRad{0.09};  ///< about 5 degrees
    double maxSizeMismatch{0.04};   ///< relative, of a round target's size between the views
    double maxAreaMismatch{0.08};
    /// A target without a round model this close to the image's or the
    /// search window's edge (px) is cut.
    int nearEdgePx{3};   ///< relative, of the range-scaled areas of other shapes
    double minConcavityDepth{0.08};  ///< of a round silhouette's waist, relative to its radius
    double minTypeShare{0.8};       ///< of an object split between filters, for its type to be decided
    double minTypeShareUnchecked{0.97};  ///< the same when a type of the object has no round model
    /// Variance factor of the centroid covariance (see measureSilhouette()):
    /// measured, trust_report --covariance 20 --seed 21 (docs/accuracy.md).
    double centroidCorrelation{15.0};
};

class TargetAssembler {
public:
    explicit TargetAssembler(const AvatarConfig& config, CompletenessLimits limits = {});

    /// Appends the targets of @p frame (its masks, features and matches of
    /// every type) to frame.result.targets: the stereo targets, then the
    /// features seen in one image only, by type.
    void assemble(AnalysisFrame& frame) const;

private:
    struct Object;
    /// A stereo target, and in which views it touches another target (which
    /// only the depths of the targets it touches can judge).
    struct Built {
        VisionTarget target;
        bool contact[2]{false, false};
    };

    std::vector<Object> objects(const AnalysisFrame& frame, Side side) const;
    Built stereoTarget(const AnalysisFrame& frame, const Object& left, const Object& right, double matchError,
                       bool conflict) const;
    VisionTarget singleTarget(const AnalysisFrame& frame, const Object& object, Side side) const;

    AvatarConfig config_;
    CompletenessLimits limits_;
    StereoCoordinateCalculator calculator_;
    cv::Matx33d rightRLeft_;
};

}  // namespace avatar::detail
