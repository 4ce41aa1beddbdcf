// avatar-camtest: finds the cameras of a backend, checks what the backend
// needs from the machine (driver, device permissions), grabs N pairs, saves
// them and reports the frame rate, dropped and failed frames and the
// left/right synchronisation (thesis 4.5.1). User guide: docs/tools/avatar-camtest.md

#include "CameraTools.h"
#include "ToolMain.h"
#include "ToolProgress.h"

#include <avatar/acquire/AcquireSIPGenICam.h>
#include <avatar/acquire/AcquisitionBackends.h>
#include <avatar/common/Error.h>
#include <avatar/config/ConfigXml.h>

#include <boost/program_options.hpp>
#include <nlohmann/json.hpp>

#include <algorithm>
#include <cctype>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <iostream>
#include <memory>
#include <optional>
#include <string>
#include <vector>

namespace po = boost::program_options;
using namespace avatar;
using namespace avatar::tools;
using nlohmann::json;

namespace {

/// One pair grabbed.
struct Grabbed {
    double wallS{0.0};  ///< when acquire() returned, seconds since the first attempt
    AcquisitionId id;
};

std::string fixed(double v, int decimals) {
    char text[64];
    std::snprintf(text, sizeof text, "%.*f", decimals, v);
    return text;
}

std::string lower(std::string s) {
    std::transform(s.begin(), s.end(), s.begin(), [](unsigned char c) { return static_cast<char>(std::tolower(c)); });
    return s;
}

json surveyJson(const BackendSurvey& s) {
    json checks = json::array();
    for (const BackendCheck& c : s.checks) checks.push_back({{"what", c.what}, {"ok", c.ok}, {"detail", c.detail}});
    json cameras = json::array();
    for (const CameraListing& c : s.cameras)
        cameras.push_back({{"id", c.id},
                           {"model", c.model},
                           {"address", c.address},
                           {"reachable", c.reachable},
                           {"detail", c.detail}});
    return {{"checks", checks}, {"cameras", cameras}, {"ok", s.ok()}};
}

void printSurvey(const BackendSurvey& s) {
    std::cout << "backend " << s.backend << ": " << s.cameras.size() << " camera(s)"
              << (s.ok() ? "" : ", PROBLEMS FOUND") << "\n";
    for (const BackendCheck& c : s.checks)
        std::cout << "  " << (c.ok ? "[ok]   " : "[FAIL] ") << c.what << ": " << c.detail << "\n";
    for (const CameraListing& c : s.cameras)
        std::cout << "  camera " << (c.id.empty() ? std::string("(no id)") : c.id) << "  "
                  << (c.model.empty() ? std::string("(model unknown)") : c.model)
                  << (c.address.empty() ? "" : "  " + c.address)
                  << (c.reachable ? "  reachable" : "  NOT REACHABLE") << (c.detail.empty() ? "" : "  (" + c.detail + ")")
                  << "\n";
}

/// Whether the survey lists the camera a configuration names (by id, address or serial).
bool listed(const BackendSurvey& s, const std::string& id) {
    for (const CameraListing& c : s.cameras)
        if (lower(c.id) == lower(id) || (!c.address.empty() && c.address == id) ||
            c.detail.find("serial " + id) != std::string::npos)
            return true;
    return false;
}

int run(const po::variables_map& vm) {
    BackendRequest request = backendRequest(vm);
    const bool listOnly = vm.count("list") > 0;
    requireBackendOptions(request, !listOnly);
    const std::size_t wanted = vm["pairs"].as<std::size_t>();
    if (wanted < 1 || wanted > 1000000) throw UsageError("--pairs must be 1..1000000, got " + std::to_string(wanted));
    const SaveFormat format = parseSaveFormat(vm["format"].as<std::string>());
    if (!vm["format"].defaulted() && !vm.count("out")) throw UsageError("--format needs --out DIR");
    const std::size_t maxFailures = vm["max-failures"].as<std::size_t>();
    configureLogging(vm);

    json report = {{"backend", request.name}};
    const auto finish = [&](int status) {
        if (vm.count("report")) writeText(vm["report"].as<std::string>(), report.dump(2) + "\n", "the report");
        return status;
    };

    // ---- what the backend can reach
    const BackendSurvey survey = surveyBackend(request);
    printSurvey(survey);
    report["survey"] = surveyJson(survey);
    if (listOnly) return finish(survey.ok() ? 0 : 1);

    const bool live = request.name == "firewire" || request.name == "genicam";
    if (live && request.config) {
        try {
            const AvatarConfig c = readConfigFile(*request.config);
            for (const auto& [side, id] : {std::pair<const char*, std::string>{"left", c.camera.leftCameraId},
                                           {"right", c.camera.rightCameraId}})
                std::cout << "configured " << side << " camera " << (id.empty() ? std::string("(none)") : id) << ": "
                          << (id.empty() ? "not set" : listed(survey, id) ? "found" : "NOT FOUND") << "\n";
        } catch (const Error&) {
            // makeBackend() reports a configuration it cannot read, naming it.
        }
    }

    // ---- start the backend
    Backend backend = makeBackend(request);
    AcquireStereoImagePair& acquisition = *backend.acquisition;
    acquisition.applyConfig(backend.config);  // firewire starts here; the others take the format
    std::unique_ptr<PairSaver> saver;
    if (vm.count("out"))
        saver = std::make_unique<PairSaver>(vm["out"].as<std::string>(), format, backend.config,
                                            vm["queue"].as<std::size_t>());

    // ---- grab
    std::cout << "grabbing " << wanted << " pair(s) from " << request.name << " (configuration: "
              << backend.configSource << ")" << std::endl;
    Progress progress("pairs", wanted);
    progress.update(0, "waiting for the first pair");
    std::vector<Grabbed> grabbed;
    std::vector<std::string> failures;
    std::string endReason;
    const auto start = std::chrono::steady_clock::now();
    std::size_t attempts = 0;
    while (grabbed.size() < wanted) {
        const AcquisitionStatus status = acquisition.status();
        if (status.state == AcquisitionStatus::State::Finished) {
            endReason = "the source has no more pairs (" + status.message + ")";
            break;
        }
        if (status.state == AcquisitionStatus::State::Failed) {
            endReason = "the backend failed: " + status.message;
            break;
        }
        if (failures.size() >= maxFailures) {
            endReason = std::to_string(failures.size()) + " failed attempts (--max-failures)";
            break;
        }
        ++attempts;
        try {
            AcquiredPair a = acquisition.acquire();
            Grabbed g;
            g.wallS = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
            g.id = a.pair.id();
            grabbed.push_back(g);
            if (saver) saver->save(a.pair);
            progress.update(grabbed.size(), a.pair.describe());
        } catch (const AcquisitionError& e) {
            failures.push_back(e.what());
            progress.line("attempt " + std::to_string(attempts) + " failed: " + e.what());
        }
    }
    progress.clear();
    const double elapsedS = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();

    // ---- what it measured
    const std::size_t n = grabbed.size();
    std::optional<double> rateHz;
    std::optional<double> captureRateHz;
    std::optional<double> nominalHz = request.frameRateHz;
    std::optional<std::int64_t> dropped;
    double syncMeanMs = 0.0;
    double syncMaxMs = 0.0;
    if (n >= 2) {
        const double wall = grabbed.back().wallS - grabbed.front().wallS;
        if (wall > 0.0) rateHz = static_cast<double>(n - 1) / wall;
        const double span = static_cast<double>(grabbed.back().id.left.timestampUs - grabbed.front().id.left.timestampUs);
        if (span > 0.0) captureRateHz = static_cast<double>(n - 1) * 1e6 / span;
        // Frames the cameras sent in the span of the pairs that did not become pairs: the span in frame
        // periods less the pairs' own intervals. Counted over the whole span, not gap by gap, so that a
        // frame received late (host reception times jitter on a loaded host) is not taken for a lost one.
        double period = 0.0;
        if (nominalHz) {
            period = 1e6 / *nominalHz;
        } else {
            std::vector<double> intervals;
            for (std::size_t i = 1; i < n; ++i)
                intervals.push_back(
                    static_cast<double>(grabbed[i].id.left.timestampUs - grabbed[i - 1].id.left.timestampUs));
            std::nth_element(intervals.begin(), intervals.begin() + static_cast<std::ptrdiff_t>(intervals.size() / 2),
                             intervals.end());
            period = intervals[intervals.size() / 2];  // the median interval
        }
        if (period > 0.0)
            dropped = std::max<std::int64_t>(0, std::llround(span / period) - static_cast<std::int64_t>(n - 1));
    }
    for (const Grabbed& g : grabbed) {
        const double ms = std::fabs(static_cast<double>(g.id.left.timestampUs - g.id.right.timestampUs)) / 1000.0;
        syncMeanMs += ms / static_cast<double>(std::max<std::size_t>(n, 1));
        syncMaxMs = std::max(syncMaxMs, ms);
    }
    json counters = json::object();
    if (const auto* genicam = dynamic_cast<const AcquireSIPGenICam*>(&acquisition)) {
        const GenICamStatistics s = genicam->statistics();
        counters = {{"incomplete_frames", {s.incompleteFrames[0], s.incompleteFrames[1]}},
                    {"unmatched_frames", {s.unmatchedFrames[0], s.unmatchedFrames[1]}},
                    {"camera_losses", s.cameraLosses},
                    {"reconnections", s.reconnections}};
    }
    SessionRecorderStatus saved;
    if (saver) {
        saver->flush();
        saved = saver->status();
    }

    // ---- say it
    std::cout << "grabbed " << n << " of " << wanted << " pair(s) in " << fixed(elapsedS, 2) << " s, "
              << failures.size() << " failed" << (endReason.empty() ? "" : "; stopped: " + endReason) << "\n";
    std::cout << "rate: " << (rateHz ? fixed(*rateHz, 2) + " pairs/s (wall clock)" : std::string("- (fewer than 2 pairs)"))
              << (captureRateHz ? ", " + fixed(*captureRateHz, 2) + " Hz (capture times)" : std::string())
              << (nominalHz ? ", " + fixed(*nominalHz, 2) + " Hz set" : std::string()) << "\n";
    std::cout << "dropped frames (from the capture times): "
              << (dropped ? std::to_string(*dropped) : std::string("-")) << "\n";
    std::cout << "left/right capture-time difference: mean " << fixed(syncMeanMs, 3) << " ms, max "
              << fixed(syncMaxMs, 3) << " ms\n";
    if (!counters.empty())
        std::cout << "genicam: incomplete frames left " << counters["incomplete_frames"][0] << ", right "
                  << counters["incomplete_frames"][1] << "; unmatched frames left " << counters["unmatched_frames"][0]
                  << ", right " << counters["unmatched_frames"][1] << "\n";
    if (saver) {
        std::cout << "saved " << saved.recorded << " pair(s) in " << saver->directory().string() << " ("
                  << toString(format) << ")";
        if (saved.unrecorded() > 0)
            std::cout << "; NOT saved: " << saved.unrecorded() << " (" << saved.dropped << " queue full, "
                      << saved.failed << " failed: " << saved.lastError << ")";
        std::cout << "\n";
        if (format != SaveFormat::Png)
            std::cout << "replay them: --backend replay --session " << saver->directory().string() << "\n";
    }

    json perPair = json::array();
    for (const Grabbed& g : grabbed)
        perPair.push_back({{"group", g.id.group},
                           {"member", g.id.member},
                           {"left_camera", g.id.left.cameraId},
                           {"right_camera", g.id.right.cameraId},
                           {"left_time_us", g.id.left.timestampUs},
                           {"right_time_us", g.id.right.timestampUs},
                           {"wall_s", g.wallS}});
    const auto optional = [](const auto& v) { return v ? json(*v) : json(nullptr); };
    report["config"] = backend.configSource;
    report["requested_pairs"] = wanted;
    report["pairs"] = n;
    report["attempts"] = attempts;
    report["failed"] = failures.size();
    report["failures"] = failures;
    report["end_reason"] = endReason;
    report["elapsed_s"] = elapsedS;
    report["rate_hz"] = optional(rateHz);
    report["capture_rate_hz"] = optional(captureRateHz);
    report["nominal_rate_hz"] = optional(nominalHz);
    report["dropped_frames"] = optional(dropped);
    report["sync_ms"] = {{"mean", syncMeanMs}, {"max", syncMaxMs}};
    report["backend_counters"] = counters;
    if (saver)
        report["saved"] = {{"directory", saver->directory().string()},
                           {"format", toString(format)},
                           {"pairs", saved.recorded},
                           {"dropped", saved.dropped},
                           {"failed", saved.failed},
                           {"last_error", saved.lastError}};
    report["per_pair"] = perPair;

    const bool allSaved = !saver || saved.recorded == n;
    if (n == wanted && failures.empty() && allSaved) return finish(0);
    std::string why;
    if (n < wanted) why = "only " + std::to_string(n) + " of " + std::to_string(wanted) + " pairs" +
                          (endReason.empty() ? "" : ": " + endReason);
    else if (!failures.empty()) why = std::to_string(failures.size()) + " attempt(s) failed, the last: " + failures.back();
    else why = std::to_string(n - saved.recorded) + " pair(s) not saved: " + saved.lastError;
    std::cerr << "avatar-camtest: " << why << "\n";
    return finish(1);
}

}  // namespace

