// avatar-lightfit on images whose falloff is known: a synthetic image of
// coloured patches divided by a per-channel exp(e * d) with sensor noise, and
// a render of data/scenes/seabed.xml's strobe over a uniform floor. The fit
// must recover the falloff within the noise (and its standard errors must
// describe that noise), and the fitted configuration, applied by the real
// LightingCorrector, must make the dark patch of each pair as bright as its
// light patch. The executable is run as a user runs it.

#include "SampleConfigs.h"
#include "TempDir.h"
#include "ToolRun.h"

#include "LightFit.h"

#include <avatar/analyze/LightingCorrection.h>
#include <avatar/common/ImageUtils.h>
#include <avatar/common/StereoImagePairFileIO.h>
#include <avatar/config/ConfigXml.h>
#include <avatar/render/Renderer.h>
#include <avatar/render/Scene.h>

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>
#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include <algorithm>
#include <cmath>
#include <functional>
#include <stdexcept>
#include <cstdlib>
#include <fstream>
#include <sstream>

using namespace avatar;
namespace fs = std::filesystem;

namespace {

// ---- the synthetic image -------------------------------------------------------

/// The falloff rendered into the synthetic image: each channel is multiplied
/// by exp(-e d), d from kCentre; the light patches lie kLightD px from it, so
/// the correction factor is c exp(e d) with c = exp(-e kLightD) (1 at the
/// light patches).
constexpr std::array<double, 3> kExponentRgb{1.6e-3, 1.2e-3, 0.9e-3};
const cv::Point2d kCentre(700, 430);
constexpr double kLightD = 60.0;
constexpr int kPatchSide = 41;  ///< the coloured squares
constexpr int kPairs = 24;
constexpr int kBits = 12;

double trueCoefficient(std::size_t k) { return std::exp(-kExponentRgb[k] * kLightD); }

/// Albedos (R, G, B) of the six colours: yellow, red, green, blue, grey, orange.
const std::array<std::array<double, 3>, 6> kColours{{{0.85, 0.80, 0.20},
                                                     {0.80, 0.30, 0.25},
                                                     {0.25, 0.65, 0.30},
                                                     {0.30, 0.40, 0.85},
                                                     {0.60, 0.60, 0.60},
                                                     {0.90, 0.50, 0.10}}};

struct Synthetic {
    tools::WorkingImage image;
    std::vector<lightfit::PointPair> pairs;
};

/// 1280x960, 12-bit BGR in 16-bit samples: grey ground (albedo 0.3), for each
/// pair a dark square of one of the six colours 150..650 px from kCentre and
/// a light square of the same colour on the ring of kLightD around it (one per
/// colour, shared by the pairs of that colour); value = 4000 * albedo *
/// exp(-e d) plus read noise (6 DN) and shot noise (variance 0.25 * value).
/// @p lightDistance, when given, places the light square of each pair at
/// lightDistance(d_dark) instead, a square of its own. No two squares overlap.
Synthetic synthesize(std::uint64_t seed, const std::function<double(double)>& lightDistance = {}) {
    const cv::Size size(1280, 960);
    std::vector<std::array<double, 3>> albedo(static_cast<std::size_t>(size.area()), {0.3, 0.3, 0.3});
    std::vector<cv::Rect> placed;
    const auto square = [](cv::Point2d c) {
        return cv::Rect(cvRound(c.x) - kPatchSide / 2, cvRound(c.y) - kPatchSide / 2, kPatchSide, kPatchSide);
    };
    const auto free = [&](const cv::Rect& r) {
        return std::none_of(placed.begin(), placed.end(),
                            [&](const cv::Rect& o) { return o != r && (o & r).area() > 0; });
    };
    const auto paint = [&](cv::Point2d c, const std::array<double, 3>& rgb) {
        const cv::Rect r = square(c);
        if (!free(r)) throw std::logic_error("synthesize: squares overlap");
        placed.push_back(r);
        for (int y = r.y; y < r.br().y; ++y)
            for (int x = r.x; x < r.br().x; ++x) albedo[static_cast<std::size_t>(y * size.width + x)] = rgb;
        return cv::Point2d(cvRound(c.x), cvRound(c.y));
    };
    const cv::Rect inside(kPatchSide, kPatchSide, size.width - 2 * kPatchSide, size.height - 2 * kPatchSide);
    Synthetic s;
    std::vector<double> darkD;
    for (int i = 0; i < kPairs; ++i) {
        const double angle = 2 * CV_PI * i / kPairs + 0.13;
        const cv::Point2d dir(std::cos(angle), std::sin(angle));
        double dd = 150.0 + 100.0 * ((i / 6 + i) % 6);
        while (!inside.contains(kCentre + dd * dir)) dd -= 10.0;  // short of the border
        s.pairs.push_back({{}, paint(kCentre + dd * dir, kColours[static_cast<std::size_t>(i % 6)]), 0});
        darkD.push_back(dd);
    }
    for (int i = 0; i < kPairs; ++i) {
        const std::array<double, 3>& colour = kColours[static_cast<std::size_t>(i % 6)];
        if (!lightDistance) {
            const double angle = 2 * CV_PI * (i % 6) / 6;
            const cv::Point2d at = kCentre + kLightD * cv::Point2d(std::cos(angle), std::sin(angle));
            s.pairs[static_cast<std::size_t>(i)].light =
                i < 6 ? paint(at, colour) : s.pairs[static_cast<std::size_t>(i % 6)].light;
            continue;
        }
        // Opposite its dark square, turned until it is clear of the others.
        const double dl = lightDistance(darkD[static_cast<std::size_t>(i)]);
        for (double angle = 2 * CV_PI * i / kPairs + 0.13 + CV_PI;; angle += 0.05) {
            const cv::Point2d at = kCentre + dl * cv::Point2d(std::cos(angle), std::sin(angle));
            if (free(square(at)) && inside.contains(at)) {
                s.pairs[static_cast<std::size_t>(i)].light = paint(at, colour);
                break;
            }
        }
    }
    cv::Mat signal(size, CV_64FC3);
    for (int y = 0; y < size.height; ++y)
        for (int x = 0; x < size.width; ++x) {
            const double d = std::hypot(x - kCentre.x, y - kCentre.y);
            const auto& a = albedo[static_cast<std::size_t>(y * size.width + x)];
            for (int k = 0; k < 3; ++k)
                signal.at<cv::Vec3d>(y, x)[2 - k] =
                    4000.0 * a[static_cast<std::size_t>(k)] * std::exp(-kExponentRgb[static_cast<std::size_t>(k)] * d);
        }
    cv::Mat sigma;
    cv::sqrt(signal * 0.25 + cv::Scalar::all(36.0), sigma);
    cv::Mat noise(size, CV_64FC3);
    cv::RNG rng(seed);
    rng.fill(noise, cv::RNG::NORMAL, 0.0, 1.0);
    cv::Mat noisy = signal + noise.mul(sigma);
    cv::min(noisy, std::ldexp(1.0, kBits) - 1.0, noisy);
    noisy.convertTo(s.image.bgr, CV_16UC3);  // rounds and saturates at 0
    s.image.bitDepth = kBits;
    s.image.description = "synthetic";
    return s;
}

/// Mean of the inner 31x31 of the square around @p p (per channel, BGR).
cv::Vec3d squareMean(const cv::Mat& bgr, cv::Point2d p) {
    const cv::Scalar m = cv::mean(bgr(cv::Rect(cvRound(p.x) - 15, cvRound(p.y) - 15, 31, 31)));
    return {m[0], m[1], m[2]};
}

/// The worst |corrected dark / corrected light - 1| over the pairs and channels
/// after @p corrector, and the same ratio's worst before it.
std::pair<double, double> darkAgainstLight(const Synthetic& s, const LightingCorrector& corrector) {
    cv::Mat corrected = s.image.bgr.clone();
    corrector.apply(corrected, s.image.bitDepth);
    double worstAfter = 0.0, worstBefore = 0.0;
    for (const lightfit::PointPair& p : s.pairs) {
        const cv::Vec3d la = squareMean(corrected, p.light), da = squareMean(corrected, p.dark);
        const cv::Vec3d lb = squareMean(s.image.bgr, p.light), db = squareMean(s.image.bgr, p.dark);
        for (int k = 0; k < 3; ++k) {
            worstAfter = std::max(worstAfter, std::fabs(da[k] / la[k] - 1.0));
            worstBefore = std::max(worstBefore, std::fabs(db[k] / lb[k] - 1.0));
        }
    }
    return {worstAfter, worstBefore};
}

using test::run;
using test::slurp;

void writeFile(const fs::path& p, const std::string& text) {
    std::ofstream out(p);
    out << text;
}

std::string pairsCsv(const std::vector<lightfit::PointPair>& pairs) {
    std::ostringstream out;
    out << "# light and dark points\nlight_x,light_y,dark_x,dark_y\n";
    for (const lightfit::PointPair& p : pairs)
        out << p.light.x << "," << p.light.y << "," << p.dark.x << "," << p.dark.y << "\n";
    return out.str();
}

}  // namespace

