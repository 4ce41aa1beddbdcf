#include <avatar/analyze/SIPFeatureMatcher.h>

#include "PointGrid.h"

#include <avatar/common/CameraModel.h>
#include <avatar/common/Error.h>
#include <avatar/common/Logging.h>
#include <avatar/config/ConfigXml.h>

#include <log4cpp/Category.hh>
#include <opencv2/core.hpp>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstddef>
#include <limits>
#include <sstream>
#include <string>

namespace avatar {

namespace {

log4cpp::Category& logger() {
    // Categories live as long as log4cpp; look this one up once.
    static log4cpp::Category& category = logging::category("analyze");
    return category;
}

constexpr std::size_t kInterestPoints = 9;
/// RepeatMatchPolicy::Reassign: the longest augmenting path, in left features,
/// and how many of each left feature's best admissible right features it may
/// take (its own among them). Bounded so that a scene full of look-alikes
/// costs at most a few dozen path steps per voided left feature.
constexpr int kMaxPathLefts = 3;
constexpr std::size_t kPathOptions = 4;
constexpr std::size_t kPairs = kInterestPoints * (kInterestPoints - 1) / 2;  // 36

/// M and S of Figure 3-14 for the unordered pairs i < j. The thesis fills the
/// full 9 x 9 matrices; M is symmetric and S antisymmetric, so |M_a - M_b| and
/// |S_a - S_b| take the same values on (i, j) and (j, i) and the diagonal adds
/// zeros: the mean over the 36 pairs equals the mean over the 72 off-diagonal
/// entries.
struct ShapeDescriptor {
    std::array<double, kPairs> magnitude{};
    std::array<double, kPairs> directionX{};
    std::array<double, kPairs> directionY{};
    double magnitudeSum{0.0};
    /// Sum of the unit vectors S over the 36 pairs, for shapeErrorLowerBound().
    double directionSumX{0.0};
    double directionSumY{0.0};
};

ShapeDescriptor describe(const Feature& feature) {
    const std::array<cv::Point2d, kInterestPoints> p = feature.interestPoints();
    ShapeDescriptor d;
    std::size_t k = 0;
    for (std::size_t i = 0; i < kInterestPoints; ++i)
        for (std::size_t j = i + 1; j < kInterestPoints; ++j, ++k) {
            const double dx = p[i].x - p[j].x;
            const double dy = p[i].y - p[j].y;
            const double m = std::sqrt(dx * dx + dy * dy);
            d.magnitude[k] = m;
            // Coincident points: no direction, (0, 0) as the thesis's diagonal.
            if (m > 0.0) {
                const double inverse = 1.0 / m;
                d.directionX[k] = dx * inverse;
                d.directionY[k] = dy * inverse;
            }
            d.magnitudeSum += m;
            d.directionSumX += d.directionX[k];
            d.directionSumY += d.directionY[k];
        }
    return d;
}

/// The shape error of Figure 3-14 (see shapeError() in the header). With a
/// @p limit, the pairs are summed in the same order, but when the error of
/// the pairs summed so far exceeds the limit, the sum stops and that partial
/// error is returned: the final error would be at least as large (every term
/// is non-negative and rounding is monotonic, so a partial sum never exceeds
/// the full one). Either way, the result exceeds the limit exactly when the
/// error does, and otherwise is the error, bit for bit.
double shapeErrorOf(const ShapeDescriptor& a, const ShapeDescriptor& b,
                    const ShapeMatchConfig& weights,
                    double limit = std::numeric_limits<double>::infinity()) {
    // sum|dM| / (0.5 (sum M_a + sum M_b)) = mean|dM| / mean of the two mean distances.
    const double scale = 0.5 * (a.magnitudeSum + b.magnitudeSum);
    double magnitudeDiff = 0.0;
    double directionDiff = 0.0;
    const auto error = [&] {
        const double magnitudeTerm = scale > 0.0 ? magnitudeDiff / scale : 0.0;
        const double directionTerm = directionDiff / static_cast<double>(kPairs);
        return weights.magnitudeWeight * magnitudeTerm + weights.directionWeight * directionTerm;
    };
    for (std::size_t k = 0; k < kPairs; ++k) {
        magnitudeDiff += std::abs(a.magnitude[k] - b.magnitude[k]);
        const double ux = a.directionX[k] - b.directionX[k];
        const double uy = a.directionY[k] - b.directionY[k];
        directionDiff += std::sqrt(ux * ux + uy * uy);
        if (k % 9 == 8 && k + 1 < kPairs) {  // after 9, 18 and 27 of the 36 pairs
            const double partial = error();
            if (partial > limit) return partial;
        }
    }
    return error();
}

/// A lower bound of shapeErrorOf(a, b, weights) for one square root instead
/// of 36: by the triangle inequality
///   sum_k |M_a,k - M_b,k| >= |sum_k M_a,k - sum_k M_b,k|   and
///   sum_k |S_a,k - S_b,k| >= |sum_k S_a,k - sum_k S_b,k|   (2-vectors),
/// so the error is at least
///   magnitudeWeight * |sum M_a - sum M_b| / (0.5 (sum M_a + sum M_b))
///   + directionWeight * |sum S_a - sum S_b| / 36:
/// a difference in size, or in the mean direction of the point pairs (a
/// rotated or differently proportioned outline). Look-alike targets get a
/// bound near 0 and are told apart by the shape error itself.
///
/// Both this bound and shapeErrorOf() round, in different orders. Each of
/// their terms lies in [0, 2] and is computed to within 1e-13 of its exact
/// value over the same stored M and S (sums of 36 terms, each rounding by at
/// most 1.1e-16 of a partial sum of at most 36). The bound is lowered by
/// kBoundSlack per unit of weight, four orders of magnitude more, and clamped
/// at 0 (a computed error is never negative), so it never exceeds the
/// computed error: pruning with it leaves every result bit for bit as it was.
constexpr double kBoundSlack = 1e-9;

double shapeErrorLowerBound(const ShapeDescriptor& a, const ShapeDescriptor& b,
                            const ShapeMatchConfig& weights) {
    const double scale = 0.5 * (a.magnitudeSum + b.magnitudeSum);
    const double magnitudeTerm =
        scale > 0.0 ? std::abs(a.magnitudeSum - b.magnitudeSum) / scale : 0.0;
    const double sx = a.directionSumX - b.directionSumX;
    const double sy = a.directionSumY - b.directionSumY;
    const double directionTerm = std::sqrt(sx * sx + sy * sy) / static_cast<double>(kPairs);
    const double bound =
        weights.magnitudeWeight * magnitudeTerm + weights.directionWeight * directionTerm;
    return std::max(
        0.0, bound - kBoundSlack * (weights.magnitudeWeight + weights.directionWeight));
}

bool areasCompatible(const Feature& a, const Feature& b, double maxAreaRatio) {
    const double small = std::min(a.area, b.area);
    const double large = std::max(a.area, b.area);
    return large <= maxAreaRatio * small;
}

/// The best admissible right feature of each left feature so far.
struct Choice {
    int right{-1};
    double error{0.0};
    /// Keeps the lower error; on equal errors the lower right index.
    void offer(int candidate, double candidateError) {
        if (right < 0 || candidateError < error || (candidateError == error && candidate < right)) {
            right = candidate;
            error = candidateError;
        }
    }
};

/// HandleRepeatMatches (Figure 3-15): a right feature chosen by several left
/// features stays with the lowest error (equal errors: the lower left index);
/// the others are voided. Returns the surviving matches in left order.
std::vector<FeatureMatch> handleRepeatMatches(const std::vector<Choice>& choices,
                                              std::size_t rightCount, std::size_t& voided) {
    std::vector<int> owner(rightCount, -1);
    for (std::size_t i = 0; i < choices.size(); ++i) {
        const Choice& c = choices[i];
        if (c.right < 0) continue;
        int& o = owner[static_cast<std::size_t>(c.right)];
        if (o < 0 || c.error < choices[static_cast<std::size_t>(o)].error) o = static_cast<int>(i);
    }
    std::vector<FeatureMatch> matches;
    voided = 0;
    for (std::size_t i = 0; i < choices.size(); ++i) {
        const Choice& c = choices[i];
        if (c.right < 0) continue;
        if (owner[static_cast<std::size_t>(c.right)] == static_cast<int>(i))
            matches.push_back({static_cast<int>(i), c.right, c.error});
        else
            ++voided;
    }
    return matches;
}

void validateFeatures(const std::vector<Feature>& features, const char* side) {
    for (std::size_t i = 0; i < features.size(); ++i) {
        const Feature& f = features[i];
        if (f.area < 1 || !std::isfinite(f.centroid.x) || !std::isfinite(f.centroid.y)) {
            std::ostringstream msg;
            msg << "SIPFeatureMatcher::match: " << side << " feature " << i << " has area "
                << f.area << " and centroid (" << f.centroid.x << ", " << f.centroid.y
                << "); a feature needs an area of at least 1 and a finite centroid";
            throw InvalidArgument(msg.str());
        }
    }
}

/// The configuration, after the configuration's own checks (ConfigError naming the element).
const MatchConfig& checked(const MatchConfig& match, const StereoSystemConfig& stereo) {
    validateMatchConfig(match);
    validateStereoConfig(stereo);
    return match;
}

/// The geometry of the depth test: the calibration without the registration,
/// so no base-frame point is computed for a candidate.
StereoGeometry depthGeometry(const StereoSystemConfig& stereo) {
    StereoGeometry geometry = stereoGeometry(stereo);
    geometry.baseTVision.reset();
    return geometry;
}

const char* methodName(MatchMethod m) {
    switch (m) {
        case MatchMethod::Shape:
            return "Shape";
        case MatchMethod::EpipolarBox:
            return "EpipolarBox";
        case MatchMethod::EpipolarLine:
            return "EpipolarLine";
    }
    return "?";
}

/// The matching state shared by the three methods: the inputs, their shape
/// descriptors and the per-left choices.
///
/// A method calls consider(i, j) for every right feature j that its geometry
/// admits for left feature i, those of one left feature one after the other
/// (the methods loop over the left features). When the next left feature
/// starts, or at finish(), the candidates collected for the last one are
/// resolved to the one of least shape error (equal errors: the lower right
/// index) without computing the shape error of every candidate:
///   1. candidates whose areas are not compatible are dropped;
///   2. each remaining one gets shapeErrorLowerBound() (one square root);
///   3. the one with the least bound (then the lowest index) is evaluated
///      first: it is most often the best, and its error sets the bar;
///   4. every other candidate is evaluated only if its bound does not rule it
///      out: bound > maxError, bound > the best error so far, or bound equal
///      to it and a right index above the best's (it would lose the tie).
/// The choice is the least (error, right index) over the admissible
/// candidates, whatever order they are evaluated in, and a candidate that its
/// bound rules out cannot be that least: the result is the same as evaluating
/// every candidate (tests/analyze/FeatureMatcherTest.cpp compares with a
/// brute-force scan of all pairs).
///
/// Descriptors are computed once per feature, and only for features that are
/// some pair's candidate: the left one when its candidates are resolved, the
/// right ones on first use, kept for the other left features that see them.
class MatchRun {
public:
    MatchRun(const MatchConfig& config, const std::vector<Feature>& left,
             const std::vector<Feature>& right)
        : config_(config),
          left_(left),
          right_(right),
          rightSlot_(right.size(), -1),
          choices_(left.size()) {
        // Room for every right descriptor: growing would copy them, and the
        // pages of what is never used are never touched.
        rightShapes_.reserve(right.size());
    }

