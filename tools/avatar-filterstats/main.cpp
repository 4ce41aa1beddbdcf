// avatar-filterstats: colour statistics of labelled target and background
// samples and a proposed target type whose filter separates them (replaces
// the thesis's MATLAB filter tool, 3.3.1-3.3.2). User guide:
// docs/tools/avatar-filterstats.md

#include "FilterStats.h"
#include "ToolImages.h"
#include "ToolMain.h"
#include "ToolProgress.h"

#include <avatar/common/Error.h>
#include <avatar/config/ConfigXml.h>

#include <boost/program_options.hpp>
#include <nlohmann/json.hpp>

#include <array>
#include <cmath>
#include <iostream>
#include <sstream>
#include <string>

namespace po = boost::program_options;
using namespace avatar;
using nlohmann::json;

namespace {

json rangeJson(const Range& r) { return json::array({r.min, r.max}); }

json ratesJson(const filterstats::Rates& r) {
    return {{"true_positive_rate", r.truePositive}, {"false_positive_rate", r.falsePositive}};
}

json reportOf(const filterstats::Proposal& p, const tools::WorkingImage& image) {
    const TargetType& t = p.type;
    json ranges = {{"rg", rangeJson(t.redGreen)}, {"rb", rangeJson(t.redBlue)}, {"bg", rangeJson(t.blueGreen)},
                   {"brightness", t.brightness ? rangeJson(*t.brightness) : json::array({0.0, nullptr})}};
    json report = {{"name", t.name},
                   {"image", image.description},
                   {"method", t.filter == ColorFilterMethod::Hsv ? "hsv" : "rgb_ratio"},
                   {"why", p.why},
                   {"ranges", ranges},
                   {"true_positive_rate", p.rates.truePositive},
                   {"false_positive_rate", p.rates.falsePositive},
                   {"samples", {{"target", p.targetSamples}, {"background", p.backgroundSamples}}},
                   {"candidates",
                    {{"rgb_ratio", ratesJson(p.bestRatio)},
                     {"hsv", ratesJson(p.bestHsv)},
                     {"brightness_bands", p.bands ? ratesJson(*p.bands) : json(nullptr)}}},
                   {"min_area", t.area.min},
                   {"area_why", p.areaWhy},
                   {"target_feature_areas", p.targetAreas},
                   {"look_alike_areas", p.lookAlikeAreas}};
    if (t.veil)
        report["veil"] = {{"colour_rgb", t.veil->colourRgb}, {"max_share", t.veil->maxShare}, {"why", p.veilWhy}};
    else if (!p.veilWhy.empty())
        report["veil"] = {{"why", p.veilWhy}};
    if (t.water)
        report["water"] = {{"attenuation_per_m", t.water->attenuationPerM},
                           {"max_path_m", t.water->maxPathM},
                           {"why", p.waterWhy}};
    else if (!p.waterWhy.empty())
        report["water"] = {{"why", p.waterWhy}};
    if (t.filter == ColorFilterMethod::Hsv)
        report["hsv"] = {{"hue", rangeJson(t.hsv.hue)},
                         {"saturation", rangeJson(t.hsv.saturation)},
                         {"value", rangeJson(t.hsv.value)}};
    json bands = json::array();
    for (const BrightnessBand& b : t.brightnessBands)
        bands.push_back({{"brightness", rangeJson(b.brightness)},
                         {"rg", rangeJson(b.redGreen)},
                         {"rb", rangeJson(b.redBlue)},
                         {"bg", rangeJson(b.blueGreen)}});
    report["brightness_bands"] = bands;
    return report;
}

}  // namespace

