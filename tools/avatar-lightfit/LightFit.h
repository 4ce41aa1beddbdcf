#pragma once
/// @file LightFit.h
/// avatar-lightfit (docs/tools/avatar-lightfit.md; thesis 3.2, Figures 3-2 to
/// 3-4): the offline step of the lighting correction. From pairs of points on
/// similar objects, one near the strobe's centre (light) and one farther out
/// (dark), the per-channel falloff factor c * exp(e * d) that LightingCorrector
/// applies, fitted by nonlinear least squares (the thesis fitted it in a
/// spreadsheet); from a set of raw images and their corrected references, the
/// frame-average gains (Figure 3-2).
///
/// What is fitted. Per channel k and pair i, the ratio r_i = light_i / dark_i
/// (each the mean over a small patch) against d_i, the distance of the dark
/// point from the pattern centre (Figure 3-3): r_i = c * exp(e * d_i). Applied
/// by LightingCorrector, the factor c * exp(e * d) turns the dark sample into
/// r_i * dark_i = light_i: far objects come out as bright as the near ones, so
/// e > 0 (the factor grows away from the centre). The factor is 1 at
/// d = -ln(c) / e (ChannelFit::unityDistancePx): the light samples keep their
/// brightness when they lie near that distance, which the thesis model assumes
/// (light points close to the centre, or all at about one distance). When the
/// light points lie at different distances, Model::Paired fits
/// r_i = exp(e * (d_dark_i - d_light_i)) instead, the ratio the factor must
/// remove between the two points of each pair wherever they lie, and sets c so
/// that the factor is 1 at the light points' mean distance.
///
/// The image is read as the lighting correction sees it by ToolImages.h
/// (tools::kForLightingCorrection).
///
/// Error policy: avatar::IoError / avatar::FormatError name the file at fault
/// (and its line), avatar::InvalidArgument the pair, point or option.

#include "ToolImages.h"

#include <avatar/common/ImageFormat.h>
#include <avatar/config/LightingConfig.h>

#include <opencv2/core/mat.hpp>
#include <opencv2/core/types.hpp>

#include <array>
#include <cstdint>
#include <filesystem>
#include <functional>
#include <optional>
#include <string>
#include <vector>

namespace avatar::lightfit {

/// A light point and the dark point picked on a similar object, in pixels
/// (column, row; integer = pixel centre).
struct PointPair {
    cv::Point2d light;
    cv::Point2d dark;
    int line{0};  ///< line in the pairs file (0: not from a file)
};

/// Reads a pairs file: one "light_x,light_y,dark_x,dark_y" per line; blank
/// lines and '#' comments are skipped, as is an optional header line of those
/// four names. FormatError naming file and line for a line that does not parse.
std::vector<PointPair> readPairsFile(const std::filesystem::path& path);
/// Writes @p pairs in the form readPairsFile() reads (with the header).
void writePairsFile(const std::filesystem::path& path, const std::vector<PointPair>& pairs);

/// Which ratio is fitted (see the file comment).
enum class Model {
    Thesis,  ///< r = c * exp(e * d_dark), thesis Figure 3-3
    Paired   ///< r = exp(e * (d_dark - d_light)); c = exp(-e * mean d_light)
};
/// "thesis" or "paired"; InvalidArgument naming the text otherwise.
Model parseModel(const std::string& text);
const char* toString(Model model);

/// One picked pair as measured on the image.
struct Sample {
    PointPair pair;
    cv::Vec3d lightBgr;   ///< patch means
    cv::Vec3d darkBgr;
    double dLightPx{0};   ///< distances from the pattern centre
    double dDarkPx{0};
    cv::Vec3d lightErrorBgr;  ///< standard errors of the patch means (patch scatter / sqrt(n))
    cv::Vec3d darkErrorBgr;
    std::array<double, 3> ratioRgb{};     ///< light / dark, in R, G, B order
    std::array<double, 3> ratioStdRgb{};  ///< its standard error, propagated from the patch means'
    bool saturated{false};  ///< a patch holds a sample at full scale (the ratio is then too small)
    /// Its residual, in units of its standard error (unweighted: in ratio
    /// units), lies beyond 4 robust standard deviations (1.4826 x the median
    /// absolute value, at least 0.5 standard errors, unweighted 1e-4 of the
    /// median ratio) in some channel: probably not a pair of alike objects.
    /// Set with 5 pairs or more.
    bool suspect{false};
};

/// The fit of one channel.
struct ChannelFit {
    double coefficient{1.0};  ///< c of the correction factor, as LightingConfig holds it
    double exponent{0.0};     ///< e, 1/px
    /// Standard errors from the residuals (s^2 (J^T W J)^-1, s^2 the weighted
    /// residual sum of squares over the degrees of freedom); NaN when there
    /// are no more pairs than parameters.
    double coefficientStd{0.0};
    double exponentStd{0.0};
    /// The log-linear least-squares fit the iteration starts from (what a
    /// spreadsheet's exponential trend line gives), thesis model only.
    double logLinearCoefficient{1.0};
    double logLinearExponent{0.0};
    /// Per sample, data ratio minus fitted ratio, in pair order.
    std::vector<double> residuals;
    double rmsResidual{0.0};
    double maxAbsResidual{0.0};
    /// Weighted fits: the residuals' scatter in units of the ratios' standard
    /// errors (sqrt of the weighted sum of squares over the degrees of
    /// freedom). About 1 when the pairs differ by their noise only; well above
    /// 1 when the model or some pairs do not fit (objects not alike, a clipped
    /// patch, an edge in a patch). NaN unweighted.
    double scatterOverNoise{0.0};
    int iterations{0};
    /// The distance at which the factor is 1 (-ln c / e); NaN when e = 0.
    double unityDistancePx{0.0};
};

struct Options {
    int patch{5};                       ///< odd side of the square sampled around each point
    std::optional<cv::Point2d> centre;  ///< pattern centre; default: (width / 2, height / 2)
    Model model{Model::Thesis};
    /// Weight each ratio by its standard error (from the patches' scatter;
    /// patches of 3x3 and more), so that noisy dark samples count less.
    bool weighted{true};
};

struct Fit {
    Model model{Model::Thesis};
    cv::Point2d centre;
    int patch{5};
    bool weighted{true};
    cv::Size imageSize;
    std::vector<Sample> samples;
    /// The abscissa of each sample in the fitted model: d_dark (thesis) or
    /// d_dark - d_light (paired).
    std::vector<double> abscissa;
    std::array<ChannelFit, 3> rgb;  ///< red, green, blue