    /// Right feature j is a geometric candidate of left feature i.
    void consider(std::size_t i, int j) {
        if (i != current_) {
            resolve();
            current_ = i;
        }
        ++candidates_;
        if (areasCompatible(left_[i], right_[static_cast<std::size_t>(j)],
                            config_.shape.maxAreaRatio))
            pending_.push_back({j, 0.0});
    }

    /// Resolves the last left feature, applies HandleRepeatMatches and, with
    /// RepeatMatchPolicy::Reassign, re-pairs the voided left features along
    /// augmenting paths (reassign()). @p source enumerates a left feature's
    /// geometric candidates again: source.forEach(i, emit).
    template <typename Source>
    std::vector<FeatureMatch> finish(MatchMethod method, Source& source) {
        resolve();
        std::size_t voided = 0;
        std::vector<FeatureMatch> matches = handleRepeatMatches(choices_, right_.size(), voided);
        std::size_t reassigned = 0;
        if (voided > 0 && config_.repeats == RepeatMatchPolicy::Reassign)
            reassigned = reassign(matches, source);
        log4cpp::Category& log = logger();
        if (log.isDebugEnabled()) {
            std::ostringstream msg;
            msg << "SIPFeatureMatcher " << methodName(method) << ": " << left_.size() << " left, "
                << right_.size() << " right, " << candidates_ << " candidate pairs, "
                << shapeErrors_ << " shape errors computed, " << matches.size() << " matches, "
                << voided << " voided repeats, " << reassigned << " of them re-paired";
            log.debug(msg.str());
        }
        return matches;
    }

private:
    struct Pending {
        int right;
        double bound;  ///< shapeErrorLowerBound() with the left feature current_
    };

