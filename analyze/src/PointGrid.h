#pragma once
/// @file PointGrid.h
/// Internal: the spatial look-ups of the stereo matcher (SIPFeatureMatcher.cpp):
/// a grid over the right image's centroids, and the clipping and distance of
/// the epipolar segment a candidate must lie near.

#include <opencv2/core/types.hpp>

#include <algorithm>
#include <cmath>
#include <limits>
#include <vector>

namespace avatar::detail {

/// A uniform grid over 2-D points with compressed cell lists. Queries visit the
/// cells that overlap a rectangle, so they cost the cells and points near the
/// rectangle, not all points. Points that are not finite are left out.
class PointGrid {
public:
    explicit PointGrid(const std::vector<cv::Point2d>& points) {
        double minX = std::numeric_limits<double>::infinity(), minY = minX;
        double maxX = -minX, maxY = -minX;
        std::size_t finite = 0;
        for (const cv::Point2d& p : points) {
            if (!std::isfinite(p.x) || !std::isfinite(p.y)) continue;
            minX = std::min(minX, p.x);
            maxX = std::max(maxX, p.x);
            minY = std::min(minY, p.y);
            maxY = std::max(maxY, p.y);
            ++finite;
        }
        if (finite == 0) return;
        originX_ = minX;
        originY_ = minY;
        const double width = std::max(maxX - minX, 1.0);
        const double height = std::max(maxY - minY, 1.0);
        // About one point per cell; a flat point set gets a row of cells.
        const double n = static_cast<double>(finite);
        cell_ = std::sqrt(width * height / n);
        const double maxCells = 4.0 * n + 16.0;
        while ((std::floor(width / cell_) + 1.0) * (std::floor(height / cell_) + 1.0) > maxCells)
            cell_ *= 2.0;
        nx_ = static_cast<int>(std::floor(width / cell_)) + 1;
        ny_ = static_cast<int>(std::floor(height / cell_)) + 1;

        const std::size_t cells = static_cast<std::size_t>(nx_) * static_cast<std::size_t>(ny_);
        start_.assign(cells + 1, 0);
        std::vector<int> cellOf(points.size(), -1);
        for (std::size_t i = 0; i < points.size(); ++i) {
            const cv::Point2d& p = points[i];
            if (!std::isfinite(p.x) || !std::isfinite(p.y)) continue;
            const int c = cellX(p.x) + nx_ * cellY(p.y);
            cellOf[i] = c;
            ++start_[static_cast<std::size_t>(c) + 1];
        }
        for (std::size_t c = 0; c < cells; ++c) start_[c + 1] += start_[c];
        items_.resize(finite);
        std::vector<int> fill(start_.begin(), start_.end() - 1);
        for (std::size_t i = 0; i < points.size(); ++i)
            if (cellOf[i] >= 0)
                items_[static_cast<std::size_t>(fill[static_cast<std::size_t>(cellOf[i])]++)] =
                    static_cast<int>(i);
    }

    /// Calls visit(index) for every point in the cells overlapping
    /// [x0, x1] x [y0, y1] (a superset of the points inside it).
    template <typename Visit>
    void query(double x0, double y0, double x1, double y1, Visit&& visit) const {
        if (nx_ == 0 || !(x0 <= x1) || !(y0 <= y1)) return;
        const int cx0 = cellX(x0), cx1 = cellX(x1);
        const int cy0 = cellY(y0), cy1 = cellY(y1);
        for (int cy = cy0; cy <= cy1; ++cy)
            for (int cx = cx0; cx <= cx1; ++cx) {
                const std::size_t c = static_cast<std::size_t>(cx + nx_ * cy);
                for (int k = start_[c]; k < start_[c + 1]; ++k)
                    visit(items_[static_cast<std::size_t>(k)]);
            }
    }

    double cellSize() const { return cell_; }
    /// The area the cells cover.
    cv::Rect2d bounds() const { return {originX_, originY_, nx_ * cell_, ny_ * cell_}; }

private:
    int clampIndex(double v, int n) const {
        if (!(v > 0.0)) return 0;  // also NaN
        if (v >= static_cast<double>(n - 1)) return n - 1;
        return static_cast<int>(v);
    }
    int cellX(double x) const { return clampIndex(std::floor((x - originX_) / cell_), nx_); }
    int cellY(double y) const { return clampIndex(std::floor((y - originY_) / cell_), ny_); }

    double originX_{0.0}, originY_{0.0}, cell_{1.0};
    int nx_{0}, ny_{0};
    std::vector<int> start_;
    std::vector<int> items_;
};

/// Liang-Barsky: clips the segment a-b to @p rect; false when nothing is left.
inline bool clipSegment(cv::Point2d& a, cv::Point2d& b, const cv::Rect2d& rect) {
    const cv::Point2d d = b - a;
    double t0 = 0.0, t1 = 1.0;
    const double p[4] = {-d.x, d.x, -d.y, d.y};
    const double q[4] = {a.x - rect.x, rect.x + rect.width - a.x, a.y - rect.y,
                         rect.y + rect.height - a.y};
    for (int k = 0; k < 4; ++k) {
        if (p[k] == 0.0) {
            if (q[k] < 0.0) return false;
            continue;
        }
        const double t = q[k] / p[k];
        if (p[k] < 0.0)
            t0 = std::max(t0, t);
        else
            t1 = std::min(t1, t);
    }
    if (!(t0 <= t1)) return false;
    const cv::Point2d start = a;
    a = start + d * t0;
    b = start + d * t1;
    return true;
}

/// Distance from @p q to the segment [a, b].
inline double distanceToSegment(const cv::Point2d& q, const cv::Point2d& a, const cv::Point2d& b) {
    const cv::Point2d ab = b - a;
    const double length2 = ab.dot(ab);
    const double t = length2 > 0.0 ? std::clamp((q - a).dot(ab) / length2, 0.0, 1.0) : 0.0;
    const cv::Point2d d = q - (a + ab * t);
    return std::hypot(d.x, d.y);
}

}  // namespace avatar::detail
