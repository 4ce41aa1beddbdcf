#pragma once
/// @file SIPFeatureMatcher.h
/// Stereo feature matching (thesis 3.4.1): the shape method (Figures 3-14,
/// 3-15), the epipolar box (Figure 3-16) with shape to break ties, and the
/// general epipolar-line method for cameras that are not parallel (Appendix A).

#include <avatar/analyze/Feature.h>
#include <avatar/common/StereoCoordinateCalculator.h>
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
///
/// Over the 36 unordered pairs (i, j) of Feature::interestPoints():
///   error = magnitudeWeight * sum |M_a - M_b| / (0.5 * (sum M_a + sum M_b))
///         + directionWeight * mean |S_a - S_b|
/// i.e. the mean distance difference divided by the mean distance of the two
/// features. Scaling both features by the same factor leaves the error
/// unchanged (one maxError serves near and far targets), while a size
/// difference between the two still counts. Each term lies in [0, 2], so the
/// error lies in [0, 2 (magnitudeWeight + directionWeight)]. Coincident points
/// (one-pixel or one-row features) have S = (0, 0), as the thesis's diagonal,
/// and two point-like features have a magnitude term of 0: never NaN.
/// Symmetric: shapeError(a, b) == shapeError(b, a).
double shapeError(const Feature& a, const Feature& b, const ShapeMatchConfig& weights);

/// Pairs the features of the left and right images by MatchConfig::method.
///
/// Every method admits a pair only when the larger area is at most
/// shape.maxAreaRatio times the smaller and the shape error is at most
/// shape.maxError; among several admissible right features a left feature
/// takes the one of least shape error (equal errors: the lower right index).
/// - Shape (Figure 3-15): every right feature with x_left > x_right (centroids,
///   pixels) is admissible. O(n_left * n_right) candidates.
/// - EpipolarBox (Figure 3-16): right features whose centroid satisfies
///   boxDxMin < x_left - x_right < boxDxMax and boxDyMin < y_left - y_right <
///   boxDyMax, in distorted pixels as the thesis's box.
/// - EpipolarLine: centroids are undistorted (normalizePixel) and mapped to
///   undistorted pixels; a right feature is admissible when (1) its distance
///   to the epipolar line F p_left is at most maxEpipolarDistancePx, (2) it
///   lies within 2 * maxEpipolarDistancePx + 2 px of the segment of that line
///   between the right-image projections of the left ray's points at depths
///   minRangeMm and maxRangeMm (shortened where the ray passes behind the
///   right camera), and (3) the pair triangulates to a left-camera depth z in
///   [minRangeMm, maxRangeMm] (StereoCoordinateCalculator's midpoint
///   triangulation, Figure 3-18). The fundamental matrix F is that of
///   avatar/common/CameraModel.h (Appendix A). Rule (2) keeps out pairs whose
///   rays are nearly parallel (disparity near zero: a point near infinity),
///   whose midpoint can land at any depth.
/// Box and line look up candidates in a grid of the right centroids, so their
/// cost grows with the number of candidates, not with n_left * n_right.
///
/// The shape error (36 point pairs) is not computed for every candidate: a
/// lower bound of it from the features' summed distances and directions (one
/// square root) rules out candidates that cannot beat the best one found, or
/// exceed maxError, and the result is the same as computing every shape error,
/// bit for bit (tests/analyze/FeatureMatcherTest.cpp, CandidatePruning). With
/// 1,000 look-alike targets per 640x480 image in scorpion.xml's box (27
/// candidates per left feature) about one candidate in four is evaluated.
///
/// HandleRepeatMatches: a right feature chosen by several left features goes to
/// the lowest shape error (equal errors: the lower left index). What becomes
/// of the others is MatchConfig::repeats:
/// - RepeatMatchPolicy::Void: they stay unmatched, as in the thesis. They do
///   not fall back to their next-best candidate: with look-alike targets that
///   candidate is most often another target's image.
/// - RepeatMatchPolicy::Reassign (the default): each of them, in left order,
///   is re-paired along the best augmenting path of at most three left
///   features, if there is one: it takes one of its four best admissible
///   right features (by shape error, then index); the left feature holding
///   that one moves to another of its own four best, and so on, until a
///   right feature no match holds is taken. Best is the least shape error
///   added (the new pairs' errors less the errors of the pairs they
///   replace), then the fewest left features moved, then the lower right
///   indices. Every left feature matched before
///   stays matched, every pair stays admissible, and the matches grow by one
///   per path. It undoes the commoner failure with look-alikes in a tall
///   box: a left image that took a look-alike's right image with a lower
///   error than the look-alike's own left image gives it back and takes its
///   own, where voiding stranded both targets (docs/accuracy.md, the
///   thirtieth and thirty-first rounds: 6 whole targets gained on 28 seeds of
///   60 varied scenes, none lost, no false whole added). Its cost is bounded
///   by the path length and the four options: at most 4 + 16 + 64 paths
///   looked at per voided left feature, whose options are found with the
///   same shape error bound as above, and nothing at all when no repeat was
///   voided.
///
/// Immutable after construction; match() is safe to call from several threads.
class SIPFeatureMatcher {
public:
    /// Checks both parts with the configuration's own rules
    /// (validateMatchConfig(), validateStereoConfig()) and throws their
    /// ConfigError, naming the element, for one that cannot be used.
    SIPFeatureMatcher(const MatchConfig& match, const StereoSystemConfig& stereo);

    /// Pairs left and right features; each feature is used at most once. A
    /// right feature claimed by several left features goes to the lowest
    /// shape error (HandleRepeatMatches); the others are voided or re-paired
    /// (MatchConfig::repeats). Matches are ordered by left index.
    /// Cost grows with the number of candidates, not with left x right, for
    /// the box and line methods. Throws avatar::InvalidArgument when a feature
    /// has an area below 1 or a centroid that is not finite.
    std::vector<FeatureMatch> match(const std::vector<Feature>& left,
                                    const std::vector<Feature>& right) const;

private:
    MatchConfig match_;
    StereoCoordinateCalculator calculator_;
    cv::Matx33d fundamental_;
};

}  // namespace avatar