    /// An admissible right feature of a left feature and its shape error.
    struct Option {
        int right;
        double error;
    };

    /// An augmenting path: lefts[0] (a voided left feature) takes rights[0];
    /// each lefts[k] (k > 0) is the one holding rights[k - 1] and moves to
    /// rights[k]; the last right feature is free.
    struct Path {
        std::array<int, kMaxPathLefts> lefts{};
        std::array<int, kMaxPathLefts> rights{};
        std::array<double, kMaxPathLefts> errors{};
        int length{0};
        double cost{0.0};  ///< shape error added: errors[0] + sum over k > 0 of (errors[k] - held)
        /// Less cost; equal costs: fewer moves, then the lower right indices.
        bool before(const Path& o) const {
            if (cost != o.cost) return cost < o.cost;
            if (length != o.length) return length < o.length;
            return std::lexicographical_compare(rights.begin(), rights.begin() + length,
                                                o.rights.begin(), o.rights.begin() + o.length);
        }
    };

    /// The kPathOptions best admissible right features of left feature i
    /// (geometry, area ratio, shape error <= maxError), in order of (error,
    /// right index); computed on first need. As resolve() does, candidates
    /// are taken in order of their lower bound, and those whose bound cannot
    /// beat the worst kept are not evaluated: the same options as evaluating
    /// every candidate, bit for bit.
    template <typename Source>
    const std::vector<Option>& optionsOf(std::size_t i, Source& source) {
        if (options_.empty()) {
            options_.resize(left_.size());
            optionsKnown_.assign(left_.size(), false);
        }
        std::vector<Option>& options = options_[i];
        if (optionsKnown_[i]) return options;
        optionsKnown_[i] = true;
        const ShapeMatchConfig& shape = config_.shape;
        const ShapeDescriptor leftShape = describe(left_[i]);
        std::vector<Pending> candidates;
        source.forEach(i, [&](int j) {
            if (areasCompatible(left_[i], right_[static_cast<std::size_t>(j)], shape.maxAreaRatio))
                candidates.push_back({j, shapeErrorLowerBound(leftShape, rightShape(j), shape)});
        });
        std::sort(candidates.begin(), candidates.end(), [](const Pending& a, const Pending& b) {
            return a.bound < b.bound || (a.bound == b.bound && a.right < b.right);
        });
        const auto before = [](const Option& a, const Option& b) {
            return a.error < b.error || (a.error == b.error && a.right < b.right);
        };
        for (const Pending& c : candidates) {
            // Later candidates' bounds are no lower: none of them can enter.
            if (c.bound > shape.maxError) break;
            const bool full = options.size() == kPathOptions;
            if (full && c.bound > options.back().error) break;
            const double limit = full ? std::min(shape.maxError, options.back().error) : shape.maxError;
            ++shapeErrors_;
            const Option o{c.right, shapeErrorOf(leftShape, rightShape(c.right), shape, limit)};
            if (o.error > shape.maxError || (full && !before(o, options.back()))) continue;
            if (full) options.pop_back();
            options.insert(std::upper_bound(options.begin(), options.end(), o, before), o);
        }
        return options;
    }

