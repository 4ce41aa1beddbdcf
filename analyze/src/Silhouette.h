#pragma once
/// @file Silhouette.h
/// Internal to avatar::analyze: one feature's silhouette as the completeness
/// checks and the shape models need it (thesis 3.3.3, 3.4.2, 3.6.2, done
/// with sub-pixel edges). What a binary mask cannot tell:
/// - where the silhouette edge lies between two pixels: each boundary edge of
///   the mask is moved to the sub-pixel position where the image's colour
///   crosses half-way between the target's colour, taken next to that edge,
///   and the background's, taken beyond the edge's blur (demosaicing and
///   optics blur the edge over two pixels, so four pixels across it are
///   used; the filter may stop up to two pixels short of it); a notch's
///   side walls, which look along the outline, keep their pixel edge;
/// - what is beyond each part of the edge: free background, the image edge,
///   the search window's edge, or another target's pixels (contact); a rim
///   of fragment pixels at most about two pixels deep across the outline,
///   background beyond, is the edge's own mixed pixels passing another
///   filter, and the edge there is free;
/// - how well the centroid is known: the noise of the colour at the edge,
///   measured inside the target, divided by the edge's contrast.

#include <avatar/analyze/Feature.h>
#include <avatar/analyze/ProcessStereoImagePair.h>

#include <opencv2/core/mat.hpp>
#include <opencv2/core/types.hpp>

#include <cstdint>
#include <vector>

namespace avatar::detail {

/// What lies beyond a piece of a silhouette's edge.
enum class EdgeKind : std::uint8_t {
    Free,        ///< background: the edge is the target's own outline
    ImageEdge,   ///< the last pixel of the image
    WindowEdge,  ///< the last pixel of the type's search window
    Contact,     ///< another target's pixels (of any type) within 2 px
    Fragment     ///< pixels of some filter that belong to no feature: what is there is unknown
};

/// One piece of the outline: the sub-pixel position of a pixel edge of the
/// mask's boundary (the midpoint for non-free edges), in distorted pixels.
struct OutlinePoint {
    cv::Point2d px;
    EdgeKind kind{EdgeKind::Free};
    double sigmaPx{0.0};  ///< standard deviation of its position along the edge normal (free edges)
    /// A free edge that is the wall of a notch (the feature's own pixels again
    /// a pixel or two beyond it): it looks along the outline, not out of it,
    /// so it has no sub-pixel position (its pixel edge is kept). It tells
    /// where the outline is to within the notch's depth, which is enough to
    /// say that part of the outline is there, not to fit the outline to it.
    bool wall{false};
    /// A free edge found through a rim of another filter's pixels (the
    /// edge's own mixed pixels passing it, Silhouette.h's header): placed as
    /// any free edge, but what it says beyond the outline is less sure, so a
    /// rim point well outside the fitted ellipse is no second object.
    bool rim{false};
};

struct Silhouette {
    std::vector<OutlinePoint> outline;
    /// Area and centroid of the region the sub-pixel outline encloses (the
    /// mask's, holes filled, with each free edge moved to its sub-pixel place).
    double area{0.0};
    cv::Point2d centroid;
    /// Covariance of the centroid from the image noise (px^2).
    cv::Matx22d centroidCovariance{0, 0, 0, 0};
    int freePoints{0}, imageEdgePoints{0}, windowEdgePoints{0}, contactPoints{0}, fragmentPoints{0};
    /// Standard deviation of one pixel's colour along the target-background
    /// direction over the edge contrast: the noise of one pixel's coverage.
    double coverageNoise{0.0};
    bool subPixel{false};  ///< false when target and background colours were too close to use
    /// Mean colour (B, G, R, in the image's units) of its pixels away from the edge.
    cv::Vec3f colour{0.f, 0.f, 0.f};
    /// Its holes: background inside the outline that no filter passed, apart
    /// from the seams next to other targets (something in front of it, such
    /// as a speck of silt; or noise, whose holes have the target's colour).
    /// A pocket is one too: background that reaches the outside only through
    /// a mouth of at most two pixels (its pixels two or more from the
    /// feature's), where the filter cut open a speck's mixed rim.
    struct Hole {
        int areaPx{0};
        /// How far its mean colour is from the target's: the larger change
        /// of R/G and B/G, in natural log.
        double colourLog{0.0};
        /// The standard error of that mean colour from the image noise
        /// around the hole (natural log; the larger of R/G's and B/G's).
        double noiseLog{0.0};
        /// Its mean colour: natural log of R/G and of B/G.
        cv::Vec2d ratiosLog{0.0, 0.0};
        /// That colour less the target's around the hole (R/G, B/G, natural
        /// log), and the standard error of each from the image noise there.
        cv::Vec2d offsetLog{0.0, 0.0};
        cv::Vec2d axisNoiseLog{0.0, 0.0};
    };
    std::vector<Hole> holes;
    /// The region examined (full-image coordinates) and its labels: what
    /// probe() reads.
    cv::Rect region;
    cv::Mat labels;

    /// What lies at a pixel position: ImageEdge beyond the image's outer
    /// pixel edges, WindowEdge beyond the window's, Contact on another
    /// target's pixels, Fragment on a fragment's, Free otherwise; @p own is
    /// set on this feature's pixels.
    EdgeKind probe(const cv::Point2d& px, const cv::Size& image, const cv::Rect& window, bool& own) const;
    /// An 8-connected group of fragment pixels in the region.
    struct Fragment {
        cv::Rect box;  ///< full-image coordinates
        cv::Mat mask;  ///< CV_8UC1 of the box's size, 255 on its pixels
    };
    std::vector<Fragment> fragments() const;
};

/// cv::floodFill(@p labels, @p seed, @p to) with no tolerance, for a CV_8UC1
/// image (or a view of one): the @p eight- (else 4-) connected pixels of the
/// seed's value @p from become @p to; nothing when the seed is not @p from.
/// @p stack is scratch (reused across calls).
void fillComponent(cv::Mat& labels, cv::Point seed, std::uint8_t from, std::uint8_t to, bool eight,
                   std::vector<cv::Point>& stack);

/// Measures @p feature of work.masks[@p own] in work.image (the 3-channel
/// image the masks were computed from). Other targets are the pixels of the
/// features of every mask (work.features' boxes), other than this one;
/// mask pixels outside every feature's box are fragments too small to be a
/// target, neither the target nor another one (they are left out of the
/// colour estimates and never count as contact). @p window is the type's
/// search window (full-image coordinates). A compound's closed union may be
/// given in @p ownOverride instead of masks[@p own] (own is then ignored).
/// @p correlation multiplies the centroid covariance for the correlation of
/// neighbouring pixels' noise that demosaicing introduces (measured, see
/// docs/accuracy.md).
Silhouette measureSilhouette(const ImageWork& work, std::size_t own, const Feature& feature, const cv::Rect& window,
                             double correlation, const cv::Mat& ownOverride = cv::Mat());

}  // namespace avatar::detail