int main(int argc, char** argv) {
    po::options_description options(
        "avatar-camtest: find the cameras of a backend, check the driver and permissions, grab pairs, save them and\n"
        "report the frame rate, dropped and failed frames\n"
        "Usage: avatar-camtest --backend NAME --list\n"
        "       avatar-camtest --backend NAME [--config FILE] --pairs N [--out DIR [--format F]] [--report FILE]\n\n"
        "Options");
    // clang-format off
    options.add_options()
        ("help,h", "show this help")
        ("list,l", "only list the cameras and check what the backend needs (exit 1 when a check fails)");
    addBackendOptions(options);
    options.add_options()
        ("pairs,n", po::value<std::size_t>()->default_value(10), "pairs to grab")
        ("max-failures", po::value<std::size_t>()->default_value(5), "stop after this many failed attempts")
        ("out,o", po::value<std::string>(), "save the pairs in this new directory")
        ("format,f", po::value<std::string>()->default_value("session"),
            "session: a session directory of raw files (the replay backend and avatar-calibrate --session read it); "
            "session-png: the same with 16-bit PNG files; png: left_NNNN.png, right_NNNN.png, the samples as acquired")
        ("queue", po::value<std::size_t>()->default_value(16), "pairs that may wait to be saved (1..1024)")
        ("report,r", po::value<std::string>(), "write a JSON report here")
        ("log", po::value<std::string>()->default_value("warn"), "log priority: debug, info, notice, warn, error")
        ("log-config", po::value<std::string>(), "log4cpp property file (instead of --log)");
    // clang-format on
    return runTool("avatar-camtest", HelpHint::WithName, [&] {
        const po::variables_map vm = parseCommandLine(argc, argv, options);
        if (vm.count("help"))
            return printHelp(
                options, backendHelp() +
                    "\nExit status: 0 all pairs grabbed and saved (--list: every check passed); 1 a camera, file or\n"
                    "check at fault (the message names it), or fewer pairs than asked; 2 usage.\n");
        return run(vm);
    });
}