    /// RepeatMatchPolicy::Reassign: each voided left feature u, in left order,
    /// takes the best augmenting path (Path::before) of at most kMaxPathLefts
    /// left features, if it has one: u takes one of its options (optionsOf());
    /// where another left feature holds it, that one moves to one of its own
    /// options, and so on, until a right feature no match holds is reached.
    /// Every left feature that had a match keeps one, and every pair stays
    /// admissible; a left image that took a look-alike's right image gives it
    /// back to its owner and takes its own. At most kPathOptions +
    /// kPathOptions^2 + kPathOptions^3 paths per voided left feature. Returns the number of left features
    /// re-paired; @p matches stays in left order.
    template <typename Source>
    std::size_t reassign(std::vector<FeatureMatch>& matches, Source& source) {
        std::vector<int> owner(right_.size(), -1);
        std::vector<int> held(left_.size(), -1);
        std::vector<double> heldError(left_.size(), 0.0);
        for (const FeatureMatch& m : matches) {
            owner[static_cast<std::size_t>(m.right)] = m.left;
            held[static_cast<std::size_t>(m.left)] = m.right;
            heldError[static_cast<std::size_t>(m.left)] = m.shapeError;
        }
        std::size_t reassigned = 0;
        for (std::size_t u = 0; u < left_.size(); ++u) {
            if (choices_[u].right < 0 || held[u] >= 0) continue;  // no candidate, or matched
            Path best;
            Path path;
            // Extends path (its first k steps set) with the options of the
            // left feature at step k; the last step can only take a free
            // right feature.
            const auto extend = [&](auto& self, int k) -> void {
                const auto step = static_cast<std::size_t>(k);
                const auto lk = static_cast<std::size_t>(path.lefts[step]);
                const double before = path.cost;
                const bool last = k + 1 == kMaxPathLefts;
                for (const Option& o : optionsOf(lk, source)) {
                    if (k > 0 && o.right == held[lk]) continue;  // its own right feature
                    const int next = owner[static_cast<std::size_t>(o.right)];
                    if (next >= 0 && last) continue;
                    const auto inPath = path.lefts.begin() + k + 1;
                    if (next >= 0 && std::find(path.lefts.begin(), inPath, next) != inPath) continue;
                    path.rights[step] = o.right;
                    path.errors[step] = o.error;
                    path.cost = k == 0 ? o.error : before + (o.error - heldError[lk]);
                    path.length = k + 1;
                    if (next < 0) {
                        if (best.length == 0 || path.before(best)) best = path;
                    } else {
                        path.lefts[step + 1] = next;
                        self(self, k + 1);
                    }
                }
                path.cost = before;
            };
            path.lefts[0] = static_cast<int>(u);
            extend(extend, 0);
            if (best.length == 0) continue;
            for (int k = 0; k < best.length; ++k) {
                const auto step = static_cast<std::size_t>(k);
                const auto l = static_cast<std::size_t>(best.lefts[step]);
                held[l] = best.rights[step];
                heldError[l] = best.errors[step];
                owner[static_cast<std::size_t>(best.rights[step])] = best.lefts[step];
            }
            ++reassigned;
        }
        matches.clear();
        for (std::size_t i = 0; i < left_.size(); ++i)
            if (held[i] >= 0) matches.push_back({static_cast<int>(i), held[i], heldError[i]});
        return reassigned;
    }