// ---- the fit itself ------------------------------------------------------------

// Exact data: the fit returns the curve it was given; two points determine it
// (no standard errors); with noise it minimises the squared ratio residuals,
// which the log-linear start (a spreadsheet's trend line) does not.
TEST(LightFit, ExponentialFitIsTheLeastSquaresSolution) {
    std::vector<double> x, y;
    for (int i = 0; i < 12; ++i) {
        x.push_back(100.0 + 50.0 * i);
        y.push_back(0.9 * std::exp(1.5e-3 * x.back()));
    }
    lightfit::ChannelFit f = lightfit::fitExponential(x, y, false);
    EXPECT_NEAR(f.coefficient, 0.9, 1e-12);
    EXPECT_NEAR(f.exponent, 1.5e-3, 1e-15);
    EXPECT_LT(f.rmsResidual, 1e-12);
    EXPECT_LT(f.coefficientStd, 1e-12);

    f = lightfit::fitExponential({200.0, 600.0}, {1.2, 2.0}, false);
    EXPECT_NEAR(f.exponent, std::log(2.0 / 1.2) / 400.0, 1e-14);
    EXPECT_NEAR(f.coefficient, 1.2 * std::exp(-200.0 * std::log(2.0 / 1.2) / 400.0), 1e-12);
    EXPECT_TRUE(std::isnan(f.exponentStd));

    // Noisy: the residual sum of squares is at a minimum (no nearby c, e does
    // better) and below the log-linear start's.
    cv::RNG rng(5);
    for (double& v : y) v *= 1.0 + 0.02 * rng.gaussian(1.0);
    f = lightfit::fitExponential(x, y, false);
    const auto rss = [&](double c, double e) {
        double s = 0;
        for (std::size_t i = 0; i < x.size(); ++i) s += std::pow(y[i] - c * std::exp(e * x[i]), 2);
        return s;
    };
    const double best = rss(f.coefficient, f.exponent);
    EXPECT_NEAR(std::sqrt(best / static_cast<double>(x.size())), f.rmsResidual, 1e-12);
    EXPECT_LT(best, rss(f.logLinearCoefficient, f.logLinearExponent));
    for (const double dc : {-1e-4, 1e-4})
        for (const double de : {-1e-7, 0.0, 1e-7}) EXPECT_GT(rss(f.coefficient + dc, f.exponent + de), best);

    EXPECT_THROW(lightfit::fitExponential({300.0, 300.0, 300.0}, {1.0, 1.1, 1.2}, false), InvalidArgument);
    EXPECT_THROW(lightfit::fitExponential({100.0, 200.0}, {1.0, 0.0}, false), InvalidArgument);
}