    /// The ratio the fitted model predicts at abscissa @p x for channel @p k (0 red).
    double modelRatio(std::size_t k, double x) const;
};

/// Samples every pair on @p image (patch means, distances, ratios). Throws
/// InvalidArgument naming @p source, the line and the point for a point
/// outside the image or a patch mean of 0 in a channel (no ratio can be
/// formed); a saturated patch is logged as a warning and flagged.
std::vector<Sample> samplePairs(const tools::WorkingImage& image, const std::vector<PointPair>& pairs,
                                cv::Point2d centre, int patch, const std::string& source);

/// Fits y = c * exp(e * x) by Levenberg-Marquardt from the (unweighted)
/// log-linear fit, c fixed at 1 when @p fixCoefficient. @p y > 0. With
/// @p sigma (the standard error of each y) the squared residuals are weighted
/// by 1 / sigma^2, else all alike. Fills coefficient, exponent, their standard
/// errors, the log-linear start, the residuals, scatterOverNoise and
/// iterations (not unityDistancePx). InvalidArgument when there are fewer
/// points than parameters, a sigma is not finite and > 0, or the x do not
/// spread (less than 1e-6 of their magnitude + 1e-9).
ChannelFit fitExponential(const std::vector<double>& x, const std::vector<double>& y, bool fixCoefficient,
                          const std::vector<double>& sigma = {});

/// Samples the pairs and fits each channel. InvalidArgument (naming @p source)
/// for fewer than 2 pairs, dark points that all lie at one distance from the
/// centre (paired: pairs whose distance differences do not spread), or an
/// option out of range (patch not odd in 1..101).
Fit fitFalloff(const tools::WorkingImage& image, const std::vector<PointPair>& pairs, const Options& options,
               const std::string& source);

/// @p config with the pattern set from @p fit: enabled, centre, the three
/// channels, and templateImagePath = @p templatePath (empty: the analytic
/// falloff). Frame averaging is left as it is.
LightingConfig withPattern(LightingConfig config, const Fit& fit, const std::string& templatePath = {});

/// The per-pixel pattern factors of @p fit for images of @p size, as
/// LightingCorrector computes them (CV_32FC3, BGR): the template image.
cv::Mat patternTemplate(const Fit& fit, cv::Size size);
/// Writes @p factors as a 32-bit float BGR TIFF without compression, the form
/// LightingCorrector reads. IoError naming the path.
void writeTemplate(const std::filesystem::path& path, const cv::Mat& factors);

/// One raw image and its corrected reference of a frame-averaging set.
struct GainPair {
    std::filesystem::path raw, corrected;
    std::array<double, 3> gainsRgb{};  ///< this pair's own gains
};

struct Gains {
    std::array<double, 3> gainsRgb{1.0, 1.0, 1.0};  ///< over the whole set, R, G, B
    std::vector<GainPair> pairs;
};

/// Frame-average gains (thesis Figure 3-2, frameAverageGains()) of a set of
/// raw images and their corrected references. @p raw and @p corrected are
/// both directories (images paired by file name without extension: every raw
/// image needs a corrected one) or both image files. Each image is read with
/// tools::loadImage() (tools::kForLightingCorrection) and taken as a fraction
/// of its full scale, so a 16-bit raw image may have an 8-bit reference: the
/// gains then map raw samples to the reference's brightness in raw units. @p progress is called with (done,
/// total) pairs. IoError / FormatError / InvalidArgument naming the file or
/// directory at fault (an empty directory, a raw image without reference,
/// images of different sizes).
Gains frameAverageGainsOfSets(const std::filesystem::path& raw, const std::filesystem::path& corrected,
                              std::optional<BayerPattern> bayer = std::nullopt,
                              const std::function<void(int, int)>& progress = {});

/// The data ratios of each channel against the model's abscissa with the
/// fitted curves (red, green, blue), 820 x 600 px PNG. IoError naming the path.
void writePlot(const std::filesystem::path& path, const Fit& fit);

}  // namespace avatar::lightfit
