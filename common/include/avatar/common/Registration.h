#pragma once
/// @file Registration.h
/// Camera-manipulator registration (thesis 3.1.2, Appendix B): the rigid
/// transform base_T_vision that maps points measured by the vision system
/// onto the same points measured in the manipulator base frame,
/// base = R vision + t, from n >= 3 corresponding points.
///
/// Three solvers:
/// - registerClosedForm(): the least-squares solution in closed form (the SVD
///   of the cross-covariance, Arun/Horn/Umeyama without scale, the reflection
///   case handled). With independent isotropic Gaussian noise it is the
///   maximum-likelihood estimate: no iterative method can do better on
///   average. The default.
/// - registerIterative(): the thesis's algorithm of Figure 3-1 exactly:
///   repeated rotations about x, then y, then z, each the best rotation about
///   that one axis, kept for comparison. Failure modes: it can stop in a
///   wrong solution for large rotations (each axis step is locally optimal,
///   not the joint rotation), converges slowly when the cloud is elongated,
///   and an axis about which the points have no spread (near-collinear or
///   planar clouds) gives a zero sum: that step is skipped.
/// - registerRobust(): least median of squares over minimal sets of three
///   points (random sampling, the closed form on each), then the closed form
///   on the inliers: gross outliers (a wrong match, a point recorded while the
///   arm moved) are found and marked instead of bending the result.
///
/// Units: millimetres, radians. Errors: avatar::InvalidArgument naming the
/// problem for fewer than 3 points, different counts, non-finite
/// coordinates, and a layout that cannot determine a rotation (all points on
/// one line, or all in one place): the solvers never return a wrong solution
/// silently.

#include <avatar/common/RigidTransform.h>

#include <opencv2/core/types.hpp>

#include <array>
#include <cstdint>
#include <vector>

namespace avatar {

/// The closed-form least-squares registration. Throws avatar::InvalidArgument
/// (see the file comment).
RigidTransform registerClosedForm(const std::vector<cv::Point3d>& vision, const std::vector<cv::Point3d>& base);

/// The iterative algorithm of thesis Figure 3-1: @p maxIterations rounds of
/// x, y, z rotations (it stops early once a round changes the rotation by
/// less than 1e-12 rad), then the mean displacement as the translation.
/// Throws avatar::InvalidArgument as registerClosedForm() does.
RigidTransform registerIterative(const std::vector<cv::Point3d>& vision, const std::vector<cv::Point3d>& base,
                                 int maxIterations = 100);

/// The distance (mm) between base_T_vision vision[i] and base[i], for each i.
std::vector<double> registrationResiduals(const RigidTransform& baseTVision, const std::vector<cv::Point3d>& vision,
                                          const std::vector<cv::Point3d>& base);

/// Tuning of registerRobust().
struct RobustRegistrationOptions {
    /// Minimal sets tried (each three points); more than enough for 40 %
    /// outliers at n >= 7 (the chance of never drawing three inliers is below 1e-9).
    int samples{500};
    std::uint64_t seed{1};  ///< the sampling is deterministic for a seed
    /// A point is an outlier when its residual exceeds this many robust
    /// standard deviations of the residual norm (3-D Gaussian: 4.03 keeps
    /// 99.9 % of the inliers), and never below minThresholdMm.
    double thresholdSigmas{4.03};
    double minThresholdMm{1e-6};
};

/// What registerRobust() found.
struct RobustRegistration {
    RigidTransform baseTVision;     ///< the closed form on the inliers
    std::vector<bool> inliers;      ///< per point
    std::vector<double> residualsMm;
    double rmsMm{0.0};              ///< over the inliers
    double thresholdMm{0.0};        ///< the inlier limit used
};

/// Least median of squares, then the closed form on the inliers. Works with
/// fewer than half of the points wrong. Throws avatar::InvalidArgument as
/// registerClosedForm() does, and when the inliers do not determine a rotation.
RobustRegistration registerRobust(const std::vector<cv::Point3d>& vision, const std::vector<cv::Point3d>& base,
                                  const RobustRegistrationOptions& options = {});

/// The first-order uncertainty of a registration, from its residuals and the
/// layout of the points: with per-axis noise sigma (both frames together),
/// the rotation error has covariance sigma^2 (tr(S) I - S)^-1, S the scatter
/// matrix of the vision points about their centroid, which is large about an
/// axis the points do not spread around (the line of near-collinear points).
struct RegistrationUncertainty {
    double sigmaMm{0.0};                     ///< per-axis residual standard deviation, sqrt(RSS / (3 n - 6))
    std::array<double, 3> rotationStdRad{};  ///< about the vision frame's x, y and z axes
    double worstRotationStdRad{0.0};         ///< about the worst-determined axis
    std::array<double, 3> translationStdMm{};  ///< of t, in the base frame's x, y and z
};

/// The uncertainty of @p baseTVision over the points where @p use is true
/// (all when empty). Needs at least 3 points.
RegistrationUncertainty registrationUncertainty(const RigidTransform& baseTVision,
                                                const std::vector<cv::Point3d>& vision,
                                                const std::vector<cv::Point3d>& base,
                                                const std::vector<bool>& use = {});

enum class RegistrationMethod {
    ClosedForm,  ///< registerClosedForm(), the default
    Iterative    ///< registerIterative(), thesis Figure 3-1
};

/// How registerPoints() works.
struct RegistrationOptions {
    RegistrationMethod method{RegistrationMethod::ClosedForm};
    /// Find gross outliers first (registerRobust()) and fit the inliers only.
    bool rejectOutliers{true};
    RobustRegistrationOptions robust;
    /// Refuse a result whose rotation is this uncertain about some axis (the
    /// points lie too close to one line, or too few for their noise): a
    /// registration that may be wrong by degrees sends the arm centimetres off.
    double maxRotationStdRad{1.0 * 3.14159265358979323846 / 180.0};
    int maxIterations{100};  ///< of the iterative method
};

/// A registration and everything said about it.
struct PointRegistration {
    RigidTransform baseTVision;
    std::vector<bool> inliers;        ///< all true without outlier rejection
    std::vector<double> residualsMm;  ///< per point, outliers included
    double rmsMm{0.0};                ///< over the inliers
    RegistrationUncertainty uncertainty;
};

/// What avatar-register does: outlier rejection (unless off), the chosen
/// solver on the inliers, residuals and uncertainty. Throws
/// avatar::InvalidArgument for the inputs the solvers refuse and when the
/// rotation is more uncertain than options.maxRotationStdRad, naming the
/// predicted uncertainty: the default never returns a wrong solution silently.
PointRegistration registerPoints(const std::vector<cv::Point3d>& vision, const std::vector<cv::Point3d>& base,
                                 const RegistrationOptions& options = {});

/// Z-Y-X Euler angles [alpha, beta, gamma] of a rotation, as thesis Table
/// 6-6 reports them: R = Rz(alpha) Ry(beta) Rx(gamma) (the order in which
/// Figure 3-1 composes its rotations).
std::array<double, 3> eulerZyx(const cv::Matx33d& rotation);

/// The angle (rad) of the rotation that takes @p a to @p b: |log(b a^T)|.
double rotationAngleBetween(const cv::Matx33d& a, const cv::Matx33d& b);

}  // namespace avatar