// The synthetic falloff is recovered. Per-sample noise: a 5x5 patch mean of
// v = 120..3600 DN with sigma^2 = 36 + 0.25 v has a relative error of
// 0.2 % (bright) to 2 % (the blue of the orange squares 650 px out), so the
// ratios scatter by 0.3-2 %; weighted by that noise, over 24 pairs 150..650 px
// out, the fit's standard errors come to 0.3-0.8 % of e and 0.15-0.4 % of c.
// Tolerance: 4 standard errors, which must themselves stay below 1.5 % of e
// and 0.6 % of c. Over 20 noise seeds the scatter of the estimates must agree
// with the standard errors reported (ratio within 0.6..1.6: the 90 % range of
// a standard deviation estimated from 20 draws is 0.72..1.26, the rest for
// the noise of the reported errors themselves) and show no bias, so the
// errors the tool reports are the errors a user gets.
TEST(LightFit, RecoversTheRenderedFalloffWithinItsStandardErrors) {
    std::array<std::vector<double>, 3> e, eStd;
    std::array<double, 3> worstE{}, worstC{};
    for (std::uint64_t seed = 1; seed <= 20; ++seed) {
        const Synthetic s = synthesize(seed);
        lightfit::Options o;
        o.centre = kCentre;
        const lightfit::Fit fit = lightfit::fitFalloff(s.image, s.pairs, o, "synthetic");
        ASSERT_EQ(fit.samples.size(), static_cast<std::size_t>(kPairs));
        ASSERT_TRUE(fit.weighted);
        for (std::size_t k = 0; k < 3; ++k) {
            const lightfit::ChannelFit& f = fit.rgb[k];
            SCOPED_TRACE("seed " + std::to_string(seed) + " channel " + std::to_string(k));
            EXPECT_NEAR(f.exponent, kExponentRgb[k], 4 * f.exponentStd);
            EXPECT_NEAR(f.coefficient, trueCoefficient(k), 4 * f.coefficientStd);
            EXPECT_LT(f.exponentStd / kExponentRgb[k], 0.015);
            EXPECT_LT(f.coefficientStd / trueCoefficient(k), 0.006);
            EXPECT_NEAR(f.unityDistancePx, kLightD, 15.0);
            worstE[k] = std::max(worstE[k], std::fabs(f.exponent / kExponentRgb[k] - 1.0));
            worstC[k] = std::max(worstC[k], std::fabs(f.coefficient / trueCoefficient(k) - 1.0));
            e[k].push_back(f.exponent);
            eStd[k].push_back(f.exponentStd);
            if (seed == 1)
                std::printf("seed 1 channel %zu: e %.6e (true %.6e) +- %.2e, c %.6f (true %.6f) +- %.2e, rms %.4f, "
                            "max %.4f, %.2f x the noise\n",
                            k, f.exponent, kExponentRgb[k], f.exponentStd, f.coefficient, trueCoefficient(k),
                            f.coefficientStd, f.rmsResidual, f.maxAbsResidual, f.scatterOverNoise);
        }
    }
    for (std::size_t k = 0; k < 3; ++k) {
        cv::Scalar mean, sd;
        cv::meanStdDev(e[k], mean, sd);
        const double reported = cv::mean(eStd[k])[0];
        const double scatter = sd[0] * std::sqrt(20.0 / 19.0);
        std::printf("channel %zu over 20 seeds: e %.6e, scatter %.2e, mean reported standard error %.2e; worst "
                    "error of e %.2f %%, of c %.2f %%\n",
                    k, mean[0], scatter, reported, 100 * worstE[k], 100 * worstC[k]);
        EXPECT_GT(scatter / reported, 0.6);
        EXPECT_LT(scatter / reported, 1.6);
        EXPECT_NEAR(mean[0], kExponentRgb[k], 4 * scatter / std::sqrt(20.0));  // no bias
    }
}