int main(int argc, char** argv) {
    po::options_description options(
        "avatar-filterstats: colour statistics of target and background samples, and a proposed filter\n"
        "Usage: avatar-filterstats --image IMG --target-mask T.png --background-mask B.png --name NAME\n"
        "                          --out TARGET.xml --report REPORT.json --plots DIR\n\nOptions");
    // clang-format off
    options.add_options()
        ("help,h", "show this help");
    tools::addImageOptions(options, "the image: raw (docs/formats.md), 8/16-bit PNG or TIFF, or any 8-bit image file");
    options.add_options()
        ("config", po::value<std::string>(), "measure after this configuration's lighting correction, as the colour filter sees the image")
        ("target-mask", po::value<std::string>(), "8-bit image, non-zero = target sample")
        ("background-mask", po::value<std::string>(), "8-bit image, non-zero = background sample")
        ("target-polygon", po::value<std::string>(), "instead of --target-mask: 'x y' vertices, one per line")
        ("background-polygon", po::value<std::string>(), "instead of --background-mask: 'x y' vertices")
        ("target-points", po::value<std::string>(), "instead of --target-mask: picked points, 'x y' one per line")
        ("background-points", po::value<std::string>(), "instead of --background-mask: picked points")
        ("point-radius", po::value<int>()->default_value(0), "with --*-points: also take the pixels within this many px of each point")
        ("name", po::value<std::string>(), "the target type's name")
        ("out", po::value<std::string>(), "write the proposed <target> element here")
        ("merge-into", po::value<std::string>(), "also put it into this configuration (replacing a type of the same name)")
        ("report", po::value<std::string>(), "write the statistics and rates here (JSON)")
        ("plots", po::value<std::string>(), "write the scatter plots into this directory (rg.png, rb.png, bg.png, hue.png)")
        ("fp-weight", po::value<double>()->default_value(10.0), "a false positive costs this many true positives when choosing")
        ("veil", po::value<std::string>(), "the site's haze backscatter colour 'R G B' (docs/config.md): propose the largest share of it the background allows")
        ("water", po::value<std::string>(), "the site's murkiest water 'kR kG kB' per metre of light path (docs/config.md): propose the longest path of it the background allows")
        ("water-path", po::value<double>()->default_value(5.0), "with --water: the longest light path to consider, m (lamp -> target -> camera)")
        ("log", po::value<std::string>()->default_value("warn"), "log priority");
    // clang-format on
    return tools::runTool("avatar-filterstats", tools::HelpHint::Short, [&] {
        const po::variables_map vm = tools::parseCommandLine(argc, argv, options);
        if (vm.count("help")) return tools::printHelp(options, tools::kInputExitStatus);
        const auto need = [&](const char* a, const char* b, const char* c = "") {
            return vm.count(a) + vm.count(b) + (*c != 0 ? vm.count(c) : 0) == 1;
        };
        if (!need("image", "session")) throw tools::UsageError("give exactly one of --image and --session");
        if (!need("target-mask", "target-polygon", "target-points"))
            throw tools::UsageError("give exactly one of --target-mask, --target-polygon and --target-points");
        if (!need("background-mask", "background-polygon", "background-points"))
            throw tools::UsageError(
                "give exactly one of --background-mask, --background-polygon and --background-points");
        if (!vm.count("name")) throw tools::UsageError("--name is required");
        if (!vm.count("out") && !vm.count("report") && !vm.count("merge-into"))
            throw tools::UsageError("nothing to write: give --out, --report or --merge-into");

        tools::configureLogging(vm);
        tools::WorkingImage image = tools::imageFromOptions(vm, tools::kForColourFilter);
        if (vm.count("config")) {
            const std::filesystem::path file = vm["config"].as<std::string>();
            tools::correctLighting(image, readConfigFile(file), file.parent_path());
        }
        const cv::Size size = image.bgr.size();
        const int radius = vm["point-radius"].as<int>();
        const auto sample = [&](const std::string& which) {
            if (vm.count(which + "-mask")) return filterstats::loadMask(vm[which + "-mask"].as<std::string>(), size);
            if (vm.count(which + "-polygon"))
                return filterstats::polygonMask(vm[which + "-polygon"].as<std::string>(), size);
            return filterstats::pointsMask(vm[which + "-points"].as<std::string>(), size, radius);
        };
        const cv::Mat target = sample("target");
        const cv::Mat background = sample("background");
        filterstats::Options o;
        o.name = vm["name"].as<std::string>();
        o.falsePositiveWeight = vm["fp-weight"].as<double>();
        if (!(o.falsePositiveWeight >= 0.0)) throw InvalidArgument("--fp-weight must be >= 0");
        if (vm.count("veil")) {
            const std::string text = vm["veil"].as<std::string>();
            std::istringstream in(text);
            std::array<double, 3> v{};
            std::string rest;
            if (!(in >> v[0] >> v[1] >> v[2]) || (in >> rest) || !(v[0] >= 0.0 && v[2] >= 0.0 && v[1] > 0.0) ||
                !std::isfinite(v[0]) || !std::isfinite(v[1]) || !std::isfinite(v[2]))
                throw tools::UsageError("--veil must be three numbers 'R G B', each >= 0 and G > 0, got '" + text + "'");
            o.veil = v;
        }
        if (vm.count("water")) {
            const std::string text = vm["water"].as<std::string>();
            std::istringstream in(text);
            std::array<double, 3> k{};
            std::string rest;
            const auto ok = [](double v) { return v >= 0.0 && v <= 1000.0; };
            if (!(in >> k[0] >> k[1] >> k[2]) || (in >> rest) || !ok(k[0]) || !ok(k[1]) || !ok(k[2]))
                throw tools::UsageError("--water must be three numbers 'kR kG kB', each 0..1000 per m, got '" + text +
                                        "'");
            o.water = k;
            o.waterPathM = vm["water-path"].as<double>();
            if (!(o.waterPathM > 0.0 && o.waterPathM <= 1000.0))
                throw tools::UsageError("--water-path must be above 0 and at most 1000 m, got " +
                                        std::to_string(o.waterPathM));
        }
        tools::Progress progress("candidate filters", 0);
        o.progress = progress.reporter();
        const filterstats::Proposal p = filterstats::propose(image, target, background, o);
        progress.clear();
        const std::string xml = writeTargetString(p.type);  // validates the proposal
        if (vm.count("out")) tools::writeText(vm["out"].as<std::string>(), xml, "target element");
        if (vm.count("merge-into")) {
            const std::string path = vm["merge-into"].as<std::string>();
            AvatarConfig config = readConfigFile(path);
            bool replaced = false;
            for (TargetType& t : config.targets.targets)
                if (t.name == p.type.name) {
                    TargetType merged = p.type;
                    merged.window = t.window;  // where to look stays the site's choice
                    merged.shape = t.shape;
                    merged.erodeRestore = t.erodeRestore;
                    merged.erodeKernelSize = t.erodeKernelSize;
                    t = merged;
                    replaced = true;
                }
            if (!replaced) config.targets.targets.push_back(p.type);
            writeConfigFile(config, path);
            std::cout << (replaced ? "replaced" : "added") << " target type '" << p.type.name << "' in " << path << "\n";
        }
        if (vm.count("report")) tools::writeText(vm["report"].as<std::string>(), reportOf(p, image).dump(2) + "\n", "report");
        if (vm.count("plots")) filterstats::writePlots(vm["plots"].as<std::string>(), image, target, background, p);
        std::cout << p.type.name << ": " << p.why << "\n"
                  << "on the samples: true positives " << p.rates.truePositive * 100 << " % of "
                  << p.targetSamples << ", false positives " << p.rates.falsePositive * 100 << " % of "
                  << p.backgroundSamples << "\nminimum area " << p.type.area.min << " px: " << p.areaWhy << "\n";
        if (!p.veilWhy.empty()) std::cout << p.veilWhy << "\n";
        if (!p.waterWhy.empty()) std::cout << p.waterWhy << "\n";
        return 0;
    });
}
