#include "TargetAssembly.h"

#include "NinePointTriangulation.h"

#include <avatar/analyze/SphereSilhouette.h>

#include <optional>

namespace avatar::detail {

TargetAssembler::TargetAssembler(const StereoSystemConfig& stereo, const AnalysisConfig& analysis)
    : calculator_(stereoGeometry(stereo)),
      weighted_(analysis.centroid == CentroidMode::IntensityWeighted),
      ninePoints_(analysis.triangulation == TriangulationMode::NinePoints) {}

void TargetAssembler::assemble(const TargetType& type, const std::vector<Feature>& left,
                               const std::vector<Feature>& right, const cv::Mat& leftMask, const cv::Mat& rightMask,
                               const std::vector<FeatureMatch>& matches, std::vector<VisionTarget>& out) const {
    std::vector<bool> usedLeft(left.size()), usedRight(right.size());
    for (const FeatureMatch& m : matches) {
        const Feature& fl = left[static_cast<std::size_t>(m.left)];
        const Feature& fr = right[static_cast<std::size_t>(m.right)];
        usedLeft[static_cast<std::size_t>(m.left)] = true;
        usedRight[static_cast<std::size_t>(m.right)] = true;
        out.push_back(stereoTarget(type, fl, fr, leftMask, rightMask, m));
    }
    for (std::size_t i = 0; i < usedLeft.size(); ++i)
        if (!usedLeft[i]) out.push_back(singleTarget(type, left[i], Side::Left));
    for (std::size_t i = 0; i < usedRight.size(); ++i)
        if (!usedRight[i]) out.push_back(singleTarget(type, right[i], Side::Right));
}

VisionTarget TargetAssembler::stereoTarget(const TargetType& type, const Feature& fl, const Feature& fr,
                                           const cv::Mat& maskL, const cv::Mat& maskR,
                                           const FeatureMatch& m) const {
    VisionTarget target;
    target.type = type.name;
    target.flags = kTargetStereo;
    if (fl.touchesBorder || fr.touchesBorder) target.flags |= kTargetAtBorder;
    target.centroidLeftPx = point(fl);
    target.centroidRightPx = point(fr);
    target.areaLeftPx = fl.area;
    target.areaRightPx = fr.area;
    target.matchError = m.shapeError;

    std::optional<StereoPoint> p;
    if (type.shape == TargetShape::Sphere && !(target.flags & kTargetAtBorder)) {
        const StereoGeometry& stereo = calculator_.geometry();
        const auto dl = sphereCentreDirection(stereo.left, featureOutline(maskL, fl));
        const auto dr = sphereCentreDirection(stereo.right, featureOutline(maskR, fr));
        if (dl && dr) {
            p = calculator_.triangulateNormalized(*dl, *dr);
            if (p) target.flags |= kTargetShapeCorrected;
        }
    }
    if (!p && ninePoints_) p = triangulateNinePoints(calculator_, fl, fr, point(fl), point(fr));
    if (!p) p = calculator_.triangulate(point(fl), point(fr));
    if (p) {
        target.positionVisionMm = p->leftMm;
        target.positionBaseMm = p->baseMm;
    } else {
        target.flags &= ~static_cast<std::uint32_t>(kTargetStereo);  // parallel rays: no position
    }
    return target;
}

VisionTarget TargetAssembler::singleTarget(const TargetType& type, const Feature& f, Side side) const {
    VisionTarget target;
    target.type = type.name;
    target.flags = side == Side::Left ? kTargetLeftOnly : kTargetRightOnly;
    if (f.touchesBorder) target.flags |= kTargetAtBorder;
    if (side == Side::Left) {
        target.centroidLeftPx = point(f);
        target.areaLeftPx = f.area;
    } else {
        target.centroidRightPx = point(f);
        target.areaRightPx = f.area;
    }
    return target;
}

}  // namespace avatar::detail