// What the fit is for: LightingCorrector with the fitted configuration makes
// each dark square as bright as its light square, within 1 % (measured 0.5 %:
// the 31x31 means carry 0.05-0.3 % noise, the fitted factor's error at 650 px
// is ~0.3-0.5 %), where they differed by up to 61 % before; and it leaves the
// light squares as they were (factor 1 there, within 0.5 %). The template
// image written for the same fit gives the same factors, bit for bit.
TEST(LightFit, FittedCorrectionMakesTheDarkPatchesMatchTheLightOnes) {
    test::TempDir dir("lightfit");
    const Synthetic s = synthesize(1);
    lightfit::Options o;
    o.centre = kCentre;
    const lightfit::Fit fit = lightfit::fitFalloff(s.image, s.pairs, o, "synthetic");
    for (std::size_t k = 0; k < 3; ++k) EXPECT_GT(fit.rgb[k].exponent, 0.0) << "the factor brightens the periphery";
    const LightingConfig analytic = lightfit::withPattern(LightingConfig{}, fit);
    LightingCorrector corrector(analytic);
    corrector.prepare(s.image.bgr.size());
    const auto [after, before] = darkAgainstLight(s, corrector);
    std::printf("dark against light: worst %.2f %% before, %.2f %% after the correction\n", 100 * before, 100 * after);
    EXPECT_GT(before, 0.5);
    EXPECT_LT(after, 0.01);
    for (const lightfit::PointPair& p : s.pairs) {
        cv::Mat corrected = s.image.bgr.clone();
        corrector.apply(corrected, s.image.bitDepth);
        const cv::Vec3d was = squareMean(s.image.bgr, p.light), is = squareMean(corrected, p.light);
        for (int k = 0; k < 3; ++k) EXPECT_NEAR(is[k] / was[k], 1.0, 0.005);
        break;  // one is enough: all light squares lie at the same distance
    }

    const fs::path tiff = dir / "factors.tiff";
    lightfit::writeTemplate(tiff, lightfit::patternTemplate(fit, s.image.bgr.size()));
    LightingConfig withTemplate = lightfit::withPattern(LightingConfig{}, fit, "factors.tiff");
    LightingCorrector fromTemplate(withTemplate, dir.path());
    fromTemplate.prepare(s.image.bgr.size());
    EXPECT_EQ(cv::norm(fromTemplate.factors(), corrector.factors(), cv::NORM_INF), 0.0);
}

// Light points at different distances (here they move out with their dark
// points, d_light = 0.4 d_dark = 60..260 px): the thesis model, which assumes
// one light distance, takes the light points' own falloff for part of the
// ratio and comes out 40 % low (0.6 e), and its correction leaves the far
// squares 22 % dark; the paired model fits the ratio each pair's distance
// difference explains and recovers e within 4 standard errors and 1.5 %, and
// its correction matches dark to light within 1 % (measured 0.3 %).
TEST(LightFit, PairedModelForLightPointsAtDifferentDistances) {
    const auto lightAt = [](double dd) { return 0.4 * dd; };
    const Synthetic s = synthesize(2, lightAt);
    lightfit::Options o;
    o.centre = kCentre;
    const lightfit::Fit thesis = lightfit::fitFalloff(s.image, s.pairs, o, "synthetic");
    o.model = lightfit::Model::Paired;
    const lightfit::Fit paired = lightfit::fitFalloff(s.image, s.pairs, o, "synthetic");
    double meanLight = 0;
    for (const lightfit::Sample& x : paired.samples) meanLight += x.dLightPx / kPairs;
    for (std::size_t k = 0; k < 3; ++k) {
        SCOPED_TRACE(k);
        std::printf("channel %zu: e true %.3e, thesis model %.3e, paired model %.3e +- %.1e\n", k, kExponentRgb[k],
                    thesis.rgb[k].exponent, paired.rgb[k].exponent, paired.rgb[k].exponentStd);
        EXPECT_LT(thesis.rgb[k].exponent / kExponentRgb[k], 0.9);
        EXPECT_NEAR(paired.rgb[k].exponent / kExponentRgb[k], 1.0, 0.015);
        EXPECT_NEAR(paired.rgb[k].exponent, kExponentRgb[k], 4 * paired.rgb[k].exponentStd);
        EXPECT_NEAR(paired.rgb[k].unityDistancePx, meanLight, 1e-6);
    }
    LightingCorrector thesisCorrector(lightfit::withPattern(LightingConfig{}, thesis));
    thesisCorrector.prepare(s.image.bgr.size());
    LightingCorrector pairedCorrector(lightfit::withPattern(LightingConfig{}, paired));
    pairedCorrector.prepare(s.image.bgr.size());
    const double thesisAfter = darkAgainstLight(s, thesisCorrector).first;
    const double pairedAfter = darkAgainstLight(s, pairedCorrector).first;
    std::printf("dark against light after the correction: thesis model %.2f %%, paired model %.2f %%\n",
                100 * thesisAfter, 100 * pairedAfter);
    EXPECT_GT(thesisAfter, 0.1);
    EXPECT_LT(pairedAfter, 0.01);
}

// A pair of unlike objects (the dark point moved off its square onto the
// grey ground beside it) is flagged, and only it; a patch that reaches full
// scale is flagged as clipped; the clean image flags nothing.
TEST(LightFit, FlagsUnlikePairsAndClippedPatches) {
    Synthetic s = synthesize(5);
    lightfit::Options o;
    o.centre = kCentre;
    const lightfit::Fit clean = lightfit::fitFalloff(s.image, s.pairs, o, "synthetic");
    for (const lightfit::Sample& x : clean.samples) EXPECT_FALSE(x.suspect || x.saturated);
    std::vector<lightfit::PointPair> pairs = s.pairs;
    pairs[3].dark += cv::Point2d(0, kPatchSide);  // off the square, same distance within ~40 px
    pairs[3].line = 5;
    s.image.bgr(cv::Rect(cvRound(pairs[7].light.x) - 1, cvRound(pairs[7].light.y) - 1, 2, 2))
        .setTo(cv::Scalar::all(std::ldexp(1.0, kBits) - 1));
    const lightfit::Fit fit = lightfit::fitFalloff(s.image, pairs, o, "synthetic");
    for (std::size_t i = 0; i < fit.samples.size(); ++i) {
        SCOPED_TRACE(i);
        EXPECT_EQ(fit.samples[i].suspect, i == 3);
        EXPECT_EQ(fit.samples[i].saturated, cvRound(pairs[i].light.x) == cvRound(pairs[7].light.x) &&
                                                cvRound(pairs[i].light.y) == cvRound(pairs[7].light.y));
    }
    // Pair 3 is blue (albedo 0.30, 0.40, 0.85) on grey (0.3): its blue ratio is off by ~3x.
    EXPECT_GT(fit.rgb[2].scatterOverNoise, 10.0 * clean.rgb[2].scatterOverNoise);
    EXPECT_LT(clean.rgb[2].scatterOverNoise, 1.5);
}

