// avatar-calibrate: stereo calibration from checkerboard pairs (thesis 3.1.1),
// import and export of calibrations, and the Appendix A diagnostics.
// User guide: docs/tools/avatar-calibrate.md; procedure: docs/calibration.md.
//
//   avatar-calibrate --board 9x6 --square-mm 25 --left 'DIR/left*.jpg' --right 'DIR/right*.jpg'
//                    --out CONFIG.xml --report REPORT.json
//   avatar-calibrate --import FILE --out CONFIG.xml
//   avatar-calibrate --config CONFIG.xml --export-opencv FILE --export-ros DIR
//   avatar-calibrate --config CONFIG.xml --diagnose LEFT,RIGHT --out DIR

#include "Diagnose.h"
#include "Formats.h"
#include "Inputs.h"

#include <avatar/analyze/StereoCalibration.h>
#include <avatar/common/Error.h>
#include <avatar/common/Logging.h>
#include <avatar/config/ConfigXml.h>

#include <boost/program_options.hpp>
#include <nlohmann/json.hpp>

#include <cmath>
#include <cstdio>
#include <fstream>
#include <iostream>
#include <optional>
#include <string>
#include <vector>

namespace po = boost::program_options;
namespace fs = std::filesystem;
using namespace avatar;
using namespace avatar::calibrate;