    /// Steps 2-4 above for the left feature current_.
    void resolve() {
        if (pending_.empty()) return;
        const ShapeMatchConfig& shape = config_.shape;
        const ShapeDescriptor leftShape = describe(left_[current_]);
        Choice& choice = choices_[current_];
        const auto evaluate = [&](const Pending& p) {
            // An error above the best so far cannot win: stop summing there.
            const double limit =
                choice.right >= 0 ? std::min(shape.maxError, choice.error) : shape.maxError;
            ++shapeErrors_;
            const double error = shapeErrorOf(leftShape, rightShape(p.right), shape, limit);
            if (error <= shape.maxError) choice.offer(p.right, error);
        };
        if (pending_.size() == 1) {
            // Nothing to prune. A right feature first seen as a lone candidate
            // (most of them, in sparse scenes) is described on the stack and
            // not kept: cheaper than keeping 1,000 descriptors of 888 bytes.
            const int j = pending_[0].right;
            const int slot = rightSlot_[static_cast<std::size_t>(j)];
            double error = 0.0;
            if (slot >= 0)
                error = shapeErrorOf(leftShape, rightShapes_[static_cast<std::size_t>(slot)], shape);
            else
                error = shapeErrorOf(leftShape, describe(right_[static_cast<std::size_t>(j)]), shape);
            ++shapeErrors_;
            if (error <= shape.maxError) choice.offer(j, error);
            pending_.clear();
            return;
        }
        std::size_t first = 0;
        for (std::size_t k = 0; k < pending_.size(); ++k) {
            Pending& p = pending_[k];
            p.bound = shapeErrorLowerBound(leftShape, rightShape(p.right), shape);
            const Pending& f = pending_[first];
            if (p.bound < f.bound || (p.bound == f.bound && p.right < f.right)) first = k;
        }
        if (pending_[first].bound <= shape.maxError) evaluate(pending_[first]);
        for (std::size_t k = 0; k < pending_.size(); ++k) {
            const Pending& p = pending_[k];
            if (k == first || p.bound > shape.maxError) continue;
            if (choice.right >= 0 &&
                (p.bound > choice.error || (p.bound == choice.error && p.right > choice.right)))
                continue;
            evaluate(p);
        }
        pending_.clear();
    }