// Errors name the pair and the point at fault.
TEST(LightFit, SamplingErrorsNameThePoint) {
    Synthetic s = synthesize(3);
    lightfit::Options o;
    std::vector<lightfit::PointPair> pairs = s.pairs;
    pairs[2].dark = {1300, 20};
    pairs[2].line = 7;
    try {
        lightfit::fitFalloff(s.image, pairs, o, "pairs file p.csv");
        ADD_FAILURE() << "no error";
    } catch (const InvalidArgument& e) {
        EXPECT_STREQ(e.what(), "pairs file p.csv:7: the dark point (1300, 20) lies outside the 1280x960 image");
    }
    s.image.bgr(cv::Rect(0, 0, 20, 20)).setTo(cv::Scalar(0, 0, 0));
    pairs = s.pairs;
    pairs[0].dark = {10, 10};
    try {
        lightfit::fitFalloff(s.image, pairs, o, "pairs file p.csv");
        ADD_FAILURE() << "no error";
    } catch (const InvalidArgument& e) {
        EXPECT_NE(std::string(e.what()).find("pairs file p.csv pair 1: the dark point (10, 10) is black in blue"),
                  std::string::npos)
            << e.what();
    }
    pairs.resize(1);
    EXPECT_THROW(lightfit::fitFalloff(s.image, pairs, o, "p"), InvalidArgument);
    pairs = s.pairs;
    for (lightfit::PointPair& p : pairs) p.dark = pairs[0].dark;
    try {
        lightfit::fitFalloff(s.image, pairs, o, "p");
        ADD_FAILURE() << "no error";
    } catch (const InvalidArgument& e) {
        EXPECT_NE(std::string(e.what()).find("the dark points all lie"), std::string::npos) << e.what();
    }
    o.patch = 4;
    EXPECT_THROW(lightfit::fitFalloff(s.image, s.pairs, o, "p"), InvalidArgument);
}

// ---- the program ---------------------------------------------------------------

namespace {

/// data/scenes/seabed.xml's strobe (the inverse of data/config/seabed.xml's
/// pattern: c 1, e 0.0015, 0.001, 0.0008 about (640, 480)) over a uniform,
/// untextured floor facing the cameras, lit evenly (ambient only), with
/// read and shot noise: the left image, 16-bit Bayer BG as the cameras deliver it.
render::RenderResult renderStrobe() {
    render::Scene scene;
    scene.name = "strobe";
    scene.seabed.distanceMm = 1500;
    scene.seabed.albedo = {0.55, 0.6, 0.5};
    scene.seabed.textureContrast = 0.0;
    scene.lighting.ambient = {1.0, 1.0, 1.0};
    scene.lighting.lightIntensity = {0.0, 0.0, 0.0};
    scene.lighting.strobe.enabled = true;
    scene.lighting.strobe.centrePx = {640, 480};
    scene.lighting.strobe.rgb = {{{1.0, -0.0015}, {1.0, -0.001}, {1.0, -0.0008}}};
    scene.sensor.readNoiseDn = 40.0;
    scene.sensor.shotNoise = true;
    scene.sensor.fullWellElectrons = 20000.0;
    render::RenderOptions options;
    options.sensor = render::sensorFormatFrom(test::scorpionSample().camera);
    options.seed = 11;
    return render::render(scene, test::scorpionCalibration(), options);
}

}  // namespace

