#include <avatar/analyze/SphereSilhouette.h>

#include "ShapeFit.h"

#include <avatar/common/CameraModel.h>

#include <opencv2/core.hpp>
#include <opencv2/imgproc.hpp>

#include <cmath>

namespace avatar {

std::vector<cv::Point2d> featureOutline(const cv::Mat& mask, const Feature& feature) {
    // Isolate the feature's own component inside its box: flood it from its
    // first pixel (another feature may reach into the box).
    // The box gets a one-pixel frame so that everything outside the feature
    // is connected. Holes (noise inside a dim feature) are not silhouette
    // edges: only the outer boundary is kept, by flooding the outside too.
    const cv::Rect box = feature.box;
    cv::Mat region = cv::Mat::zeros(box.height + 2, box.width + 2, CV_8UC1);
    cv::threshold(mask(box), region(cv::Rect(1, 1, box.width, box.height)), 0, 255, cv::THRESH_BINARY);
    const cv::Point seed = feature.boundary[kTopLeft] - box.tl() + cv::Point(1, 1);
    cv::floodFill(region, seed, cv::Scalar(128), nullptr, cv::Scalar(), cv::Scalar(), 8);
    cv::Mat notFeature = region != 128;  // 255 outside, holes and other features' pixels
    cv::floodFill(notFeature, cv::Point(0, 0), cv::Scalar(0), nullptr, cv::Scalar(), cv::Scalar(), 4);
    region.setTo(cv::Scalar(128), notFeature);  // holes join the feature

    std::vector<cv::Point2d> outline;
    auto inside = [&](int x, int y) {
        return x >= 0 && y >= 0 && x < region.cols && y < region.rows && region.at<uchar>(y, x) == 128;
    };
    for (int y = 0; y < region.rows; ++y) {
        for (int x = 0; x < region.cols; ++x) {
            if (!inside(x, y)) continue;
            const double px = x - 1 + box.x, py = y - 1 + box.y;
            if (!inside(x - 1, y)) outline.emplace_back(px - 0.5, py);
            if (!inside(x + 1, y)) outline.emplace_back(px + 0.5, py);
            if (!inside(x, y - 1)) outline.emplace_back(px, py - 0.5);
            if (!inside(x, y + 1)) outline.emplace_back(px, py + 0.5);
        }
    }
    return outline;
}

std::optional<cv::Point2d> sphereCentreDirection(const CameraIntrinsics& camera,
                                                 const std::vector<cv::Point2d>& outlinePx) {
    if (outlinePx.size() < 6) return std::nullopt;
    // Undistort into an ideal pinhole image with the camera's own fc and cc, so
    // the fit works in well-conditioned pixel-sized numbers.
    const double f = camera.fc[0];
    std::vector<cv::Point2f> ideal;
    ideal.reserve(outlinePx.size());
    cv::Point2d mean(0, 0);
    for (const auto& p : outlinePx) {
        const cv::Point2d n = normalizePixel(camera, p);
        mean += n;
        ideal.emplace_back(static_cast<float>(n.x * f), static_cast<float>(n.y * f));
    }
    mean *= 1.0 / static_cast<double>(outlinePx.size());
    // Centre the points before the float fit to keep precision.
    const cv::Point2f offset(static_cast<float>(mean.x * f), static_cast<float>(mean.y * f));
    for (auto& p : ideal) p -= offset;
    const cv::RotatedRect e = cv::fitEllipseDirect(ideal);
    if (!(e.size.width > 0 && e.size.height > 0)) return std::nullopt;

    // The cone's axis from the conic of the ellipse in normalised coordinates.
    const auto cone = detail::sphereCone(detail::ellipseConic(e, f, mean));
    if (!cone) return std::nullopt;
    return cone->axis;
}

}  // namespace avatar
