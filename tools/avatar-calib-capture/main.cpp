// avatar-calib-capture: grabs synchronized pairs, says for each whether the
// whole checkerboard is visible in both images, and saves the good ones in the
// layout avatar-calibrate reads (thesis 3.1.1, 4.5.1). User guide:
// docs/tools/avatar-calib-capture.md

#include "CameraTools.h"
#include "ToolMain.h"
#include "ToolProgress.h"

#include <avatar/acquire/AcquisitionBackends.h>
#include <avatar/analyze/StereoCalibration.h>
#include <avatar/common/Error.h>
#include <avatar/common/ImageUtils.h>

#include <boost/program_options.hpp>
#include <nlohmann/json.hpp>
#include <opencv2/calib3d.hpp>
#include <opencv2/core.hpp>
#include <opencv2/imgproc.hpp>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <iostream>
#include <optional>
#include <string>
#include <thread>
#include <vector>

namespace po = boost::program_options;
using namespace avatar;
using namespace avatar::tools;
using nlohmann::json;
using Clock = std::chrono::steady_clock;

namespace {

/// Coverage grid: cells across and down the image.
constexpr int kGridX = 8;
constexpr int kGridY = 6;

std::string fixed(double v, int decimals) {
    char text[64];
    std::snprintf(text, sizeof text, "%.*f", decimals, v);
    return text;
}

cv::Size parseBoard(const std::string& text) {
    const auto x = text.find('x');
    char* end = nullptr;
    const long w = x == std::string::npos ? 0 : std::strtol(text.c_str(), &end, 10);
    const bool widthOk = x != std::string::npos && end == text.c_str() + x;
    const long h = x == std::string::npos ? 0 : std::strtol(text.c_str() + x + 1, &end, 10);
    if (!widthOk || *end != '\0' || w < 2 || h < 2 || w > 100 || h > 100)
        throw UsageError("--board: expected the inner corners as COLUMNSxROWS, e.g. 9x6, got '" + text + "'");
    return {static_cast<int>(w), static_cast<int>(h)};
}

/// Mean distance between corresponding corners of two detections of the same board.
double meanShift(const std::vector<cv::Point2f>& a, const std::vector<cv::Point2f>& b) {
    double sum = 0.0;
    for (std::size_t i = 0; i < a.size() && i < b.size(); ++i) sum += std::hypot(a[i].x - b[i].x, a[i].y - b[i].y);
    return a.empty() ? 0.0 : sum / static_cast<double>(a.size());
}

/// OpenCV's quick test for a board (cv::checkChessboard, a few ms where a
/// full search of an image without a board takes most of a second): false
/// when the image surely shows no whole board.
bool mayShowBoard(const cv::Mat& image, cv::Size board, int bitDepth) {
    cv::Mat grey = image;
    if (image.channels() == 3) cv::cvtColor(image, grey, cv::COLOR_BGR2GRAY);
    if (grey.depth() == CV_16U) {
        cv::Mat eight;
        grey.convertTo(eight, CV_8U, 255.0 / ((1 << std::clamp(bitDepth, 1, 16)) - 1));
        grey = eight;
    }
    return cv::checkChessboard(grey, board);
}

/// The 8-bit images people and avatar-calibrate --left/--right read: demosaiced, scaled from the bit depth.
StereoImagePair display8(const StereoImagePair& bgr) {
    PairLayout layout = bgr.layout();
    layout.bitDepth = 8;
    return StereoImagePair(toDisplay8(bgr.left(), bgr.layout().bitDepth), toDisplay8(bgr.right(), bgr.layout().bitDepth),
                           layout, bgr.id());
}

int run(const po::variables_map& vm) {
    BackendRequest request = backendRequest(vm);
    requireBackendOptions(request, true);
    if (!vm.count("board")) throw UsageError("--board COLUMNSxROWS (inner corners) is required");
    const cv::Size board = parseBoard(vm["board"].as<std::string>());
    if (!vm.count("out")) throw UsageError("--out DIR (where to save the good pairs) is required");
    const std::string outDir = vm["out"].as<std::string>();
    const std::size_t wanted = vm["pairs"].as<std::size_t>();
    if (wanted < 1 || wanted > 10000) throw UsageError("--pairs must be 1..10000");
    const double timeoutS = vm["timeout"].as<double>();
    if (!(timeoutS > 0.0)) throw UsageError("--timeout must be > 0 s");
    const std::size_t maxAttempts = vm["attempts"].as<std::size_t>();
    const double minMove = vm["min-move"].as<double>();
    if (!(minMove >= 0.0)) throw UsageError("--min-move must be >= 0 px");
    const int intervalMs = vm["interval-ms"].as<int>();
    if (intervalMs < 0) throw UsageError("--interval-ms must be >= 0");
    const SaveFormat format = parseSaveFormat(vm["format"].as<std::string>());
    const bool fastCheck = vm.count("no-fast-check") == 0;
    configureLogging(vm);

    Backend backend = makeBackend(request);
    AcquireStereoImagePair& acquisition = *backend.acquisition;
    acquisition.applyConfig(backend.config);  // firewire starts here
    PairSaver saver(outDir, format, backend.config);

    std::cout << "looking for a " << board.width << "x" << board.height << " board (inner corners) in pairs from "
              << request.name << "; want " << wanted << " good pair(s) within " << fixed(timeoutS, 0) << " s"
              << std::endl;
    Progress progress("good pairs", wanted);
    progress.update(0, "waiting for the first pair");
    std::vector<std::vector<cv::Point2f>> savedLeft;
    std::vector<std::vector<bool>> coverage(2, std::vector<bool>(kGridX * kGridY, false));
    cv::Size imageSize;
    json perPair = json::array();
    std::vector<std::string> failures;
    std::size_t attempts = 0;
    std::size_t grabbed = 0;
    std::string endReason;
    const auto start = Clock::now();
    while (savedLeft.size() < wanted) {
        const double elapsed = std::chrono::duration<double>(Clock::now() - start).count();
        const AcquisitionStatus status = acquisition.status();
        if (status.state == AcquisitionStatus::State::Finished) {
            endReason = "the source has no more pairs";
            break;
        }
        if (status.state == AcquisitionStatus::State::Failed) {
            endReason = "the backend failed: " + status.message;
            break;
        }
        if (elapsed > timeoutS) {
            endReason = "--timeout " + fixed(timeoutS, 0) + " s reached";
            break;
        }
        if (maxAttempts > 0 && attempts >= maxAttempts) {
            endReason = std::to_string(attempts) + " attempts made (--attempts)";
            break;
        }
        if (attempts > 0 && intervalMs > 0) std::this_thread::sleep_for(std::chrono::milliseconds(intervalMs));
        ++attempts;
        AcquiredPair acquired;
        try {
            acquired = acquisition.acquire();
        } catch (const AcquisitionError& e) {
            failures.push_back(e.what());
            progress.line("attempt " + std::to_string(attempts) + ": no pair: " + e.what());
            continue;
        }
        ++grabbed;
        const StereoImagePair& pair = acquired.pair;
        const StereoImagePair bgr = pair.layout().format == PixelFormat::Bayer ? demosaic(pair) : pair;
        const int bits = pair.layout().bitDepth;
        imageSize = pair.size();
        // The detector avatar-calibrate uses, after the quick test unless --no-fast-check.
        const auto detect = [&](const cv::Mat& image) -> std::optional<std::vector<cv::Point2f>> {
            if (fastCheck && !mayShowBoard(image, board, bits)) return std::nullopt;
            return findBoardCorners(image, board, bits);
        };
        const auto left = detect(bgr.left());
        const auto right = detect(bgr.right());
        std::string verdict;
        bool good = left && right;
        if (!left && !right) verdict = "the whole board is in neither image";
        else if (!left) verdict = "the whole board is not in the left image";
        else if (!right) verdict = "the whole board is not in the right image";
        std::optional<std::size_t> sameAs;
        double shift = 0.0;
        if (good && minMove > 0.0) {
            for (std::size_t k = 0; k < savedLeft.size(); ++k) {
                const double s = meanShift(*left, savedLeft[k]);
                if (s < minMove && (!sameAs || s < shift)) {
                    sameAs = k + 1;
                    shift = s;
                }
            }
            if (sameAs) {
                good = false;
                verdict = "board in both, but in the pose of saved pair " + std::to_string(*sameAs) +
                          " (corners moved " + fixed(shift, 1) + " px < --min-move " + fixed(minMove, 1) +
                          "): move the board";
            }
        }
        json entry = {{"attempt", attempts},
                      {"group", pair.id().group},
                      {"member", pair.id().member},
                      {"left_board", left.has_value()},
                      {"right_board", right.has_value()},
                      {"saved", nullptr}};
        if (good) {
            saver.save(format == SaveFormat::Png ? display8(bgr) : pair);
            saver.flush();  // a good pair is saved before the next is looked at
            savedLeft.push_back(*left);
            for (const auto& [i, corners] : {std::pair<int, const std::vector<cv::Point2f>*>{0, &*left}, {1, &*right}})
                for (const cv::Point2f& p : *corners) {
                    const int cx = std::clamp(static_cast<int>(p.x * kGridX / imageSize.width), 0, kGridX - 1);
                    const int cy = std::clamp(static_cast<int>(p.y * kGridY / imageSize.height), 0, kGridY - 1);
                    coverage[static_cast<std::size_t>(i)][static_cast<std::size_t>(cy * kGridX + cx)] = true;
                }
            verdict = "board in both: saved as pair " + std::to_string(savedLeft.size());
            entry["saved"] = savedLeft.size();
        }
        entry["verdict"] = verdict;
        perPair.push_back(entry);
        progress.line("pair " + std::to_string(attempts) + " (group " + std::to_string(pair.id().group) + " member " +
                      std::to_string(pair.id().member) + "): " + verdict);
        progress.update(savedLeft.size());
    }
    progress.clear();
    saver.flush();
    const SessionRecorderStatus saved = saver.status();
    const double elapsedS = std::chrono::duration<double>(Clock::now() - start).count();
    const auto covered = [&](int i) {
        const auto& c = coverage[static_cast<std::size_t>(i)];
        return 100.0 * static_cast<double>(std::count(c.begin(), c.end(), true)) / static_cast<double>(c.size());
    };

    std::cout << "saved " << saved.recorded << " good pair(s) of " << grabbed << " grabbed in " << fixed(elapsedS, 1)
              << " s, in " << outDir << " (" << toString(format) << ")"
              << (endReason.empty() ? "" : "; stopped: " + endReason) << "\n";
    if (saved.recorded > 0) {
        std::cout << "the saved boards cover " << fixed(covered(0), 0) << " % of the left and " << fixed(covered(1), 0)
                  << " % of the right image (" << kGridX << "x" << kGridY << " cells); aim for most of both\n";
        const std::string boardText = std::to_string(board.width) + "x" + std::to_string(board.height);
        std::cout << "calibrate: avatar-calibrate --board " << boardText << " --square-mm SIZE "
                  << (format == SaveFormat::Png ? "--left '" + outDir + "/left_*.png' --right '" + outDir + "/right_*.png'"
                                                : "--session " + outDir)
                  << " --out CONFIG.xml --report REPORT.json\n";
    }
    if (vm.count("report")) {
        const json report = {{"backend", request.name},
                             {"board", {{"inner_corners", {board.width, board.height}}}},
                             {"requested_pairs", wanted},
                             {"saved_pairs", saved.recorded},
                             {"grabbed", grabbed},
                             {"attempts", attempts},
                             {"failed", failures.size()},
                             {"failures", failures},
                             {"end_reason", endReason},
                             {"elapsed_s", elapsedS},
                             {"out", outDir},
                             {"format", toString(format)},
                             {"coverage_percent", {covered(0), covered(1)}},
                             {"min_move_px", minMove},
                             {"pairs", perPair}};
        writeText(vm["report"].as<std::string>(), report.dump(2) + "\n", "the report");
    }
    if (saved.unrecorded() > 0) throw IoError("could not save every good pair in " + outDir + ": " + saved.lastError);
    if (saved.recorded < wanted) {
        std::cerr << "avatar-calib-capture: only " << saved.recorded << " of " << wanted << " good pairs: " << endReason
                  << "\n";
        return 1;
    }
    return 0;
}

}  // namespace

