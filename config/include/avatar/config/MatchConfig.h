#pragma once
/// @file MatchConfig.h
/// Stereo feature matching parameters (thesis 3.4.1, 4.2.4).

namespace avatar {

/// How left and right features are paired.
enum class MatchMethod {
    Shape,         ///< least shape difference with the centroid-x constraint (Figure 3-15)
    EpipolarBox,   ///< disparity box (Figure 3-16), shape breaks ties
    EpipolarLine   ///< distance to the calibrated epipolar line within a depth range
};

/// What happens to a left feature whose chosen right feature goes to another
/// left feature of lower shape error (HandleRepeatMatches, Figure 3-15).
enum class RepeatMatchPolicy {
    Void,     ///< it stays unmatched, as in the thesis
    Reassign  ///< re-paired along an augmenting path where its candidates allow (SIPFeatureMatcher.h)
};

/// Weights and limits of the shape difference between two features (Figure 3-14).
struct ShapeMatchConfig {
    double magnitudeWeight{1.0};  ///< weight of relative point-to-point distance differences
    double directionWeight{1.0};  ///< weight of unit-vector direction differences
    double maxError{1e9};         ///< a pair with a larger shape error is not a match
    double maxAreaRatio{4.0};     ///< larger/smaller feature area above this: not a match
    bool operator==(const ShapeMatchConfig& o) const {
        return magnitudeWeight == o.magnitudeWeight && directionWeight == o.directionWeight &&
               maxError == o.maxError && maxAreaRatio == o.maxAreaRatio;
    }
};

struct MatchConfig {
    MatchMethod method{MatchMethod::EpipolarBox};
    /// Disparity box: dx = x_left - x_right, dy = y_left - y_right, in pixels.
    double boxDxMin{0.0};
    double boxDxMax{400.0};
    double boxDyMin{-10.0};
    double boxDyMax{10.0};
    /// EpipolarLine: largest distance in pixels from the epipolar line.
    double maxEpipolarDistancePx{3.0};
    /// EpipolarLine: depth range in millimetres the targets can be at.
    double minRangeMm{200.0};
    double maxRangeMm{5000.0};
    ShapeMatchConfig shape;
    /// Left features that lose their chosen right feature to another.
    RepeatMatchPolicy repeats{RepeatMatchPolicy::Reassign};

    bool operator==(const MatchConfig& o) const {
        return method == o.method && repeats == o.repeats && boxDxMin == o.boxDxMin && boxDxMax == o.boxDxMax &&
               boxDyMin == o.boxDyMin && boxDyMax == o.boxDyMax &&
               maxEpipolarDistancePx == o.maxEpipolarDistancePx && minRangeMm == o.minRangeMm &&
               maxRangeMm == o.maxRangeMm && shape == o.shape;
    }
};

}  // namespace avatar
