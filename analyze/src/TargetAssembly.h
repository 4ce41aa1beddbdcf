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
/// - a colour two types may have (undecided) leaves the type to the shape
///   where one has a round model and the other a composite one: a target
///   not whole by its filter's type's model but whole by the other's is
///   the other's (TargetAssembler::decideByShape());
/// - two touching spheres of one colour (one merged feature in each view)
///   are two targets when both views show two sphere cones that pair up in
///   space (TargetAssembler::splitMerged()); the farther one is occluded
///   where their images overlap;
/// - the position comes from the shape model that fits (sphere cone axes,
///   disc centres), else the centroids; its covariance from the centroids'
///   through the triangulation;
/// - kTargetWhole only when nothing says otherwise.

#include "ColorFilterKernel.h"
#include "Silhouette.h"

#include <avatar/analyze/Feature.h>
#include <avatar/analyze/ProcessStereoImagePair.h>
#include <avatar/analyze/SIPFeatureMatcher.h>
#include <avatar/common/StereoCoordinateCalculator.h>
#include <avatar/common/VisionTargets.h>
#include <avatar/config/AvatarConfig.h>

#include <opencv2/core/mat.hpp>

#include <array>
#include <optional>
#include <vector>

namespace avatar::detail {

/// The evidence thresholds of the completeness checks (docs/accuracy.md
/// says how they were chosen: on scene sets of one seed, reported on another).
struct CompletenessLimits {
    double minFitThresholdPx{0.5};  ///< smallest inlier limit of the ellipse fits
    int maxUnsupportedBins{1};      ///< ellipse bins without outline points that are tolerated
    double maxFitRmsPx{0.45};       ///< RMS of a round silhouette's inliers about its ellipse
    double maxSphereAnisotropy{0.04};  ///< of a sphere's cone (0 for a sphere)
    /// A small sphere's cone may be elongated by more: the filter loses up
    /// to a pixel of its dim limb, so its outline's radius differs by that
    /// across it. The limit is then this (px) over the ellipse's mean radius
    /// in pixels, when larger (5 % at 15 px; 0.04 from 19 px on).
    double sphereLimbPx{0.75};
    double maxSphereRadiusMismatch{0.03};  ///< relative, between the two views' radii
    double maxDiscNormalDisagreementRad{0.09};  ///< about 5 degrees
    double maxSizeMismatch{0.04};   ///< relative, of a round target's size between the views
    double maxAreaMismatch{0.08};
    /// relative, of the range-scaled widths and heights of other shapes
    double maxExtentMismatch{0.15};
    /// A target without a round model this close to the image's or the
    /// search window's edge (px) is cut.
    int nearEdgePx{3};   ///< relative, of the range-scaled areas of other shapes
    double minConcavityDepth{0.08};  ///< of a round silhouette's waist, relative to its radius
    /// Two touching targets at nearly one depth: the one whose model's
    /// bins run on under the other in at least this many bins (the other's
    /// running under nothing) is behind it (0: the depths alone judge).
    int minSeamOrderBins{2};
    /// A contact is judged against the targets the outline's contact points
    /// lie at (false: against every target whose box is within 3 px).
    bool touchedOnly{true};
    double minTypeShare{0.8};       ///< of an object split between filters, for its type to be decided
    double minTypeShareUnchecked{0.97};  ///< the same when a type of the object has no round model
    /// A colour that another type's filter passes once its R/G or B/G
    /// changes by this factor (natural log; 0.1 = 10 %) cannot be told from
    /// that type: a colour between two filters, or one water or light has
    /// moved. Its type is undecided, and touching features of two types are
    /// fragments of one object only when one's colour is this near the
    /// other's filter (otherwise they are two targets).
    double typeMarginLog{0.1};
    /// A colour that another type with a haze veil explains as its own seen
    /// through more haze than its filter passes (its clear colour moved
    /// towards the veil by a share between this and kHazeShareMax) is that
    /// type's as likely as its own: undecided. Below this share, pixels of
    /// other colours under water lie there too.
    double minHazeShare{0.1};
    /// A round silhouette with a missing bin (within maxUnsupportedBins) is
    /// hidden there when, 1.5-3.5 px outside its ellipse, the colour differs
    /// from the free background's all around the outline by at least
    /// minForeignLog (B/G or R/G either way, or brighter; natural log) and
    /// by foreignFactor times that background's spread: something in front
    /// of it that no filter passes (a stone, a speck of silt), not a limb
    /// the filter left a bin short of (foreignAtMissing()).
    double minForeignLog{0.1};
    double foreignFactor{4.0};
    /// A round silhouette with a hole of at least this many pixels (inside
    /// its outline, passed by no filter) whose mean colour differs from the
    /// target's by at least minHoleColourLog (R/G or B/G, natural log) and
    /// tells from the target by holeNoiseFactor times that mean's noise
    /// (holeEvidence()), or differs by twice minHoleColourLog and by
    /// holeNoiseFactor times the noise, is hidden in part by something in
    /// front of it. Noise leaves holes too: small ones, near
    /// the target's colour (in the dark, single pixels stray far, and the
    /// pixels a filter leaves out are the noise's tail: holes of 4 px,
    /// 0.4-0.6 from the target's colour in log, in dark frames of the
    /// trust report's seeds 30, 32 and 37 called whole targets hidden; of
    /// 5-19 px, 0.5-0.76 from it but only 0.1-0.35 past the filter's edge,
    /// at a dim limb, in dark frames of seeds 40-57).
    int minHolePx{5};
    /// Largest difference (px) between the two views' top or bottom
    /// rectified rows (the epipolar tangency of a whole rigid object;
    /// whole targets agree within 0.3 px, median).
    double maxTangencyPx{2.0};
    /// A porous round feature (a hole of its own colour, an outline no
    /// ellipse fits) is measured again with its mask closed, 5x5: only from
    /// this mean radius (px) of its ellipse on, two and a half times the
    /// widest channel the closing shuts (docs/accuracy.md, the
    /// thirty-sixth round).
    double minPorousRadiusPx{10.0};
    /// A partial neighbour's depth from its outlines' free edges
    /// (Built::outlineDepthMm): the fewest rectified rows with an edge free
    /// in both views (both sides together); the largest spread of each
    /// side's disparities (median absolute deviation: this many px, or this
    /// share of the disparity); and how far apart the two sides' medians
    /// may be (this share of the disparity, or twice that spread in px: a
    /// disc tilted 45 degrees about the vertical, 35 mm across at 0.9 m,
    /// has its rims' disparities 5.5 % apart).
    int minOutlineDisparityRows{8};
    double maxOutlineDisparitySpreadPx{1.0};
    double maxOutlineDisparitySpreadShare{0.03};
    double maxOutlineDisparitySidesShare{0.08};
    double minHoleColourLog{0.5};
    double holeNoiseFactor{4.0};
    /// Variance factor of the centroid covariance (see measureSilhouette()):
    /// measured, trust_report --covariance 40 --seed 21
    /// --covariance-centroids (docs/accuracy.md).
    double centroidCorrelation{66.0};
    /// The same for a round model's point, whose covariance is propagated
    /// from the outline through the ellipse fit (modelPointCovariance()):
    /// measured per model, trust_report --covariance 40 --seed 21. A
    /// sphere's shaded limb needs more: its edges are placed against the
    /// colour a few pixels inside, which neighbouring edge points share.
    double sphereFitCorrelation{38.0};
    double discFitCorrelation{20.0};
    /// A composite's body placed by its part's cone (coneAxisCovariance()):
    /// measured on three ducks over noise seeds 7100-7129 (38 gave
    /// 1.2-1.55 times too small a sigma); Accuracy.ADucksPredictedSigmaMatchesItsSpread
    /// checks it on other seeds.
    double compositeFitCorrelation{75.0};
    /// A composite type's round parts (fitRoundParts()): at most this many
    /// (the duck's body and head), each point within partThresholdPx of its
    /// part's cone.
    int compositeParts{2};
    double partThresholdPx{1.0};
    double minPartSided{0.8};  ///< of a part's points with the silhouette on the inside of its arc (fitRoundParts())
    /// Largest share of a composite's pixels its parts may leave
    /// unexplained (a duck's beak that the filter passes in part).
    double maxStrayShare{0.04};
    /// A round part more than the type has, at least this share of the
    /// body's diameter and covering minPartCoverage of its circle, is
    /// another object of its colour run into it: `merged` (two touching
    /// ducks, whose other head is left over; seed 49). Beak corners fit
    /// circles of 0.08-0.16 of it.
    double minExtraPartRatio{0.3};
    /// A composite's other parts (the head) are checked when their outline
    /// covers this share of their circle, and may then miss this share of
    /// it (what a beak covers).
    double minPartCoverage{0.25};
    double maxPartMissing{0.15};
    /// A silhouette that the shape decides is a composite type's
    /// (decideByShape()) must show the composite's head in both views, sunk
    /// into its body: their centres at most this share of the sum of their
    /// radii apart (a duck's 0.6; two touching spheres 1).
    double maxPartSeparation{0.8};
    /// ... and at least this share: a second part nearly at the body's
    /// centre is no head but the body's own outline fitted twice (a far
    /// orange sphere with a ragged limb, fitted without its deeper notches
    /// in a trial, had one at 0.09 and was taken for a whole yellow duck;
    /// docs/accuracy.md, the twenty-eighth round). Half a duck's; heads lay
    /// at 0.41-0.73 in the 74 decisions for a duck on 28 seeds of
    /// trust_report.
    double minPartSeparation{0.3};
    /// Two touching spheres of one colour in one feature (merged) are told
    /// apart when each view's outline is two sphere cones (fitRoundParts()
    /// with two parts) that pair up across the views within this RMS
    /// reprojection error (px) and these radii (maxSphereRadiusMismatch).
    double maxSplitReprojectionPx{1.0};
    /// Two such spheres apart in space whose cones from the camera overlap
    /// by more than this (px at the focal length): the one whose surface a
    /// ray through the overlap meets second is hidden in part there.
    double maxSplitOverlapPx{0.25};
    /// Two spheres touch when the gap between them in space is within the
    /// larger of these (touching pairs split from one feature measured
    /// 0.3-1.3 mm apart on seeds 11 and 16 of trust_report); then the one
    /// behind the contact is hidden in part in that view.
    double splitTouchMm{1.5};
    double splitTouchShare{0.05};  ///< of the sum of their radii
    /// A sphere touching another is hidden in part when the sliver behind
    /// the contact would hide at least this many pixels of it (a lens of
    /// 0.2 px depth between outlines of 70 and 50 px radius hides 1 px:
    /// less moves no centre measurably).
    double minHiddenAtContactPx{0.5};
    /// Each sphere is fitted on its outline points at least this far (px)
    /// outside the other's circle (the waist's mixed pixels bend both).
    double splitWaistPx{3.0};
    /// An object one view alone shows, touching a target there, lies
    /// behind it when the other view, at every disparity larger than the
    /// target's within the match box, shows less than this share of the
    /// object's area of its colour in a box of the object's size: in
    /// front, it would show there whole. (Any pixel of its colour in that
    /// stretch, which spans the workspace's depths and so often holds
    /// something else of its colour, had occluded three whole targets on
    /// 28 seeds of trust_report.)
    double minLoneShareInOtherView{0.5};
};

/// How far a colour (natural log of R/G and of B/G) lies outside each of
/// the ratio ranges of @p type's filter: R/G, B/G and R/B, natural log, 0
/// inside. None when the filter is not a box of ratios (HSV, brightness
/// bands).
std::optional<cv::Vec3d> outsideFilterLog(const TargetType& type, const cv::Vec2d& ratiosLog);

/// How many times its noise a hole's colour (@p offsetLog from the target's
/// around it, R/G and B/G, natural log, each with its standard error
/// @p noiseLog) tells it from the target: the largest over the ratios. On
/// a ratio the filter cut the hole's pixels by (@p outside, from
/// outsideFilterLog()) the pixels are chosen for straying, and a hole the
/// noise makes lies just past the filter's edge however far that edge is
/// from the target's colour: only how far past it counts. On any other
/// ratio the hole's colour is a fair sample: its distance from the
/// target's counts. Without @p outside, the distances on both.
double holeEvidence(const cv::Vec2d& offsetLog, const cv::Vec2d& noiseLog, const std::optional<cv::Vec3d>& outside);

/// Whether a hole in a round silhouette of @p type is made by something in
/// front of the target (CompletenessLimits::minHolePx says when).
bool foreignHole(const Silhouette::Hole& hole, const TargetType& type, const CompletenessLimits& limits);

/// Whether a composite's head lies where its type's does: seen in both
/// views (@p separation: the distance of its centre from the body's over
/// the sum of their radii, none when a view lacks it) and sunk into its
/// body, within the limits' minPartSeparation..maxPartSeparation.
bool headSunk(const std::optional<double>& separation, const CompletenessLimits& limits);

/// Whether an object seen in view @p side only (its box @p box, its
/// members' types @p memberTypes) lies behind a target whose disparity
/// (x_left - x_right) is at least @p minDisparityPx: in front of it, the
/// object would show in the other view at a larger disparity, within the
/// match box (dx up to its maximum, dy within its range: the workspace).
/// With @p minPx 0, none of its types' filters may pass a pixel there (a
/// fragment: too small to count on its shape); otherwise no box of its
/// size moved by such a disparity may hold @p minPx of their pixels (an
/// object: it would show whole; other things of its colour, such as a
/// target's own part of another colour, do not hide it; a box the other
/// image or a type's search window cuts must hold its share of @p minPx in
/// the part it shows). False where that stretch is empty, where the
/// object's box at one of its disparities shows less than a quarter of
/// itself in the other image and every type's search window (a fragment,
/// counted by any pixel: any part of it beyond them), or where the other
/// view was searched in regions only (tracking, coarse-to-fine): it may
/// lie there unseen.
bool behindByAbsence(const AnalysisFrame& frame, const MatchConfig& match, const std::vector<TargetType>& types,
                     const cv::Rect& box, const std::vector<std::size_t>& memberTypes, Side side,
                     double minDisparityPx, double minPx = 0.0);

/// Whether a hole in a silhouette of @p composite, found by a round type's
/// filter (its colour in haze), is a part of the composite of another colour
/// rather than something in front: its colour lies on the far side of the
/// target's from @p composite's veil, beyond holeNoiseFactor times the
/// noise, in R/G or B/G. A speck of silt in front is lit as the
/// backscatter is, so with the target's colour mixed in at its rim its hole
/// lies between the two colours or beyond the veil's (hazy ducks hidden by
/// silt: -0.1 to -0.2 in R/G, +1.2 to +2.0 in B/G from the duck's, natural
/// log); a duck's beak is redder than its body in any haze (+0.5 to +0.7 in
/// R/G). False for a type without a veil.
bool ownPartHole(const Silhouette::Hole& hole, const TargetType& composite, const CompletenessLimits& limits);

/// Which of @p types' filters (their search windows are ignored) pass the
/// colour @p bgr (in the units of @p depth, CV_8U or CV_16U, with
/// @p bitDepth significant bits) once its R/G and B/G are each moved by up
/// to @p marginLog (natural log) either way.
std::vector<bool> typesNear(const std::vector<TargetType>& types, const cv::Vec3f& bgr, int depth, int bitDepth,
                            double marginLog);

/// How a small sphere at @p pointMm (camera frame) is imaged, per unit of
/// its angular radius (radius / range): its image's area over pi (px^2),
/// and half the width and height of its bounding box (px). Off the axis the
/// image is stretched radially by 1/cos^2 and across by 1/cos of the ray's
/// angle; the lens distortion's Jacobian and the focal lengths follow.
struct ImageScale {
    double area{1.0}, width{1.0}, height{1.0};
};
ImageScale imageScale(const CameraIntrinsics& camera, const cv::Point3d& pointMm);

/// Of two touching spheres seen from @p camera (all in one frame, focal
/// length @p focalPx), the area in pixels of the first that the second
/// hides: 0 when the first is in front. The ray through their contact
/// point passes through the nearer sphere before it reaches the other, so
/// the one whose centre lies beyond the contact along that ray is hidden
/// there; not the nearer centre: a large sphere can hide a small one whose
/// centre is nearer, and two touching spheres hide each other in turn, one
/// in each view. How much: their outlines overlap by (rA + rB)(1 - cos phi)
/// at the contact's distance, phi the angle between the line through their
/// centres and the image plane (0 when they stand side by side), and a
/// lens of depth d between circles of radii r1, r2 has an area of about
/// 4/3 sqrt(2 r1 r2 / (r1 + r2)) d^1.5.
double hiddenAtContactPx(const cv::Point3d& a, double radiusA, const cv::Point3d& b, double radiusB,
                         const cv::Point3d& camera, double focalPx);

/// Of two spheres seen from @p camera, the share of the first's cone that
/// the second hides: its rays along which the second's surface comes first,
/// counted on a grid of 64 x 64 across the cone (in the plane at unit
/// distance along its axis; the image's share to within a few per cent off
/// the axis). For any two spheres, also ones that pass into each other,
/// which hide each other in turn (each in front where its own part of their
/// common lens lies nearer); 0 when the camera is inside either.
double hiddenShareBySphere(const cv::Point3d& a, double radiusA, const cv::Point3d& b, double radiusB,
                           const cv::Point3d& camera);

class TargetAssembler {
public:
    explicit TargetAssembler(const AvatarConfig& config, CompletenessLimits limits = {});

