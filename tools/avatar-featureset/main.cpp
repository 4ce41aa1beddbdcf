// avatar-featureset: lets the cameras' automatic exposure, gain and white
// balance settle, checks that they are stable, reads the values back, switches
// the cameras to manual with those values and stores them as the feature set
// of the configuration (thesis 4.2.4, 4.5.1). A camera that lacks a feature is
// reported by name, not an error. User guide: docs/tools/avatar-featureset.md

#include "CameraTools.h"
#include "ToolMain.h"
#include "ToolProgress.h"
#include "FeatureSet.h"

#include <avatar/acquire/AcquisitionBackends.h>
#include <avatar/common/Error.h>
#include <avatar/config/ConfigXml.h>

#include <boost/program_options.hpp>
#include <nlohmann/json.hpp>

#include <algorithm>
#include <cmath>
#include <iostream>
#include <optional>
#include <sstream>
#include <string>
#include <vector>

namespace po = boost::program_options;
using namespace avatar;
using namespace avatar::tools;
using nlohmann::json;

namespace {

std::string number(double v) {
    std::ostringstream os;
    os.precision(10);
    os << v;
    return os.str();
}

std::vector<std::string> split(const std::string& list) {
    std::vector<std::string> out;
    std::stringstream in(list);
    for (std::string item; std::getline(in, item, ',');)
        if (!item.empty()) out.push_back(item);
    return out;
}

std::string describeValue(const std::string& name, double value, double redV) {
    return name == "whiteBalance" ? number(value) + "/" + number(redV) + " (blue/U / red/V)" : number(value);
}

int run(const po::variables_map& vm) {
    BackendRequest request = backendRequest(vm);
    requireBackendOptions(request, true);
    featureset::Options options;
    options.features = split(vm["features"].as<std::string>());
    options.tolerance = vm["tolerance"].as<double>();
    options.stableReads = vm["stable-reads"].as<int>();
    options.poll = std::chrono::milliseconds(vm["poll-ms"].as<int>());
    options.timeout = std::chrono::duration<double>(vm["settle-timeout"].as<double>());
    try {
        options.validate();
    } catch (const InvalidArgument& e) {
        throw UsageError(std::string("--") + e.what());
    }
    const bool dryRun = vm.count("dry-run") > 0;
    std::optional<std::filesystem::path> out;
    if (vm.count("out")) out = vm["out"].as<std::string>();
    else if (request.config) out = *request.config;
    if (!out && !dryRun) throw UsageError("--out FILE is needed: there is no --config to write the feature set back into");
    configureLogging(vm);

    Backend backend = makeBackend(request);
    AcquireStereoImagePair& acquisition = *backend.acquisition;
    acquisition.applyConfig(backend.config);  // firewire starts here

    Progress progress("stable reads", static_cast<std::size_t>(options.stableReads));
    options.progress = [&](int least, int reads) {
        progress.update(static_cast<std::size_t>(least), std::to_string(reads) + " reads");
    };
    const featureset::Result result = featureset::run(acquisition, backend.config, options);
    progress.clear();

    // ---- say it
    for (const std::string& n : result.notApplicable) std::cout << n << "\n";
    if (result.settleNeeded)
        std::cout << "settled after " << number(std::round(result.settledS * 100.0) / 100.0) << " s (" << result.reads
                  << " reads, " << result.pairs << " pairs grabbed meanwhile)\n";
    else
        std::cout << "no camera adjusts any of the features itself: their current values are kept\n";
    const std::array<Side, 2> sides{Side::Left, Side::Right};
    const auto camera = [&](std::size_t i) {
        return std::string(i == 0 ? "left" : "right") + " camera" +
               (result.cameraIds[i].empty() ? "" : " " + result.cameraIds[i]);
    };
    json features = json::array();
    json missing = json::array();
    std::size_t stored = 0;
    for (const featureset::FeatureResult& f : result.features) {
        std::string line = f.name + ":";
        json cameras = json::array();
        for (std::size_t i = 0; i < sides.size(); ++i) {
            const FeatureReading& r = f.reading[i];
            const featureset::Mode mode = f.mode[i];
            line += std::string(i == 0 ? " " : ", ") + camera(i) + " ";
            if (mode == featureset::Mode::Missing) {
                line += "MISSING (" + r.note + ")";
                missing.push_back({{"feature", f.name},
                                   {"side", i == 0 ? "left" : "right"},
                                   {"camera", result.cameraIds[i]},
                                   {"note", r.note}});
            } else {
                line += describeValue(f.name, r.value, r.redV) + " (" + toString(mode) +
                        (mode == featureset::Mode::Automatic && f.settledAfterS
                             ? ", stable from " + number(std::round(*f.settledAfterS * 100.0) / 100.0) + " s"
                             : std::string()) +
                        ")";
            }
            json c = {{"side", i == 0 ? "left" : "right"},
                      {"camera", result.cameraIds[i]},
                      {"present", r.present},
                      {"auto_available", r.autoAvailable},
                      {"mode", toString(mode)},
                      {"value", r.value},
                      {"note", r.note},
                      {"verified", f.verified[i] ? json(*f.verified[i]) : json(nullptr)}};
            if (f.name == "whiteBalance") c["red_v"] = r.redV;
            if (!f.verifyNote[i].empty()) c["verify_note"] = f.verifyNote[i];
            cameras.push_back(c);
        }
        json storedJson = nullptr;
        if (f.stored) {
            ++stored;
            line += " -> stored " + describeValue(f.name, f.value, f.redV) + ", manual";
            storedJson = {{"value", f.value}, {"auto", false}};
            if (f.name == "whiteBalance") storedJson = {{"blue_u", f.value}, {"red_v", f.redV}, {"auto", false}};
        } else {
            line += " -> not stored: no camera has it (the configuration keeps its value)";
        }
        std::cout << line << "\n";
        features.push_back({{"name", f.name},
                            {"stored", storedJson},
                            {"settled_after_s", f.settledAfterS ? json(*f.settledAfterS) : json(nullptr)},
                            {"cameras", cameras}});
    }
    json report = {{"backend", request.name},
                   {"config", backend.configSource},
                   {"features", features},
                   {"missing", missing},
                   {"not_applicable", result.notApplicable},
                   {"settle",
                    {{"needed", result.settleNeeded},
                     {"seconds", result.settledS},
                     {"reads", result.reads},
                     {"poll_ms", options.poll.count()},
                     {"tolerance", options.tolerance},
                     {"stable_reads", options.stableReads},
                     {"timeout_s", options.timeout.count()}}},
                   {"pairs_grabbed", result.pairs},
                   {"pair_failures", result.pairFailures},
                   {"mismatches", result.mismatches},
                   {"written", false}};
    if (out) report["out"] = out->string();
    const auto writeReport = [&] {
        if (vm.count("report")) writeText(vm["report"].as<std::string>(), report.dump(2) + "\n", "the report");
    };
    if (!result.mismatches.empty()) {
        writeReport();
        std::string all;
        for (const auto& m : result.mismatches) all += (all.empty() ? "" : "; ") + m;
        throw AcquisitionError("the cameras did not keep the values after switching to manual: " + all +
                               "; the configuration was not written");
    }
    std::cout << stored << " of " << result.features.size() << " feature(s) stored";
    if (!missing.empty()) std::cout << "; " << missing.size() << " missing on a camera (named above; not an error)";
    std::cout << "\n";
    if (!dryRun) {
        writeConfigFile(result.config, *out);
        report["written"] = true;
        std::cout << "feature set written to " << out->string() << " (the rest of the configuration unchanged)\n";
    } else {
        std::cout << "dry run: nothing written\n";
    }
    writeReport();
    return 0;
}

}  // namespace