namespace {

/// A command line that cannot work (exit status 2); every other error is 1.
class UsageError : public InvalidArgument {
public:
    using InvalidArgument::InvalidArgument;
};

constexpr const char* kConvention =
    "X_right = R(om) X_left + T (om in rad, T in mm); pixel (0, 0) is the centre of the top-left pixel";

/// "9x6" -> 9 x 6.
cv::Size parseBoard(const std::string& text) {
    const auto x = text.find('x');
    char* end = nullptr;
    const long w = x == std::string::npos ? 0 : std::strtol(text.c_str(), &end, 10);
    const bool widthOk = end == text.c_str() + x;
    const long h = x == std::string::npos ? 0 : std::strtol(text.c_str() + x + 1, &end, 10);
    if (x == std::string::npos || !widthOk || *end != '\0' || w < 2 || h < 2 || w > 100 || h > 100)
        throw UsageError("--board: expected the inner corners as COLUMNSxROWS, e.g. 9x6, got '" + text + "'");
    return cv::Size(static_cast<int>(w), static_cast<int>(h));
}

/// "x,y;x,y" -> points.
std::vector<cv::Point2d> parsePoints(const std::string& text) {
    std::vector<cv::Point2d> out;
    std::size_t start = 0;
    while (start < text.size()) {
        const auto end = text.find(';', start);
        const std::string item = text.substr(start, end == std::string::npos ? std::string::npos : end - start);
        double x = 0, y = 0;
        char comma = 0;
        std::istringstream in(item);
        if (!(in >> x >> comma >> y) || comma != ',')
            throw UsageError("--points: expected x,y;x,y;... in left-image pixels, got '" + item + "'");
        out.emplace_back(x, y);
        if (end == std::string::npos) break;
        start = end + 1;
    }
    return out;
}

nlohmann::json arrayOf(const double* values, std::size_t n) {
    nlohmann::json a = nlohmann::json::array();
    for (std::size_t i = 0; i < n; ++i) a.push_back(values[i]);
    return a;
}

nlohmann::json cameraJson(const CameraIntrinsics& in, const IntrinsicsUncertainty& u, double rmsPx) {
    nlohmann::json j;
    j["rms_px"] = rmsPx;
    j["fc"] = arrayOf(in.fc.data(), 2);
    j["cc"] = arrayOf(in.cc.data(), 2);
    j["alpha_c"] = in.alphaC;
    j["kc"] = arrayOf(in.kc.data(), 5);
    j["fc_std"] = arrayOf(u.fc.data(), 2);
    j["cc_std"] = arrayOf(u.cc.data(), 2);
    j["alpha_c_std"] = u.alphaC;
    j["kc_std"] = arrayOf(u.kc.data(), 5);
    return j;
}

void writeJson(const std::string& path, const nlohmann::json& j) {
    std::ofstream out(path, std::ios::trunc);
    out << j.dump(2) << "\n";
    out.close();
    if (!out) throw IoError("cannot write the report '" + path + "'");
}

/// What the images were: the camera format a new configuration gets.
struct ImageFormat {
    cv::Size size;
    int bitDepth{8};
    int channels{3};
};

/// Puts @p stereo into the configuration at @p out: the existing one (its
/// camera must be the images' size), else @p base, else a new configuration
/// for the images (with a placeholder target type, named in the warning).
/// Returns true when a new configuration was made.
bool writeCalibration(const std::string& out, const std::optional<std::string>& base, StereoSystemConfig stereo,
                      const ImageFormat& format) {
    AvatarConfig config;
    bool created = false;
    std::error_code ec;
    const std::optional<std::string> from = fs::exists(out, ec) ? std::optional<std::string>(out) : base;
    if (from) {
        config = readConfigFile(*from);
        if (format.size.width > 0 && (config.camera.width != format.size.width || config.camera.height != format.size.height))
            throw InvalidArgument("the calibration is for " + std::to_string(format.size.width) + "x" +
                                  std::to_string(format.size.height) + " images but " + *from + " configures " +
                                  std::to_string(config.camera.width) + "x" + std::to_string(config.camera.height));
        if (config.stereo.baseTVision) {
            stereo.baseTVision = config.stereo.baseTVision;
            std::printf("note: the camera-manipulator registration of %s was kept; run avatar-register again "
                        "with points measured through the new calibration\n",
                        from->c_str());
        }
    } else {
        if (format.size.width <= 0)
            throw InvalidArgument(out + " does not exist and the image size is unknown: give --config BASE.xml");
        created = true;
        config.camera.width = format.size.width;
        config.camera.height = format.size.height;
        config.camera.bitDepth = format.bitDepth;
        config.camera.channels = format.channels;
        config.camera.bayer = false;
        TargetType placeholder;
        placeholder.name = "sample";
        config.targets.targets = {placeholder};
        std::printf("warning: %s is a new configuration: its target type 'sample' is a placeholder that passes "
                    "every colour; make real colour filters before searching (docs/calibration.md)\n",
                    out.c_str());
    }
    config.stereo = stereo;
    writeConfigFile(config, out);
    return created;
}

int run(const po::variables_map& vm) {
    const std::optional<std::string> configFile =
        vm.count("config") ? std::optional<std::string>(vm["config"].as<std::string>()) : std::nullopt;

    // ---- diagnose
    if (vm.count("diagnose")) {
        if (!vm.count("out")) throw UsageError("--diagnose needs --out DIR for the pictures");
        StereoSystemConfig stereo;
        if (vm.count("import")) stereo = importCalibration(vm["import"].as<std::string>()).stereo;
        else if (configFile) stereo = readConfigFile(*configFile).stereo;
        else throw UsageError("--diagnose needs a calibration: --config CONFIG.xml or --import FILE");
        const std::string pair = vm["diagnose"].as<std::string>();
        const auto comma = pair.find(',');
        if (comma == std::string::npos) throw UsageError("--diagnose: expected LEFT_IMAGE,RIGHT_IMAGE, got '" + pair + "'");
        const LoadedImage left = loadImage(pair.substr(0, comma)), right = loadImage(pair.substr(comma + 1));
        std::vector<cv::Point2d> points;
        if (vm.count("points")) {
            points = parsePoints(vm["points"].as<std::string>());
        } else if (vm.count("board")) {
            const cv::Size inner = parseBoard(vm["board"].as<std::string>());
            if (const auto corners = findBoardCorners(left.bgr, inner, left.bitDepth)) {
                // The board's four outer corners and its middle.
                const int w = inner.width, h = inner.height;
                for (const int i : {0, w - 1, (h / 2) * w + w / 2, (h - 1) * w, h * w - 1})
                    points.emplace_back((*corners)[static_cast<std::size_t>(i)].x,
                                        (*corners)[static_cast<std::size_t>(i)].y);
            }
        }
        if (points.empty())
            for (int j = 1; j <= 3; ++j)
                for (int i = 1; i <= 4; ++i)
                    points.emplace_back(left.bgr.cols * i / 5.0, left.bgr.rows * j / 4.0);
        const nlohmann::json matrices = diagnose(stereo, left, right, points, vm["out"].as<std::string>());
        std::printf("essential matrix E and fundamental matrix F written to %s/matrices.json\n",
                    vm["out"].as<std::string>().c_str());
        for (const char* name : {"E", "F"}) {
            std::printf("%s =\n", name);
            for (const auto& row : matrices[name]) std::printf("  % .9e % .9e % .9e\n", row[0].get<double>(),
                                                               row[1].get<double>(), row[2].get<double>());
        }
        std::printf("epipolar lines of %zu points: %s/epipolar.png; rectified pair: %s/rectified.png\n", points.size(),
                    vm["out"].as<std::string>().c_str(), vm["out"].as<std::string>().c_str());
        return 0;
    }

    StereoSystemConfig stereo;
    ImageFormat format;
    nlohmann::json report;
    bool haveCalibration = false;

    // ---- calibrate from checkerboard pairs
    const bool fromImages = vm.count("left") || vm.count("right") || vm.count("session");
    if (fromImages) {
        if (vm.count("import")) throw UsageError("give either checkerboard images or --import, not both");
        if (!vm.count("board") || !vm.count("square-mm"))
            throw UsageError("calibration needs --board COLUMNSxROWS (inner corners) and --square-mm S");
        if (!vm.count("out")) throw UsageError("calibration needs --out CONFIG.xml");
        BoardGeometry board{parseBoard(vm["board"].as<std::string>()), vm["square-mm"].as<double>()};
        board.validate();
        std::vector<std::pair<LoadedImage, LoadedImage>> images;
        std::vector<std::string> skipped, skippedReasons;
        if (vm.count("session")) {
            if (vm.count("left") || vm.count("right")) throw UsageError("give --session or --left/--right, not both");
            images = loadSession(vm["session"].as<std::string>(), skippedReasons);
        } else {
            if (!vm.count("left") || !vm.count("right")) throw UsageError("--left and --right go together");
            const auto left = globFiles(vm["left"].as<std::string>());
            const auto right = globFiles(vm["right"].as<std::string>());
            if (left.size() != right.size())
                throw InvalidArgument("--left matches " + std::to_string(left.size()) + " files but --right " +
                                      std::to_string(right.size()) + "; pairs are made in name order");
            for (std::size_t i = 0; i < left.size(); ++i) images.emplace_back(loadImage(left[i]), loadImage(right[i]));
        }
        std::vector<CalibrationPair> pairs;
        for (std::size_t i = 0; i < images.size(); ++i) {
            const LoadedImage& l = images[i].first;
            const LoadedImage& r = images[i].second;
            if (i == 0) format = {l.bgr.size(), l.bitDepth, l.bgr.channels()};
            if (l.bgr.size() != format.size || r.bgr.size() != format.size)
                throw InvalidArgument("image " + (l.bgr.size() != format.size ? l.name : r.name) +
                                      " differs in size from the first pair's");
            const auto cl = findBoardCorners(l.bgr, board.innerCorners, l.bitDepth);
            const auto cr = findBoardCorners(r.bgr, board.innerCorners, r.bitDepth);
            std::printf("[%zu/%zu] %s: %s\n", i + 1, images.size(), fs::path(l.name).filename().c_str(),
                        cl && cr ? "board found in both" : !cl && !cr ? "no board in either" : !cl ? "no board in the left image" : "no board in the right image");
            std::fflush(stdout);
            if (!cl || !cr) {
                skipped.push_back(l.name + ", " + r.name);
                skippedReasons.push_back(l.name + ", " + r.name + ": the whole board is not found in " +
                                         (!cl && !cr ? "either image" : !cl ? "the left image" : "the right image"));
                continue;
            }
            pairs.push_back({fs::path(l.name).filename().string(), *cl, *cr});
        }
        StereoCalibrationOptions options;
        const std::string strategy = vm["strategy"].as<std::string>();
        if (strategy == "fix-intrinsics") options.strategy = StereoStrategy::FixIntrinsics;
        else if (strategy == "refine-all") options.strategy = StereoStrategy::RefineAll;
        else if (strategy != "best")
            throw UsageError("--strategy must be best, fix-intrinsics or refine-all, got '" + strategy + "'");
        options.estimateK3 = vm.count("estimate-k3") > 0;
        const StereoCalibration c = calibrateStereo(pairs, board, format.size, options);
        stereo = c.stereo;
        haveCalibration = true;
        const CalibrationUncertainty& u = *c.stereo.uncertainty;
        report["pairs_used"] = pairs.size();
        report["pairs_skipped"] = skipped;
        report["skipped"] = skippedReasons;
        report["rms_px"] = c.rmsPx;
        report["epipolar_rms_px"] = c.epipolarRmsPx;
        report["left"] = cameraJson(c.stereo.left, u.left, c.leftRmsPx);
        report["right"] = cameraJson(c.stereo.right, u.right, c.rightRmsPx);
        report["om"] = arrayOf(c.stereo.om.data(), 3);
        report["T"] = arrayOf(c.stereo.translationMm.data(), 3);
        report["om_std"] = arrayOf(u.om.data(), 3);
        report["T_std"] = arrayOf(u.translationMm.data(), 3);
        report["strategy"] = toString(c.strategy);
        if (c.heldOutFixedPx) {
            report["held_out"] = {{"pairs", c.heldOutPairs},
                                  {"fix_intrinsics_rms_px", *c.heldOutFixedPx},
                                  {"refine_all_rms_px", *c.heldOutRefinedPx}};
        }
        nlohmann::json perPair = nlohmann::json::array();
        for (std::size_t i = 0; i < pairs.size(); ++i)
            perPair.push_back({{"name", pairs[i].name},
                               {"rms_px", c.perPairRmsPx[i]},
                               {"left_rms_px", c.perPairLeftRmsPx[i]},
                               {"right_rms_px", c.perPairRightRmsPx[i]}});
        report["per_pair"] = perPair;
        report["board"] = {{"inner_corners", {board.innerCorners.width, board.innerCorners.height}},
                           {"square_mm", board.squareMm}};
        std::printf("calibrated from %zu pairs (%zu skipped), %s: RMS %.4f px (left %.4f, right %.4f), epipolar RMS %.4f px\n",
                    pairs.size(), skipped.size(), toString(c.strategy), c.rmsPx, c.leftRmsPx, c.rightRmsPx,
                    c.epipolarRmsPx);
        if (c.heldOutFixedPx)
            std::printf("  held back %zu pairs: %.4f px with the cameras' own calibrations fixed, %.4f px refining all\n",
                        c.heldOutPairs.size(), *c.heldOutFixedPx, *c.heldOutRefinedPx);
        std::printf("  left  fc (%.2f, %.2f) +- (%.2f, %.2f)  cc (%.2f, %.2f) +- (%.2f, %.2f)\n", stereo.left.fc[0],
                    stereo.left.fc[1], u.left.fc[0], u.left.fc[1], stereo.left.cc[0], stereo.left.cc[1], u.left.cc[0],
                    u.left.cc[1]);
        std::printf("  right fc (%.2f, %.2f) +- (%.2f, %.2f)  cc (%.2f, %.2f) +- (%.2f, %.2f)\n", stereo.right.fc[0],
                    stereo.right.fc[1], u.right.fc[0], u.right.fc[1], stereo.right.cc[0], stereo.right.cc[1],
                    u.right.cc[0], u.right.cc[1]);
        std::printf("  om (%.5f, %.5f, %.5f) +- (%.5f, %.5f, %.5f) rad, T (%.3f, %.3f, %.3f) +- (%.3f, %.3f, %.3f) mm\n",
                    stereo.om[0], stereo.om[1], stereo.om[2], u.om[0], u.om[1], u.om[2], stereo.translationMm[0],
                    stereo.translationMm[1], stereo.translationMm[2], u.translationMm[0], u.translationMm[1],
                    u.translationMm[2]);
    } else if (vm.count("import")) {
        const ImportedCalibration imported = importCalibration(vm["import"].as<std::string>());
        stereo = imported.stereo;
        format.size = imported.imageSize;
        haveCalibration = true;
        report["imported"] = vm["import"].as<std::string>();
        report["format"] = imported.format;
        std::printf("imported a %s calibration from %s\n", imported.format.c_str(), vm["import"].as<std::string>().c_str());
    } else if (configFile) {
        const AvatarConfig config = readConfigFile(*configFile);
        stereo = config.stereo;
        format.size = cv::Size(config.camera.width, config.camera.height);
        haveCalibration = true;
    }
    if (!haveCalibration)
        throw UsageError("nothing to do: give checkerboard pairs (--left/--right or --session), --import FILE, "
                              "or --config CONFIG.xml with --export-opencv/--export-ros/--diagnose (see --help)");

    if (vm.count("out") && (fromImages || vm.count("import"))) {
        const std::string out = vm["out"].as<std::string>();
        const bool created = writeCalibration(out, configFile, stereo, format);
        report["config"] = out;
        report["config_created"] = created;
        std::printf("calibration written into %s\n", out.c_str());
    }
    if (format.size.width <= 0 && configFile) {
        const AvatarConfig config = readConfigFile(*configFile);
        format.size = cv::Size(config.camera.width, config.camera.height);
    }
    if (vm.count("export-opencv")) {
        exportOpenCv(stereo, format.size, vm["export-opencv"].as<std::string>());
        std::printf("OpenCV FileStorage YAML written to %s\n", vm["export-opencv"].as<std::string>().c_str());
    }
    if (vm.count("export-ros")) {
        exportRos(stereo, format.size, vm["export-ros"].as<std::string>());
        std::printf("ROS camera_info written to %s/left.yaml and right.yaml\n", vm["export-ros"].as<std::string>().c_str());
    }
    if (vm.count("report")) {
        report["image_size"] = {format.size.width, format.size.height};
        report["convention"] = kConvention;
        writeJson(vm["report"].as<std::string>(), report);
    }
    return 0;
}

}  // namespace