    /// The descriptor of right feature j, computed on first use.
    const ShapeDescriptor& rightShape(int j) {
        int& slot = rightSlot_[static_cast<std::size_t>(j)];
        if (slot < 0) {
            slot = static_cast<int>(rightShapes_.size());
            rightShapes_.push_back(describe(right_[static_cast<std::size_t>(j)]));
        }
        return rightShapes_[static_cast<std::size_t>(slot)];
    }

    const MatchConfig& config_;
    const std::vector<Feature>& left_;
    const std::vector<Feature>& right_;
    std::vector<int> rightSlot_;                ///< index into rightShapes_, or -1
    std::vector<ShapeDescriptor> rightShapes_;  ///< in order of first use
    std::vector<Choice> choices_;
    std::size_t current_{std::numeric_limits<std::size_t>::max()};  ///< left feature of pending_
    std::vector<Pending> pending_;
    std::size_t candidates_{0};
    std::size_t shapeErrors_{0};
    std::vector<std::vector<Option>> options_;  ///< optionsOf(), for reassign()
    std::vector<bool> optionsKnown_;
};

std::vector<cv::Point2d> centroids(const std::vector<Feature>& features) {
    std::vector<cv::Point2d> c;
    c.reserve(features.size());
    for (const Feature& f : features) c.push_back(f.centroid);
    return c;
}

/// The geometric candidates of the configured method (see the header):
/// forEach(i, emit) calls emit(j) once for every right feature j that the
/// method's geometry admits for left feature i. Built once per match() call;
/// a left feature may be asked for again (MatchRun::reassign()).
class CandidateSource {
public:
    CandidateSource(const MatchConfig& match, const StereoCoordinateCalculator& calculator,
                    const cv::Matx33d& fundamental, const std::vector<Feature>& left,
                    const std::vector<Feature>& right)
        : match_(match),
          calculator_(calculator),
          left_(left),
          right_(right),
          seen_(right.size(), 0) {
        const StereoGeometry& stereo = calculator.geometry();
        if (match.method == MatchMethod::EpipolarBox) {
            rightPoints_ = centroids(right);
        } else if (match.method == MatchMethod::EpipolarLine) {
            // Undistorted normalised coordinates of the right centroids and
            // their undistorted pixels K_r x_n.
            rightNormalized_.reserve(right.size());
            rightPoints_.reserve(right.size());
            for (const Feature& f : right) {
                rightNormalized_.push_back(normalizePixel(stereo.right, f.centroid));
                rightPoints_.push_back(normalizedToPixel(stereo.right, rightNormalized_.back()));
            }
            rotation_ = rotationMatrix(stereo.rightTLeft);
            translation_ = translationVector(stereo.rightTLeft);
            kLeft_ = cameraMatrix(stereo.left);
            kRight_ = cameraMatrix(stereo.right);
            fundamental_ = fundamental;
        }
        grid_ = detail::PointGrid(rightPoints_);
    }

