#include "LightFit.h"

#include <avatar/analyze/LightingCorrection.h>
#include <avatar/common/Error.h>
#include <avatar/common/Logging.h>

#include <log4cpp/Category.hh>
#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <fstream>
#include <limits>
#include <map>
#include <numeric>
#include <sstream>

namespace avatar::lightfit {
namespace {

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();
constexpr const char* kPairsHeader = "light_x,light_y,dark_x,dark_y";
constexpr const char* kChannelNames[3] = {"red", "green", "blue"};

log4cpp::Category& logger() { return logging::category("lightfit"); }

std::string lower(std::string s) {
    for (char& c : s) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
    return s;
}

std::string trim(const std::string& s) {
    const auto first = s.find_first_not_of(" \t\r");
    if (first == std::string::npos) return {};
    return s.substr(first, s.find_last_not_of(" \t\r") - first + 1);
}

std::string fmt(double v, int precision = 4) {
    std::ostringstream s;
    s.precision(precision);
    s << v;
    return s.str();
}

std::string pointText(cv::Point2d p) { return "(" + fmt(p.x, 7) + ", " + fmt(p.y, 7) + ")"; }
std::string sizeText(cv::Size s) { return std::to_string(s.width) + "x" + std::to_string(s.height); }

bool isImageFile(const std::filesystem::path& p) {
    static const char* const extensions[] = {".raw", ".png", ".tif", ".tiff", ".jpg", ".jpeg", ".bmp", ".pfm"};
    const std::string ext = lower(p.extension().string());
    return std::find_if(std::begin(extensions), std::end(extensions), [&](const char* e) { return ext == e; }) !=
           std::end(extensions);
}

/// Per-channel sums of an image as a fraction of its full scale, as a 1x1
/// CV_64FC3 image: frameAverageGains() of such images is the ratio of the sums.
cv::Mat normalisedSums(const tools::WorkingImage& image) {
    const cv::Scalar sum = cv::sum(image.bgr);
    const double fullScale = std::ldexp(1.0, image.bitDepth) - 1.0;
    return cv::Mat(1, 1, CV_64FC3, cv::Scalar(sum[0] / fullScale, sum[1] / fullScale, sum[2] / fullScale));
}

}  // namespace

// ---- pairs ---------------------------------------------------------------------

std::vector<PointPair> readPairsFile(const std::filesystem::path& path) {
    std::ifstream in(path);
    if (!in) throw IoError("pairs file " + path.string() + ": cannot be opened");
    std::vector<PointPair> pairs;
    std::string line;
    int number = 0;
    bool first = true;
    while (std::getline(in, line)) {
        ++number;
        const auto hash = line.find('#');
        if (hash != std::string::npos) line.erase(hash);
        const std::string text = trim(line);
        if (text.empty()) continue;
        const std::string where = path.string() + ":" + std::to_string(number) + ": ";
        if (first) {
            first = false;
            std::string compact;
            for (const char c : text)
                if (c != ' ' && c != '\t') compact += static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
            if (compact == kPairsHeader) continue;
        }
        std::vector<double> values;
        std::stringstream fields(text);
        std::string field;
        while (std::getline(fields, field, ',')) {
            const std::string f = trim(field);
            char* end = nullptr;
            const double v = std::strtod(f.c_str(), &end);
            if (f.empty() || *end != '\0' || !std::isfinite(v))
                throw FormatError(where + "field " + std::to_string(values.size() + 1) +
                                  " is not a finite number: '" + f + "'");
            values.push_back(v);
        }
        if (values.size() != 4)
            throw FormatError(where + "expected 4 numbers (" + kPairsHeader + "), got " +
                              std::to_string(values.size()));
        pairs.push_back({{values[0], values[1]}, {values[2], values[3]}, number});
    }
    return pairs;
}

void writePairsFile(const std::filesystem::path& path, const std::vector<PointPair>& pairs) {
    std::ofstream out(path, std::ios::trunc);
    out << "# light and dark points on similar objects (avatar-lightfit), pixels\n" << kPairsHeader << "\n";
    for (const PointPair& p : pairs)
        out << fmt(p.light.x, 10) << "," << fmt(p.light.y, 10) << "," << fmt(p.dark.x, 10) << ","
            << fmt(p.dark.y, 10) << "\n";
    out.close();
    if (!out) throw IoError("pairs file " + path.string() + ": cannot be written");
}

Model parseModel(const std::string& text) {
    if (text == "thesis") return Model::Thesis;
    if (text == "paired") return Model::Paired;
    throw InvalidArgument("model must be thesis or paired, got '" + text + "'");
}

const char* toString(Model model) { return model == Model::Thesis ? "thesis" : "paired"; }

std::vector<Sample> samplePairs(const tools::WorkingImage& image, const std::vector<PointPair>& pairs,
                                cv::Point2d centre, int patch, const std::string& source) {
    const cv::Rect whole(0, 0, image.bgr.cols, image.bgr.rows);
    const double fullScale = std::ldexp(1.0, image.bitDepth) - 1.0;
    const int half = patch / 2;
    std::vector<Sample> samples;
    for (std::size_t i = 0; i < pairs.size(); ++i) {
        const PointPair& pair = pairs[i];
        const std::string where =
            source + (pair.line > 0 ? ":" + std::to_string(pair.line) : " pair " + std::to_string(i + 1)) + ": ";
        Sample s;
        s.pair = pair;
        for (const bool light : {true, false}) {
            const cv::Point2d p = light ? pair.light : pair.dark;
            const char* which = light ? "light" : "dark";
            const cv::Point px(cvRound(p.x), cvRound(p.y));
            if (!whole.contains(px))
                throw InvalidArgument(where + "the " + which + " point " + pointText(p) + " lies outside the " +
                                      sizeText(image.bgr.size()) + " image");
            const cv::Mat roi = image.bgr(cv::Rect(px.x - half, px.y - half, patch, patch) & whole);
            cv::Scalar mean, spread;
            cv::meanStdDev(roi, mean, spread);
            double largest = 0.0;
            cv::minMaxLoc(roi.reshape(1), nullptr, &largest);
            if (largest >= fullScale) {
                s.saturated = true;
                logger().warnStream() << where << "the " << which << " patch around " << pointText(p)
                                      << " holds samples at full scale (" << fullScale
                                      << "): its ratio is too small there; pick an unclipped point";
            }
            const cv::Vec3d bgr(mean[0], mean[1], mean[2]);
            // The standard error of each patch mean, from the patch's own
            // scatter and the rounding to whole samples (never 0).
            const double n = static_cast<double>(roi.total());
            cv::Vec3d error;
            for (int k = 0; k < 3; ++k) error[k] = std::sqrt((spread[k] * spread[k] + 1.0 / 12.0) / n);
            (light ? s.lightErrorBgr : s.darkErrorBgr) = error;
            for (int k = 0; k < 3; ++k)
                if (!(bgr[k] > 0.0))
                    throw InvalidArgument(where + "the " + which + " point " + pointText(p) + " is black in " +
                                          kChannelNames[2 - k] + " (mean 0 over its " + std::to_string(roi.cols) +
                                          "x" + std::to_string(roi.rows) +
                                          " patch): no ratio can be formed; pick a point on a lit part of the object");
            const double d = std::hypot(px.x - centre.x, px.y - centre.y);
            (light ? s.lightBgr : s.darkBgr) = bgr;
            (light ? s.dLightPx : s.dDarkPx) = d;
        }
        for (int k = 0; k < 3; ++k) {
            const auto rgb = static_cast<std::size_t>(2 - k);
            s.ratioRgb[rgb] = s.lightBgr[k] / s.darkBgr[k];
            s.ratioStdRgb[rgb] = s.ratioRgb[rgb] * std::hypot(s.lightErrorBgr[k] / s.lightBgr[k],
                                                              s.darkErrorBgr[k] / s.darkBgr[k]);
        }
        samples.push_back(s);
    }
    return samples;
}

// ---- the fit -------------------------------------------------------------------

ChannelFit fitExponential(const std::vector<double>& x, const std::vector<double>& y, bool fixCoefficient,
                          const std::vector<double>& sigma) {
    const std::size_t n = x.size();
    const std::size_t params = fixCoefficient ? 1 : 2;
    if (y.size() != n || n < params)
        throw InvalidArgument("fitExponential: " + std::to_string(n) + " abscissae and " + std::to_string(y.size()) +
                              " values; at least " + std::to_string(params) + " of each are needed");
    if (!sigma.empty() && sigma.size() != n)
        throw InvalidArgument("fitExponential: " + std::to_string(sigma.size()) + " standard errors for " +
                              std::to_string(n) + " values");
    std::vector<double> w(n, 1.0);
    for (std::size_t i = 0; i < sigma.size(); ++i) {
        if (!(sigma[i] > 0.0) || !std::isfinite(sigma[i]))
            throw InvalidArgument("fitExponential: the standard error of point " + std::to_string(i + 1) + " is " +
                                  fmt(sigma[i]) + "; it must be finite and > 0");
        w[i] = 1.0 / (sigma[i] * sigma[i]);
    }
    double xMin = x[0], xMax = x[0], xAbs = 0.0;
    for (std::size_t i = 0; i < n; ++i) {
        if (!(y[i] > 0.0) || !std::isfinite(y[i]) || !std::isfinite(x[i]))
            throw InvalidArgument("fitExponential: point " + std::to_string(i + 1) + " (" + fmt(x[i]) + ", " +
                                  fmt(y[i]) + ") is not finite with a value > 0");
        xMin = std::min(xMin, x[i]);
        xMax = std::max(xMax, x[i]);
        xAbs = std::max(xAbs, std::fabs(x[i]));
    }
    const double spreadNeeded = 1e-6 * xAbs + 1e-9;
    if (fixCoefficient ? xAbs <= spreadNeeded : xMax - xMin <= spreadNeeded)
        throw InvalidArgument("fitExponential: the abscissae " + (fixCoefficient ? std::string("are all 0")
                                                                                 : "do not spread (all " + fmt(xMin) +
                                                                                       ")") +
                              "; the exponent is undetermined");

    ChannelFit f;
    // The log-linear start: ln y = ln c + e x, least squares.
    double c = 1.0, e = 0.0;
    {
        std::vector<double> ly(n);
        std::transform(y.begin(), y.end(), ly.begin(), [](double v) { return std::log(v); });
        if (fixCoefficient) {
            double sxy = 0.0, sxx = 0.0;
            for (std::size_t i = 0; i < n; ++i) {
                sxy += x[i] * ly[i];
                sxx += x[i] * x[i];
            }
            e = sxy / sxx;
        } else {
            const double mx = std::accumulate(x.begin(), x.end(), 0.0) / static_cast<double>(n);
            const double my = std::accumulate(ly.begin(), ly.end(), 0.0) / static_cast<double>(n);
            double sxy = 0.0, sxx = 0.0;
            for (std::size_t i = 0; i < n; ++i) {
                sxy += (x[i] - mx) * (ly[i] - my);
                sxx += (x[i] - mx) * (x[i] - mx);
            }
            e = sxy / sxx;
            c = std::exp(my - e * mx);
        }
    }
    f.logLinearCoefficient = c;
    f.logLinearExponent = e;

    std::vector<double> r(n);
    const auto rssAt = [&](double cc, double ee, std::vector<double>& res) {
        double rss = 0.0;
        for (std::size_t i = 0; i < n; ++i) {
            res[i] = y[i] - cc * std::exp(ee * x[i]);
            rss += w[i] * res[i] * res[i];
        }
        return rss;
    };
    // J^T J and J^T r of the model c exp(e x) (columns d/dc, d/de).
    const auto normal = [&](double cc, double ee, const std::vector<double>& res, cv::Matx22d& a, cv::Vec2d& g) {
        a = cv::Matx22d::zeros();
        g = cv::Vec2d(0, 0);
        for (std::size_t i = 0; i < n; ++i) {
            const double ex = std::exp(ee * x[i]);
            const cv::Vec2d j(ex, cc * x[i] * ex);
            a += w[i] * (j * j.t());
            g += w[i] * res[i] * j;
        }
    };

    // Levenberg-Marquardt with Marquardt's diagonal scaling.
    double rss = rssAt(c, e, r);
    double lambda = 1e-3;
    std::vector<double> trial(n);
    int iteration = 0;
    for (; iteration < 200; ++iteration) {
        cv::Matx22d a;
        cv::Vec2d g;
        normal(c, e, r, a, g);
        double dc = 0.0, de = 0.0;
        bool accepted = false;
        while (lambda < 1e20) {
            if (fixCoefficient) {
                de = g[1] / (a(1, 1) * (1.0 + lambda));
            } else {
                cv::Matx22d damped = a;
                damped(0, 0) *= 1.0 + lambda;
                damped(1, 1) *= 1.0 + lambda;
                const cv::Vec2d step = damped.solve(g, cv::DECOMP_CHOLESKY);
                dc = step[0];
                de = step[1];
            }
            const double cTrial = c + dc, eTrial = e + de;
            if (cTrial > 0.0 && std::isfinite(eTrial)) {
                const double rssTrial = rssAt(cTrial, eTrial, trial);
                if (rssTrial <= rss) {
                    const bool small = std::fabs(dc) <= 1e-13 * c && std::fabs(de) * xAbs <= 1e-13;
                    c = cTrial;
                    e = eTrial;
                    r.swap(trial);
                    const bool flat = rss - rssTrial <= 1e-15 * rss;
                    rss = rssTrial;
                    lambda = std::max(lambda / 10.0, 1e-12);
                    accepted = !(small || flat);
                    break;
                }
            }
            lambda *= 10.0;
        }
        if (!accepted) break;  // converged: no step lowers the sum of squares any more
    }
    if (iteration == 200)
        logger().warnStream() << "fitExponential: no convergence in 200 iterations (c " << c << ", e " << e << ")";
    f.iterations = std::min(iteration + 1, 200);
    f.coefficient = c;
    f.exponent = e;
    f.residuals = r;
    f.rmsResidual = 0.0;
    f.maxAbsResidual = 0.0;
    for (const double v : r) {
        f.rmsResidual += v * v / static_cast<double>(n);
        f.maxAbsResidual = std::max(f.maxAbsResidual, std::fabs(v));
    }
    f.rmsResidual = std::sqrt(f.rmsResidual);
    f.scatterOverNoise = !sigma.empty() && n > params ? std::sqrt(rss / static_cast<double>(n - params)) : kNaN;
    // Standard errors: s^2 (J^T J)^-1 at the solution.
    if (n > params) {
        const double s2 = rss / static_cast<double>(n - params);
        cv::Matx22d a;
        cv::Vec2d g;
        normal(c, e, r, a, g);
        if (fixCoefficient) {
            f.coefficientStd = 0.0;
            f.exponentStd = std::sqrt(s2 / a(1, 1));
        } else {
            const cv::Matx22d cov = a.inv(cv::DECOMP_CHOLESKY) * s2;
            f.coefficientStd = std::sqrt(cov(0, 0));
            f.exponentStd = std::sqrt(cov(1, 1));
        }
    } else {
        f.coefficientStd = f.exponentStd = kNaN;
    }
    return f;
}

double Fit::modelRatio(std::size_t k, double x) const {
    const ChannelFit& f = rgb[k];
    if (model == Model::Thesis) return f.coefficient * std::exp(f.exponent * x);
    return std::exp(f.exponent * x);
}

Fit fitFalloff(const tools::WorkingImage& image, const std::vector<PointPair>& pairs, const Options& options,
               const std::string& source) {
    if (options.patch < 1 || options.patch > 101 || options.patch % 2 == 0)
        throw InvalidArgument("the patch size must be odd, 1..101, got " + std::to_string(options.patch));
    if (pairs.size() < 2)
        throw InvalidArgument(source + " holds " + std::to_string(pairs.size()) + " point pair" +
                              (pairs.size() == 1 ? "" : "s") +
                              "; the falloff needs at least 2 (3 or more for standard errors)");
    Fit fit;
    fit.model = options.model;
    fit.patch = options.patch;
    fit.weighted = options.weighted && options.patch >= 3;
    fit.imageSize = image.bgr.size();
    fit.centre = options.centre.value_or(cv::Point2d(image.bgr.cols / 2.0, image.bgr.rows / 2.0));
    if (!std::isfinite(fit.centre.x) || !std::isfinite(fit.centre.y))
        throw InvalidArgument("the pattern centre " + pointText(fit.centre) + " is not finite");
    fit.samples = samplePairs(image, pairs, fit.centre, options.patch, source);

    double meanLight = 0.0;
    for (const Sample& s : fit.samples) {
        fit.abscissa.push_back(fit.model == Model::Thesis ? s.dDarkPx : s.dDarkPx - s.dLightPx);
        meanLight += s.dLightPx / static_cast<double>(fit.samples.size());
    }
    const auto [lo, hi] = std::minmax_element(fit.abscissa.begin(), fit.abscissa.end());
    if (fit.model == Model::Thesis && *hi - *lo < 1.0)
        throw InvalidArgument(source + ": the dark points all lie " + fmt(*lo) + " px from the centre " +
                              pointText(fit.centre) +
                              "; the falloff needs dark points at different distances");
    if (fit.model == Model::Paired && std::max(std::fabs(*lo), std::fabs(*hi)) < 1.0)
        throw InvalidArgument(source + ": the light and dark points of every pair lie at the same distance from "
                                       "the centre " + pointText(fit.centre) +
                              "; the falloff needs dark points farther out than their light points");
    for (std::size_t k = 0; k < 3; ++k) {
        std::vector<double> y, sigma;
        for (const Sample& s : fit.samples) {
            y.push_back(s.ratioRgb[k]);
            if (fit.weighted) sigma.push_back(s.ratioStdRgb[k]);
        }
        ChannelFit f = fitExponential(fit.abscissa, y, fit.model == Model::Paired, sigma);
        if (fit.model == Model::Paired) {
            // The factor is 1 at the light points' mean distance.
            f.coefficient = std::exp(-f.exponent * meanLight);
            f.coefficientStd = f.coefficient * meanLight * f.exponentStd;
            f.logLinearCoefficient = std::exp(-f.logLinearExponent * meanLight);
        }
        f.unityDistancePx = f.exponent != 0.0 ? -std::log(f.coefficient) / f.exponent : kNaN;
        logger().infoStream() << kChannelNames[k] << ": c = " << f.coefficient << " +- " << f.coefficientStd
                              << ", e = " << f.exponent << " +- " << f.exponentStd << " /px, rms residual "
                              << f.rmsResidual << " (" << f.iterations << " iterations)";
        if (f.exponent < 0.0 && !(f.exponent + 2.0 * f.exponentStd >= 0.0))
            logger().warnStream() << source << ": " << kChannelNames[k] << " e = " << f.exponent
                                  << " < 0: the factor darkens the periphery; are the light and dark points "
                                     "swapped, or is the pattern centre wrong?";
        fit.rgb[k] = f;
    }
    // Suspect pairs: robust z-scores of the normalised residuals.
    if (fit.samples.size() >= 5)
        for (std::size_t k = 0; k < 3; ++k) {
            std::vector<double> z;
            for (std::size_t i = 0; i < fit.samples.size(); ++i)
                z.push_back(std::fabs(fit.rgb[k].residuals[i]) /
                            (fit.weighted ? fit.samples[i].ratioStdRgb[k] : 1.0));
            std::vector<double> sorted = z;
            std::nth_element(sorted.begin(), sorted.begin() + static_cast<std::ptrdiff_t>(sorted.size() / 2),
                             sorted.end());
            // A floor keeps the rounding of near-exact data from flagging pairs:
            // half a standard error (weighted), 1e-4 of the ratios (unweighted).
            std::vector<double> ratios;
            for (const Sample& x : fit.samples) ratios.push_back(x.ratioRgb[k]);
            std::nth_element(ratios.begin(), ratios.begin() + static_cast<std::ptrdiff_t>(ratios.size() / 2),
                             ratios.end());
            const double floor = fit.weighted ? 0.5 : 1e-4 * ratios[ratios.size() / 2];
            const double scale = std::max(1.4826 * sorted[sorted.size() / 2], floor);
            for (std::size_t i = 0; i < z.size(); ++i)
                if (z[i] > 4.0 * scale && !fit.samples[i].suspect) {
                    fit.samples[i].suspect = true;
                    logger().warnStream() << source
                                          << (fit.samples[i].pair.line > 0
                                                  ? ":" + std::to_string(fit.samples[i].pair.line)
                                                  : " pair " + std::to_string(i + 1))
                                          << ": the pair's " << kChannelNames[k] << " ratio "
                                          << fit.samples[i].ratioRgb[k] << " lies far off the fit (residual "
                                          << fit.rgb[k].residuals[i] << "); are the two objects alike?";
                }
        }
    double lightMin = fit.samples[0].dLightPx, lightMax = lightMin;
    for (const Sample& s : fit.samples) {
        lightMin = std::min(lightMin, s.dLightPx);
        lightMax = std::max(lightMax, s.dLightPx);
    }
    const double darkSpread = fit.model == Model::Thesis ? *hi - *lo : 0.0;
    if (fit.model == Model::Thesis && lightMax - lightMin > 0.25 * darkSpread)
        logger().warnStream() << source << ": the light points lie " << fmt(lightMin) << " .. " << fmt(lightMax)
                              << " px from the centre, a spread of more than a quarter of the dark points'; the "
                                 "thesis model assumes them at about one distance (--model paired does not)";
    return fit;
}

LightingConfig withPattern(LightingConfig config, const Fit& fit, const std::string& templatePath) {
    config.patternEnabled = true;
    config.patternCentrePx = {fit.centre.x, fit.centre.y};
    FalloffChannel* channels[3] = {&config.red, &config.green, &config.blue};
    for (std::size_t k = 0; k < 3; ++k) *channels[k] = {fit.rgb[k].coefficient, fit.rgb[k].exponent};
    config.templateImagePath = templatePath;
    return config;
}

cv::Mat patternTemplate(const Fit& fit, cv::Size size) {
    LightingConfig config = withPattern(LightingConfig{}, fit);
    config.frameAverageEnabled = false;
    LightingCorrector corrector(config);
    corrector.prepare(size);
    return corrector.factors().clone();
}

void writeTemplate(const std::filesystem::path& path, const cv::Mat& factors) {
    if (factors.type() != CV_32FC3)
        throw InvalidArgument("lighting template " + path.string() + ": the factors must be CV_32FC3, got " +
                              cv::typeToString(factors.type()));
    const std::string ext = lower(path.extension().string());
    if (ext != ".tif" && ext != ".tiff")
        throw InvalidArgument("lighting template " + path.string() +
                              ": must be a .tif or .tiff file (a 32-bit float TIFF without compression)");
    bool ok = false;
    try {
        ok = cv::imwrite(path.string(), factors, {cv::IMWRITE_TIFF_COMPRESSION, 1});
    } catch (const cv::Exception& e) {
        throw IoError("lighting template " + path.string() + ": cannot be written: " + e.what());
    }
    if (!ok) throw IoError("lighting template " + path.string() + ": cannot be written");
}

// ---- frame-average gains -------------------------------------------------------

Gains frameAverageGainsOfSets(const std::filesystem::path& raw, const std::filesystem::path& corrected,
                              std::optional<BayerPattern> bayer, const std::function<void(int, int)>& progress) {
    std::error_code ec;
    for (const auto& [path, what] : {std::pair{&raw, "raw"}, std::pair{&corrected, "corrected"}})
        if (!std::filesystem::exists(*path, ec))
            throw IoError(std::string("the ") + what + " image set " + path->string() + " does not exist");
    const bool rawDir = std::filesystem::is_directory(raw, ec);
    const bool correctedDir = std::filesystem::is_directory(corrected, ec);
    Gains gains;
    if (rawDir != correctedDir)
        throw InvalidArgument("the raw set " + raw.string() + " and the corrected set " + corrected.string() +
                              " must both be directories or both be image files");
    if (!rawDir) {
        gains.pairs.push_back({raw, corrected, {}});
    } else {
        const auto list = [](const std::filesystem::path& dir) {
            std::map<std::string, std::filesystem::path> byStem;
            std::error_code listError;
            for (const auto& entry : std::filesystem::directory_iterator(dir, listError)) {
                if (!entry.is_regular_file() || !isImageFile(entry.path())) continue;
                const std::string stem = entry.path().stem().string();
                const auto [at, inserted] = byStem.emplace(stem, entry.path());
                if (!inserted)
                    throw InvalidArgument("image set " + dir.string() + " holds two images named " + stem + ": " +
                                          at->second.filename().string() + " and " + entry.path().filename().string());
            }
            if (listError) throw IoError("image set " + dir.string() + ": cannot be listed: " + listError.message());
            if (byStem.empty()) throw InvalidArgument("image set " + dir.string() + " holds no image file");
            return byStem;
        };
        const auto raws = list(raw), references = list(corrected);
        for (const auto& [stem, path] : raws) {
            const auto found = references.find(stem);
            if (found == references.end())
                throw InvalidArgument("the raw image " + path.string() + " has no corrected image named " + stem +
                                      ".* in " + corrected.string());
            gains.pairs.push_back({path, found->second, {}});
        }
        if (references.size() > raws.size())
            logger().warnStream() << "the corrected set " << corrected.string() << " holds "
                                  << references.size() - raws.size() << " image(s) without a raw image; ignored";
    }
    std::vector<cv::Mat> rawSums, correctedSums;
    const int total = static_cast<int>(gains.pairs.size());
    for (GainPair& pair : gains.pairs) {
        const tools::WorkingImage r = tools::loadImage(pair.raw, tools::kForLightingCorrection, bayer);
        const tools::WorkingImage c = tools::loadImage(pair.corrected, tools::kForLightingCorrection, bayer);
        if (r.bgr.size() != c.bgr.size())
            throw InvalidArgument("the raw image " + pair.raw.string() + " is " + sizeText(r.bgr.size()) +
                                  " but its corrected image " + pair.corrected.string() + " is " +
                                  sizeText(c.bgr.size()));
        rawSums.push_back(normalisedSums(r));
        correctedSums.push_back(normalisedSums(c));
        try {
            pair.gainsRgb = frameAverageGains(rawSums.back(), correctedSums.back());
        } catch (const InvalidArgument& e) {
            throw InvalidArgument("the raw image " + pair.raw.string() + ": " + e.what());
        }
        if (progress) progress(static_cast<int>(rawSums.size()), total);
    }
    gains.gainsRgb = frameAverageGains(rawSums, correctedSums);
    return gains;
}

// ---- the plot ------------------------------------------------------------------

namespace {

struct Axes {
    cv::Rect box{80, 40, 700, 490};
    double xMin{0}, xMax{1}, yMin{0}, yMax{1};
    cv::Point at(double x, double y) const {
        const double cx = std::clamp((x - xMin) / (xMax - xMin), 0.0, 1.0);
        const double cy = std::clamp((y - yMin) / (yMax - yMin), 0.0, 1.0);
        return {box.x + cvRound(cx * box.width), box.y + box.height - cvRound(cy * box.height)};
    }
};

}  // namespace

void writePlot(const std::filesystem::path& path, const Fit& fit) {
    const cv::Scalar black(0, 0, 0);
    const cv::Scalar colours[3] = {cv::Scalar(40, 40, 220), cv::Scalar(30, 160, 30), cv::Scalar(200, 120, 30)};
    Axes a;
    double xLo = 0.0, xHi = 1.0, yLo = 1.0, yHi = 1.0;
    for (std::size_t i = 0; i < fit.abscissa.size(); ++i) {
        xLo = std::min(xLo, fit.abscissa[i]);
        xHi = std::max(xHi, fit.abscissa[i]);
        for (std::size_t k = 0; k < 3; ++k) {
            yLo = std::min(yLo, fit.samples[i].ratioRgb[k]);
            yHi = std::max(yHi, fit.samples[i].ratioRgb[k]);
        }
    }
    for (std::size_t k = 0; k < 3; ++k)
        for (const double x : {xLo, xHi}) {
            yLo = std::min(yLo, fit.modelRatio(k, x));
            yHi = std::max(yHi, fit.modelRatio(k, x));
        }
    a.xMin = xLo;
    a.xMax = xLo + 1.05 * (xHi - xLo);
    const double margin = 0.08 * std::max(yHi - yLo, 1e-3);
    a.yMin = std::max(0.0, yLo - margin);
    a.yMax = yHi + margin;

    cv::Mat img(600, 820, CV_8UC3, cv::Scalar(255, 255, 255));
    cv::rectangle(img, a.box, black, 1);
    const auto text = [&](const std::string& s, cv::Point at, double scale, const cv::Scalar& colour) {
        cv::putText(img, s, at, cv::FONT_HERSHEY_SIMPLEX, scale, colour, 1, cv::LINE_AA);
    };
    // Ticks at round steps (1, 2 or 5 times a power of 10), about 5 per axis.
    const auto step = [](double range) {
        const double raw = range / 5.0, power = std::pow(10.0, std::floor(std::log10(raw)));
        for (const double m : {1.0, 2.0, 5.0})
            if (m * power >= raw) return m * power;
        return 10.0 * power;
    };
    const double xStep = step(a.xMax - a.xMin), yStep = step(a.yMax - a.yMin);
    for (double x = std::ceil(a.xMin / xStep) * xStep; x <= a.xMax + 1e-9 * xStep; x += xStep) {
        const cv::Point px = a.at(x, a.yMin);
        cv::line(img, px, px + cv::Point(0, 5), black);
        text(fmt(std::fabs(x) < 1e-9 * xStep ? 0.0 : x, 4), px + cv::Point(-15, 20), 0.4, black);
    }
    for (double y = std::ceil(a.yMin / yStep) * yStep; y <= a.yMax + 1e-9 * yStep; y += yStep) {
        const cv::Point py = a.at(a.xMin, y);
        cv::line(img, py, py - cv::Point(5, 0), black);
        text(fmt(y, 4), py + cv::Point(-60, 4), 0.4, black);
    }
    if (a.yMin < 1.0 && a.yMax > 1.0)
        cv::line(img, a.at(a.xMin, 1.0), a.at(a.xMax, 1.0), cv::Scalar(190, 190, 190), 1);
    // Curves, then the data on top.
    for (std::size_t k = 0; k < 3; ++k) {
        std::vector<cv::Point> curve;
        for (int i = 0; i <= 200; ++i) {
            const double x = a.xMin + (a.xMax - a.xMin) * i / 200;
            curve.push_back(a.at(x, fit.modelRatio(k, x)));
        }
        cv::polylines(img, curve, false, colours[k], 2, cv::LINE_AA);
    }
    for (std::size_t i = 0; i < fit.abscissa.size(); ++i)
        for (std::size_t k = 0; k < 3; ++k) {
            const cv::Point p = a.at(fit.abscissa[i], fit.samples[i].ratioRgb[k]);
            cv::circle(img, p, 4, colours[k], 1, cv::LINE_AA);
            if (fit.samples[i].saturated) cv::drawMarker(img, p, black, cv::MARKER_CROSS, 12);
            if (fit.samples[i].suspect) cv::drawMarker(img, p, black, cv::MARKER_SQUARE, 14);
        }
    const std::string xLabel = fit.model == Model::Thesis ? "d of the dark point from the centre (px)"
                                                          : "d(dark) - d(light) (px)";
    text(xLabel, cv::Point(a.box.x + a.box.width / 2 - 150, a.box.y + a.box.height + 40), 0.5, black);
    text("light / dark", cv::Point(6, a.box.y - 8), 0.45, black);
    text(std::string("lighting falloff (") + toString(fit.model) + " model, " + std::to_string(fit.samples.size()) +
             " pairs): ratio against distance, fitted " +
             (fit.model == Model::Thesis ? "c exp(e d)" : "exp(e d)"),
         cv::Point(a.box.x, 16), 0.5, black);
    const auto any = [&](bool Sample::*flag) {
        return std::any_of(fit.samples.begin(), fit.samples.end(), [&](const Sample& x) { return x.*flag; });
    };
    const bool anySaturated = any(&Sample::saturated), anySuspect = any(&Sample::suspect);
    if (anySaturated || anySuspect)
        text(std::string(anySaturated ? "+ a patch clipped  " : "") + (anySuspect ? "square: suspect pair" : ""),
             cv::Point(a.box.x + 10, a.box.y + 80), 0.45, black);
    for (std::size_t k = 0; k < 3; ++k) {
        const ChannelFit& f = fit.rgb[k];
        text(std::string(kChannelNames[k]) + ": c " + fmt(f.coefficient, 5) + ", e " + fmt(f.exponent, 4) +
                 "/px, rms " + fmt(f.rmsResidual, 3),
             cv::Point(a.box.x + 10, a.box.y + 20 + 20 * static_cast<int>(k)), 0.45, colours[k]);
    }
    bool ok = false;
    try {
        ok = cv::imwrite(path.string(), img);
    } catch (const cv::Exception& e) {
        throw IoError("plot " + path.string() + ": cannot be written: " + e.what());
    }
    if (!ok) throw IoError("plot " + path.string() + ": cannot be written");
}

}  // namespace avatar::lightfit
