// Camera-manipulator registration (thesis 3.1.2): the closed form against the
// truth and against the statistical optimum, the thesis's iterative algorithm
// of Figure 3-1, outlier rejection, and the layouts that determine no rotation.
#include "RegistrationScenes.h"

#include <avatar/common/Error.h>
#include <avatar/common/Registration.h>

#include <gtest/gtest.h>
#include <opencv2/core.hpp>

#include <algorithm>
#include <array>
#include <cmath>
#include <random>
#include <string>
#include <vector>

namespace avatar {
namespace {

double rotationErrorRad(const RigidTransform& a, const RigidTransform& b) {
    return rotationAngleBetween(rotationMatrix(a), rotationMatrix(b));
}
double translationErrorMm(const RigidTransform& a, const RigidTransform& b) {
    return cv::norm(translationVector(a) - translationVector(b));
}
double median(std::vector<double> v) {
    std::sort(v.begin(), v.end());
    return v[v.size() / 2];
}

TEST(Registration, ClosedFormRecoversExactDataForAnyRotation) {
    for (const double angle : {0.0, 0.01, 1.0, 2.5, M_PI - 1e-3, M_PI}) {
        for (std::uint64_t seed = 1; seed <= 5; ++seed) {
            test::PointSetSpec spec;
            spec.noiseMm = 0.0;
            spec.points = 7;
            spec.rotationRad = angle;
            const test::PointSet set = test::drawPointSet(spec, seed);
            const RigidTransform r = registerClosedForm(set.vision, set.base);
            EXPECT_LT(rotationErrorRad(r, set.baseTVision), 1e-12) << "angle " << angle;
            EXPECT_LT(translationErrorMm(r, set.baseTVision), 1e-9) << "angle " << angle;
            EXPECT_NEAR(cv::determinant(rotationMatrix(r)), 1.0, 1e-12);
        }
    }
}

TEST(Registration, PlanarPointsGiveARotationNotAReflection) {
    // All points in one plane: the cross-covariance has rank 2, and the
    // orthogonal matrix that fits best may be the reflection through the
    // plane; the solver must give the rotation.
    for (std::uint64_t seed = 1; seed <= 20; ++seed) {
        test::PointSetSpec spec;
        spec.lineThicknessMm = -1.0;  // planar
        spec.noiseMm = 0.0;
        spec.rotationRad = 2.0;
        const test::PointSet set = test::drawPointSet(spec, seed);
        const RigidTransform r = registerClosedForm(set.vision, set.base);
        EXPECT_NEAR(cv::determinant(rotationMatrix(r)), 1.0, 1e-12);
        EXPECT_LT(rotationErrorRad(r, set.baseTVision), 1e-10) << seed;
    }
}

TEST(Registration, LayoutsThatDetermineNoRotationAreRefused) {
    const std::vector<cv::Point3d> line{{0, 0, 800}, {100, 0, 800}, {250, 0, 800}, {-70, 0, 800}};
    std::vector<cv::Point3d> moved;
    for (const auto& p : line) moved.push_back({p.y, p.x, p.z + 5});
    try {
        registerClosedForm(line, moved);
        ADD_FAILURE() << "solved a line";
    } catch (const InvalidArgument& e) {
        EXPECT_NE(std::string(e.what()).find("lie on one line"), std::string::npos) << e.what();
    }
    EXPECT_THROW(registerIterative(line, moved), InvalidArgument);
    EXPECT_THROW(registerRobust(line, moved), InvalidArgument);
    const std::vector<cv::Point3d> two{{0, 0, 800}, {10, 0, 800}};
    EXPECT_THROW(registerClosedForm(two, two), InvalidArgument);
    const std::vector<cv::Point3d> same(5, cv::Point3d(1, 2, 3));
    EXPECT_THROW(registerClosedForm(same, same), InvalidArgument);
    std::vector<cv::Point3d> three{{0, 0, 800}, {100, 0, 800}, {0, 100, 800}};
    EXPECT_THROW(registerClosedForm(three, line), InvalidArgument);  // counts differ
    three[1].y = std::nan("");
    EXPECT_THROW(registerClosedForm(three, three), InvalidArgument);
}

/// The closed form reaches the statistical optimum: with independent Gaussian
/// noise sigma in both frames, the rotation error of the maximum-likelihood
/// estimate is to first order Gaussian with covariance
///   2 sigma^2 (tr(S) I - S)^-1,   S = sum of (v_i - mean)(v_i - mean)^T,
/// and its median over trials must match the median of that distribution.
TEST(Registration, ClosedFormReachesTheStatisticalOptimum) {
    test::PointSetSpec spec;
    spec.points = 20;
    spec.noiseMm = 1.0;
    spec.rotationRad = 1.2;
    std::vector<double> closed, iterative, predicted;
    std::mt19937_64 gauss(99);
    std::normal_distribution<double> normal;
    for (std::uint64_t seed = 1; seed <= 600; ++seed) {
        const test::PointSet set = test::drawPointSet(spec, seed);
        closed.push_back(rotationErrorRad(registerClosedForm(set.vision, set.base), set.baseTVision));
        iterative.push_back(rotationErrorRad(registerIterative(set.vision, set.base), set.baseTVision));
        // One draw from the first-order distribution of this layout.
        cv::Vec3d mean(0, 0, 0);
        for (const auto& p : set.vision) mean += cv::Vec3d(p.x, p.y, p.z);
        mean *= 1.0 / set.vision.size();
        cv::Matx33d s = cv::Matx33d::zeros();
        for (const auto& p : set.vision) {
            const cv::Vec3d d = cv::Vec3d(p.x, p.y, p.z) - mean;
            s += d * d.t();
        }
        const double trace = s(0, 0) + s(1, 1) + s(2, 2);
        const cv::Matx33d cov = 2.0 * spec.noiseMm * spec.noiseMm * (trace * cv::Matx33d::eye() - s).inv();
        cv::Mat values, vectors;  // cov = Q^T diag(values) Q, rows of Q the eigenvectors
        cv::eigen(cv::Mat(cov), values, vectors);
        cv::Vec3d draw(0, 0, 0);
        for (int k = 0; k < 3; ++k)
            draw += cv::Vec3d(vectors.at<double>(k, 0), vectors.at<double>(k, 1), vectors.at<double>(k, 2)) *
                    (std::sqrt(values.at<double>(k)) * normal(gauss));
        predicted.push_back(cv::norm(draw));
    }
    const double m = median(closed), p = median(predicted);
    EXPECT_NEAR(m / p, 1.0, 0.1) << "closed form " << m * 180 / M_PI << " deg, optimum " << p * 180 / M_PI << " deg";
    // The thesis's iterative algorithm converges to the same solution here (a
    // well-spread cube), never to a better one.
    EXPECT_GE(median(iterative), m * 0.999);
    // About 0.075 degree at 1 mm noise and 20 points in a 1 m workspace.
    EXPECT_LT(m * 180 / M_PI, 0.09);
}

TEST(Registration, IterativeMatchesTheClosedFormOnGoodLayouts) {
    for (std::uint64_t seed = 1; seed <= 20; ++seed) {
        test::PointSetSpec spec;
        spec.noiseMm = 0.0;
        spec.rotationRad = 0.3;
        const test::PointSet set = test::drawPointSet(spec, seed);
        const RigidTransform r = registerIterative(set.vision, set.base, 1000);
        EXPECT_LT(rotationErrorRad(r, set.baseTVision), 1e-9) << seed;
        EXPECT_LT(translationErrorMm(r, set.baseTVision), 1e-6) << seed;
    }
}

TEST(Registration, RobustMarksGrossOutliersAndKeepsTheAccuracy) {
    test::PointSetSpec clean;
    clean.points = 20;
    clean.noiseMm = 1.0;
    test::PointSetSpec dirty = clean;
    dirty.outlierFraction = 0.2;  // 4 of 20 points off by 50..200 mm
    std::vector<double> cleanErrors, robustErrors;
    int missed = 0, falseAlarms = 0;
    for (std::uint64_t seed = 1; seed <= 200; ++seed) {
        const test::PointSet a = test::drawPointSet(clean, seed);
        cleanErrors.push_back(rotationErrorRad(registerClosedForm(a.vision, a.base), a.baseTVision));
        const test::PointSet b = test::drawPointSet(dirty, seed);
        RobustRegistrationOptions options;
        options.seed = seed;
        const RobustRegistration r = registerRobust(b.vision, b.base, options);
        robustErrors.push_back(rotationErrorRad(r.baseTVision, b.baseTVision));
        for (std::size_t i = 0; i < b.outlier.size(); ++i) {
            missed += b.outlier[i] && r.inliers[i];
            falseAlarms += !b.outlier[i] && !r.inliers[i];
        }
    }
    EXPECT_EQ(missed, 0);
    EXPECT_LE(falseAlarms, 200 * 16 / 500);  // the 99.9 % threshold: about 1 in 1,000 inliers
    EXPECT_LT(median(robustErrors), 2.0 * median(cleanErrors))
        << median(robustErrors) * 180 / M_PI << " vs " << median(cleanErrors) * 180 / M_PI << " deg";
}

TEST(Registration, PredictedUncertaintyMatchesTheSpreadOverTrials) {
    test::PointSetSpec spec;
    spec.points = 20;
    spec.noiseMm = 2.0;
    spec.rotationRad = 0.8;
    spec.halfSizeMm = 300.0;
    std::array<double, 3> sumSquares{}, predicted{};
    std::array<double, 3> tSquares{}, tPredicted{};
    double sigma = 0.0;
    const int trials = 600;
    for (int t = 1; t <= trials; ++t) {
        const test::PointSet set = test::drawPointSet(spec, static_cast<std::uint64_t>(t));
        RegistrationOptions options;
        options.rejectOutliers = false;
        const PointRegistration r = registerPoints(set.vision, set.base, options);
        // The rotation error as a small vector in the vision frame.
        const cv::Matx33d truth = rotationMatrix(set.baseTVision);
        const std::array<double, 3> wb = rodriguesVector(rotationMatrix(r.baseTVision) * truth.t());
        const cv::Vec3d wv = truth.t() * cv::Vec3d(wb[0], wb[1], wb[2]);
        const cv::Vec3d dt = translationVector(r.baseTVision) - translationVector(set.baseTVision);
        for (std::size_t k = 0; k < 3; ++k) {
            sumSquares[k] += wv[static_cast<int>(k)] * wv[static_cast<int>(k)];
            predicted[k] += r.uncertainty.rotationStdRad[k];
            tSquares[k] += dt[static_cast<int>(k)] * dt[static_cast<int>(k)];
            tPredicted[k] += r.uncertainty.translationStdMm[k];
        }
        sigma += r.uncertainty.sigmaMm;
    }
    // Noise in both frames: the residual's per-axis sigma is sqrt(2) times each frame's.
    EXPECT_NEAR(sigma / trials, std::sqrt(2.0) * spec.noiseMm, 0.05 * std::sqrt(2.0) * spec.noiseMm);
    for (std::size_t k = 0; k < 3; ++k) {
        const double measured = std::sqrt(sumSquares[k] / trials);
        EXPECT_NEAR(predicted[k] / trials / measured, 1.0, 0.15) << "rotation axis " << k;
        const double tMeasured = std::sqrt(tSquares[k] / trials);
        EXPECT_NEAR(tPredicted[k] / trials / tMeasured, 1.0, 0.15) << "translation axis " << k;
    }
}

TEST(Registration, TheDefaultRefusesARotationItCannotDetermine) {
    // 20 points within 5 mm of a line, 1 mm noise: the rotation about the
    // line is uncertain by degrees; the closed form alone would return it.
    test::PointSetSpec spec;
    spec.lineThicknessMm = 5.0;
    try {
        registerPoints(test::drawPointSet(spec, 3).vision, test::drawPointSet(spec, 3).base);
        ADD_FAILURE() << "accepted";
    } catch (const InvalidArgument& e) {
        EXPECT_NE(std::string(e.what()).find("too close to one line"), std::string::npos) << e.what();
    }
    // The same layout without noise determines the rotation exactly.
    spec.noiseMm = 0.0;
    const test::PointSet exact = test::drawPointSet(spec, 3);
    const PointRegistration r = registerPoints(exact.vision, exact.base);
    EXPECT_LT(rotationErrorRad(r.baseTVision, exact.baseTVision), 1e-9);
    EXPECT_EQ(std::count(r.inliers.begin(), r.inliers.end(), true), 20);
}

TEST(Registration, EulerAnglesAreTableSixSixs) {
    const double a = 0.3, b = -0.2, g = 1.1;
    const cv::Matx33d rz(std::cos(a), -std::sin(a), 0, std::sin(a), std::cos(a), 0, 0, 0, 1);
    const cv::Matx33d ry(std::cos(b), 0, std::sin(b), 0, 1, 0, -std::sin(b), 0, std::cos(b));
    const cv::Matx33d rx(1, 0, 0, 0, std::cos(g), -std::sin(g), 0, std::sin(g), std::cos(g));
    const auto e = eulerZyx(rz * ry * rx);
    EXPECT_NEAR(e[0], a, 1e-12);
    EXPECT_NEAR(e[1], b, 1e-12);
    EXPECT_NEAR(e[2], g, 1e-12);
    EXPECT_NEAR(rotationAngleBetween(cv::Matx33d::eye(), rx), g, 1e-12);
}

}  // namespace
}  // namespace avatar
