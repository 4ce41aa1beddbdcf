#include "NinePointTriangulation.h"

#include <cmath>

namespace avatar::detail {

std::optional<StereoPoint> triangulateNinePoints(const StereoCoordinateCalculator& calculator,
                                                 const Feature& left, const Feature& right,
                                                 const cv::Point2d& leftCentroid, const cv::Point2d& rightCentroid) {
    const auto pl = left.interestPoints(), pr = right.interestPoints();
    cv::Point3d sumL(0, 0, 0), sumR(0, 0, 0);
    std::optional<cv::Point3d> sumBase;
    double gap = 0.0, reprojection = 0.0;
    int n = 0;
    for (std::size_t i = 0; i < pl.size(); ++i) {
        // Point 8 is the centroid: use the configured kind.
        const auto q = calculator.triangulate(i == 8 ? leftCentroid : pl[i], i == 8 ? rightCentroid : pr[i]);
        if (!q) continue;
        sumL += q->leftMm;
        sumR += q->rightMm;
        gap += q->rayGapMm;
        reprojection += q->reprojectionPx * q->reprojectionPx;
        if (q->baseMm) sumBase = sumBase.value_or(cv::Point3d(0, 0, 0)) + *q->baseMm;
        ++n;
    }
    if (n == 0) return std::nullopt;
    StereoPoint average;
    average.leftMm = sumL * (1.0 / n);
    average.rightMm = sumR * (1.0 / n);
    average.rayGapMm = gap / n;                           // mean over the nine pairs
    average.reprojectionPx = std::sqrt(reprojection / n);  // RMS over the nine pairs
    if (sumBase) average.baseMm = *sumBase * (1.0 / n);
    return average;
}

}  // namespace avatar::detail