    /// Appends the targets of @p frame (its masks, features and matches of
    /// every type) to frame.result.targets: the stereo targets, then the
    /// features seen in one image only, by type.
    void assemble(AnalysisFrame& frame) const;

private:
    struct Object;
    /// Something one view shows beside a target (an object the other view
    /// does not, or a fragment): its box and the types whose filters pass it.
    struct Unseen {
        cv::Rect box;
        std::vector<std::size_t> types;
        int areaPx{0};  ///< its pixels (an object's; 0 for a fragment)
    };
    /// A stereo target, and in which views it touches another target (which
    /// only the depths of the targets it touches can judge).
    struct Built {
        VisionTarget target;
        bool contact[2]{false, false};
        /// Per view, a round target's outline points at another target
        /// where no bin of its model is (no contact): hidden there only by
        /// a sphere whose cone lies in front of its own (assemble()).
        bool glancing[2]{false, false};
        /// Per view: complete but for bins at these fragments, each of which
        /// the other view must show to lie behind it; empty: none.
        std::array<std::vector<Unseen>, 2> fragments;
        /// A composite's contact in a view that is not all on its body's
        /// outline (a contact point nearer another part's circle than the
        /// body's, or another part's bins at a target): what its body's
        /// sphere cannot judge by depth.
        bool contactOffBody[2]{false, false};
        /// Per view, where a round model's bins (a composite's parts' bins)
        /// run on under another target, and whether that model's outline
        /// is trusted to tell so (it fits, is not merged, not cut).
        std::array<std::vector<cv::Point2d>, 2> atTargetPx;
        bool seamTells[2]{false, false};
        /// Per view, its outline's points at another target (distorted
        /// pixels): the targets it touches there.
        std::array<std::vector<cv::Point2d>, 2> contactPx;
        /// Located by the sphere model: its radius; by the composite model:
        /// its body's (a sphere's cone); else 0.
        double sphereRadiusMm{0.0};
        /// Per view, the types its colour may as well be (rivals()); empty
        /// for a compound object.
        std::array<std::vector<bool>, 2> rivals;
        /// Per view, the types with a veil whose colour seen through any
        /// share of it up to kHazeShareMax (none too) is its colour; empty
        /// for a compound object.
        std::array<std::vector<bool>, 2> hazeRivals;
        /// Located by the composite model with a head in both views: the
        /// distance between head and body centres over their radii's sum
        /// (partSeparation() in TargetAssembly.cpp).
        std::optional<double> partSeparation;
        /// `ambiguous` for a reason other than its colour's rivals: its
        /// fragments' types, its match, its shape or size.
        bool ambiguousNotByColour{false};
        /// The depth (mm, left camera frame) of its outlines' free edges
        /// matched row by row (outlineDisparity() in TargetAssembly.cpp),
        /// along its left centroid's ray; none where too few rows agree.
        std::optional<double> outlineDepthMm;
    };