// The issue's run on a render of the seabed strobe: light points at the
// strobe's centre, dark points on a spiral 100..760 px out, the raw file as
// the cameras write it. The tool writes <lighting> into a copy of the sample
// configuration (nothing else changes), the template the LightingCorrector
// then reads, the report and the plot. The pattern it finds is the seabed
// configuration's: e within 4 standard errors and 1 % (the ratios scatter by
// 0.2-0.5 %: shot noise of ~1 % per pixel, 9x9 patches, demosaiced), c
// within 0.5 % of what the sampling makes it (below) -- the error of c is
// that of the one light patch all pairs share, ~0.2 % -- and the corrected
// render is flat within 1 % from the centre to the corners.
TEST(LightFitTool, TheIssuesCommandLineOnARenderedStrobe) {
    test::TempDir dir("lightfit");
    const render::RenderResult r = renderStrobe();
    const render::SensorFormat sensor = render::sensorFormatFrom(test::scorpionSample().camera);
    const render::WrittenFiles files = render::writeRender(r, sensor, dir.path(), 1, 0, false);
    std::vector<lightfit::PointPair> pairs;
    for (int i = 0; i < 30; ++i) {
        const double d = 100.0 + 22.0 * i, angle = 2.4 * i;  // a spiral, golden-angle-like spread
        cv::Point2d dark(640 + d * std::cos(angle), 480 + d * std::sin(angle));
        dark.x = std::clamp(std::round(dark.x), 10.0, 1269.0);
        dark.y = std::clamp(std::round(dark.y), 10.0, 949.0);
        pairs.push_back({{640, 480}, dark, 0});
    }
    writeFile(dir / "pairs.csv", pairsCsv(pairs));
    const AvatarConfig original = test::scorpionSample();
    writeConfigFile(original, dir / "site.xml");

    const std::string exe = AVATAR_LIGHTFIT_EXECUTABLE;
    const std::string cmd = exe + " --image " + files.leftRaw.string() + " --pairs " + (dir / "pairs.csv").string() +
                            " --centre 640 480 --patch 9 --out " + (dir / "site.xml").string() + " --template " +
                            (dir / "strobe.tiff").string() + " --report " + (dir / "report.json").string() +
                            " --plot " + (dir / "fit.png").string();
    ASSERT_EQ(run(cmd + " > " + (dir / "stdout.txt").string() + " 2> " + (dir / "stderr.txt").string()), 0)
        << slurp(dir / "stderr.txt");
    std::printf("%s", slurp(dir / "stdout.txt").c_str());
    EXPECT_NE(slurp(dir / "stdout.txt").find("falloff c*exp(e*d) from 30 pairs (thesis model, centre 640 480"),
              std::string::npos);

    // The configuration: the pattern, the template beside it; the rest as it was.
    const AvatarConfig site = readConfigFile(dir / "site.xml");
    AvatarConfig rest = site;
    rest.lighting = original.lighting;
    EXPECT_TRUE(rest == original);
    EXPECT_TRUE(site.lighting.patternEnabled);
    EXPECT_FALSE(site.lighting.frameAverageEnabled);
    EXPECT_EQ(site.lighting.templateImagePath, "strobe.tiff");
    EXPECT_EQ(site.lighting.patternCentrePx, (std::array<double, 2>{640, 480}));
    // The light samples are 9x9 patch means at the strobe's centre, where the
    // falloff has its cusp: they are exp(-e d) averaged over the patch
    // (d = 3.0 px on average) darker than the centre pixel, and so c is.
    const AvatarConfig seabed = readConfigFile(std::string(AVATAR_DATA_DIR) + "/config/seabed.xml");
    const std::array<const FalloffChannel*, 3> fitted{&site.lighting.red, &site.lighting.green, &site.lighting.blue};
    const std::array<const FalloffChannel*, 3> truth{&seabed.lighting.red, &seabed.lighting.green,
                                                     &seabed.lighting.blue};
    const nlohmann::json j = nlohmann::json::parse(slurp(dir / "report.json"));
    for (std::size_t k = 0; k < 3; ++k) {
        SCOPED_TRACE(k);
        double patchMean = 0.0;
        for (int dy = -4; dy <= 4; ++dy)
            for (int dx = -4; dx <= 4; ++dx) patchMean += std::exp(-truth[k]->exponent * std::hypot(dx, dy)) / 81.0;
        const nlohmann::json& ch = j["channels"][std::array<const char*, 3>{"red", "green", "blue"}[k]];
        EXPECT_NEAR(fitted[k]->coefficient, truth[k]->coefficient * patchMean, 0.005);
        EXPECT_NEAR(fitted[k]->coefficient, truth[k]->coefficient * patchMean, 4 * ch["coefficient_std"].get<double>());
        EXPECT_NEAR(fitted[k]->exponent / truth[k]->exponent, 1.0, 0.01);
        EXPECT_NEAR(fitted[k]->exponent, truth[k]->exponent, 4 * ch["exponent_std"].get<double>());
    }

    // The report: per channel coefficients, errors and residuals; the pairs.
    EXPECT_EQ(j["points"], 30);
    EXPECT_EQ(j["model"], "thesis");
    EXPECT_EQ(j["patch"], 9);
    EXPECT_EQ(j["weighted"], true);
    EXPECT_EQ(j["samples"].size(), 30u);
    for (std::size_t k = 0; k < 3; ++k) {
        const nlohmann::json& ch = j["channels"][std::array<const char*, 3>{"red", "green", "blue"}[k]];
        EXPECT_EQ(ch["coefficient"].get<double>(), fitted[k]->coefficient);
        EXPECT_EQ(ch["exponent"].get<double>(), fitted[k]->exponent);
        EXPECT_GT(ch["exponent_std"].get<double>(), 0.0);
        EXPECT_LT(ch["exponent_std"].get<double>(), 0.005 * fitted[k]->exponent);
        EXPECT_EQ(ch["residuals"].size(), 30u);
        EXPECT_LT(ch["rms_residual"].get<double>(), 0.01);
        EXPECT_GE(ch["max_residual"].get<double>(), ch["rms_residual"].get<double>());
    }
    EXPECT_EQ(j["config"], (dir / "site.xml").string());
    EXPECT_EQ(cv::imread((dir / "fit.png").string()).size(), cv::Size(820, 600));

    // The vision system's view: the configuration read, its template loaded,
    // the render corrected: flat within 1 % from the centre to the corners
    // (it fell to 32 % in red before).
    LightingCorrector corrector(site.lighting, dir.path());
    corrector.prepare(cv::Size(1280, 960));
    const cv::Mat tiff = cv::imread((dir / "strobe.tiff").string(), cv::IMREAD_UNCHANGED);
    EXPECT_EQ(tiff.type(), CV_32FC3);
    cv::Mat image = demosaic(r.pair.left(), BayerPattern::BG);
    cv::Mat corrected = image.clone();
    corrector.apply(corrected, 16);
    const cv::Vec3d centre = squareMean(corrected, {640, 480});
    double worstBefore = 0.0, worstAfter = 0.0;
    for (const cv::Point2d p : {cv::Point2d(40, 40), cv::Point2d(1240, 40), cv::Point2d(40, 920),
                                cv::Point2d(1240, 920), cv::Point2d(640, 40), cv::Point2d(300, 480)}) {
        const cv::Vec3d was = squareMean(image, p), is = squareMean(corrected, p);
        for (int k = 0; k < 3; ++k) {
            worstBefore = std::max(worstBefore, std::fabs(was[k] / squareMean(image, {640, 480})[k] - 1.0));
            worstAfter = std::max(worstAfter, std::fabs(is[k] / centre[k] - 1.0));
        }
    }
    std::printf("render against its centre: worst %.1f %% before, %.2f %% after the correction\n", 100 * worstBefore,
                100 * worstAfter);
    EXPECT_GT(worstBefore, 0.6);
    EXPECT_LT(worstAfter, 0.01);
}