int main(int argc, char** argv) {
    po::options_description options(
        "avatar-calib-capture: grab synchronized pairs, say whether the whole checkerboard is visible in both\n"
        "images, and save the good pairs where avatar-calibrate reads them\n"
        "Usage: avatar-calib-capture --backend NAME --config FILE --board CxR --out DIR [--pairs N] [--timeout S]\n\n"
        "Options");
    // clang-format off
    options.add_options()("help,h", "show this help");
    addBackendOptions(options);
    options.add_options()
        ("board", po::value<std::string>(), "inner corners of the board, columns x rows (a 10 x 7 square board is 9x6)")
        ("out,o", po::value<std::string>(), "save the good pairs in this new directory")
        ("format,f", po::value<std::string>()->default_value("session"),
            "session: a session directory of raw files (avatar-calibrate --session DIR); session-png: the same with "
            "16-bit PNG files; png: 8-bit colour left_NNNN.png, right_NNNN.png (avatar-calibrate --left/--right)")
        ("pairs,n", po::value<std::size_t>()->default_value(15), "good pairs to collect")
        ("timeout", po::value<double>()->default_value(300.0), "stop after this many s")
        ("attempts", po::value<std::size_t>()->default_value(0), "stop after this many pairs grabbed (0: no limit)")
        ("min-move", po::value<double>()->default_value(20.0),
            "a good pair is saved only when the board's corners moved at least this many px (mean, left image) "
            "from every pair saved before; 0 saves every good pair")
        ("interval-ms", po::value<int>()->default_value(0), "pause between pairs, ms")
        ("no-fast-check", "search every image in full (slow without a board), not only those OpenCV's quick test passes")
        ("report,r", po::value<std::string>(), "write a JSON report here")
        ("log", po::value<std::string>()->default_value("warn"), "log priority: debug, info, notice, warn, error")
        ("log-config", po::value<std::string>(), "log4cpp property file (instead of --log)");
    // clang-format on
    return runTool("avatar-calib-capture", HelpHint::WithName, [&] {
        const po::variables_map vm = parseCommandLine(argc, argv, options);
        if (vm.count("help"))
            return printHelp(
                options, backendHelp() +
                    "\nExit status: 0 all good pairs saved; 1 a camera, file or value at fault (the message names it),\n"
                    "or fewer good pairs than asked when the time, the attempts or the source ran out (those found\n"
                    "are saved); 2 usage.\n");
        return run(vm);
    });
}