    template <typename Emit>
    void forEach(std::size_t i, Emit&& emit) {
        switch (match_.method) {
            case MatchMethod::Shape:
                // Figure 3-15, FindBestMatch: every right feature with x_left > x_right.
                for (std::size_t j = 0; j < right_.size(); ++j)
                    if (left_[i].centroid.x > right_[j].centroid.x) emit(static_cast<int>(j));
                return;
            case MatchMethod::EpipolarBox:
                boxCandidates(i, emit);
                return;
            case MatchMethod::EpipolarLine:
                lineCandidates(i, emit);
                return;
        }
    }

private:
    /// Figure 3-16: the right centroid lies in the box
    /// (x_l - dxMax, x_l - dxMin) x (y_l - dyMax, y_l - dyMin).
    template <typename Emit>
    void boxCandidates(std::size_t i, Emit& emit) const {
        const cv::Point2d& l = left_[i].centroid;
        grid_.query(l.x - match_.boxDxMax, l.y - match_.boxDyMax, l.x - match_.boxDxMin,
                    l.y - match_.boxDyMin, [&](int j) {
                        const cv::Point2d& r = rightPoints_[static_cast<std::size_t>(j)];
                        const double dx = l.x - r.x;
                        const double dy = l.y - r.y;
                        if (match_.boxDxMin < dx && dx < match_.boxDxMax && match_.boxDyMin < dy &&
                            dy < match_.boxDyMax)
                            emit(j);
                    });
    }

