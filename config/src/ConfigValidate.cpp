#include "ConfigValidate.h"

#include "ConfigText.h"

#include <avatar/config/ConfigXml.h>

#include <algorithm>
#include <cmath>
#include <cstddef>
#include <limits>
#include <string_view>
#include <utility>

namespace avatar::config_internal {

namespace {

constexpr double kInf = std::numeric_limits<double>::infinity();
constexpr int kMaxImageSize = 16384;
/// Largest element of |R R^T - I| accepted for a rotation matrix; generous
/// enough for rotations printed with four decimals.
constexpr double kRotationTolerance = 1e-3;

std::string quote(std::string_view text) {
    return "'" + std::string(text) + "'";
}

/// Checks with the paths of one section.
class Checker {
public:
    explicit Checker(const ErrorSite& site) : site_(site) {}

    [[noreturn]] void fail(const std::string& path, const std::string& problem) const {
        site_.fail(path, problem);
    }

    void intBetween(int value, int lo, int hi, const std::string& path) const {
        if (value < lo || value > hi) {
            fail(path, "must be between " + std::to_string(lo) + " and " + std::to_string(hi) +
                           ", got " + std::to_string(value));
        }
    }

    void finite(double value, const std::string& path, const std::string& what = {}) const {
        if (!std::isfinite(value)) {
            fail(path, prefix(what) + "must be a finite number, got " + formatDouble(value));
        }
    }

    /// lo <= value <= hi (hi may be infinite).
    void between(double value, double lo, double hi, const std::string& path,
                 const std::string& what = {}) const {
        finite(value, path, what);
        if (value < lo || value > hi) {
            if (hi == kInf) {
                fail(path, prefix(what) + "must be >= " + formatDouble(lo) + ", got " + formatDouble(value));
            }
            fail(path, prefix(what) + "must be between " + formatDouble(lo) + " and " + formatDouble(hi) +
                           ", got " + formatDouble(value));
        }
    }

    void positive(double value, const std::string& path, const std::string& what = {}) const {
        finite(value, path, what);
        if (!(value > 0.0)) {
            fail(path, prefix(what) + "must be > 0, got " + formatDouble(value));
        }
    }

    /// Both ends within [lo, hi] and, when @p ordered, min <= max.
    void range(const Range& r, double lo, double hi, const std::string& path, bool ordered = true) const {
        between(r.min, lo, hi, path + "/min");
        between(r.max, lo, hi, path + "/max");
        if (ordered && r.min > r.max) {
            fail(path, "min " + formatDouble(r.min) + " is above max " + formatDouble(r.max));
        }
    }

    /// As range(), and min < max: an interval that must not be empty.
    void openRange(const Range& r, double lo, double hi, const std::string& path) const {
        range(r, lo, hi, path);
        if (r.min == r.max) {
            fail(path, "min " + formatDouble(r.min) + " equals max; the range must not be empty");
        }
    }

    template <std::size_t N>
    void allFinite(const std::array<double, N>& values, const std::string& path) const {
        for (std::size_t i = 0; i < N; ++i) {
            finite(values[i], path, component(i));
        }
    }

    /// Every component within [lo, hi].
    template <std::size_t N>
    void allBetween(const std::array<double, N>& values, double lo, double hi, const std::string& path) const {
        for (std::size_t i = 0; i < N; ++i) {
            between(values[i], lo, hi, path, component(i));
        }
    }

    /// The Euclidean length of @p values within [lo, hi], named @p what.
    template <std::size_t N>
    void lengthBetween(const std::array<double, N>& values, double lo, double hi, const std::string& path,
                       const std::string& what) const {
        const double length = euclidean(values, path);
        if (!(length >= lo && length <= hi)) {
            fail(path, what + " must be between " + formatDouble(lo) + " and " + formatDouble(hi) + ", got " +
                           formatDouble(length));
        }
    }

    /// The Euclidean length, computed without overflow or underflow.
    template <std::size_t N>
    double euclidean(const std::array<double, N>& values, const std::string& path) const {
        allFinite(values, path);
        double scale = 0.0;
        for (double v : values) {
            scale = std::max(scale, std::abs(v));
        }
        if (scale == 0.0) {
            return 0.0;
        }
        double sq = 0.0;
        for (double v : values) {
            sq += (v / scale) * (v / scale);
        }
        return scale * std::sqrt(sq);
    }

