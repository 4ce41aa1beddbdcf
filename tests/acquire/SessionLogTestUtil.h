#pragma once
// Builders and field-by-field comparison of session records for the acquire tests.
#include "TestUtil.h"

#include <avatar/acquire/SessionLog.h>

#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <string>

namespace avatar::test {

inline AcquisitionId acquisition(std::uint32_t group, std::uint32_t member, std::int64_t t) {
    return {group, member, {"0x00b09d01004a5e2c", t}, {"cam right #2", t + 17}};
}

inline StereoImagePair bayerPair(const AcquisitionId& id, std::uint64_t seed) {
    return StereoImagePair(randomImage(6, 8, CV_16UC1, 12, seed), randomImage(6, 8, CV_16UC1, 12, seed + 1),
                           {PixelFormat::Bayer, BayerPattern::GB, 12}, id);
}

/// A result exercising every field: all optional combinations, awkward strings
/// and doubles that only round-trip when written in shortest exact form.
inline VisionTargets fullResult(std::uint64_t iteration, const AcquisitionId& id) {
    VisionTargets v;
    v.iteration = iteration;
    v.acquisition = id;
    v.visibility = Visibility::Poor;
    v.visibilityReason = "left: contrast 0.02 below 0.05; right, too: 100% dark";
    v.timings = {{"acquire", 12.5}, {"colour filter", 0.1 + 0.2}, {"match:stereo", 1.0 / 3.0}};
    VisionTarget stereo;
    stereo.type = "sample";
    stereo.flags = kTargetStereo | kTargetShapeCorrected;
    stereo.positionVisionMm = cv::Point3d(12.25, -3.0 / 7.0, 1234.5678901234567);
    stereo.positionBaseMm = cv::Point3d(-0.0, 1e-300, std::numeric_limits<double>::max());
    stereo.centroidLeftPx = cv::Point2d(640.125, 480.0000001);
    stereo.centroidRightPx = cv::Point2d(std::numeric_limits<double>::denorm_min(), 2.0 / 3.0);
    stereo.areaLeftPx = 1523.0;
    stereo.areaRightPx = 1498.5;
    stereo.matchError = 0.017;
    stereo.model = ShapeModel::Sphere;
    stereo.covarianceVisionMm2 = Covariance3(0.04, 0.001, -0.002, 0.001, 0.05, 1.0 / 3.0, -0.002, 1.0 / 3.0, 2.25);
    stereo.covarianceBaseMm2 = Covariance3(2.25, 0, 0, 0, 0.04, -1e-7, 0, -1e-7, 0.05);
    stereo.rayResidualMm = 0.125;
    stereo.rayResidualPx = 1.0 / 7.0;
    VisionTarget leftOnly;
    leftOnly.type = "arm, end-effector: IEEM 50%";
    leftOnly.flags = kTargetLeftOnly | kTargetAtBorder;
    leftOnly.centroidLeftPx = cv::Point2d(1.5, 2.5);
    leftOnly.areaLeftPx = 77.75;
    leftOnly.model = ShapeModel::Composite;
    VisionTarget bare;  // nothing optional set, empty type
    bare.flags = 0xFFFFFFFFu;
    bare.areaRightPx = std::numeric_limits<double>::infinity();
    bare.matchError = -std::numeric_limits<double>::infinity();
    v.targets = {stereo, leftOnly, bare};
    return v;
}

inline const char* kConfigXmlV1 =
    "<?xml version=\"1.0\" encoding=\"UTF-8\"?>\n"
    "<avatar version=\"1\">\n"
    "\t<camera width=\"1280\" height=\"960\"/>\r\n"
    "  <!-- 100% sure: a,b;c:d=e \xC3\xA9 -->\n"
    "</avatar>\n";
inline const char* kConfigXmlV2 = "<avatar version=\"2\"><camera width=\"640\"/></avatar>";

inline void expectSameAcquisition(const AcquisitionId& a, const AcquisitionId& b, const std::string& what) {
    SCOPED_TRACE(what);
    EXPECT_EQ(a.group, b.group);
    EXPECT_EQ(a.member, b.member);
    EXPECT_EQ(a.left.cameraId, b.left.cameraId);
    EXPECT_EQ(a.left.timestampUs, b.left.timestampUs);
    EXPECT_EQ(a.right.cameraId, b.right.cameraId);
    EXPECT_EQ(a.right.timestampUs, b.right.timestampUs);
}

/// Bitwise equality of doubles: also -0.0 vs 0.0 must survive.
inline bool sameBits(double a, double b) { return std::signbit(a) == std::signbit(b) && (a == b || (a != a && b != b)); }

inline void expectSameTarget(const VisionTarget& a, const VisionTarget& b) {
    EXPECT_EQ(a, b);  // VisionTarget::operator== compares every field
    if (a.positionBaseMm && b.positionBaseMm) {
        EXPECT_TRUE(sameBits(a.positionBaseMm->x, b.positionBaseMm->x)) << "sign of zero lost";
    }
}

inline void expectSameRecord(const SessionRecord& a, const SessionRecord& b) {
    SCOPED_TRACE("iteration " + std::to_string(a.iteration));
    EXPECT_EQ(a.iteration, b.iteration);
    expectSameAcquisition(a.acquisition, b.acquisition, "record acquisition");
    EXPECT_EQ(a.files.left, b.files.left);
    EXPECT_EQ(a.files.right, b.files.right);
    EXPECT_EQ(a.configVersion, b.configVersion);
    EXPECT_EQ(a.configXml, b.configXml);
    ASSERT_EQ(a.result.has_value(), b.result.has_value());
    if (!a.result) return;
    const VisionTargets& x = *a.result;
    const VisionTargets& y = *b.result;
    EXPECT_EQ(x.iteration, y.iteration);
    expectSameAcquisition(x.acquisition, y.acquisition, "result acquisition");
    EXPECT_EQ(x.visibility, y.visibility);
    EXPECT_EQ(x.visibilityReason, y.visibilityReason);
    EXPECT_EQ(x.timings, y.timings);
    ASSERT_EQ(x.targets.size(), y.targets.size());
    for (std::size_t i = 0; i < x.targets.size(); ++i) {
        SCOPED_TRACE("target " + std::to_string(i));
        expectSameTarget(x.targets[i], y.targets[i]);
    }
}

}  // namespace avatar::test
