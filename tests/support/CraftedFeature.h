#pragma once
/// @file CraftedFeature.h
/// Crafted features for the matcher's tests and benchmarks: the geometry of
/// Feature.h computed from a pixel set, as the labelling computes it.

#include <avatar/analyze/Feature.h>

#include <opencv2/core/types.hpp>

#include <algorithm>
#include <vector>

namespace avatar::test {

/// A feature of exactly these pixels (area, centroid, the eight boundary
/// points of Table 3-1 with Appendix C's tie rules, bounding box).
inline Feature featureFromPixels(const std::vector<cv::Point>& pixels) {
    Feature f;
    f.area = static_cast<int>(pixels.size());
    int xl = pixels[0].x, xr = xl, yt = pixels[0].y, yb = yt;
    double sx = 0.0, sy = 0.0;
    for (const cv::Point& p : pixels) {
        xl = std::min(xl, p.x);
        xr = std::max(xr, p.x);
        yt = std::min(yt, p.y);
        yb = std::max(yb, p.y);
        sx += p.x;
        sy += p.y;
    }
    f.centroid = {sx / f.area, sy / f.area};
    f.weightedCentroid = f.centroid;
    // Table 3-1: extremes of the top row, rightmost column, bottom row, leftmost column.
    int topMin = xr, topMax = xl, botMin = xr, botMax = xl;
    int rightMin = yb, rightMax = yt, leftMin = yb, leftMax = yt;
    for (const cv::Point& p : pixels) {
        if (p.y == yt) topMin = std::min(topMin, p.x), topMax = std::max(topMax, p.x);
        if (p.y == yb) botMin = std::min(botMin, p.x), botMax = std::max(botMax, p.x);
        if (p.x == xr) rightMin = std::min(rightMin, p.y), rightMax = std::max(rightMax, p.y);
        if (p.x == xl) leftMin = std::min(leftMin, p.y), leftMax = std::max(leftMax, p.y);
    }
    f.boundary[kTopLeft] = {topMin, yt};
    f.boundary[kTopRight] = {topMax, yt};
    f.boundary[kRightTop] = {xr, rightMin};
    f.boundary[kRightBottom] = {xr, rightMax};
    f.boundary[kBottomRight] = {botMax, yb};
    f.boundary[kBottomLeft] = {botMin, yb};
    f.boundary[kLeftBottom] = {xl, leftMax};
    f.boundary[kLeftTop] = {xl, leftMin};
    f.box = cv::Rect(xl, yt, xr - xl + 1, yb - yt + 1);
    f.aspectRatio = static_cast<double>(f.box.width) / f.box.height;
    f.areaRatio = static_cast<double>(f.area) / f.box.area();
    return f;
}

}  // namespace avatar::test
