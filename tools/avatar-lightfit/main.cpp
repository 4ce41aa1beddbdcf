// avatar-lightfit: the lighting correction's offline step (thesis 3.2): the
// strobe falloff c * exp(e * d) per channel fitted to light/dark point pairs
// (Figures 3-3, 3-4; the thesis fitted it in a spreadsheet) and the
// frame-average gains of a raw and a corrected image set (Figure 3-2),
// written into a configuration's <lighting>. User guide:
// docs/tools/avatar-lightfit.md

#include "LightFit.h"
#include "ToolImages.h"
#include "ToolMain.h"
#include "ToolProgress.h"
#ifdef AVATAR_LIGHTFIT_PICK
#include "Pick.h"
#endif

#include <avatar/analyze/LightingCorrection.h>
#include <avatar/common/Error.h>
#include <avatar/common/Logging.h>
#include <avatar/config/ConfigXml.h>

#include <boost/program_options.hpp>
#include <log4cpp/Category.hh>
#include <nlohmann/json.hpp>

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <iomanip>
#include <iostream>
#include <sstream>
#include <string>
#include <vector>

namespace po = boost::program_options;
namespace fs = std::filesystem;
using namespace avatar;
using nlohmann::json;

namespace {

constexpr const char* kChannelNames[3] = {"red", "green", "blue"};

/// "--centre X Y" with two numbers (negative ones too, which the option parser
/// would take for options) becomes "--centre=X,Y".
std::vector<std::string> joinCentre(int argc, char** argv) {
    const auto number = [](const std::string& s) {
        char* end = nullptr;
        std::strtod(s.c_str(), &end);
        return !s.empty() && *end == '\0';
    };
    std::vector<std::string> args(argv, argv + argc);
    std::vector<std::string> out;
    for (std::size_t i = 0; i < args.size(); ++i) {
        if (args[i] == "--centre" && i + 2 < args.size() && number(args[i + 1]) && number(args[i + 2])) {
            out.push_back("--centre=" + args[i + 1] + "," + args[i + 2]);
            i += 2;
        } else {
            out.push_back(args[i]);
        }
    }
    return out;
}

/// "X,Y" -> the point; nullopt when it is not two finite numbers.
std::optional<cv::Point2d> parseCentre(const std::string& text) {
    std::string s = text;
    std::replace(s.begin(), s.end(), ',', ' ');
    std::istringstream in(s);
    double x = 0, y = 0;
    std::string rest;
    if (!(in >> x >> y) || (in >> rest) || !std::isfinite(x) || !std::isfinite(y)) return std::nullopt;
    return cv::Point2d(x, y);
}

json finite(double v) { return std::isfinite(v) ? json(v) : json(nullptr); }
json rgbJson(const std::array<double, 3>& a) { return json::array({a[0], a[1], a[2]}); }

json reportOf(const lightfit::Fit& fit) {
    json channels;
    for (std::size_t k = 0; k < 3; ++k) {
        const lightfit::ChannelFit& f = fit.rgb[k];
        channels[kChannelNames[k]] = {{"coefficient", f.coefficient},
                                      {"exponent", f.exponent},
                                      {"coefficient_std", finite(f.coefficientStd)},
                                      {"exponent_std", finite(f.exponentStd)},
                                      {"rms_residual", f.rmsResidual},
                                      {"max_residual", f.maxAbsResidual},
                                      {"scatter_over_noise", finite(f.scatterOverNoise)},
                                      {"residuals", f.residuals},
                                      {"unity_distance_px", finite(f.unityDistancePx)},
                                      {"log_linear", {{"coefficient", f.logLinearCoefficient},
                                                      {"exponent", f.logLinearExponent}}},
                                      {"iterations", f.iterations}};
    }
    json samples = json::array();
    for (std::size_t i = 0; i < fit.samples.size(); ++i) {
        const lightfit::Sample& s = fit.samples[i];
        samples.push_back({{"line", s.pair.line},
                           {"light_px", {s.pair.light.x, s.pair.light.y}},
                           {"dark_px", {s.pair.dark.x, s.pair.dark.y}},
                           {"d_light_px", s.dLightPx},
                           {"d_dark_px", s.dDarkPx},
                           {"light_rgb", {s.lightBgr[2], s.lightBgr[1], s.lightBgr[0]}},
                           {"dark_rgb", {s.darkBgr[2], s.darkBgr[1], s.darkBgr[0]}},
                           {"ratio_rgb", rgbJson(s.ratioRgb)},
                           {"ratio_std_rgb", rgbJson(s.ratioStdRgb)},
                           {"saturated", s.saturated},
                           {"suspect", s.suspect}});
    }
    return {{"model", lightfit::toString(fit.model)},
            {"centre_px", {fit.centre.x, fit.centre.y}},
            {"patch", fit.patch},
            {"weighted", fit.weighted},
            {"image_size", {fit.imageSize.width, fit.imageSize.height}},
            {"points", fit.samples.size()},
            {"channels", channels},
            {"samples", samples}};
}

/// How the configuration refers to the template: relative to its directory
/// when the template lies inside it, else absolute.
std::string storedTemplatePath(const fs::path& configFile, const fs::path& templateFile) {
    const fs::path dir = fs::absolute(configFile).parent_path().lexically_normal();
    const fs::path file = fs::absolute(templateFile).lexically_normal();
    const fs::path rel = file.lexically_relative(dir);
    if (!rel.empty() && *rel.begin() != "..") return rel.generic_string();
    return file.string();
}

std::string fixed(double v, int precision) {
    std::ostringstream s;
    s << std::setprecision(precision) << v;
    return s.str();
}

}  // namespace