int main(int argc, char** argv) {
    po::options_description options(
        "avatar-calibrate: stereo calibration from checkerboard pairs, import/export, diagnostics");
    // clang-format off
    options.add_options()
        ("help,h", "show this help")
        ("board", po::value<std::string>(), "inner corners of the board, COLUMNSxROWS, e.g. 9x6")
        ("square-mm", po::value<double>(), "size of one square, mm")
        ("left", po::value<std::string>(), "left images: a shell pattern in quotes, e.g. 'DIR/left*.jpg' (sorted by name)")
        ("right", po::value<std::string>(), "right images, paired with the left ones in name order")
        ("session", po::value<std::string>(), "a recorded session directory instead of --left/--right (raw pairs are demosaiced)")
        ("out", po::value<std::string>(), "the configuration to write the calibration into (with --diagnose: a directory)")
        ("report", po::value<std::string>(), "write the JSON report here")
        ("strategy", po::value<std::string>()->default_value("best"), "stereo step: best (compare on held-back pairs), fix-intrinsics, refine-all")
        ("estimate-k3", "estimate the sixth-order radial term k3 too (off: fixed at 0, as the Bouguet toolbox)")
        ("config", po::value<std::string>(), "a configuration whose calibration to export or diagnose; for a new --out, the base to start from")
        ("import", po::value<std::string>(), "read a calibration: OpenCV FileStorage YAML, ROS camera_info (DIR or LEFT.yaml,RIGHT.yaml), Bouguet text")
        ("export-opencv", po::value<std::string>(), "write the calibration as OpenCV FileStorage YAML")
        ("export-ros", po::value<std::string>(), "write ROS camera_info YAML files left.yaml and right.yaml into this directory")
        ("diagnose", po::value<std::string>(), "LEFT,RIGHT images: E, F, epipolar lines and the rectified pair into --out DIR")
        ("points", po::value<std::string>(), "with --diagnose: left-image points x,y;x,y;... (default: board corners or a grid)")
        ("log", po::value<std::string>()->default_value("warn"), "log priority: debug, info, notice, warn, error");
    // clang-format on
    po::variables_map vm;
    try {
        po::store(po::parse_command_line(argc, argv, options), vm);
        po::notify(vm);
    } catch (const po::error& e) {
        std::cerr << "avatar-calibrate: " << e.what() << "\n" << options;
        return 2;
    }
    if (vm.count("help") || argc == 1) {
        std::cout << options;
        return vm.count("help") ? 0 : 2;
    }
    try {
        logging::configure(logging::parsePriority(vm["log"].as<std::string>()));
        return run(vm);
    } catch (const UsageError& e) {
        std::cerr << "avatar-calibrate: " << e.what() << " (see --help)\n";
        return 2;
    } catch (const Error& e) {
        std::cerr << "avatar-calibrate: " << e.what() << "\n";
        return 1;
    }
}