    std::vector<Object> objects(const AnalysisFrame& frame, Side side) const;
    /// @p w with the features of round types that single-feature object @p o
    /// touches and is seen inside the convex hull of (in front of them)
    /// taken out of their masks; nullopt when there are none.
    std::optional<ImageWork> withoutNeighboursBehind(const ImageWork& w, const Object& o) const;
    std::vector<bool> typesNear(const cv::Vec3f& bgr, int depth, int bitDepth) const;
    /// The types other than @p own whose colour a colour of type @p own may
    /// as well be: within the margin of the colours their targets may have
    /// (clearColourTypes(): their clear colour through their water and
    /// veil, not their trained ranges where those are wider), or seen through
    /// thicker haze than their filters take (minHazeShare). With @p hazy,
    /// also the types whose colour seen through any share of their veil is
    /// this colour (Built::hazeRivals).
    std::vector<bool> rivals(const cv::Vec3f& bgr, std::size_t own, int depth, int bitDepth,
                             std::vector<bool>* hazy = nullptr) const;
    /// Whether rivals() names any type.
    bool undecided(const cv::Vec3f& bgr, std::size_t own, int depth, int bitDepth) const;
    /// The stereo target of two objects, judged by the shape model, size
    /// and name of type @p modelType (their own filter's type, or a rival
    /// the shape decides for: decideByShape()).
    Built stereoTarget(const AnalysisFrame& frame, const Object& left, const Object& right, double matchError,
                       bool conflict, std::size_t modelType) const;
    /// @p own (the objects judged as their filter's type), merged or
    /// occluded by its type's model, as another type: where its colour
    /// leaves one rival type in all (either view's rivals() when undecided;
    /// when decided and its type is round, either view's hazeRivals: a
    /// composite type), with the other kind of model (round against
    /// composite), and that model finds the target whole (a composite with
    /// its head seen in both views, sunk into its body: maxPartSeparation),
    /// that type's target. Neither merged nor occluded, decideForOwn().
    /// Otherwise none (@p own stands).
    std::optional<Built> decideByShape(const AnalysisFrame& frame, const Object& left, const Object& right,
                                       double matchError, const Built& own) const;
    /// @p own whole by its type's model but `ambiguous` for its colour
    /// alone, with one rival type of the other kind of model: its own
    /// type's, no longer ambiguous, where its model's evidence is positive
    /// (a round model placed it; a composite's head shows in both views,
    /// sunk into its body) and the rival's model finds it merged, not its
    /// shape or size (Built::ambiguousNotByColour), or, a round rival,
    /// occluded; otherwise none.
    std::optional<Built> decideForOwn(const AnalysisFrame& frame, const Object& left, const Object& right,
                                      double matchError, const Built& own) const;
    /// A merged stereo target of a round type as the two spheres it holds,
    /// when both views show them (splitMerged() in TargetAssembly.cpp says
    /// what that takes); empty otherwise (it stays one merged target).
    std::vector<Built> splitMerged(const AnalysisFrame& frame, const Object& left, const Object& right,
                                   double matchError) const;
    VisionTarget singleTarget(const AnalysisFrame& frame, const Object& object, Side side) const;

    AvatarConfig config_;
    CompletenessLimits limits_;
    StereoCoordinateCalculator calculator_;
    cv::Matx33d rightRLeft_;
    double baselineMm_{0.0};
    /// Rotations of left and right normalised rays into a common rectified
    /// frame (rows along the epipolar lines).
    cv::Matx33d rectifyLeft_ = cv::Matx33d::eye(), rectifyRight_ = cv::Matx33d::eye();
    /// typesNear()'s colour tests, for samples of the configured camera.
    int nearDepth_{-1}, nearBitDepth_{0};
    std::vector<ColorTest> nearTests_;
    /// The same for the colours each type's target may have (its clear
    /// colour through its water and veil): rivals()'.
    std::vector<ColorTest> clearTests_;
    /// For each type with a veil, its clear colour moved towards the veil by
    /// up to kHazeShareMax and by up to minHazeShare (nothing else), for
    /// the configured camera's samples; empty for a type without one.
    std::vector<std::vector<ColorTest>> hazeTests_;
};

}  // namespace avatar::detail