int main(int argc, char** argv) {
    po::options_description options(
        "avatar-lightfit: the strobe falloff c*exp(e*d) fitted to light/dark point pairs, and frame-average\n"
        "gains, written into a configuration's <lighting> (thesis 3.2)\n"
        "Usage: avatar-lightfit --image IMG --pairs PAIRS.csv [--centre X Y] --out CONFIG.xml\n"
        "                       [--template FACTORS.tiff] [--report REPORT.json] [--plot FIT.png]\n"
        "       avatar-lightfit --raw-set DIR --corrected-set DIR --out CONFIG.xml [--report REPORT.json]\n\n"
        "Options");
    // clang-format off
    options.add_options()
        ("help,h", "show this help");
    tools::addImageOptions(options, "the uncorrected image the pairs were picked on: raw (docs/formats.md), "
                                    "8/16-bit PNG or TIFF, or any 8-bit image file");
    options.add_options()
        ("pairs", po::value<std::string>(), "CSV of point pairs, one 'light_x,light_y,dark_x,dark_y' per line ('#' comments)")
#ifdef AVATAR_LIGHTFIT_PICK
        ("pick", "pick the pairs on the image in a window first, and save them to --pairs")
#endif
        ("patch", po::value<int>()->default_value(5), "sample each point as the mean of an N x N patch (odd)")
        ("centre", po::value<std::string>(), "X Y: the centre of the light pattern in px (default: the image centre)")
        ("model", po::value<std::string>()->default_value("thesis"), "thesis: ratio = c*exp(e*d_dark); paired: ratio = exp(e*(d_dark - d_light)), for light points at different distances")
        ("unweighted", "weigh every pair alike (default: by the noise of its patches)")
        ("raw-set", po::value<std::string>(), "frame-average gains: the raw images (a directory, or one image)")
        ("corrected-set", po::value<std::string>(), "their corrected references (a directory with the same file names, or one image)")
        ("out", po::value<std::string>(), "the configuration to write <lighting> into (must exist; the rest is kept)")
        ("template", po::value<std::string>(), "also write the per-pixel factors as a 32-bit float TIFF and make the configuration use it")
        ("report", po::value<std::string>(), "write the coefficients, standard errors, residuals and gains here (JSON)")
        ("plot", po::value<std::string>(), "write the data ratios and the fitted curves here (PNG)")
        ("log", po::value<std::string>()->default_value("warn"), "log priority: debug, info, notice, warn, error");
    // clang-format on
    return tools::runTool("avatar-lightfit", tools::HelpHint::Short, [&] {
        const std::vector<std::string> args = joinCentre(argc, argv);
        std::vector<const char*> argp;
        for (const std::string& a : args) argp.push_back(a.c_str());
        const po::variables_map vm = tools::parseCommandLine(static_cast<int>(argp.size()), argp.data(), options);
        if (vm.count("help")) return tools::printHelp(options, tools::kInputExitStatus);
        const bool fitting = vm.count("pairs") != 0;
        const bool gains = vm.count("raw-set") + vm.count("corrected-set") > 0;
        const bool pick = vm.count("pick") != 0;
        std::optional<cv::Point2d> centre;
        if (vm.count("centre") && !(centre = parseCentre(vm["centre"].as<std::string>())))
            throw tools::UsageError("--centre takes two numbers X Y, got '" + vm["centre"].as<std::string>() + "'");
        if (!fitting && !gains)
            throw tools::UsageError(
                "nothing to do: give --pairs (the falloff) or --raw-set and --corrected-set (the gains)");
        if (gains && vm.count("raw-set") + vm.count("corrected-set") != 2)
            throw tools::UsageError("give both --raw-set and --corrected-set");
        if (fitting && vm.count("image") + vm.count("session") != 1)
            throw tools::UsageError("give exactly one of --image and --session: the image the pairs were picked on");
        if (!fitting && (vm.count("image") || vm.count("session") || pick))
            throw tools::UsageError("--image, --session and --pick go with --pairs");
        if (!fitting && (vm.count("template") || vm.count("plot")))
            throw tools::UsageError("--template and --plot need the falloff: give --pairs");
        if (!vm.count("out") && !vm.count("template") && !vm.count("report") && !vm.count("plot"))
            throw tools::UsageError("nothing to write: give --out, --template, --report or --plot");

        tools::configureLogging(vm);
        log4cpp::Category& log = logging::category("lightfit");
        json report;
        std::optional<lightfit::Fit> fit;
        cv::Size imageSize;
        // Read the configuration first: a missing one should not cost the work.
        std::optional<AvatarConfig> config;
        if (vm.count("out")) {
            try {
                config = readConfigFile(vm["out"].as<std::string>());
            } catch (const IoError& e) {
                throw IoError(std::string(e.what()) +
                              " (avatar-lightfit writes <lighting> into an existing configuration; give one)");
            }
        }

        if (fitting) {
            const tools::WorkingImage image = tools::imageFromOptions(vm, tools::kForLightingCorrection);
            imageSize = image.bgr.size();
            const std::string pairsPath = vm["pairs"].as<std::string>();
            lightfit::Options o;
            o.patch = vm["patch"].as<int>();
            o.centre = centre;
            o.model = lightfit::parseModel(vm["model"].as<std::string>());
            o.weighted = vm.count("unweighted") == 0;
#ifdef AVATAR_LIGHTFIT_PICK
            if (pick) {
                std::vector<lightfit::PointPair> start;
                std::error_code ec;
                if (fs::exists(pairsPath, ec)) start = lightfit::readPairsFile(pairsPath);
                const cv::Point2d c = centre.value_or(cv::Point2d(imageSize.width / 2.0, imageSize.height / 2.0));
                lightfit::writePairsFile(pairsPath, lightfit::pickPairs(image, c, start));
            }
#endif
            const std::vector<lightfit::PointPair> pairs = lightfit::readPairsFile(pairsPath);
            fit = lightfit::fitFalloff(image, pairs, o, "pairs file " + pairsPath);
            report = reportOf(*fit);
            report["image"] = image.description;
            report["pairs_file"] = pairsPath;
        }

        std::optional<lightfit::Gains> g;
        if (gains) {
            std::optional<BayerPattern> bayer;
            if (vm.count("bayer")) bayer = parseBayerPattern(vm["bayer"].as<std::string>());
            tools::Progress progress("image pairs", 0);
            g = lightfit::frameAverageGainsOfSets(vm["raw-set"].as<std::string>(),
                                                  vm["corrected-set"].as<std::string>(), bayer, progress.reporter());
            progress.clear();
            json perPair = json::array();
            for (const lightfit::GainPair& p : g->pairs)
                perPair.push_back(
                    {{"raw", p.raw.string()}, {"corrected", p.corrected.string()}, {"gains_rgb", rgbJson(p.gainsRgb)}});
            report["gains_rgb"] = rgbJson(g->gainsRgb);
            report["gain_pairs"] = perPair;
        }

        std::string storedTemplate;
        if (vm.count("template")) {
            const std::string path = vm["template"].as<std::string>();
            if (config && (config->camera.width != imageSize.width || config->camera.height != imageSize.height))
                throw InvalidArgument("the template would be " + std::to_string(imageSize.width) + "x" +
                                      std::to_string(imageSize.height) + " (the image's size) but the cameras of " +
                                      vm["out"].as<std::string>() + " deliver " +
                                      std::to_string(config->camera.width) + "x" +
                                      std::to_string(config->camera.height) +
                                      "; fit on an image of the cameras' size");
            lightfit::writeTemplate(path, lightfit::patternTemplate(*fit, imageSize));
            storedTemplate = config ? storedTemplatePath(vm["out"].as<std::string>(), path) : path;
            report["template"] = path;
        }

        if (config) {
            const std::string path = vm["out"].as<std::string>();
            if (fit) {
                config->lighting = lightfit::withPattern(config->lighting, *fit, storedTemplate);
                if (config->camera.width != imageSize.width || config->camera.height != imageSize.height)
                    log.warnStream() << "the image is " << imageSize.width << "x" << imageSize.height
                                     << " but the cameras of " << path << " deliver " << config->camera.width << "x"
                                     << config->camera.height << ": check the pattern centre";
            }
            if (g) {
                config->lighting.frameAverageEnabled = true;
                config->lighting.gainsRgb = g->gainsRgb;
            }
            // The configuration as the vision system will load it: validated,
            // its template read and its factors built for the cameras' size.
            LightingCorrector check(config->lighting, fs::absolute(path).parent_path());
            check.prepare(cv::Size(config->camera.width, config->camera.height));
            const auto& stages = config->analysis.stages;
            if (std::find(stages.begin(), stages.end(), "lighting") == stages.end())
                log.warnStream() << path << ": the analysis stages hold no 'lighting' stage; the correction "
                                 << "written will not be applied";
            writeConfigFile(*config, path);
            report["config"] = path;
        }
        if (vm.count("report")) tools::writeText(vm["report"].as<std::string>(), report.dump(2) + "\n", "report");
        if (vm.count("plot")) lightfit::writePlot(vm["plot"].as<std::string>(), *fit);

        if (fit) {
            std::cout << "falloff c*exp(e*d) from " << fit->samples.size() << " pairs (" << toString(fit->model)
                      << " model, centre " << fit->centre.x << " " << fit->centre.y << ", " << fit->patch << "x"
                      << fit->patch << " patches):\n";
            for (std::size_t k = 0; k < 3; ++k) {
                const lightfit::ChannelFit& f = fit->rgb[k];
                std::cout << "  " << std::left << std::setw(6) << kChannelNames[k] << std::right
                          << "c = " << fixed(f.coefficient, 6) << " +- " << fixed(f.coefficientStd, 2)
                          << "  e = " << fixed(f.exponent, 6) << " +- " << fixed(f.exponentStd, 2)
                          << " /px  residuals rms " << fixed(f.rmsResidual, 3) << ", max "
                          << fixed(f.maxAbsResidual, 3);
                if (std::isfinite(f.scatterOverNoise))
                    std::cout << " (" << fixed(f.scatterOverNoise, 2) << " x the noise)";
                std::cout << "\n";
            }
            for (const lightfit::Sample& s : fit->samples)
                if (s.saturated || s.suspect)
                    std::cout << "  pair at line " << s.pair.line << ": "
                              << (s.saturated ? "a patch is clipped, its ratios are too small"
                                              : "far off the fit; are the two objects alike?")
                              << "\n";
        }
        if (g)
            std::cout << "frame-average gains (R G B) from " << g->pairs.size() << " image pair(s): "
                      << fixed(g->gainsRgb[0], 6) << " " << fixed(g->gainsRgb[1], 6) << " "
                      << fixed(g->gainsRgb[2], 6) << "\n";
        if (config) std::cout << "<lighting> written into " << vm["out"].as<std::string>() << "\n";
        return 0;
    });
}