int main(int argc, char** argv) {
    po::options_description options(
        "avatar-featureset: let the cameras' automatic exposure, gain and white balance settle, read the values\n"
        "back, switch the cameras to manual with them and store them in the configuration's <camera><features>\n"
        "Usage: avatar-featureset --backend NAME --config FILE [--out FILE] [--features LIST] [--report FILE]\n\n"
        "Options");
    // clang-format off
    options.add_options()("help,h", "show this help");
    addBackendOptions(options);
    options.add_options()
        ("features", po::value<std::string>()->default_value("exposure,gain,whiteBalance"),
            "the features to let the cameras adjust, comma-separated: exposure, shutter, gain, whiteBalance, "
            "brightness, gamma")
        ("tolerance", po::value<double>()->default_value(0.01),
            "a value is stable when it changes by at most this fraction from one read to the next")
        ("stable-reads", po::value<int>()->default_value(5), "consecutive stable reads that make a value settled")
        ("poll-ms", po::value<int>()->default_value(200), "pause between reads, ms")
        ("settle-timeout", po::value<double>()->default_value(30.0), "give up when the values have not settled after this many s")
        ("out,o", po::value<std::string>(), "write the configuration here (default: back into --config)")
        ("dry-run", "settle and report, but write no configuration")
        ("report,r", po::value<std::string>(), "write a JSON report here")
        ("log", po::value<std::string>()->default_value("warn"), "log priority: debug, info, notice, warn, error")
        ("log-config", po::value<std::string>(), "log4cpp property file (instead of --log)");
    // clang-format on
    return runTool("avatar-featureset", HelpHint::WithName, [&] {
        const po::variables_map vm = parseCommandLine(argc, argv, options);
        if (vm.count("help"))
            return printHelp(
                options, backendHelp() +
                    "\nExit status: 0 the feature set is stored (features a camera lacks are reported, not an error);\n"
                    "1 a camera, file or value at fault, the values did not settle, or a camera did not keep them\n"
                    "(the message names it; nothing is written); 2 usage.\n");
        return run(vm);
    });
}