// Frame averaging (Figure 3-2): raw 16-bit images and 8-bit references made
// from them with known gains; pairs found by name, the gains recovered to
// 0.2 % (the 8-bit rounding), written into the configuration.
TEST(LightFitTool, FrameAverageGainsFromTwoImageSets) {
    test::TempDir dir("lightfit");
    fs::create_directories(dir / "raw");
    fs::create_directories(dir / "whoi");
    const std::array<double, 3> gainsRgb{1.3, 1.1, 0.85};
    cv::RNG rng(9);
    for (int i = 0; i < 3; ++i) {
        cv::Mat raw(480, 640, CV_16UC3);
        rng.fill(raw, cv::RNG::UNIFORM, 2000, 40000);
        cv::Mat reference;
        raw.convertTo(reference, CV_64FC3, 1.0 / 257.0);
        cv::multiply(reference, cv::Scalar(gainsRgb[2], gainsRgb[1], gainsRgb[0]), reference);
        reference.convertTo(reference, CV_8UC3);
        const std::string name = "img" + std::to_string(i);
        StereoImagePairFileIO::writeLossless(dir / "raw" / (name + ".png"), raw);
        cv::imwrite((dir / "whoi" / (name + ".png")).string(), reference);
    }
    writeConfigFile(test::scorpionSample(), dir / "site.xml");
    const std::string exe = AVATAR_LIGHTFIT_EXECUTABLE;
    const std::string cmd = exe + " --raw-set " + (dir / "raw").string() + " --corrected-set " +
                            (dir / "whoi").string() + " --out " + (dir / "site.xml").string() + " --report " +
                            (dir / "report.json").string();
    ASSERT_EQ(run(cmd + " > " + (dir / "out.txt").string() + " 2>&1"), 0) << slurp(dir / "out.txt");
    const AvatarConfig site = readConfigFile(dir / "site.xml");
    EXPECT_TRUE(site.lighting.frameAverageEnabled);
    EXPECT_FALSE(site.lighting.patternEnabled);
    for (std::size_t k = 0; k < 3; ++k) EXPECT_NEAR(site.lighting.gainsRgb[k] / gainsRgb[k], 1.0, 0.002) << k;
    const nlohmann::json j = nlohmann::json::parse(slurp(dir / "report.json"));
    EXPECT_EQ(j["gain_pairs"].size(), 3u);
    EXPECT_EQ(j["gains_rgb"][0].get<double>(), site.lighting.gainsRgb[0]);
    EXPECT_NE(slurp(dir / "out.txt").find("frame-average gains (R G B) from 3 image pair(s)"), std::string::npos);

    // A set that is not there, and a raw image without its reference, are named.
    ASSERT_EQ(run(exe + " --raw-set " + (dir / "nothing").string() + " --corrected-set " + (dir / "whoi").string() +
                  " --report " + (dir / "r.json").string() + " > /dev/null 2> " + (dir / "err.txt").string()),
              1);
    EXPECT_NE(slurp(dir / "err.txt").find("the raw image set " + (dir / "nothing").string() + " does not exist"),
              std::string::npos)
        << slurp(dir / "err.txt");
    cv::imwrite((dir / "raw" / "img9.png").string(), cv::Mat(480, 640, CV_8UC3, cv::Scalar(1, 2, 3)));
    ASSERT_EQ(run(cmd + " > /dev/null 2> " + (dir / "err.txt").string()), 1);
    EXPECT_NE(slurp(dir / "err.txt").find("the raw image " + (dir / "raw" / "img9.png").string() +
                                          " has no corrected image named img9.* in " + (dir / "whoi").string()),
              std::string::npos)
        << slurp(dir / "err.txt");
}

