#pragma once
/// @file TargetAssembly.h
/// Internal: how matched and unmatched features become the targets of a
/// VisionTargets (thesis 3.4.2, 3.6.2): the position of each stereo target
/// (sphere silhouette cone, nine points or centroid), its flags, and the
/// single-image targets.

#include <avatar/analyze/Feature.h>
#include <avatar/analyze/SIPFeatureMatcher.h>
#include <avatar/common/ImageFormat.h>
#include <avatar/common/StereoCoordinateCalculator.h>
#include <avatar/common/VisionTargets.h>
#include <avatar/config/AnalysisConfig.h>
#include <avatar/config/StereoSystemConfig.h>
#include <avatar/config/TargetConfig.h>

#include <opencv2/core/mat.hpp>

#include <vector>

namespace avatar::detail {

class TargetAssembler {
public:
    TargetAssembler(const StereoSystemConfig& stereo, const AnalysisConfig& analysis);

    /// Appends the targets of one type: a stereo target per match (in match
    /// order), then the unmatched left features, then the unmatched right ones.
    /// @p leftMask and @p rightMask are the type's masks the features were found in.
    void assemble(const TargetType& type, const std::vector<Feature>& left, const std::vector<Feature>& right,
                  const cv::Mat& leftMask, const cv::Mat& rightMask, const std::vector<FeatureMatch>& matches,
                  std::vector<VisionTarget>& out) const;

    /// A matched pair. A sphere away from the border is triangulated through
    /// its silhouette cones (kTargetShapeCorrected); otherwise by the nine
    /// points when configured, else by its centroids. Parallel rays give no
    /// position and clear kTargetStereo.
    VisionTarget stereoTarget(const TargetType& type, const Feature& left, const Feature& right,
                              const cv::Mat& leftMask, const cv::Mat& rightMask, const FeatureMatch& match) const;
    /// A feature seen in one image only.
    VisionTarget singleTarget(const TargetType& type, const Feature& feature, Side side) const;

private:
    /// The configured centroid of a feature.
    cv::Point2d point(const Feature& f) const { return weighted_ ? f.weightedCentroid : f.centroid; }

    StereoCoordinateCalculator calculator_;
    bool weighted_;
    bool ninePoints_;
};

}  // namespace avatar::detail
