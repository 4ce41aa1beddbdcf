#pragma once
/// @file Feature.h
/// A connected region of filtered pixels and its geometry (thesis 3.3.3,
/// Table 3-1, Figure 3-13, Appendix C).

#include <opencv2/core/types.hpp>

#include <array>

namespace avatar {

/// Indices of the eight boundary points, in the order of thesis Table 3-1.
/// "Top" is the smallest y (image rows grow downwards), "left" the smallest x.
enum BoundaryPoint : int {
    kTopLeft = 0,      ///< 1: smallest x among the pixels of the top row
    kTopRight = 1,     ///< 2: largest x among the pixels of the top row
    kRightTop = 2,     ///< 3: smallest y among the pixels of the rightmost column
    kRightBottom = 3,  ///< 4: largest y among the pixels of the rightmost column
    kBottomRight = 4,  ///< 5: largest x among the pixels of the bottom row
    kBottomLeft = 5,   ///< 6: smallest x among the pixels of the bottom row
    kLeftBottom = 6,   ///< 7: largest y among the pixels of the leftmost column
    kLeftTop = 7       ///< 8: smallest y among the pixels of the leftmost column
};

/// One 8-connected feature of a filtered image. All positions are full-image
/// pixel coordinates (x to the right, y downwards), whatever the search window.
struct Feature {
    int area{0};                        ///< number of pixels
    cv::Point2d centroid;               ///< mean pixel position (Figure 3-13)
    /// Intensity-weighted centroid (weights: the image's brightness R+G+B at
    /// each pixel of the feature); equals centroid when no intensity was given.
    cv::Point2d weightedCentroid;
    std::array<cv::Point, 8> boundary;  ///< Table 3-1 points, indexed by BoundaryPoint
    /// Bounding box with inclusive extents: x = X_l, width = X_r - X_l + 1.
    cv::Rect box;
    /// box.width / box.height. The thesis divides the extents X_r - X_l by
    /// Y_bot - Y_top, which is 0/0 for a one-pixel feature; we count pixels.
    double aspectRatio{0.0};
    double areaRatio{0.0};              ///< area / (box.width * box.height), in (0, 1]
    bool touchesBorder{false};          ///< box touches the image or search-window edge

    /// The nine interest points of the shape matcher (Figure 3-14): the eight
    /// boundary points in Table 3-1 order, then the centroid.
    std::array<cv::Point2d, 9> interestPoints() const {
        std::array<cv::Point2d, 9> p;
        for (int i = 0; i < 8; ++i) p[static_cast<std::size_t>(i)] = boundary[static_cast<std::size_t>(i)];
        p[8] = centroid;
        return p;
    }
};

}  // namespace avatar