// What a user gets wrong, and the message and exit status for each.
TEST(LightFitTool, ErrorsNameTheInputAndUsageExitsTwo) {
    test::TempDir dir("lightfit");
    const Synthetic s = synthesize(4);
    const fs::path image = dir / "image.png", pairs = dir / "pairs.csv", config = dir / "site.xml";
    StereoImagePairFileIO::writeLossless(image, s.image.bgr);
    writeFile(pairs, pairsCsv(s.pairs));
    writeConfigFile(test::scorpionSample(), config);
    const std::string exe = AVATAR_LIGHTFIT_EXECUTABLE;
    const std::string err = (dir / "err.txt").string();
    const auto fails = [&](const std::string& args, int status, const std::string& message) {
        SCOPED_TRACE(args);
        EXPECT_EQ(run(exe + " " + args + " > /dev/null 2> " + err), status);
        EXPECT_NE(slurp(err).find(message), std::string::npos) << slurp(err);
    };
    const std::string base = "--image " + image.string() + " --pairs ";

    // A centre outside the image (negative) is fine; the report has it.
    ASSERT_EQ(run(exe + " " + base + pairs.string() + " --bit-depth 12 --centre -20 480 --report " +
                  (dir / "r.json").string() + " > /dev/null"),
              0);
    const nlohmann::json j = nlohmann::json::parse(slurp(dir / "r.json"));
    EXPECT_EQ(j["centre_px"][0].get<double>(), -20.0);

    fails(base + (dir / "missing.csv").string() + " --out " + config.string(), 1,
          "pairs file " + (dir / "missing.csv").string() + ": cannot be opened");
    const std::string report = " --report " + (dir / "r.json").string();
    fails("--image " + (dir / "missing.png").string() + " --pairs " + pairs.string() + report, 1,
          (dir / "missing.png").string());
    fails(base + pairs.string() + " --out " + (dir / "none.xml").string(), 1,
          (dir / "none.xml").string());
    writeFile(dir / "bad.csv", "light_x,light_y,dark_x,dark_y\n700,430,900,500\n700,x,900,600\n");
    fails(base + (dir / "bad.csv").string() + " --report " + (dir / "r.json").string(), 1,
          (dir / "bad.csv").string() + ":3: field 2 is not a finite number: 'x'");
    writeFile(dir / "outside.csv", "# picked\n700,430,900,500\n\n700,430,1500,20\n");
    fails(base + (dir / "outside.csv").string() + " --report " + (dir / "r.json").string(), 1,
          (dir / "outside.csv").string() + ":4: the dark point (1500, 20) lies outside the 1280x960 image");
    writeFile(dir / "one.csv", "700,430,900,500\n");
    fails(base + (dir / "one.csv").string() + " --report " + (dir / "r.json").string(), 1,
          "pairs file " + (dir / "one.csv").string() + " holds 1 point pair; the falloff needs at least 2");
    cv::Mat black = s.image.bgr.clone();
    black(cv::Rect(0, 0, 30, 30)).setTo(cv::Scalar(0, 0, 0));
    StereoImagePairFileIO::writeLossless(dir / "black.png", black);
    writeFile(dir / "black.csv", "700,430,900,500\n700,430,12,12\n");
    writeFile(dir / "small.csv", "300,200,500,400\n300,200,100,50\n");
    fails("--image " + (dir / "black.png").string() + " --pairs " + (dir / "black.csv").string() + report,
          1, (dir / "black.csv").string() + ":2: the dark point (12, 12) is black in blue");
    cv::Mat smaller;
    cv::resize(s.image.bgr, smaller, cv::Size(640, 480));
    StereoImagePairFileIO::writeLossless(dir / "small.png", smaller);
    fails("--image " + (dir / "small.png").string() + " --pairs " + (dir / "small.csv").string() + " --out " +
              config.string() + " --template " + (dir / "t.tiff").string(),
          1,
          "the template would be 640x480 (the image's size) but the cameras of " + config.string() +
              " deliver 1280x960");

    fails("--out " + config.string(), 2, "nothing to do");
    fails(base + pairs.string(), 2, "nothing to write");
    fails("--raw-set " + dir.path().string() + " --out " + config.string(), 2,
          "give both --raw-set and --corrected-set");
    fails("--pairs " + pairs.string() + " --out " + config.string(), 2, "give exactly one of --image and --session");
    fails(base + pairs.string() + " --centre 1 --out " + config.string(), 2, "--centre takes two numbers X Y");
    fails(base + pairs.string() + " --frobnicate", 2, "frobnicate");
    EXPECT_EQ(run(exe + " --help > " + err), 0);
    EXPECT_NE(slurp(err).find("Exit status: 0 done, 1 an input cannot be used"), std::string::npos);
    // --pick (built with OpenCV's highgui) without a display it can reach.
    if (slurp(err).find("--pick") != std::string::npos) {
        EXPECT_EQ(run("env -u DISPLAY -u WAYLAND_DISPLAY " + exe + " " + base + (dir / "new.csv").string() +
                      " --pick --report " + (dir / "r.json").string() + " > /dev/null 2> " + err),
                  1);
        EXPECT_NE(slurp(err).find("--pick needs a display"), std::string::npos) << slurp(err);
        EXPECT_EQ(run("env -u WAYLAND_DISPLAY DISPLAY=:4321 " + exe + " " + base + (dir / "new.csv").string() +
                      " --pick --report " + (dir / "r.json").string() + " > /dev/null 2> " + err),
                  1);
        EXPECT_NE(slurp(err).find("--pick cannot reach the display DISPLAY=:4321"), std::string::npos) << slurp(err);
        EXPECT_FALSE(fs::exists(dir / "new.csv"));
    }
    // The configuration was never touched by the failures.
    EXPECT_TRUE(readConfigFile(config) == test::scorpionSample());
}