    template <typename Emit>
    void lineCandidates(std::size_t i, Emit& emit) {
        const StereoGeometry& stereo = calculator_.geometry();
        const double maxDistance = match_.maxEpipolarDistancePx;
        // Candidates lie within this margin of the depth range's segment of
        // the epipolar line (the query covers exactly that band); it is wider
        // than the distance limit, so that a midpoint-triangulated depth just
        // inside the range is not lost.
        const double margin = 2.0 * maxDistance + 2.0;
        const cv::Point2d xl = normalizePixel(stereo.left, left_[i].centroid);
        const cv::Vec3d pl = kLeft_ * cv::Vec3d(xl.x, xl.y, 1.0);
        cv::Vec3d line = fundamental_ * pl;
        const double norm = std::hypot(line[0], line[1]);
        if (!(norm > 0.0)) return;  // the left point is the epipole: no line
        line /= norm;

        // The ray X = Z d (left depth Z) seen from the right camera:
        // X_r(Z) = Z R d + T, in front of it while Z (Rd)_z + T_z > 0.
        const cv::Vec3d Rd = rotation_ * cv::Vec3d(xl.x, xl.y, 1.0);
        const cv::Vec3d& T = translation_;
        double zNear = match_.minRangeMm;
        double zFar = match_.maxRangeMm;
        constexpr double kMinRightDepthMm = 1e-3;
        if (Rd[2] > 0.0)
            zNear = std::max(zNear, (kMinRightDepthMm - T[2]) / Rd[2]);
        else if (Rd[2] < 0.0)
            zFar = std::min(zFar, (T[2] - kMinRightDepthMm) / -Rd[2]);
        else if (!(T[2] > kMinRightDepthMm))
            return;
        if (!(zNear < zFar)) return;
        const auto project = [&](double z) {
            const cv::Vec3d h = kRight_ * (z * Rd + T);
            return cv::Point2d(h[0] / h[2], h[1] / h[2]);
        };
        // The depth range's segment of the epipolar line, clipped to the
        // grid (widened by the margin) and walked in pieces about one grid
        // cell long.
        cv::Point2d a = project(zNear);
        cv::Point2d b = project(zFar);
        if (!std::isfinite(a.x) || !std::isfinite(a.y) || !std::isfinite(b.x) || !std::isfinite(b.y))
            return;
        const cv::Point2d segmentNear = a, segmentFar = b;
        cv::Rect2d area = grid_.bounds();
        area.x -= margin;
        area.y -= margin;
        area.width += 2.0 * margin;
        area.height += 2.0 * margin;
        if (!detail::clipSegment(a, b, area)) return;
        const double length = std::hypot(b.x - a.x, b.y - a.y);
        const int pieces = std::max(1, static_cast<int>(std::ceil(length / grid_.cellSize())));
        const std::size_t stamp = ++stamp_;  // each walk marks what it has seen anew
        for (int k = 0; k < pieces; ++k) {
            const double t0 = static_cast<double>(k) / pieces;
            const double t1 = static_cast<double>(k + 1) / pieces;
            const cv::Point2d p0 = a + (b - a) * t0;
            const cv::Point2d p1 = a + (b - a) * t1;
            grid_.query(
                std::min(p0.x, p1.x) - margin, std::min(p0.y, p1.y) - margin,
                std::max(p0.x, p1.x) + margin, std::max(p0.y, p1.y) + margin, [&](int j) {
                    const std::size_t uj = static_cast<std::size_t>(j);
                    if (seen_[uj] == stamp) return;
                    seen_[uj] = stamp;
                    const cv::Point2d& q = rightPoints_[uj];
                    const double distance = std::abs(line[0] * q.x + line[1] * q.y + line[2]);
                    if (!(distance <= maxDistance)) return;
                    // Near the depth range's segment, not only near the line:
                    // nearly parallel rays (disparity ~ 0) have a meaningless
                    // midpoint depth.
                    if (!(detail::distanceToSegment(q, segmentNear, segmentFar) <= margin)) return;
                    // Parallel rays have no point and are no candidate.
                    const auto point = calculator_.triangulateNormalized(xl, rightNormalized_[uj]);
                    if (!point) return;
                    const double depth = point->leftMm.z;
                    if (depth >= match_.minRangeMm && depth <= match_.maxRangeMm) emit(j);
                });
        }
    }

    const MatchConfig& match_;
    const StereoCoordinateCalculator& calculator_;
    const std::vector<Feature>& left_;
    const std::vector<Feature>& right_;
    /// Box: the right centroids; line: their undistorted pixels.
    std::vector<cv::Point2d> rightPoints_;
    std::vector<cv::Point2d> rightNormalized_;  ///< line: undistorted normalised right centroids
    detail::PointGrid grid_{std::vector<cv::Point2d>{}};
    cv::Matx33d rotation_, kLeft_, kRight_, fundamental_;
    cv::Vec3d translation_;
    std::vector<std::size_t> seen_;  ///< line: the stamp of the walk that last saw each right feature
    std::size_t stamp_{0};
};

}  // namespace

double shapeError(const Feature& a, const Feature& b, const ShapeMatchConfig& weights) {
    return shapeErrorOf(describe(a), describe(b), weights);
}

SIPFeatureMatcher::SIPFeatureMatcher(const MatchConfig& match, const StereoSystemConfig& stereo)
    : match_(checked(match, stereo)),
      calculator_(depthGeometry(stereo)),
      fundamental_(fundamentalMatrix(calculator_.geometry())) {}

std::vector<FeatureMatch> SIPFeatureMatcher::match(const std::vector<Feature>& left,
                                                   const std::vector<Feature>& right) const {
    validateFeatures(left, "left");
    validateFeatures(right, "right");
    MatchRun run(match_, left, right);
    CandidateSource source(match_, calculator_, fundamental_, left, right);
    if (!left.empty() && !right.empty())
        for (std::size_t i = 0; i < left.size(); ++i)
            source.forEach(i, [&](int j) { run.consider(i, j); });
    return run.finish(match_.method, source);
}

}  // namespace avatar
