#include <avatar/servo/Tracking.h>

#include <avatar/common/Error.h>

#include <opencv2/core.hpp>

#include <cmath>
#include <cstdio>
#include <limits>

namespace avatar::servo {

const char* toString(Sighting sighting) {
    switch (sighting) {
        case Sighting::Found: return "found";
        case Sighting::Missing: return "missing";
        case Sighting::Flagged: return "flagged";
        case Sighting::Jumped: return "jumped";
        case Sighting::Ambiguous: return "ambiguous";
    }
    return "?";
}

namespace {

std::string mm(double value) {
    char text[32];
    std::snprintf(text, sizeof text, "%.1f mm", value);
    return text;
}

}  // namespace

TargetSighting selectTarget(const VisionTargets& data, const std::string& type, const SelectionRule& rule) {
    TargetSighting out;
    int stereo = 0;
    int whole = 0;
    const VisionTarget* onlyWhole = nullptr;
    const VisionTarget* nearest = nullptr;
    double nearestMm = std::numeric_limits<double>::infinity();
    for (const VisionTarget& t : data.targets) {
        if (t.type != type || !t.positionBaseMm) {
            continue;
        }
        ++stereo;
        if ((t.flags & kTargetWhole) != 0) {
            ++whole;
            onlyWhole = &t;
        }
        if (rule.expectedBaseMm) {
            const double d = cv::norm(*t.positionBaseMm - *rule.expectedBaseMm);
            if (d < nearestMm) {
                nearestMm = d;
                nearest = &t;
            }
        }
    }
    if (stereo == 0) {
        out.why = "no stereo '" + type + "' target with a base-frame position";
        return out;
    }
    if (!rule.expectedBaseMm) {
        if (whole == 1) {
            out.status = Sighting::Found;
            out.target = *onlyWhole;
            return out;
        }
        if (whole == 0) {
            out.status = Sighting::Flagged;
            out.why = "no whole '" + type + "' target (" + std::to_string(stereo) + " flagged partial)";
            return out;
        }
        out.status = Sighting::Ambiguous;
        out.why = std::to_string(whole) + " whole '" + type + "' targets and no position to track from";
        return out;
    }
    out.distanceMm = nearestMm;
    if (nearestMm > rule.trackingRadiusMm) {
        out.why = "no '" + type + "' target within " + mm(rule.trackingRadiusMm) + " of its expected position (nearest " +
                  mm(nearestMm) + ")";
        return out;
    }
    out.target = *nearest;
    if ((nearest->flags & kTargetWhole) == 0) {
        out.status = Sighting::Flagged;
        out.why = "the '" + type + "' target is not whole (" + targetFlagsText(nearest->flags) + ")";
        return out;
    }
    if (nearestMm > rule.maxJumpMm) {
        out.status = Sighting::Jumped;
        out.why = "the '" + type + "' target moved " + mm(nearestMm) + " from its expected position (at most " +
                  mm(rule.maxJumpMm) + ")";
        return out;
    }
    out.status = Sighting::Found;
    return out;
}

void PositionFilter::predict(double sigmaMm) {
    if (!initialised_) {
        return;
    }
    estimate_.covarianceMm2 += cv::Matx33d::eye() * (sigmaMm * sigmaMm);
}

const Estimate& PositionFilter::update(const cv::Point3d& measuredMm, const cv::Matx33d& covarianceMm2) {
    cv::Matx33d r = 0.5 * (covarianceMm2 + covarianceMm2.t());
    cv::Matx31d eigenvalues;
    cv::eigen(r, eigenvalues);
    if (!(eigenvalues(2) > 0.0) || !std::isfinite(eigenvalues(0))) {
        throw InvalidArgument("PositionFilter: the measurement covariance is not positive definite");
    }
    if (!initialised_) {
        estimate_.positionMm = measuredMm;
        estimate_.covarianceMm2 = r;
        initialised_ = true;
        return estimate_;
    }
    const cv::Matx33d& p = estimate_.covarianceMm2;
    const cv::Matx33d gain = p * (p + r).inv(cv::DECOMP_CHOLESKY);
    const cv::Vec3d innovation(measuredMm.x - estimate_.positionMm.x, measuredMm.y - estimate_.positionMm.y,
                               measuredMm.z - estimate_.positionMm.z);
    const cv::Vec3d step = gain * innovation;
    estimate_.positionMm += cv::Point3d(step[0], step[1], step[2]);
    const cv::Matx33d updated = (cv::Matx33d::eye() - gain) * p;
    estimate_.covarianceMm2 = 0.5 * (updated + updated.t());
    return estimate_;
}

}  // namespace avatar::servo
