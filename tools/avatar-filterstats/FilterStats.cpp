#include "FilterStats.h"

#include <avatar/analyze/ImageColorFilter.h>
#include <avatar/common/Error.h>

#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <fstream>
#include <limits>
#include <random>
#include <sstream>

namespace avatar::filterstats {
namespace {

constexpr double kInf = std::numeric_limits<double>::infinity();
constexpr double kOpenMax = 1e9;  ///< an open ratio maximum (passes x/0 too: ImageColorFilter.h)

/// One sample pixel.
struct Px {
    int b, g, r;
    int m() const { return b + g + r; }
};

std::vector<Px> samplesOf(const cv::Mat& bgr, const cv::Mat& mask) {
    std::vector<Px> out;
    for (int y = 0; y < bgr.rows; ++y) {
        const std::uint8_t* m = mask.ptr<std::uint8_t>(y);
        for (int x = 0; x < bgr.cols; ++x) {
            if (!m[x]) continue;
            if (bgr.depth() == CV_8U) {
                const cv::Vec3b p = bgr.at<cv::Vec3b>(y, x);
                out.push_back({p[0], p[1], p[2]});
            } else {
                const cv::Vec3w p = bgr.at<cv::Vec3w>(y, x);
                out.push_back({p[0], p[1], p[2]});
            }
        }
    }
    return out;
}

std::vector<Px> subsample(const std::vector<Px>& all, std::size_t most) {
    if (all.size() <= most) return all;
    std::vector<Px> out = all;
    std::mt19937_64 rng(12345);  // fixed: the same proposal for the same input
    std::shuffle(out.begin(), out.end(), rng);
    out.resize(most);
    return out;
}

/// The fraction of @p px that the real colour filter passes with @p type.
double passRate(const std::vector<Px>& px, int depth, int bitDepth, const TargetType& type) {
    if (px.empty()) return 0.0;
    cv::Mat row(1, static_cast<int>(px.size()), depth == CV_8U ? CV_8UC3 : CV_16UC3);
    for (std::size_t i = 0; i < px.size(); ++i) {
        const int x = static_cast<int>(i);
        if (depth == CV_8U)
            row.at<cv::Vec3b>(0, x) = cv::Vec3b(static_cast<std::uint8_t>(px[i].b), static_cast<std::uint8_t>(px[i].g),
                                                 static_cast<std::uint8_t>(px[i].r));
        else
            row.at<cv::Vec3w>(0, x) = cv::Vec3w(static_cast<std::uint16_t>(px[i].b),
                                                 static_cast<std::uint16_t>(px[i].g),
                                                 static_cast<std::uint16_t>(px[i].r));
    }
    TargetType t = type;
    t.window = {};
    std::vector<cv::Mat> masks;
    colorFilterMasks(row, bitDepth, {t}, masks);
    return static_cast<double>(cv::countNonZero(masks[0])) / static_cast<double>(px.size());
}

/// num/den as the filter sees it: +infinity for x/0, NaN for 0/0.
double ratio(int num, int den) {
    if (den == 0) return num == 0 ? std::numeric_limits<double>::quiet_NaN() : kInf;
    return static_cast<double>(num) / den;
}

/// Sorted defined values of one quantity.
std::vector<double> sortedValues(const std::vector<Px>& px, double (*f)(const Px&)) {
    std::vector<double> v;
    v.reserve(px.size());
    for (const Px& p : px) {
        const double x = f(p);
        if (!std::isnan(x)) v.push_back(x);
    }
    std::sort(v.begin(), v.end());
    return v;
}

double quantile(const std::vector<double>& sorted, double q) {
    if (sorted.empty()) return std::numeric_limits<double>::quiet_NaN();
    const double at = q * static_cast<double>(sorted.size() - 1);
    return sorted[static_cast<std::size_t>(std::clamp(std::floor(at), 0.0, static_cast<double>(sorted.size() - 1)))];
}

/// Rounds outwards to 4 significant digits, so the XML stays readable and the samples inside.
double roundOut(double v, bool down) {
    if (!std::isfinite(v) || v == 0.0) return v;
    const double scale = std::pow(10.0, 3 - std::floor(std::log10(std::fabs(v))));
    return (down ? std::floor(v * scale) : std::ceil(v * scale)) / scale;
}

double rg(const Px& p) { return ratio(p.r, p.g); }
double rb(const Px& p) { return ratio(p.r, p.b); }
double bg(const Px& p) { return ratio(p.b, p.g); }
double mOf(const Px& p) { return p.m(); }

/// [min, max] holding the values between the q and 1-q quantiles; an infinite
/// end becomes an open max (or the smallest min only +infinity passes).
Range ratioRange(const std::vector<double>& sorted, double q) {
    if (sorted.empty()) return {0.0, kOpenMax};
    double lo = quantile(sorted, q), hi = quantile(sorted, 1.0 - q);
    if (std::isinf(lo)) lo = 65536.0;
    hi = std::isinf(hi) ? kOpenMax : roundOut(hi, false);
    return {std::max(0.0, roundOut(lo, true)), std::max(hi, roundOut(lo, true))};
}

struct HsvPx {
    double h, s, v;
};

HsvPx hsvOf(const Px& p, double fullScale) {
    const int mx = std::max({p.b, p.g, p.r}), mn = std::min({p.b, p.g, p.r});
    const int c = mx - mn;
    double h = 0.0;
    if (c > 0) {
        if (mx == p.r) h = 60.0 * (p.g - p.b) / c;
        else if (mx == p.g) h = 60.0 * (p.b - p.r) / c + 120.0;
        else h = 60.0 * (p.r - p.g) / c + 240.0;
        if (h < 0) h += 360.0;
    }
    return {h, mx > 0 ? static_cast<double>(c) / mx : 0.0, mx / fullScale};
}

/// An HSV filter holding the q..1-q quantiles of the target's hue (taken
/// around the circle from its largest gap), saturation and value.
HsvRanges hsvRanges(const std::vector<Px>& target, double fullScale, double q) {
    std::vector<double> h, s, v;
    for (const Px& p : target) {
        const HsvPx x = hsvOf(p, fullScale);
        h.push_back(x.h);
        s.push_back(x.s);
        v.push_back(x.v);
    }
    std::sort(h.begin(), h.end());
    std::sort(s.begin(), s.end());
    std::sort(v.begin(), v.end());
    // The hues start after the largest gap between neighbours on the circle.
    double start = h.front(), gap = h.front() + 360.0 - h.back();
    for (std::size_t i = 1; i < h.size(); ++i)
        if (h[i] - h[i - 1] > gap) {
            gap = h[i] - h[i - 1];
            start = h[i];
        }
    std::vector<double> unwrapped;
    for (const double x : h) unwrapped.push_back(std::fmod(x - start + 360.0, 360.0));
    std::sort(unwrapped.begin(), unwrapped.end());
    const double lo = std::fmod(start + quantile(unwrapped, q), 360.0);
    const double hi = std::fmod(start + quantile(unwrapped, 1.0 - q), 360.0);
    HsvRanges r;
    r.hue = {std::floor(lo * 10) / 10, std::min(360.0, std::ceil(hi * 10) / 10)};
    r.saturation = {std::floor(quantile(s, q) * 1000) / 1000, std::min(1.0, std::ceil(quantile(s, 1.0 - q) * 1000) / 1000)};
    r.value = {std::floor(quantile(v, q) * 1000) / 1000, std::min(1.0, std::ceil(quantile(v, 1.0 - q) * 1000) / 1000)};
    return r;
}

/// Whether @p p passes every limit of a single-range ratio filter but @p skip
/// (0..5: rg min/max, rb min/max, bg min/max); the filter's own rules for x/0
/// and 0/0 (ImageColorFilter.h), the brightness range included.
bool passesOthers(const Px& p, const TargetType& t, int skip) {
    if (t.brightness && (p.m() < t.brightness->min || p.m() > t.brightness->max)) return false;
    if (p.m() == 0) return false;
    const double v[3] = {rg(p), rb(p), bg(p)};
    const Range* r[3] = {&t.redGreen, &t.redBlue, &t.blueGreen};
    for (int k = 0; k < 3; ++k) {
        if (std::isnan(v[k])) continue;
        const bool openMax = r[k]->max >= 65536.0;
        if (skip != 2 * k && v[k] < r[k]->min) return false;
        if (skip != 2 * k + 1 && v[k] > r[k]->max && !(std::isinf(v[k]) && openMax)) return false;
    }
    return true;
}

/// Widens each ratio limit of @p t half-way (in log ratio, at most a factor
/// of 2) towards the nearest background sample that would pass if the limit
/// were not there: the background samples passed stay exactly those passed
/// before, and the target's range gains a margin for the lighting and noise of
/// other images (a limit at the outermost target sample fits one image only).
void widenToMargins(TargetType& t, const std::vector<Px>& background) {
    Range* r[3] = {&t.redGreen, &t.redBlue, &t.blueGreen};
    for (int limit = 0; limit < 6; ++limit) {
        Range& range = *r[limit / 2];
        const bool isMax = limit % 2 == 1;
        if (isMax && range.max >= 65536.0) continue;  // open already
        double nearest = isMax ? kInf : 0.0;
        for (const Px& p : background) {
            if (!passesOthers(p, t, limit)) continue;
            const double v = limit / 2 == 0 ? rg(p) : limit / 2 == 1 ? rb(p) : bg(p);
            if (std::isnan(v)) continue;
            if (isMax && v > range.max) nearest = std::min(nearest, v);
            if (!isMax && v < range.min) nearest = std::max(nearest, v);
        }
        if (isMax) {
            const double wider = std::isinf(nearest) ? 2.0 * range.max : std::sqrt(range.max * nearest);
            const double rounded = roundOut(std::min(wider, 2.0 * range.max), true);
            if (rounded > range.max && rounded < nearest) range.max = rounded;
        } else if (range.min > 0.0) {
            const double wider = nearest > 0.0 ? std::sqrt(range.min * nearest) : 0.5 * range.min;
            const double rounded = roundOut(std::max(wider, 0.5 * range.min), false);
            if (rounded < range.min && rounded > nearest) range.min = rounded;
        }
    }
}

std::string fmt(double v, int precision = 4) {
    std::ostringstream s;
    s.precision(precision);
    s << v;
    return s.str();
}

std::string ratesText(const Rates& r) {
    return "TPR " + fmt(r.truePositive) + ", FPR " + fmt(r.falsePositive);
}

}  // namespace

cv::Mat loadMask(const std::filesystem::path& path, cv::Size size) {
    const cv::Mat m = cv::imread(path.string(), cv::IMREAD_UNCHANGED);
    if (m.empty()) throw IoError("mask " + path.string() + ": cannot be read as an image");
    if (m.depth() != CV_8U)
        throw FormatError("mask " + path.string() + ": must be an 8-bit image (non-zero = sample), got " +
                          cv::typeToString(m.type()));
    if (m.size() != size)
        throw InvalidArgument("mask " + path.string() + " is " + std::to_string(m.cols) + "x" + std::to_string(m.rows) +
                              " but the image is " + std::to_string(size.width) + "x" + std::to_string(size.height));
    cv::Mat gray = m;
    if (m.channels() > 1) {
        std::vector<cv::Mat> planes;
        cv::split(m, planes);
        gray = planes[0] | planes[1] | planes[2];
    }
    return gray != 0;
}

namespace {

/// The "x y" lines of @p path ('#' starts a comment, blank lines skipped);
/// FormatError naming the file and line of anything else.
std::vector<cv::Point> readPoints(const std::filesystem::path& path, const char* what) {
    std::ifstream in(path);
    if (!in) throw IoError(std::string(what) + " " + path.string() + ": cannot be opened");
    std::vector<cv::Point> points;
    std::string line;
    int number = 0;
    while (std::getline(in, line)) {
        ++number;
        const auto hash = line.find('#');
        if (hash != std::string::npos) line.erase(hash);
        std::istringstream s(line);
        double x = 0, y = 0;
        if (!(s >> x)) continue;  // empty line
        std::string rest;
        if (!(s >> y) || (s >> rest))
            throw FormatError(path.string() + ":" + std::to_string(number) + ": expected 'x y', got '" + line + "'");
        points.emplace_back(cvRound(x), cvRound(y));
    }
    return points;
}

}  // namespace

cv::Mat pointsMask(const std::filesystem::path& path, cv::Size size, int radius) {
    if (radius < 0) throw InvalidArgument("--point-radius must be >= 0, got " + std::to_string(radius));
    const std::vector<cv::Point> points = readPoints(path, "point file");
    if (points.empty()) throw FormatError("point file " + path.string() + " holds no point");
    const cv::Rect image(0, 0, size.width, size.height);
    cv::Mat mask = cv::Mat::zeros(size, CV_8UC1);
    for (const cv::Point& p : points) {
        if (!image.contains(p))
            throw InvalidArgument("point file " + path.string() + ": point (" + std::to_string(p.x) + ", " +
                                  std::to_string(p.y) + ") lies outside the " + std::to_string(size.width) + "x" +
                                  std::to_string(size.height) + " image");
        cv::circle(mask, p, radius, cv::Scalar(255), cv::FILLED);
    }
    return mask;
}

cv::Mat polygonMask(const std::filesystem::path& path, cv::Size size) {
    const std::vector<cv::Point> points = readPoints(path, "polygon file");
    if (points.size() < 3)
        throw FormatError("polygon file " + path.string() + ": " + std::to_string(points.size()) +
                          " vertices; a polygon needs at least 3");
    cv::Mat mask = cv::Mat::zeros(size, CV_8UC1);
    cv::fillPoly(mask, std::vector<std::vector<cv::Point>>{points}, cv::Scalar(255));
    return mask;
}

Proposal propose(const tools::WorkingImage& image, const cv::Mat& targetMask, const cv::Mat& backgroundMask,
                 const Options& options) {
    const cv::Mat overlap = targetMask & backgroundMask;
    const cv::Mat targetOnly = targetMask & ~backgroundMask;
    const cv::Mat backgroundOnly = backgroundMask & ~targetMask;
    const std::vector<Px> allTarget = samplesOf(image.bgr, targetOnly);
    const std::vector<Px> allBackground = samplesOf(image.bgr, backgroundOnly);
    if (allTarget.empty())
        throw InvalidArgument(cv::countNonZero(targetMask) == 0
                                  ? std::string("the target sample is empty (no non-zero pixel in its mask)")
                                  : std::string("the target sample lies entirely inside the background sample"));
    if (allBackground.empty())
        throw InvalidArgument(cv::countNonZero(backgroundMask) == 0
                                  ? std::string("the background sample is empty (no non-zero pixel in its mask)")
                                  : std::string("the background sample lies entirely inside the target sample"));
    const std::vector<Px> target = subsample(allTarget, options.maxSamples);
    const std::vector<Px> background = subsample(allBackground, options.maxSamples);
    const int depth = image.bgr.depth();
    const double fullScale = std::ldexp(1.0, image.bitDepth) - 1.0;
    const double sampleMax = depth == CV_8U ? 255.0 : 65535.0;

    const std::vector<double> rgV = sortedValues(target, rg), rbV = sortedValues(target, rb),
                              bgV = sortedValues(target, bg), mV = sortedValues(target, mOf);
    const std::vector<double> trims = {0.0, 0.001, 0.005, 0.01, 0.02, 0.05, 0.1, 0.2, 0.3};
    const int total = static_cast<int>(trims.size() * 3 + 9);
    int done = 0;
    auto tick = [&] {
        if (options.progress) options.progress(++done, total);
    };
    auto score = [&](const Rates& r) { return r.truePositive - options.falsePositiveWeight * r.falsePositive; };
    auto rates = [&](const TargetType& t, const std::vector<Px>& tp, const std::vector<Px>& bp) {
        return Rates{passRate(tp, depth, image.bitDepth, t), passRate(bp, depth, image.bitDepth, t)};
    };

    TargetType base;
    base.name = options.name;
    // RGB ratios, one range each, with and without a brightness range.
    TargetType bestRatio;
    Rates bestRatioRates{0, 1};
    double bestRatioTrim = 0.005;
    for (const double q : trims) {
        TargetType t = base;
        t.filter = ColorFilterMethod::RgbRatio;
        t.redGreen = ratioRange(rgV, q);
        t.redBlue = ratioRange(rbV, q);
        t.blueGreen = ratioRange(bgV, q);
        for (const bool withBrightness : {false, true}) {
            if (withBrightness)
                t.brightness = Range{std::floor(quantile(mV, q)), std::ceil(quantile(mV, 1.0 - q))};
            const Rates r = rates(t, target, background);
            tick();
            if (score(r) > score(bestRatioRates)) {
                bestRatio = t;
                bestRatioRates = r;
                bestRatioTrim = q;
            }
        }
    }
    // HSV.
    TargetType bestHsv;
    Rates bestHsvRates{0, 1};
    for (const double q : trims) {
        TargetType t = base;
        t.filter = ColorFilterMethod::Hsv;
        t.hsv = hsvRanges(target, fullScale, q);
        const Rates r = rates(t, target, background);
        tick();
        if (score(r) > score(bestHsvRates)) {
            bestHsv = t;
            bestHsvRates = r;
        }
    }
    // Brightness bands (thesis 3.3.2), when one range lets background through.
    std::optional<TargetType> bestBanded;
    std::optional<Rates> bestBandedRates;
    if (bestRatioRates.falsePositive > options.bandsAbove) {
        for (int k = 2; k <= 4; ++k) {
            for (const double q : {0.005, 0.02, 0.1}) {
                TargetType t = bestRatio;
                t.brightnessBands.clear();
                bool enough = true;
                double from = 0.0;
                for (int b = 0; b < k && enough; ++b) {
                    const double to = b == k - 1 ? 3.0 * sampleMax : std::floor(quantile(mV, (b + 1.0) / k));
                    std::vector<Px> in;
                    for (const Px& p : target)
                        if (p.m() >= from && p.m() <= to) in.push_back(p);
                    if (in.size() < 20 || to < from) {
                        enough = false;
                        break;
                    }
                    t.brightnessBands.push_back(BrightnessBand{{from, to},
                                                               ratioRange(sortedValues(in, rg), q),
                                                               ratioRange(sortedValues(in, rb), q),
                                                               ratioRange(sortedValues(in, bg), q)});
                    from = to + 1.0;
                }
                tick();
                if (!enough) continue;
                const Rates r = rates(t, target, background);
                if (!bestBandedRates || score(r) > score(*bestBandedRates)) {
                    bestBanded = t;
                    bestBandedRates = r;
                }
            }
        }
    }

    Proposal p;
    p.targetSamples = allTarget.size();
    p.backgroundSamples = allBackground.size();
    p.bestRatio = rates(bestRatio, allTarget, allBackground);
    p.bestHsv = rates(bestHsv, allTarget, allBackground);
    if (bestBanded) p.bands = rates(*bestBanded, allTarget, allBackground);
    tick();
    const double sRatio = score(p.bestRatio), sHsv = score(p.bestHsv);
    const double sBands = p.bands ? score(*p.bands) : -kInf;
    std::ostringstream why;
    if (p.bands && sBands > std::max(sRatio, sHsv) + 0.01) {
        p.type = *bestBanded;
        p.rates = *p.bands;
        why << "rgb_ratio with " << p.type.brightnessBands.size()
            << " brightness bands: one range cannot separate the samples (" << ratesText(p.bestRatio)
            << "; hsv " << ratesText(p.bestHsv) << "), the bands do (" << ratesText(*p.bands) << ")";
    } else if (sHsv > sRatio + 0.01) {
        p.type = bestHsv;
        p.rates = p.bestHsv;
        why << "hsv: it separates the samples better (" << ratesText(p.bestHsv) << ") than RGB ratios ("
            << ratesText(p.bestRatio) << ")";
    } else {
        p.type = bestRatio;
        widenToMargins(p.type, background);
        p.rates = rates(p.type, allTarget, allBackground);
        why << "rgb_ratio: " << ratesText(p.rates) << " (hsv: " << ratesText(p.bestHsv) << ")";
        if (p.bands) why << "; brightness bands gain too little (" << ratesText(*p.bands) << ")";
    }
    why << "; trimmed " << fmt(bestRatioTrim * 100) << " % of the target's ratio extremes"
        << (p.type.filter == ColorFilterMethod::RgbRatio && p.type.brightnessBands.empty()
                ? ", each limit widened half-way to the nearest background sample (at most 2x)"
                : "")
        << ", score TPR - "
        << fmt(options.falsePositiveWeight) << " x FPR";
    p.why = why.str();

    if (options.veil) {
        std::ostringstream veilWhy;
        if (p.type.filter != ColorFilterMethod::RgbRatio || !p.type.brightnessBands.empty()) {
            veilWhy << "no veil: it needs a single-range rgb_ratio filter";
        } else {
            double share = 0.0;
            Rates at{p.rates};
            for (double s = 0.02; s <= 0.9 + 1e-9; s += 0.02) {
                TargetType veiled = p.type;
                veiled.veil = Veil{*options.veil, s, std::nullopt, std::nullopt};
                const Rates r = rates(veiled, allTarget, allBackground);
                if (r.falsePositive > p.rates.falsePositive + options.veilFalsePositives) break;
                share = s;
                at = r;
            }
            if (share > 0.0) {
                p.type.veil = Veil{*options.veil, share, std::nullopt, std::nullopt};
                veilWhy << "veil up to " << fmt(share) << " of G: false positives " << fmt(at.falsePositive * 100)
                        << " % of the background samples (without it " << fmt(p.rates.falsePositive * 100)
                        << " %, at most " << fmt(options.veilFalsePositives * 100) << " % more)";
                p.rates = at;
            } else {
                veilWhy << "no veil: a share of 0.02 already passes more than " << fmt(options.veilFalsePositives * 100)
                        << " % more of the background samples";
            }
        }
        p.veilWhy = veilWhy.str();
    }

    if (options.water) {
        std::ostringstream waterWhy;
        if (p.type.filter != ColorFilterMethod::RgbRatio || !p.type.brightnessBands.empty()) {
            waterWhy << "no water: it needs a single-range rgb_ratio filter";
        } else {
            double path = 0.0;
            Rates at{p.rates};
            for (int step = 1; step <= 10; ++step) {
                const double l = options.waterPathM * step / 10.0;
                TargetType seen = p.type;
                seen.water = Water{*options.water, l, std::nullopt, std::nullopt};
                const Rates r = rates(seen, allTarget, allBackground);
                if (r.falsePositive > p.rates.falsePositive + options.waterFalsePositives) break;
                path = l;
                at = r;
            }
            if (path > 0.0) {
                p.type.water = Water{*options.water, path, std::nullopt, std::nullopt};
                waterWhy << "water up to " << fmt(path) << " m of path: false positives "
                         << fmt(at.falsePositive * 100) << " % of the background samples (without it "
                         << fmt(p.rates.falsePositive * 100) << " %, at most "
                         << fmt(options.waterFalsePositives * 100) << " % more)";
                p.rates = at;
            } else {
                waterWhy << "no water: a tenth of the path already passes more than "
                         << fmt(options.waterFalsePositives * 100) << " % more of the background samples";
            }
        }
        p.waterWhy = waterWhy.str();
    }

    // The minimum area: the features of this filter over the whole image,
    // those on the target sample against the look-alikes elsewhere.
    std::vector<cv::Mat> masks;
    TargetType whole = p.type;
    whole.window = {};
    colorFilterMasks(image.bgr, image.bitDepth, {whole}, masks);
    cv::Mat labels, stats, centroids;
    const int n = cv::connectedComponentsWithStats(masks[0], labels, stats, centroids, 8, CV_32S);
    std::vector<char> onTarget(static_cast<std::size_t>(n), 0);
    for (int y = 0; y < labels.rows; ++y) {
        const int* l = labels.ptr<int>(y);
        const std::uint8_t* t = targetMask.ptr<std::uint8_t>(y);
        for (int x = 0; x < labels.cols; ++x)
            if (l[x] > 0 && t[x]) onTarget[static_cast<std::size_t>(l[x])] = 1;
    }
    for (int i = 1; i < n; ++i) {
        const double area = stats.at<int>(i, cv::CC_STAT_AREA);
        (onTarget[static_cast<std::size_t>(i)] ? p.targetAreas : p.lookAlikeAreas).push_back(area);
    }
    std::sort(p.targetAreas.begin(), p.targetAreas.end(), std::greater<>());
    std::sort(p.lookAlikeAreas.begin(), p.lookAlikeAreas.end(), std::greater<>());
    const double largestTarget = p.targetAreas.empty() ? 0.0 : p.targetAreas.front();
    const double largestLookAlike = p.lookAlikeAreas.empty() ? 0.0 : p.lookAlikeAreas.front();
    double minArea = 20.0;
    std::ostringstream areaWhy;
    if (p.targetAreas.empty()) {
        areaWhy << "the filter forms no feature on the target sample; the default 20 px is kept";
    } else if (p.lookAlikeAreas.empty()) {
        minArea = std::max(1.0, std::min(20.0, std::floor(largestTarget / 2)));
        areaWhy << "no look-alike blob elsewhere in the image; " << fmt(minArea) << " px keeps specks out";
    } else if (largestLookAlike < largestTarget) {
        // Half-way (geometrically) between the largest look-alike and the target.
        minArea = std::ceil(std::sqrt((largestLookAlike + 1.0) * largestTarget));
        minArea = std::clamp(minArea, largestLookAlike + 1.0, largestTarget);
        areaWhy << p.lookAlikeAreas.size() << " look-alike blob(s) elsewhere, the largest " << fmt(largestLookAlike)
                << " px, against the target's " << fmt(largestTarget) << " px: " << fmt(minArea)
                << " px keeps them out";
    } else {
        minArea = std::max(1.0, std::floor(largestTarget / 2));
        areaWhy << "a look-alike blob of " << fmt(largestLookAlike) << " px is as large as the target's "
                << fmt(largestTarget) << " px: no area keeps it out (use a search window or tighter ranges); "
                << fmt(minArea) << " px";
    }
    p.type.area = Range{minArea, 1e9};
    p.areaWhy = areaWhy.str();
    return p;
}

// ---- plots ---------------------------------------------------------------------

namespace {

struct Axes {
    cv::Rect box{70, 20, 720, 520};
    double xMax{1}, yMax{1};
    cv::Point at(double x, double y) const {
        const double cx = std::clamp(x / xMax, 0.0, 1.0), cy = std::clamp(y / yMax, 0.0, 1.0);
        return {box.x + cvRound(cx * box.width), box.y + box.height - cvRound(cy * box.height)};
    }
};

void drawFrame(cv::Mat& img, const Axes& a, const std::string& xLabel, const std::string& yLabel,
               const std::string& title) {
    cv::rectangle(img, a.box, cv::Scalar(0, 0, 0), 1);
    for (int i = 0; i <= 4; ++i) {
        const double x = a.xMax * i / 4, y = a.yMax * i / 4;
        const cv::Point px = a.at(x, 0), py = a.at(0, y);
        cv::line(img, px, px + cv::Point(0, 5), cv::Scalar(0, 0, 0));
        const std::string xText = fmt(x, 3);
        const int xWidth = cv::getTextSize(xText, cv::FONT_HERSHEY_SIMPLEX, 0.4, 1, nullptr).width;
        const int xAt = std::min(px.x - xWidth / 2, img.cols - xWidth - 2);  // the last one stays inside
        cv::putText(img, xText, cv::Point(xAt, px.y + 20), cv::FONT_HERSHEY_SIMPLEX, 0.4, cv::Scalar(0, 0, 0));
        cv::line(img, py, py - cv::Point(5, 0), cv::Scalar(0, 0, 0));
        cv::putText(img, fmt(y, 3), py + cv::Point(-62, 4), cv::FONT_HERSHEY_SIMPLEX, 0.4, cv::Scalar(0, 0, 0));
    }
    cv::putText(img, xLabel, cv::Point(a.box.x + a.box.width / 2 - 60, a.box.y + a.box.height + 38),
                cv::FONT_HERSHEY_SIMPLEX, 0.5, cv::Scalar(0, 0, 0));
    cv::putText(img, yLabel, cv::Point(4, a.box.y + a.box.height * 3 / 8), cv::FONT_HERSHEY_SIMPLEX, 0.5,
                cv::Scalar(0, 0, 0));
    cv::putText(img, title, cv::Point(a.box.x + 8, a.box.y + 16), cv::FONT_HERSHEY_SIMPLEX, 0.5,
                cv::Scalar(0, 0, 0));
}

}  // namespace

void writePlots(const std::filesystem::path& dir, const tools::WorkingImage& image, const cv::Mat& targetMask,
                const cv::Mat& backgroundMask, const Proposal& proposal) {
    std::error_code ec;
    std::filesystem::create_directories(dir, ec);
    if (ec) throw IoError("plots directory " + dir.string() + ": " + ec.message());
    const std::vector<Px> target = subsample(samplesOf(image.bgr, targetMask & ~backgroundMask), 20000);
    const std::vector<Px> background = subsample(samplesOf(image.bgr, backgroundMask & ~targetMask), 20000);
    const double fullScale = std::ldexp(1.0, image.bitDepth) - 1.0;
    double mMax = 1;
    for (const auto* set : {&target, &background})
        for (const Px& p : *set) mMax = std::max(mMax, 1.05 * p.m());
    const TargetType& t = proposal.type;
    struct Plot {
        const char* file;
        const char* label;
        double (*f)(const Px&);
        const Range* range;
        int band;  ///< 0 rg, 1 rb, 2 bg
    };
    const Plot plots[] = {{"rg.png", "R/G", rg, &t.redGreen, 0},
                          {"rb.png", "R/B", rb, &t.redBlue, 1},
                          {"bg.png", "B/G", bg, &t.blueGreen, 2}};
    const cv::Scalar red(40, 40, 220), blue(200, 120, 30), green(30, 160, 30);
    for (const Plot& plot : plots) {
        std::vector<double> all;
        for (const auto* set : {&target, &background})
            for (const Px& p : *set) {
                const double v = plot.f(p);
                if (std::isfinite(v)) all.push_back(v);
            }
        std::sort(all.begin(), all.end());
        Axes a;
        a.xMax = mMax;
        a.yMax = std::max(1e-3, 1.3 * quantile(all, 0.99));
        // The proposed limits in view too, unless one is far beyond the data.
        for (const double limit : {plot.range->min, plot.range->max})
            if (std::isfinite(limit) && limit > a.yMax && limit < 4.0 * a.yMax) a.yMax = 1.1 * limit;
        cv::Mat img(600, 820, CV_8UC3, cv::Scalar(255, 255, 255));
        for (const auto& [set, colour] : {std::pair{&background, blue}, std::pair{&target, red}})
            for (const Px& p : *set) {
                const double v = plot.f(p);
                if (std::isnan(v)) continue;
                cv::circle(img, a.at(p.m(), std::isinf(v) ? a.yMax : v), 1, colour, cv::FILLED);
            }
        if (t.filter == ColorFilterMethod::RgbRatio) {
            const auto hline = [&](double y, double x0, double x1) {
                if (y <= a.yMax) cv::line(img, a.at(x0, y), a.at(x1, y), green, 1);
            };
            const auto bandRange = [&](const BrightnessBand& b) {
                return plot.band == 0 ? b.redGreen : plot.band == 1 ? b.redBlue : b.blueGreen;
            };
            if (t.brightnessBands.empty()) {
                hline(plot.range->min, 0, mMax);
                hline(plot.range->max, 0, mMax);
            }
            for (const BrightnessBand& b : t.brightnessBands) {
                const Range r = bandRange(b);
                hline(r.min, b.brightness.min, std::min(b.brightness.max, mMax));
                hline(r.max, b.brightness.min, std::min(b.brightness.max, mMax));
            }
            if (t.brightness)
                for (const double m : {t.brightness->min, t.brightness->max})
                    if (m <= mMax) cv::line(img, a.at(m, 0), a.at(m, a.yMax), green, 1);
        }
        drawFrame(img, a, "brightness M = R+G+B", plot.label,
                  std::string(plot.label) + " against M: target red, background blue, proposal green");
        const std::filesystem::path out = dir / plot.file;
        if (!cv::imwrite(out.string(), img)) throw IoError("cannot write plot " + out.string());
    }
    // Hue against M (HSV's view of the same samples).
    Axes a;
    a.xMax = mMax;
    a.yMax = 360.0;
    cv::Mat img(600, 820, CV_8UC3, cv::Scalar(255, 255, 255));
    for (const auto& [set, colour] : {std::pair{&background, blue}, std::pair{&target, red}})
        for (const Px& p : *set) cv::circle(img, a.at(p.m(), hsvOf(p, fullScale).h), 1, colour, cv::FILLED);
    if (t.filter == ColorFilterMethod::Hsv)
        for (const double h : {t.hsv.hue.min, t.hsv.hue.max}) cv::line(img, a.at(0, h), a.at(mMax, h), green, 1);
    drawFrame(img, a, "brightness M = R+G+B", "hue", "hue (degrees) against M");
    const std::filesystem::path out = dir / "hue.png";
    if (!cv::imwrite(out.string(), img)) throw IoError("cannot write plot " + out.string());
}

}  // namespace avatar::filterstats
