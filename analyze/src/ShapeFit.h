#pragma once
/// @file ShapeFit.h
/// Internal to avatar::analyze: the round shape models (thesis 3.4.2 done
/// with the geometry of conics). A sphere's silhouette and a flat circle's
/// image are both ellipses in undistorted coordinates, so each silhouette is
/// first fitted with an ellipse robustly (outline points that do not follow
/// it are found, and the parts of the ellipse no point supports are
/// explained: beyond the image or window edge, behind another target, or
/// simply missing); then the 3-D interpretation:
/// - sphere: the silhouette is the image of a circular cone whose axis
///   passes through the centre; the axis is the eigenvector of the conic's
///   odd eigenvalue, the cone's half-angle gives the radius once the range
///   is known, and a circular cone has two equal eigenvalues (anisotropy 0);
/// - disc: the circle's plane normal follows from the conic up to a two-fold
///   ambiguity (the two circular sections of an elliptic cone); both cameras
///   must agree on it, and the image of the circle's centre is the pole of
///   the plane's vanishing line, Q^-1 n: not the ellipse's centre.

#include "Silhouette.h"

#include <avatar/common/CameraModel.h>

#include <opencv2/core/matx.hpp>
#include <opencv2/core/types.hpp>

#include <functional>
#include <optional>
#include <utility>
#include <vector>

