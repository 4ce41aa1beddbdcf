#pragma once
/// @file SIPFeatureMatcher.h
/// Stereo feature matching (thesis 3.4.1): the shape method (Figures 3-14,
/// 3-15), the epipolar box (Figure 3-16) with shape to break ties, and the
/// general epipolar-line method for cameras that are not parallel (Appendix A).

#include <avatar/analyze/Feature.h>
#include <avatar/config/MatchConfig.h>
#include <avatar/config/StereoSystemConfig.h>

#include <opencv2/core/matx.hpp>

#include <vector>

namespace avatar {

/// A left feature paired with a right feature (indices into the lists given to match()).
struct FeatureMatch {
    int left{-1};
    int right{-1};
    double shapeError{0.0};
};

/// Shape difference of two features from the M (distances) and S (unit
/// vectors) matrices of their nine interest points, Figure 3-14: the weighted
/// sum over point pairs of |M_a - M_b| / scale and |S_a - S_b|.
double shapeError(const Feature& a, const Feature& b, const ShapeMatchConfig& weights);

/// Fundamental matrix F of Appendix A: l_right = F p_left for homogeneous pixels.
cv::Matx33d fundamentalMatrix(const StereoSystemConfig& stereo);

class SIPFeatureMatcher {
public:
    SIPFeatureMatcher(const MatchConfig& match, const StereoSystemConfig& stereo);

    /// Pairs left and right features; each feature is used at most once. A
    /// right feature claimed by several left features goes to the lowest
    /// shape error (HandleRepeatMatches). Matches are ordered by left index.
    /// Cost grows with the number of candidates, not with left x right, for
    /// the box and line methods.
    std::vector<FeatureMatch> match(const std::vector<Feature>& left,
                                    const std::vector<Feature>& right) const;

private:
    MatchConfig match_;
    StereoSystemConfig stereo_;
    cv::Matx33d fundamental_;
};

}  // namespace avatar
