#pragma once
// Synthetic camera-manipulator point sets for the registration tests and the
// registration report: points spread through an arm's workspace in front of
// the cameras, a known base_T_vision, Gaussian measurement noise in both
// frames and, optionally, gross outliers.

#include <avatar/common/RigidTransform.h>

#include <opencv2/core/types.hpp>

#include <cmath>
#include <cstdint>
#include <random>
#include <vector>

namespace avatar::test {

/// One drawn point set and the truth it was made from.
struct PointSet {
    std::vector<cv::Point3d> vision;
    std::vector<cv::Point3d> base;
    std::vector<bool> outlier;   ///< per point: a gross error was added to its base point
    RigidTransform baseTVision;  ///< the truth
};

/// How a point set is drawn.
struct PointSetSpec {
    int points{20};
    double noiseMm{1.0};            ///< per-axis standard deviation, in each frame
    double rotationRad{0.5};        ///< angle of the true rotation (about a random axis)
    double outlierFraction{0.0};    ///< share of points with a gross error
    double outlierMinMm{50.0}, outlierMaxMm{200.0};
    /// Workspace: a cube of this half size centred 800 mm in front of the left camera.
    double halfSizeMm{500.0};
    /// 0: a full cube; > 0: the points lie within this distance of one line
    /// (a near-collinear layout); < 0: all in one plane.
    double lineThicknessMm{0.0};
};

/// A rotation of @p angle about a uniformly random axis.
inline cv::Matx33d randomRotation(std::mt19937_64& rng, double angle) {
    std::normal_distribution<double> normal;
    cv::Vec3d axis(normal(rng), normal(rng), normal(rng));
    axis /= cv::norm(axis);
    return rodrigues({axis[0] * angle, axis[1] * angle, axis[2] * angle});
}

inline PointSet drawPointSet(const PointSetSpec& spec, std::uint64_t seed) {
    std::mt19937_64 rng(seed);
    std::uniform_real_distribution<double> unit(-1.0, 1.0);
    std::normal_distribution<double> noise(0.0, spec.noiseMm);
    PointSet set;
    const cv::Matx33d r = randomRotation(rng, spec.rotationRad);
    const cv::Vec3d t(unit(rng) * 1000.0, unit(rng) * 1000.0, unit(rng) * 500.0);
    set.baseTVision = makeRigidTransform(r, t);
    const int outliers = static_cast<int>(std::lround(spec.outlierFraction * spec.points));
    for (int i = 0; i < spec.points; ++i) {
        cv::Vec3d p(unit(rng) * spec.halfSizeMm, unit(rng) * spec.halfSizeMm, 800.0 + unit(rng) * spec.halfSizeMm);
        if (spec.lineThicknessMm > 0.0) {
            // along the x axis of the cube, within the thickness of it
            p[1] = unit(rng) * spec.lineThicknessMm;
            p[2] = 800.0 + unit(rng) * spec.lineThicknessMm;
        } else if (spec.lineThicknessMm < 0.0) {
            p[2] = 800.0;
        }
        const cv::Vec3d b = r * p + t;
        cv::Point3d v(p[0] + noise(rng), p[1] + noise(rng), p[2] + noise(rng));
        cv::Point3d m(b[0] + noise(rng), b[1] + noise(rng), b[2] + noise(rng));
        const bool gross = i < outliers;
        if (gross) {
            cv::Vec3d direction(unit(rng), unit(rng), unit(rng));
            direction /= cv::norm(direction);
            const double size = spec.outlierMinMm + (spec.outlierMaxMm - spec.outlierMinMm) * (0.5 + 0.5 * unit(rng));
            m += cv::Point3d(direction * size);
        }
        set.vision.push_back(v);
        set.base.push_back(m);
        set.outlier.push_back(gross);
    }
    return set;
}

}  // namespace avatar::test
