// Stereo calibration on rendered checkerboards with known intrinsics,
// distortion and extrinsics (the renderer's checkerboard mode): the corner
// detector against the exact projections, and every recovered parameter
// against the truth within the standard errors the calibration itself states.
#include "SampleConfigs.h"

#include <avatar/analyze/StereoCalibration.h>
#include <avatar/common/CameraModel.h>
#include <avatar/common/Error.h>
#include <avatar/common/ImageUtils.h>
#include <avatar/render/Renderer.h>
#include <avatar/render/SceneSet.h>

#include <gtest/gtest.h>

#include <unistd.h>

#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <iomanip>
#include <tuple>
#include <string>
#include <vector>

namespace avatar {
namespace {

/// The Scorpion pair of the sample with lens distortion of a typical wide lens.
StereoSystemConfig distortedRig() {
    StereoSystemConfig s = test::scorpionCalibration();
    s.left.kc = {-0.12, 0.08, 0.0008, -0.0005, 0.0};
    s.right.kc = {-0.11, 0.07, -0.0006, 0.0004, 0.0};
    return s;
}

struct RenderedBoards {
    std::vector<CalibrationPair> pairs;
    std::vector<render::CheckerboardTruth> truths;
    BoardGeometry board{cv::Size(9, 6), 30.0};  // 10 x 7 squares of 30 mm
    int notFound{0};
};

template <typename P>
void writeCorners(std::ostream& out, const std::vector<P>& left, const std::vector<P>& right) {
    out << left.size() << "\n";
    for (std::size_t k = 0; k < left.size(); ++k)
        out << left[k].x << " " << left[k].y << " " << right[k].x << " " << right[k].y << "\n";
}

template <typename P>
bool readCorners(std::istream& in, std::vector<P>& left, std::vector<P>& right) {
    std::size_t n = 0;
    if (!(in >> n)) return false;
    left.resize(n);
    right.resize(n);
    for (std::size_t k = 0; k < n; ++k)
        if (!(in >> left[k].x >> left[k].y >> right[k].x >> right[k].y)) return false;
    return true;
}

/// 16 rendered 1280x960 16-bit Bayer pairs of a 10 x 7 square board of 30 mm,
/// demosaiced, with the corners found in each and the exact projections.
/// Rendering takes about 20 s, and ctest runs each test in a process of its
/// own, so the first process writes what it found to AVATAR_TEST_CACHE_DIR
/// (emptied at the start of every ctest run) and the others read it back: a
/// temporary file renamed into place, so no process reads half of it.
RenderedBoards renderBoards() {
    RenderedBoards out;
    const StereoSystemConfig rig = distortedRig();
    render::CheckerboardSpec spec;
    spec.views = 16;
    spec.seed = 11;
    spec.squaresX = 10;
    spec.squaresY = 7;
    spec.squareMm = 30.0;
    render::RenderOptions options;
    options.supersampling = 4;
    const auto scenes = render::makeCheckerboardViews(spec, rig, options.sensor);
    for (std::size_t i = 0; i < scenes.size(); ++i) {
        options.seed = 100 + i;
        const render::RenderResult r = render::render(scenes[i], rig, options);
        const StereoImagePair bgr = demosaic(r.pair);
        const auto left = findBoardCorners(bgr.left(), out.board.innerCorners, 16);
        const auto right = findBoardCorners(bgr.right(), out.board.innerCorners, 16);
        if (!left || !right) {
            ++out.notFound;
            continue;
        }
        out.pairs.push_back({scenes[i].name, *left, *right});
        out.truths.push_back(*r.truth.checkerboard);
    }
    return out;
}

/// Read back what writeBoards() wrote; false when the file is absent or short.
bool readBoards(const std::filesystem::path& file, RenderedBoards& out) {
    std::ifstream in(file);
    std::size_t count = 0;
    if (!(in >> out.notFound >> count)) return false;
    out.pairs.resize(count);
    out.truths.resize(count);
    for (std::size_t i = 0; i < count; ++i)
        if (!(in >> out.pairs[i].name) || !readCorners(in, out.pairs[i].left, out.pairs[i].right) ||
            !readCorners(in, out.truths[i].cornersLeftPx, out.truths[i].cornersRightPx))
            return false;
    return true;
}

/// Exactly: 9 significant digits for the float corners, 17 for the double truths.
void writeBoards(const std::filesystem::path& file, const RenderedBoards& b) {
    namespace fs = std::filesystem;
    fs::create_directories(file.parent_path());
    const fs::path temp = file.string() + ".tmp-" + std::to_string(::getpid());
    {
        std::ofstream out(temp);
        out << b.notFound << " " << b.pairs.size() << "\n";
        for (std::size_t i = 0; i < b.pairs.size(); ++i) {
            out << b.pairs[i].name << "\n" << std::setprecision(9);
            writeCorners(out, b.pairs[i].left, b.pairs[i].right);
            out << std::setprecision(17);
            writeCorners(out, b.truths[i].cornersLeftPx, b.truths[i].cornersRightPx);
        }
    }
    fs::rename(temp, file);
}

const RenderedBoards& boards() {
    static const RenderedBoards b = [] {
        const std::filesystem::path file = std::filesystem::path(AVATAR_TEST_CACHE_DIR) / "boards.txt";
        RenderedBoards cached;
        if (readBoards(file, cached)) return cached;
        RenderedBoards fresh = renderBoards();
        writeBoards(file, fresh);
        return fresh;
    }();
    return b;
}

double nearestDistance(const cv::Point2f& p, const std::vector<cv::Point2d>& truth) {
    double best = 1e9;
    for (const auto& t : truth) best = std::min(best, std::hypot(p.x - t.x, p.y - t.y));
    return best;
}

TEST(StereoCalibration, CornersLieOnTheExactProjections) {
    const RenderedBoards& b = boards();
    ASSERT_EQ(b.notFound, 0);
    double sum = 0.0, worst = 0.0;
    int n = 0;
    for (std::size_t i = 0; i < b.pairs.size(); ++i) {
        for (const auto* side : {&b.pairs[i].left, &b.pairs[i].right}) {
            const auto& truth = side == &b.pairs[i].left ? b.truths[i].cornersLeftPx : b.truths[i].cornersRightPx;
            for (const cv::Point2f& p : *side) {
                const double d = nearestDistance(p, truth);
                sum += d * d;
                worst = std::max(worst, d);
                ++n;
            }
        }
    }
    const double rms = std::sqrt(sum / n);
    RecordProperty("corner_rms_px", std::to_string(rms));
    std::printf("corner detection: %d corners, RMS %.4f px, worst %.4f px\n", n, rms, worst);
    EXPECT_LT(rms, 0.10);
    EXPECT_LT(worst, 0.5);
}

TEST(StereoCalibration, RecoversTheRigWithinItsStatedStandardErrors) {
    const RenderedBoards& b = boards();
    const StereoSystemConfig truth = distortedRig();
    const StereoCalibration c = calibrateStereo(b.pairs, b.board, cv::Size(1280, 960));
    ASSERT_TRUE(c.stereo.uncertainty);
    const CalibrationUncertainty& u = *c.stereo.uncertainty;
    std::printf("strategy %s (held back: fixed %.4f px, refined %.4f px); rms %.4f px, epipolar %.4f px\n",
                toString(c.strategy), c.heldOutFixedPx.value_or(-1), c.heldOutRefinedPx.value_or(-1), c.rmsPx,
                c.epipolarRmsPx);
    // Each estimate within 4 of its own standard errors of the truth (a 1 in
    // 16,000 chance for a correct Gaussian error), and the standard errors
    // themselves small: 16 views of 54 corners at 0.05 px noise.
    const auto near = [](double estimate, double expected, double sigma, double maxSigma, const std::string& what) {
        EXPECT_LE(std::abs(estimate - expected), std::max(4.0 * sigma, 1e-9)) << what << ": " << estimate << " vs "
                                                                            << expected << " +- " << sigma;
        EXPECT_LT(sigma, maxSigma) << what;
    };
    for (const auto& [name, est, tr, un] :
         {std::tuple<const char*, const CameraIntrinsics&, const CameraIntrinsics&, const IntrinsicsUncertainty&>{
              "left", c.stereo.left, truth.left, u.left},
          {"right", c.stereo.right, truth.right, u.right}}) {
        const std::string side = name;
        for (std::size_t i = 0; i < 2; ++i) {
            near(est.fc[i], tr.fc[i], un.fc[i], 1.5, side + " fc");
            near(est.cc[i], tr.cc[i], un.cc[i], 1.5, side + " cc");
        }
        near(est.kc[0], tr.kc[0], un.kc[0], 0.005, side + " k1");
        near(est.kc[1], tr.kc[1], un.kc[1], 0.02, side + " k2");
        near(est.kc[2], tr.kc[2], un.kc[2], 0.0005, side + " p1");
        near(est.kc[3], tr.kc[3], un.kc[3], 0.0005, side + " p2");
        EXPECT_EQ(est.kc[4], 0.0);  // k3 fixed, as the toolbox
    }
    for (std::size_t i = 0; i < 3; ++i) {
        near(c.stereo.om[i], truth.om[i], u.om[i], 0.002, "om");
        near(c.stereo.translationMm[i], truth.translationMm[i], u.translationMm[i], 0.5, "T");
    }
    EXPECT_LT(c.rmsPx, 0.15);
    EXPECT_LT(c.epipolarRmsPx, 0.10);
    EXPECT_EQ(c.perPairRmsPx.size(), b.pairs.size());
    EXPECT_FALSE(c.stereo.baseTVision);
}

TEST(StereoCalibration, BothStrategiesAreComparedOnHeldBackPairs) {
    const RenderedBoards& b = boards();
    const StereoCalibration c = calibrateStereo(b.pairs, b.board, cv::Size(1280, 960));
    ASSERT_TRUE(c.heldOutFixedPx && c.heldOutRefinedPx);
    EXPECT_EQ(c.heldOutPairs.size(), 4u);
    EXPECT_EQ(c.strategy, *c.heldOutFixedPx < *c.heldOutRefinedPx ? StereoStrategy::FixIntrinsics
                                                                  : StereoStrategy::RefineAll);
    StereoCalibrationOptions fixed;
    fixed.strategy = StereoStrategy::FixIntrinsics;
    const StereoCalibration f = calibrateStereo(b.pairs, b.board, cv::Size(1280, 960), fixed);
    EXPECT_EQ(f.strategy, StereoStrategy::FixIntrinsics);
    EXPECT_FALSE(f.heldOutFixedPx);
    // With fixed intrinsics, the intrinsics are each camera's own calibration.
    EXPECT_EQ(f.stereo.left, f.left.intrinsics);
}

TEST(StereoCalibration, RefusesWhatCannotBeCalibrated) {
    const RenderedBoards& b = boards();
    const std::vector<CalibrationPair> two(b.pairs.begin(), b.pairs.begin() + 2);
    EXPECT_THROW(calibrateStereo(two, b.board, cv::Size(1280, 960)), InvalidArgument);
    std::vector<CalibrationPair> shortPair(b.pairs.begin(), b.pairs.begin() + 4);
    shortPair[1].right.pop_back();
    EXPECT_THROW(calibrateStereo(shortPair, b.board, cv::Size(1280, 960)), InvalidArgument);
    EXPECT_THROW(calibrateStereo(b.pairs, {cv::Size(1, 6), 30.0}, cv::Size(1280, 960)), InvalidArgument);
    // A board that is not in the image is not found (no guess).
    EXPECT_FALSE(findBoardCorners(cv::Mat(480, 640, CV_8UC1, cv::Scalar(128)), cv::Size(9, 6)));
}

}  // namespace
}  // namespace avatar