    /// Free text that survives the XML round trip unchanged.
    void text(const std::string& value, const std::string& path) const {
        for (char c : value) {
            const auto u = static_cast<unsigned char>(c);
            if (u < 0x20 || u == 0x7f) {
                fail(path, "must not contain control characters, got " + quote(escaped(value)));
            }
        }
        if (!value.empty() && (value.front() == ' ' || value.back() == ' ')) {
            fail(path, "must not begin or end with a space, got " + quote(value));
        }
    }

    /// @p value is one of the enumerators (a value cast from an integer may not be).
    template <typename Enum>
    void enumerator(Enum value, const std::string& path) const {
        if (!enumWord(value)) {
            fail(path, std::string("is not a ") + EnumWords<Enum>::type + " value (" +
                           std::to_string(static_cast<int>(value)) + ")");
        }
    }

    static std::string component(std::size_t index) {
        return "component " + std::to_string(index + 1);
    }

private:
    static std::string prefix(const std::string& what) { return what.empty() ? what : what + " "; }

    static std::string escaped(const std::string& value) { return text::escapeControl(value); }

    const ErrorSite& site_;
};

void validateFeature(const Checker& k, const CameraFeature& f, const std::string& path) {
    k.finite(f.value, path + "/value");
}

void validateCamera(const Checker& k, const CameraHardwareConfig& c) {
    const std::string p = "/avatar/camera";
    k.intBetween(c.width, 1, kMaxImageSize, p + "/width");
    k.intBetween(c.height, 1, kMaxImageSize, p + "/height");
    k.intBetween(c.bitDepth, 1, 16, p + "/bitDepth");
    if (c.channels != 1 && c.channels != 3) {
        k.fail(p + "/channels", "must be 1 or 3, got " + std::to_string(c.channels));
    }
    if (c.bayer && c.channels != 1) {
        k.fail(p + "/channels", "must be 1 when <bayer> is true, got " + std::to_string(c.channels));
    }
    k.enumerator(c.bayerPattern, p + "/bayerPattern");
    k.text(c.leftCameraId, p + "/leftCameraId");
    k.text(c.rightCameraId, p + "/rightCameraId");
    if (!c.leftCameraId.empty() && c.leftCameraId == c.rightCameraId) {
        k.fail(p + "/rightCameraId", "is the same as <leftCameraId> " + quote(c.leftCameraId));
    }
    const std::string f = p + "/features";
    validateFeature(k, c.features.exposure, f + "/exposure");
    validateFeature(k, c.features.shutter, f + "/shutter");
    validateFeature(k, c.features.gain, f + "/gain");
    k.finite(c.features.whiteBalance.blueU, f + "/whiteBalance/blueU");
    k.finite(c.features.whiteBalance.redV, f + "/whiteBalance/redV");
    validateFeature(k, c.features.brightness, f + "/brightness");
    validateFeature(k, c.features.gamma, f + "/gamma");
}

bool isTargetName(const std::string& name) {
    return !name.empty() && std::all_of(name.begin(), name.end(), [](char c) {
        return (c >= 'A' && c <= 'Z') || (c >= 'a' && c <= 'z') || (c >= '0' && c <= '9') || c == '_' ||
               c == '-';
    });
}

void validateWindow(const Checker& k, const SearchWindow& w, const CameraHardwareConfig& camera,
                    const std::string& p) {
    k.intBetween(w.x, 0, kMaxImageSize, p + "/x");
    k.intBetween(w.y, 0, kMaxImageSize, p + "/y");
    k.intBetween(w.width, 0, kMaxImageSize, p + "/width");
    k.intBetween(w.height, 0, kMaxImageSize, p + "/height");
    if ((w.width == 0) != (w.height == 0)) {
        k.fail(p, "width and height must both be 0 (whole image) or both be > 0, got " +
                      std::to_string(w.width) + " x " + std::to_string(w.height));
    }
    if (w.wholeImage()) {
        return;
    }
    if (w.x + w.width > camera.width) {
        k.fail(p + "/width", "x + width = " + std::to_string(w.x + w.width) + " exceeds the image width " +
                                 std::to_string(camera.width));
    }
    if (w.y + w.height > camera.height) {
        k.fail(p + "/height", "y + height = " + std::to_string(w.y + w.height) +
                                  " exceeds the image height " + std::to_string(camera.height));
    }
}

/// Everything of a target type but its search window, which needs the image size.
void validateTarget(const Checker& k, const TargetType& t, const std::string& p) {
    if (!isTargetName(t.name)) {
        k.fail(p + "/@name", "must be a non-empty name of letters, digits, '_' and '-', got " + quote(t.name));
    }
    k.enumerator(t.filter, p + "/filter");
    k.range(t.redGreen, 0.0, kInf, p + "/redGreen");
    k.range(t.redBlue, 0.0, kInf, p + "/redBlue");
    k.range(t.blueGreen, 0.0, kInf, p + "/blueGreen");
    if (t.brightness) {
        k.range(*t.brightness, 0.0, kInf, p + "/brightness");
    }
    if (!t.brightnessBands.empty() && t.filter != ColorFilterMethod::RgbRatio) {
        k.fail(p + "/brightnessBands", "brightness bands need <filter> rgb_ratio");
    }
    if (t.brightnessBands.size() > kMaxBrightnessBands) {
        k.fail(p + "/brightnessBands", "at most " + std::to_string(kMaxBrightnessBands) + " bands, got " +
                                           std::to_string(t.brightnessBands.size()));
    }
    for (std::size_t i = 0; i < t.brightnessBands.size(); ++i) {
        const BrightnessBand& b = t.brightnessBands[i];
        const std::string bp = p + "/brightnessBands/band[" + std::to_string(i + 1) + "]";
        k.range(b.brightness, 0.0, kInf, bp + "/brightness");
        k.range(b.redGreen, 0.0, kInf, bp + "/redGreen");
        k.range(b.redBlue, 0.0, kInf, bp + "/redBlue");
        k.range(b.blueGreen, 0.0, kInf, bp + "/blueGreen");
        for (std::size_t j = 0; j < i; ++j) {
            const Range& o = t.brightnessBands[j].brightness;
            if (o.min <= b.brightness.max && b.brightness.min <= o.max) {
                k.fail(bp + "/brightness", "overlaps band[" + std::to_string(j + 1) + "] (" +
                                               formatDouble(o.min) + ".." + formatDouble(o.max) + ")");
            }
        }
    }
    if (t.veil) {
        const std::string vp = p + "/veil";
        if (t.filter != ColorFilterMethod::RgbRatio) k.fail(vp, "a veil needs <filter> rgb_ratio");
        if (!t.brightnessBands.empty()) k.fail(vp, "a veil cannot be combined with brightness bands");
        k.allBetween(t.veil->colourRgb, 0.0, kInf, vp + "/colourRgb");
        k.positive(t.veil->colourRgb[1], vp + "/colourRgb", "G (component 2)");
        k.finite(t.veil->maxShare, vp + "/maxShare");
        if (t.veil->redGreen) k.range(*t.veil->redGreen, 0.0, kInf, vp + "/redGreen");
        if (t.veil->blueGreen) k.range(*t.veil->blueGreen, 0.0, kInf, vp + "/blueGreen");
        if (!(t.veil->maxShare > 0.0 && t.veil->maxShare < 1.0))
            k.fail(vp + "/maxShare", "must be above 0 and below 1 (at 1 the veil alone passes), got " +
                                         formatDouble(t.veil->maxShare));
    }
    if (t.water) {
        const std::string wp = p + "/water";
        if (t.filter != ColorFilterMethod::RgbRatio) k.fail(wp, "a water needs <filter> rgb_ratio");
        if (!t.brightnessBands.empty()) k.fail(wp, "a water cannot be combined with brightness bands");
        k.allBetween(t.water->attenuationPerM, 0.0, 1000.0, wp + "/attenuationPerM");
        k.finite(t.water->maxPathM, wp + "/maxPathM");
        if (t.water->redGreen) k.range(*t.water->redGreen, 0.0, kInf, wp + "/redGreen");
        if (t.water->blueGreen) k.range(*t.water->blueGreen, 0.0, kInf, wp + "/blueGreen");
        if (!(t.water->maxPathM > 0.0 && t.water->maxPathM <= 1000.0))
            k.fail(wp + "/maxPathM", "must be above 0 and at most 1000 m, got " + formatDouble(t.water->maxPathM));
    }
    // A hue range with min > max wraps through 0.
    k.range(t.hsv.hue, 0.0, 360.0, p + "/hsv/hue", /*ordered=*/false);
    k.range(t.hsv.saturation, 0.0, 1.0, p + "/hsv/saturation");
    k.range(t.hsv.value, 0.0, 1.0, p + "/hsv/value");
    k.intBetween(t.erodeKernelSize, 1, 31, p + "/erodeKernelSize");
    if (t.erodeKernelSize % 2 == 0) {
        k.fail(p + "/erodeKernelSize", "must be odd, got " + std::to_string(t.erodeKernelSize));
    }
    k.range(t.area, 0.0, kInf, p + "/area");
    k.range(t.aspectRatio, 0.0, kInf, p + "/aspectRatio");
    k.range(t.areaRatio, 0.0, 1.0, p + "/areaRatio");
    k.enumerator(t.shape, p + "/shape");
    if (t.sizeMm) {
        k.range(*t.sizeMm, 0.0, kInf, p + "/sizeMm");
    }
}

void validateTargets(const Checker& k, const TargetConfig& targets, const CameraHardwareConfig& camera) {
    const std::string p = "/avatar/targets";
    if (targets.targets.empty()) {
        k.fail(p, "at least one <target> is required");
    }
    for (std::size_t i = 0; i < targets.targets.size(); ++i) {
        const std::string tp = p + "/target[" + std::to_string(i + 1) + "]";
        validateTarget(k, targets.targets[i], tp);
        validateWindow(k, targets.targets[i].window, camera, tp + "/window");
        for (std::size_t j = 0; j < i; ++j) {
            if (targets.targets[j].name == targets.targets[i].name) {
                k.fail(tp + "/@name", "duplicate target name " + quote(targets.targets[i].name) +
                                          " (also target[" + std::to_string(j + 1) + "])");
            }
        }
    }
}

void validateMatch(const Checker& k, const MatchConfig& m) {
    const std::string p = "/avatar/match";
    k.enumerator(m.method, p + "/method");
    // The box is open (dxMin < dx < dxMax): equal limits admit nothing.
    k.openRange(Range{m.boxDxMin, m.boxDxMax}, -kInf, kInf, p + "/box/dx");
    k.openRange(Range{m.boxDyMin, m.boxDyMax}, -kInf, kInf, p + "/box/dy");
    k.positive(m.maxEpipolarDistancePx, p + "/epipolarLine/maxDistancePx");
    k.positive(m.minRangeMm, p + "/epipolarLine/rangeMm/min");
    k.openRange(Range{m.minRangeMm, m.maxRangeMm}, 0.0, kInf, p + "/epipolarLine/rangeMm");
    const std::string s = p + "/shape";
    k.between(m.shape.magnitudeWeight, 0.0, kInf, s + "/magnitudeWeight");
    k.between(m.shape.directionWeight, 0.0, kInf, s + "/directionWeight");
    if (m.shape.magnitudeWeight == 0.0 && m.shape.directionWeight == 0.0) {
        k.fail(s, "magnitudeWeight and directionWeight must not both be 0");
    }
    k.positive(m.shape.maxError, s + "/maxError");
    k.between(m.shape.maxAreaRatio, 1.0, kInf, s + "/maxAreaRatio");
    k.enumerator(m.repeats, p + "/repeats");
}

// Physical ranges of the calibration and geometry (docs/config.md): wide
// enough for any real lens and rig, narrow enough that no value in them turns
// a position into an infinity or a NaN.
constexpr double kMaxFocalPx = 1e6;         ///< a 1 mm sensor behind a 1 km lens is still below it
constexpr double kMaxPrincipalPx = 1e5;     ///< checked against the image size where it is known
constexpr double kMaxSkew = 1.0;            ///< alpha_c: 45 degrees between the pixel axes
constexpr double kMaxDistortion = 1e3;      ///< |kc|: a fisheye's plumb bob stays far below
constexpr double kMinBaselineMm = 1.0;
constexpr double kMaxBaselineMm = 100000.0; ///< 100 m
constexpr double kMaxTranslationMm = 1e7;   ///< 10 km: camera to manipulator base
constexpr double kPi = 3.14159265358979323846;

void validateIntrinsics(const Checker& k, const CameraIntrinsics& in, const std::string& p) {
    k.allBetween(in.fc, 1.0, kMaxFocalPx, p + "/fc");
    k.allBetween(in.cc, -kMaxPrincipalPx, kMaxPrincipalPx, p + "/cc");
    k.between(in.alphaC, -kMaxSkew, kMaxSkew, p + "/alphaC");
    k.allBetween(in.kc, -kMaxDistortion, kMaxDistortion, p + "/kc");
}

/// The principal point lies inside the image.
void validatePrincipalPoint(const Checker& k, const CameraIntrinsics& in, const CameraHardwareConfig& camera,
                            const std::string& p) {
    k.between(in.cc[0], 0.0, camera.width, p + "/cc", Checker::component(0) + " (x, image width " +
                                                          std::to_string(camera.width) + ")");
    k.between(in.cc[1], 0.0, camera.height, p + "/cc", Checker::component(1) + " (y, image height " +
                                                           std::to_string(camera.height) + ")");
}

void validateRotation(const Checker& k, const std::array<double, 9>& r, const std::string& path) {
    k.allFinite(r, path);
    double worst = 0.0;
    for (int i = 0; i < 3; ++i) {
        for (int j = 0; j < 3; ++j) {
            double dot = 0.0;
            for (int c = 0; c < 3; ++c) {
                dot += r[static_cast<std::size_t>(3 * i + c)] * r[static_cast<std::size_t>(3 * j + c)];
            }
            worst = std::max(worst, std::abs(dot - (i == j ? 1.0 : 0.0)));
        }
    }
    if (worst > kRotationTolerance) {
        k.fail(path, "is not a rotation matrix: largest element of |R R^T - I| is " + formatDouble(worst) +
                         ", more than " + formatDouble(kRotationTolerance));
    }
    const double det = r[0] * (r[4] * r[8] - r[5] * r[7]) - r[1] * (r[3] * r[8] - r[5] * r[6]) +
                       r[2] * (r[3] * r[7] - r[4] * r[6]);
    if (det < 0.0) {
        k.fail(path, "is not a rotation matrix: determinant " + formatDouble(det) + " (a reflection)");
    }
}

constexpr const char* kStereoPath = "/avatar/stereo";

/// Everything of the calibration but the principal points' place in the image.
void validateStereo(const Checker& k, const StereoSystemConfig& s) {
    const std::string p = kStereoPath;
    validateIntrinsics(k, s.left, p + "/left");
    validateIntrinsics(k, s.right, p + "/right");
    if (const double angle = k.euclidean(s.om, p + "/om"); angle > kPi * (1.0 + 1e-12)) {
        k.fail(p + "/om", "the rotation angle |om| must be at most pi (180 degrees), got " + formatDouble(angle) +
                              " rad");
    }
    const auto& t = s.translationMm;
    if (t[0] == 0.0 && t[1] == 0.0 && t[2] == 0.0) {
        k.fail(p + "/translationMm", "the baseline must not be zero");
    }
    k.lengthBetween(t, kMinBaselineMm, kMaxBaselineMm, p + "/translationMm", "the baseline |T| (mm)");
    if (s.baseTVision) {
        validateRotation(k, s.baseTVision->rotation, p + "/baseTVision/rotation");
        k.allBetween(s.baseTVision->translationMm, -kMaxTranslationMm, kMaxTranslationMm,
                     p + "/baseTVision/translationMm");
    }
    if (s.uncertainty) {
        const std::string u = p + "/uncertainty";
        // Standard errors: not negative, and no larger than the range of what they measure.
        for (const auto& [name, in] : {std::pair<const char*, const IntrinsicsUncertainty&>{"/left", s.uncertainty->left},
                                       {"/right", s.uncertainty->right}}) {
            k.allBetween(in.fc, 0.0, kMaxFocalPx, u + name + "/fc");
            k.allBetween(in.cc, 0.0, kMaxPrincipalPx, u + name + "/cc");
            k.between(in.alphaC, 0.0, kMaxSkew, u + name + "/alphaC");
            k.allBetween(in.kc, 0.0, kMaxDistortion, u + name + "/kc");
        }
        k.allBetween(s.uncertainty->om, 0.0, kPi, u + "/om");
        k.allBetween(s.uncertainty->translationMm, 0.0, kMaxBaselineMm, u + "/translationMm");
    }
}

void validateFalloff(const Checker& k, const FalloffChannel& f, const std::string& p) {
    k.positive(f.coefficient, p + "/coefficient");
    k.finite(f.exponent, p + "/exponent");
}

void validateLighting(const Checker& k, const LightingConfig& l) {
    const std::string p = "/avatar/lighting";
    for (std::size_t i = 0; i < 3; ++i) {
        k.positive(l.gainsRgb[i], p + "/frameAverage/gainsRgb", Checker::component(i));
    }
    k.allFinite(l.patternCentrePx, p + "/pattern/centrePx");
    validateFalloff(k, l.red, p + "/pattern/red");
    validateFalloff(k, l.green, p + "/pattern/green");
    validateFalloff(k, l.blue, p + "/pattern/blue");
    k.text(l.templateImagePath, p + "/pattern/templateImage");
}

bool isStageName(const std::string& name) {
    return !name.empty() && std::all_of(name.begin(), name.end(), [](char c) {
        return (c >= 'a' && c <= 'z') || (c >= '0' && c <= '9') || c == '_';
    });
}

void validateAnalysis(const Checker& k, const AnalysisConfig& a) {
    const std::string p = "/avatar/analysis";
    // Which names exist and their order are the pipeline's rules (it can be
    // given extra stages); here only the form of the list.
    if (a.stages.empty()) {
        k.fail(p + "/stages", "at least one stage is required");
    }
    for (std::size_t i = 0; i < a.stages.size(); ++i) {
        if (!isStageName(a.stages[i])) {
            k.fail(p + "/stages", "stage " + quote(a.stages[i]) +
                                      " is not a name of lower-case letters, digits and '_'");
        }
        for (std::size_t j = 0; j < i; ++j) {
            if (a.stages[j] == a.stages[i]) {
                k.fail(p + "/stages", "stage " + quote(a.stages[i]) + " appears twice");
            }
        }
    }
    k.enumerator(a.demosaic, p + "/demosaic");
    k.enumerator(a.centroid, p + "/centroid");
    k.enumerator(a.triangulation, p + "/triangulation");
    const std::string v = p + "/visibility";
    k.between(a.visibility.minContrast, 0.0, 1.0, v + "/minContrast");
    k.between(a.visibility.maxSaturatedFraction, 0.0, 1.0, v + "/maxSaturatedFraction");
    k.between(a.visibility.maxHaze, 0.0, 1.0, v + "/maxHaze");
    // A region must hold what the target's assembly reads beyond its feature
    // (the silhouette's edge profiles, the erosion's reach): 8 px at least.
    k.intBetween(a.tracking.fullFrameEvery, 1, 1000000, p + "/tracking/fullFrameEvery");
    k.intBetween(a.tracking.marginPx, 8, 100000, p + "/tracking/marginPx");
    k.intBetween(a.coarseToFine.marginPx, 8, 100000, p + "/coarseToFine/marginPx");
    k.intBetween(a.threads, 1, 2, p + "/threads");
}

void validateServo(const Checker& k, const ServoConfig& c, const TargetConfig* targets) {
    const std::string p = "/avatar/servo";
    k.text(c.sampleType, p + "/sampleType");
    k.text(c.armType, p + "/armType");
    const auto known = [&](const std::string& type, const std::string& path) {
        for (const TargetType& t : targets->targets) {
            if (t.name == type) {
                return;
            }
        }
        std::string names;
        for (const TargetType& t : targets->targets) {
            names += (names.empty() ? "" : ", ") + quote(t.name);
        }
        k.fail(path, "names no target type of <targets>: " + quote(type) + " (types: " + names + ")");
    };
    if (targets != nullptr) {
        known(c.sampleType, p + "/sampleType");
        known(c.armType, p + "/armType");
    }
    if (c.sampleType == c.armType) {
        k.fail(p + "/armType", "is the same type as <sampleType> " + quote(c.sampleType) +
                                   ": the arm and the sample must be told apart");
    }
    k.enumerator(c.mode, p + "/mode");
    k.enumerator(c.filter, p + "/filter");
    k.positive(c.maxMoveMm, p + "/maxMoveMm");
    k.positive(c.finalDistanceMm, p + "/finalDistanceMm");
    if (c.finalDistanceMm > c.maxMoveMm) {
        k.fail(p + "/finalDistanceMm", "must not exceed <maxMoveMm> " + formatDouble(c.maxMoveMm) + ", got " +
                                           formatDouble(c.finalDistanceMm) + ": the last move would be longer than any other");
    }
    for (std::size_t i = 0; i < 3; ++i) {
        k.between(c.toolOffsetMm[i], -5000.0, 5000.0, p + "/toolOffsetMm", Checker::component(i));
    }
    k.positive(c.armToleranceMm, p + "/armToleranceMm");
    k.between(c.armDriftMm, 0.0, kInf, p + "/armDriftMm");
    k.between(c.armDriftPerMm, 0.0, 1.0, p + "/armDriftPerMm");
    k.positive(c.maxTargetJumpMm, p + "/maxTargetJumpMm");
    k.positive(c.trackingRadiusMm, p + "/trackingRadiusMm");
    k.intBetween(c.visionTimeoutMs, 1, 600000, p + "/visionTimeoutMs");
    k.intBetween(c.moveTimeoutMs, 1, 600000, p + "/moveTimeoutMs");
    k.intBetween(c.lostTimeoutMs, 1, 3600000, p + "/lostTimeoutMs");
    k.intBetween(c.maxIterations, 1, 10000, p + "/maxIterations");
    k.between(c.probeAngleDeg, 0.0, 60.0, p + "/probeAngleDeg");
    k.positive(c.registrationStdDeg, p + "/registrationStdDeg");
    k.between(c.registrationStdDeg, 0.0, 45.0, p + "/registrationStdDeg");
    k.between(c.kalmanSampleNoiseMm, 0.0, kInf, p + "/kalman/sampleNoiseMm");
    k.between(c.kalmanArmNoisePerMm, 0.0, 1.0, p + "/kalman/armNoisePerMm");
    k.positive(c.kalmanDefaultSigmaMm, p + "/kalman/defaultSigmaMm");
}

}  // namespace

int ErrorSite::lineOf(const std::string& path) const {
    if (lines_ == nullptr) {
        return 0;
    }
    std::string p = path;
    while (!p.empty()) {
        if (const auto it = lines_->find(p); it != lines_->end()) {
            return it->second;
        }
        const std::size_t slash = p.rfind('/');
        p.erase(slash == std::string::npos ? 0 : slash);
    }
    return 0;
}

void ErrorSite::fail(const std::string& path, const std::string& problem) const {
    throw ConfigError(source_, lineOf(path), path, problem);
}

void validateTargetAt(const TargetType& type, const ErrorSite& site, const std::string& path) {
    validateTarget(Checker(site), type, path);
}

void validate(const AvatarConfig& config, const ErrorSite& site) {
    const Checker k(site);
    validateCamera(k, config.camera);
    validateTargets(k, config.targets, config.camera);
    validateMatch(k, config.match);
    validateStereo(k, config.stereo);
    validatePrincipalPoint(k, config.stereo.left, config.camera, std::string(kStereoPath) + "/left");
    validatePrincipalPoint(k, config.stereo.right, config.camera, std::string(kStereoPath) + "/right");
    validateLighting(k, config.lighting);
    validateAnalysis(k, config.analysis);
    if (config.servo) {
        validateServo(k, *config.servo, &config.targets);
    }
}

}  // namespace avatar::config_internal

