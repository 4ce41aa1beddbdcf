#include <avatar/analyze/LightingCorrection.h>

#include <avatar/common/Error.h>
#include <avatar/common/ImageUtils.h>
#include <avatar/common/Logging.h>
#include <avatar/config/ConfigXml.h>

#include "LightingFactors.h"

#include <log4cpp/Category.hh>
#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>

#include <algorithm>
#include <cstring>
#include <vector>
#include <cmath>
#include <cstdint>
#include <limits>
#include <string>
#include <system_error>

namespace avatar {
namespace {

log4cpp::Category& logger() { return logging::category("analyze"); }

using detail::kMaxFactor;

std::string sizeText(cv::Size s) { return std::to_string(s.width) + "x" + std::to_string(s.height); }

cv::Mat readTemplate(const std::filesystem::path& path) {
    std::error_code ec;
    if (!std::filesystem::is_regular_file(path, ec))
        throw IoError("LightingCorrector: lighting template image '" + path.string() + "' does not exist");
    cv::Mat image = cv::imread(path.string(), cv::IMREAD_UNCHANGED);
    if (image.empty())
        throw IoError("LightingCorrector: cannot decode lighting template image '" + path.string() + "'");
    if (image.channels() != 3)
        throw FormatError("LightingCorrector: lighting template image '" + path.string() + "' has " +
                          std::to_string(image.channels()) + " channels; 3 (BGR) are required");
    if (image.depth() != CV_32F && image.depth() != CV_64F)
        throw FormatError("LightingCorrector: lighting template image '" + path.string() + "' is " +
                          cv::typeToString(image.type()) + "; a floating-point image (CV_32FC3) is required");
    cv::Mat factors;
    image.convertTo(factors, CV_32FC3);
    cv::Point bad;
    if (!cv::checkRange(factors, true, &bad, 0.0, static_cast<double>(std::numeric_limits<float>::max()))) {
        const cv::Vec3f v = factors.at<cv::Vec3f>(bad);
        throw FormatError("LightingCorrector: lighting template image '" + path.string() + "' has factor (" +
                          std::to_string(v[0]) + ", " + std::to_string(v[1]) + ", " + std::to_string(v[2]) +
                          ") at pixel (" + std::to_string(bad.x) + ", " + std::to_string(bad.y) +
                          "); factors must be finite and >= 0");
    }
    return factors;
}

/// Float factors, not fixed point: at 1280x960x3 16-bit the loop streams the
/// image (7.4 MB read and written) and the factors (14.7 MB) at memory speed,
/// about 1.1 ms on the development machine against 2.1 ms for cv::multiply
/// (bench_color_filter). A uint16 Q-format factor would save a third of the
/// traffic but cannot hold the factor range (gain * exp(e * d) reaches well
/// above 16 for steep falloffs) with useful precision in 16 bits.
///
/// sample' = min(round(sample * factor), fullScale) over one row of
/// interleaved samples and their factors. Branch-free (min, +0.5, truncate),
/// so GCC vectorises it; the factor image has the image's channel layout, so
/// no de-interleaving is needed.
template <typename S>
void applyRow(S* __restrict px, const float* __restrict factor, int n, float fullScale) {
    for (int i = 0; i < n; ++i) {
        const float v = std::min(static_cast<float>(px[i]) * factor[i], fullScale);
        px[i] = static_cast<S>(static_cast<std::int32_t>(v + 0.5f));
    }
}

template <typename S>
void applyImage(cv::Mat& bgr, const cv::Mat& factors, float fullScale) {
    const int n = bgr.cols * 3;
    for (int y = 0; y < bgr.rows; ++y) applyRow<S>(bgr.ptr<S>(y), factors.ptr<float>(y), n, fullScale);
}

}  // namespace

LightingCorrector::LightingCorrector(const LightingConfig& config, const std::filesystem::path& configDir)
    : config_(config), configDir_(configDir) {
    validateLightingConfig(config_);
    if (!config_.patternEnabled || config_.templateImagePath.empty()) return;
    templatePath_ = config_.templateImagePath;
    if (templatePath_.is_relative() && !configDir_.empty()) templatePath_ = configDir_ / templatePath_;
    template_ = readTemplate(templatePath_);
}

bool LightingCorrector::enabled() const { return config_.frameAverageEnabled || config_.patternEnabled; }

cv::Mat LightingCorrector::buildFactors(cv::Size size, const BayerPattern* pattern) const {
    if (size.width <= 0 || size.height <= 0)
        throw InvalidArgument("LightingCorrector::prepare: empty image size " + sizeText(size));
    if (!template_.empty() && template_.size() != size)
        throw FormatError("LightingCorrector: lighting template image '" + templatePath_.string() + "' is " +
                          sizeText(template_.size()) + " but the images are " + sizeText(size));
    // Per channel (B, G, R, the image's order): exponent and gain * coefficient.
    std::array<double, 3> gain{1.0, 1.0, 1.0};
    if (config_.frameAverageEnabled) gain = {config_.gainsRgb[2], config_.gainsRgb[1], config_.gainsRgb[0]};
    const bool analytic = config_.patternEnabled && template_.empty();
    const bool templated = config_.patternEnabled && !template_.empty();
    const std::array<const FalloffChannel*, 3> falloff{&config_.blue, &config_.green, &config_.red};
    std::array<double, 3> exponent{}, multiplier{};
    for (int k = 0; k < 3; ++k) {
        exponent[static_cast<std::size_t>(k)] = analytic ? falloff[static_cast<std::size_t>(k)]->exponent : 0.0;
        multiplier[static_cast<std::size_t>(k)] =
            gain[static_cast<std::size_t>(k)] * (analytic ? falloff[static_cast<std::size_t>(k)]->coefficient : 1.0);
    }
    // Elements per row: three per pixel (B, G, R), or one per mosaic site of its
    // colour; the channel of each depends on the row's parity only.
    const int perPixel = pattern == nullptr ? 3 : 1;
    const auto n = static_cast<std::size_t>(size.width * perPixel);
    std::vector<double> xs(n), t(n, 1.0);
    std::array<std::vector<double>, 2> e{std::vector<double>(n), std::vector<double>(n)}, m = e;
    for (std::size_t i = 0; i < n; ++i) {
        const int x = static_cast<int>(i) / perPixel;
        xs[i] = x;
        for (int parity = 0; parity < 2; ++parity) {
            const int k = pattern == nullptr ? static_cast<int>(i % 3) : bayerSiteColour(*pattern, x, parity);
            e[static_cast<std::size_t>(parity)][i] = exponent[static_cast<std::size_t>(k)];
            m[static_cast<std::size_t>(parity)][i] = multiplier[static_cast<std::size_t>(k)];
        }
    }
    cv::Mat out(size, pattern == nullptr ? CV_32FC3 : CV_32FC1);
    const double ox = config_.patternCentrePx[0], oy = config_.patternCentrePx[1];
    for (int y = 0; y < size.height; ++y) {
        const auto parity = static_cast<std::size_t>(y & 1);
        if (templated) {
            const cv::Vec3f* row = template_.ptr<cv::Vec3f>(y);
            for (std::size_t i = 0; i < n; ++i) {
                const int x = static_cast<int>(i) / perPixel;
                const int k = pattern == nullptr ? static_cast<int>(i % 3) : bayerSiteColour(*pattern, x, y);
                t[i] = row[x][k];
            }
        }
        const double dy = y - oy;
        detail::lightingFactorRow(xs.data(), e[parity].data(), m[parity].data(), t.data(), dy * dy, ox, out.ptr<float>(y),
                  static_cast<int>(n));
    }
    double lo = 0.0, hi = 0.0;
    cv::minMaxLoc(out.reshape(1), &lo, &hi);
    logger().infoStream() << "lighting factors for " << sizeText(size) << (pattern != nullptr ? " (mosaic)" : "")
                          << ": gains (B,G,R) " << gain[0] << ", " << gain[1] << ", " << gain[2] << "; pattern "
                          << (!config_.patternEnabled ? std::string("off")
                              : analytic ? std::string("c*exp(e*d)")
                                         : "template '" + templatePath_.string() + "'")
                          << "; factors " << lo << " .. " << hi;
    return out;
}

void LightingCorrector::prepare(cv::Size size) {
    if (!factors_.empty() && factors_.size() == size) return;
    factors_ = buildFactors(size, nullptr);
}

void LightingCorrector::prepareMosaic(cv::Size size, BayerPattern pattern) {
    if (!mosaicFactors_.empty() && mosaicSize_ == size && mosaicPattern_ == pattern) return;
    // Without a pattern every factor is its channel's gain (exp(0) = 1 and
    // no template): the first two rows hold every row's values.
    const bool periodic = !config_.patternEnabled && size.height >= 2;
    mosaicFactors_ = buildFactors(periodic ? cv::Size(size.width, 2) : size, &pattern);
    mosaicSize_ = size;
    mosaicPattern_ = pattern;
}

void LightingCorrector::apply(cv::Mat& bgr, int bitDepth) const {
    const int depth = bgr.depth();
    if (bgr.channels() != 3 || (depth != CV_8U && depth != CV_16U))
        throw FormatError("LightingCorrector::apply: the image must be CV_8UC3 or CV_16UC3, got " +
                          cv::typeToString(bgr.type()));
    const int maxBits = depth == CV_8U ? 8 : 16;
    if (bitDepth < 1 || bitDepth > maxBits)
        throw InvalidArgument("LightingCorrector::apply: bit depth " + std::to_string(bitDepth) +
                              " is not in 1.." + std::to_string(maxBits) + " for a " +
                              cv::typeToString(bgr.type()) + " image");
    if (!enabled()) return;
    if (factors_.size() != bgr.size())
        throw InvalidArgument("LightingCorrector::apply: the image is " + sizeText(bgr.size()) +
                              " but prepare() was " +
                              (factors_.empty() ? std::string("not called") : "called for " + sizeText(factors_.size())));
    const auto fullScale = static_cast<float>((1 << bitDepth) - 1);
    if (depth == CV_8U)
        applyImage<std::uint8_t>(bgr, factors_, fullScale);
    else
        applyImage<std::uint16_t>(bgr, factors_, fullScale);
}

namespace {

void requireGainImages(const cv::Mat& raw, const cv::Mat& corrected) {
    if (raw.empty() || raw.channels() != 3 || raw.type() != corrected.type() || raw.size() != corrected.size())
        throw InvalidArgument("frameAverageGains: raw (" + cv::typeToString(raw.type()) + " " +
                              sizeText(raw.size()) + ") and corrected (" + cv::typeToString(corrected.type()) +
                              " " + sizeText(corrected.size()) +
                              ") images must be non-empty 3-channel images of the same type and size");
}

std::array<double, 3> gainsFromSums(const cv::Scalar& raw, const cv::Scalar& corrected) {
    static const char* const names[3] = {"blue", "green", "red"};
    std::array<double, 3> rgb{};
    for (int k = 0; k < 3; ++k) {
        if (!(raw[k] > 0.0))
            throw InvalidArgument(std::string("frameAverageGains: the raw ") + names[k] +
                                  " channel sums to " + std::to_string(raw[k]) + "; no gain can be computed");
        rgb[static_cast<std::size_t>(2 - k)] = corrected[k] / raw[k];
    }
    return rgb;
}

}  // namespace

std::array<double, 3> frameAverageGains(const cv::Mat& rawBgr, const cv::Mat& correctedBgr) {
    requireGainImages(rawBgr, correctedBgr);
    return gainsFromSums(cv::sum(rawBgr), cv::sum(correctedBgr));
}

std::array<double, 3> frameAverageGains(const std::vector<cv::Mat>& rawBgr,
                                        const std::vector<cv::Mat>& correctedBgr) {
    if (rawBgr.empty() || rawBgr.size() != correctedBgr.size())
        throw InvalidArgument("frameAverageGains: " + std::to_string(rawBgr.size()) + " raw and " +
                              std::to_string(correctedBgr.size()) +
                              " corrected images; the sets must be equally long and not empty");
    cv::Scalar raw, corrected;
    for (std::size_t i = 0; i < rawBgr.size(); ++i) {
        requireGainImages(rawBgr[i], correctedBgr[i]);
        raw += cv::sum(rawBgr[i]);
        corrected += cv::sum(correctedBgr[i]);
    }
    return gainsFromSums(raw, corrected);
}

}  // namespace avatar