namespace avatar::detail {

/// A robust ellipse fit of a silhouette's free outline points.
struct EllipseFit {
    bool ok{false};
    /// The ellipse in ideal pixels: undistorted normalised coordinates x fc[0].
    cv::RotatedRect ideal;
    /// Its conic in undistorted normalised coordinates, x^T Q x = 0, x = (u, v, 1).
    cv::Matx33d conic;
    double rmsPx{0.0};          ///< RMS distance of the inliers from the ellipse
    double thresholdPx{0.0};    ///< the inlier limit used
    int points{0}, inliers{0};
    int excessPoints{0};        ///< free points outside the ellipse beyond the limit
    int farExcessPoints{0};     ///< of them, those more than a pixel outside (rim points aside)
    int deficitPoints{0};       ///< free points inside it beyond the limit
    /// Covariance of the ellipse's parameters (centre x, y and semi-axes in
    /// ideal pixels, angle in rad; @p ideal's order and axes) from the
    /// inliers' position noise (OutlinePoint::sigmaPx), each point taken as
    /// independent: the weighted least-squares covariance of a geometric fit.
    cv::Matx<double, 5, 5> parameterCovariance;
};

/// The covariance (normalised coordinates squared) of a point that
/// @p modelPoint computes from an ellipse's conic (undistorted normalised
/// coordinates; the sphere's cone axis, the disc's centre image), propagated
/// from @p fit's parameter covariance by central differences; null when the
/// point cannot be computed near the fit.
std::optional<cv::Matx22d> modelPointCovariance(
    const EllipseFit& fit, double f, const std::function<std::optional<cv::Point2d>(const cv::Matx33d&)>& modelPoint);

/// What the image shows at a point (distorted pixels).
using PixelProbe = std::function<EdgeKind(const cv::Point2d& px, bool& ownFeature)>;

/// How complete a silhouette is against its fitted ellipse.
struct RoundCompleteness {
    int bins{0};           ///< the ellipse's outline in equal angle bins
    int supported{0};      ///< bins with an inlier outline point
    int present{0};        ///< unsupported bins where the silhouette still reaches the ellipse
    int cut{0};            ///< unsupported bins beyond the image or window edge
    int hidden{0};         ///< unsupported bins at another target: hidden if it is nearer
    std::vector<cv::Point2d> hiddenPx;  ///< where those bins' ellipse points lie (distorted pixels)
    /// Present bins at another target whose own pixels begin only past the
    /// seam of mixed pixels: complete if it is the nearer one, which only
    /// the depths can tell.
    int seam{0};
    int missing{0};        ///< unsupported bins with background: hidden by something else, or not an ellipse
    /// Missing bins with the silhouette's own pixels 1.75 px inside the
    /// ellipse: within a pixel or two of it, as the outline of a circle fitted
    /// on a short arc may be.
    int shallow{0};
    std::vector<int> missingBins;  ///< which bins are missing (bin k spans angle parameters -pi + [k, k + 1) 2 pi / bins)
    std::vector<int> shallowBins;  ///< which of missingBins are shallow
    /// The missing bins at a fragment (pixels of a filter that are no
    /// feature's) on the ellipse or within 2 px either side of it: what is
    /// there may be an object behind the target or in front of it, which
    /// only the other view can tell. Each is in missingBins too.
    std::vector<int> fragmentBins;
    int fragmentShallow{0};  ///< of the fragment bins, those that are shallow
    std::vector<cv::Point2d> fragmentPx;  ///< where a fragment bin's probes met the fragment (distorted pixels)
    bool excess{false};    ///< outline points well outside the ellipse: more than one object
};

/// @p c as if its fragment bins were explained (not missing): what is left
/// once the other view has shown the fragments to lie behind the target.
RoundCompleteness withoutFragments(const RoundCompleteness& c);

/// The conic (undistorted normalised coordinates, x^T Q x = 0) of ellipse
/// @p e given in ideal pixels (normalised x @p f) relative to @p offset
/// (normalised).
cv::Matx33d ellipseConic(const cv::RotatedRect& e, double f, const cv::Point2d& offset);

/// Fits @p outline's free points but a notch's walls (needs at least 10). @p minThresholdPx is
/// the smallest inlier limit (the fit's accuracy).
EllipseFit fitEllipse(const CameraIntrinsics& camera, const std::vector<OutlinePoint>& outline,
                      double minThresholdPx);

/// Explains each part of the fitted ellipse: supported by outline points, or
/// why not (@p probe tells what lies at a pixel).
RoundCompleteness roundCompleteness(const CameraIntrinsics& camera, const EllipseFit& fit,
                                    const std::vector<OutlinePoint>& outline, const PixelProbe& probe);

/// What the image shows beyond a missing bin: whether, 1.5-3.5 px outside
/// the ellipse at any of @p c's missing bins, the colour differs from the
/// background's all around the outline (the same distance outside every
/// other bin where the probe finds free background) by more than @p factor
/// times that background's spread (median absolute deviation, per channel
/// in natural log) and at least @p minLog: something in front of the target
/// there (a stone, a speck of silt) whose pixels no filter passes, rather
/// than the dark limb a filter left a bin short. @p colourAt gives the
/// image's colour (B, G, R) at a distorted pixel.
///
/// With the target's own colour @p target (its mean, B, G, R), inside the
/// ellipse is looked at too: where, 0.5-4.5 px inside at a missing bin, two
/// pixels that are not the target's are brighter (mean log over the
/// channels) than both the background and the target by @p insideLog and by
/// @p factor times the background's spread, something bright lies in front
/// of the outline there (a speck of silt whose mixed rim the filter cut
/// open, so that the outline runs round it inside). What mixes the target's
/// colour with the background's, or dims it, is not that bright.
///
/// With @p deepOnly, only the missing bins that are not shallow are judged
/// (every missing bin still stays out of the background's sample): where a
/// circle fitted on a short arc runs a pixel or two outside the silhouette,
/// what lies beyond is the silhouette's own mixed rim, not what hides it.
bool foreignAtMissing(const CameraIntrinsics& camera, const EllipseFit& fit, const RoundCompleteness& c,
                      const std::function<cv::Vec3d(const cv::Point2d&)>& colourAt, const PixelProbe& probe,
                      double factor, double minLog, const std::optional<cv::Vec3d>& target = std::nullopt,
                      double insideLog = 0.5, bool deepOnly = false);

/// The number of concavities of a silhouette's outline deeper than
/// @p minDepthPx whose deepest point borders free background (not another
/// target, nor an edge): a round target has none, one with a bite taken by
/// something in front of it one, two touching round targets in one feature
/// two (the waist on either side).
int freeConcavities(const Silhouette& silhouette, double minDepthPx);

/// A composite silhouette (the duck: a body and a head sphere) as the
/// union of round parts, fitted to its free and contact outline points (a
/// part in front of a neighbour shows its outline there too). A sphere's outline is the image of a circular cone
/// about the ray to its centre: the unit rays of its outline points are all
/// equally far from that axis, so they lie in one plane whose normal is the
/// axis. Each part is found by consensus over the points no larger part
/// explains (three rays give a plane; the largest set within
/// @p partThresholdPx of one cone wins), its cone refined by a plane fit.
struct PartsFit {
    /// The parts, the one with most outline points first: each its cone's
    /// ellipse, with the RMS of its points about the cone (no covariance).
    std::vector<EllipseFit> parts;
    /// Each part's own outline points, free and contact (what its cone was fitted to).
    std::vector<std::vector<OutlinePoint>> outlines;
    int points{0};   ///< free and contact outline points
    int outside{0};  ///< points no part explains that lie outside every part: another object
    int inside{0};   ///< points no part explains that lie inside a part: a bite out of it
};
/// A consensus is a part only when the silhouette lies inside its arc: at
/// @p minPartSided of its points, the pixel 1.5 px further from its centre
/// is not @p silhouette's own (points along a neighbour in front of the
/// object follow the neighbour's circle, with the silhouette beyond it).
PartsFit fitRoundParts(const CameraIntrinsics& camera, const Silhouette& silhouette, double minThresholdPx,
                       double partThresholdPx, int maxParts, double minPartSided);

/// The covariance (undistorted normalised coordinates squared) of the axis
/// image (x/z, y/z) of the cone of @p part, a part of fitRoundParts() fitted
/// to @p outline's rays (its free and contact points): each point's noise
/// (OutlinePoint::sigmaPx, independent) moves its ray across the cone by
/// sin(half-angle) of it, and the plane fit's normal varies as that noise
/// over the rays' scatter in the plane. Null for a part without a cone.
std::optional<cv::Matx22d> coneAxisCovariance(const CameraIntrinsics& camera, const EllipseFit& part,
                                              const std::vector<OutlinePoint>& outline);

/// The index of the part of @p parts (with an ellipse) whose outline is
/// nearest image pixel @p px; -1 when none has one.
int nearestPart(const CameraIntrinsics& camera, const PartsFit& parts, const cv::Point2d& px);

/// Whether image pixel @p px lies inside, or within @p thresholdPx (ideal
/// pixels) outside, the ellipse of some part of @p parts.
bool withinParts(const CameraIntrinsics& camera, const PartsFit& parts, const cv::Point2d& px, double thresholdPx);

/// The box (image pixels) of @p silhouette's outline points that lie within
/// @p thresholdPx of some part of @p parts: a composite's extent without
/// the outline no part explains (a beak's mixed pixels that pass the body's
/// filter in one view and not the other). Null when no point is explained.
std::optional<cv::Rect2d> partsExtent(const CameraIntrinsics& camera, const PartsFit& parts,
                                      const Silhouette& silhouette, double thresholdPx);

/// The share of @p silhouette's own pixels (its labels) that lie outside
/// every part of @p parts that has an ellipse, each part grown by
/// @p growPx: what the round parts do not explain (a beak; a neighbour of
/// its colour run into it; the corners of a box).
double shareOutsideParts(const CameraIntrinsics& camera, const PartsFit& parts, const Silhouette& silhouette,
                         double growPx);

/// The sphere interpretation of an ellipse.
struct SphereCone {
    cv::Point2d axis;        ///< normalised direction (x/z, y/z) of the centre
    double halfAngle{0.0};   ///< rad
    double anisotropy{0.0};  ///< |l1 - l2| / |l1 + l2| * 2 of the two same-sign eigenvalues: 0 for a sphere
};
std::optional<SphereCone> sphereCone(const cv::Matx33d& conic);

/// The least and greatest rectified rows v = q_y / q_z (q = @p rect x) of
/// the ellipse @p conic (undistorted normalised coordinates, x^T Q x = 0):
/// the two rows whose lines through the image, rect^T (0, 1, -v), touch it
/// (l^T Q^-1 l = 0, a quadratic in v). Null when there are not two.
std::optional<std::pair<double, double>> conicRowRange(const cv::Matx33d& conic, const cv::Matx33d& rect);

/// The two candidate unit normals (camera frame, pointing towards the
/// camera) of a circle whose image is @p conic.
std::optional<std::array<cv::Vec3d, 2>> circleNormals(const cv::Matx33d& conic);

/// The normalised image of the centre of the circle of plane normal @p n
/// (camera frame) imaged as @p conic: Q^-1 n dehomogenised.
std::optional<cv::Point2d> circleCentre(const cv::Matx33d& conic, const cv::Vec3d& n);

/// The disc interpretation of a pair of ellipses: the normal both cameras
/// agree on best (left frame) and the angle between their candidates.
struct DiscPair {
    cv::Vec3d normalLeft;
    double disagreementRad{0.0};
    cv::Point2d centreLeft, centreRight;  ///< normalised images of the circle's centre
};
std::optional<DiscPair> discPair(const cv::Matx33d& conicLeft, const cv::Matx33d& conicRight,
                                 const cv::Matx33d& rightRLeft);

}  // namespace avatar::detail