namespace avatar {

namespace {

/// Checks a value built in code: errors have source "<memory>" and line 0.
template <typename Check>
void checkInMemory(Check&& check) {
    const config_internal::ErrorSite site("<memory>", nullptr);
    check(config_internal::Checker(site));
}

}  // namespace

void validateMatchConfig(const MatchConfig& match) {
    checkInMemory([&](const config_internal::Checker& k) { config_internal::validateMatch(k, match); });
}

void validateStereoConfig(const StereoSystemConfig& stereo) {
    checkInMemory([&](const config_internal::Checker& k) { config_internal::validateStereo(k, stereo); });
}

void validateLightingConfig(const LightingConfig& lighting) {
    checkInMemory([&](const config_internal::Checker& k) { config_internal::validateLighting(k, lighting); });
}

void validateTargetType(const TargetType& type) {
    checkInMemory([&](const config_internal::Checker& k) {
        config_internal::validateTarget(k, type, "/avatar/targets/target[@name='" + type.name + "']");
    });
}

void validateServoConfig(const ServoConfig& servo) {
    checkInMemory([&](const config_internal::Checker& k) { config_internal::validateServo(k, servo, nullptr); });
}

void validateAnalysisConfig(const AnalysisConfig& analysis) {
    checkInMemory([&](const config_internal::Checker& k) { config_internal::validateAnalysis(k, analysis); });
}

}  // namespace avatar
