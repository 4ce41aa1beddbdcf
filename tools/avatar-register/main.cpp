// avatar-register: the camera-manipulator registration (thesis 3.1.2) from
// corresponding points measured by the vision system and by the arm, written
// into a configuration's <baseTVision>. User guide: docs/tools/avatar-register.md
//
//   avatar-register --points POINTS.csv --out CONFIG.xml --report REPORT.json
//                   [--method closed-form|iterative]

#include <avatar/common/Error.h>
#include <avatar/common/Logging.h>
#include <avatar/common/Registration.h>
#include <avatar/config/ConfigXml.h>

#include <boost/program_options.hpp>
#include <nlohmann/json.hpp>

#include <cmath>
#include <cstdio>
#include <fstream>
#include <iostream>
#include <sstream>
#include <string>
#include <vector>

namespace po = boost::program_options;
using namespace avatar;

namespace {

constexpr const char* kHeader = "vx,vy,vz,bx,by,bz";

std::string trim(const std::string& s) {
    const auto first = s.find_first_not_of(" \t\r");
    if (first == std::string::npos) return {};
    return s.substr(first, s.find_last_not_of(" \t\r") - first + 1);
}

/// POINTS.csv: the header vx,vy,vz,bx,by,bz, then one point pair per line (mm).
/// Blank lines and lines starting with '#' are skipped. Errors name file and line.
void readPoints(const std::string& path, std::vector<cv::Point3d>& vision, std::vector<cv::Point3d>& base,
                std::vector<int>& lines) {
    std::ifstream in(path);
    if (!in) throw IoError("cannot open points file '" + path + "'");
    std::string line;
    int number = 0;
    bool header = false;
    while (std::getline(in, line)) {
        ++number;
        const std::string text = trim(line);
        if (text.empty() || text[0] == '#') continue;
        const std::string where = path + ":" + std::to_string(number) + ": ";
        if (!header) {
            std::string compact;
            for (char c : text)
                if (c != ' ' && c != '\t') compact += c;
            if (compact != kHeader)
                throw FormatError(where + "expected the header '" + std::string(kHeader) + "', got '" + text + "'");
            header = true;
            continue;
        }
        std::vector<double> values;
        std::stringstream fields(text);
        std::string field;
        while (std::getline(fields, field, ',')) {
            const std::string f = trim(field);
            char* end = nullptr;
            const double v = std::strtod(f.c_str(), &end);
            if (f.empty() || *end != '\0' || !std::isfinite(v))
                throw FormatError(where + "field " + std::to_string(values.size() + 1) + " is not a finite number: '" +
                                  f + "'");
            values.push_back(v);
        }
        if (values.size() != 6)
            throw FormatError(where + "expected 6 numbers (vx,vy,vz,bx,by,bz), got " + std::to_string(values.size()));
        vision.emplace_back(values[0], values[1], values[2]);
        base.emplace_back(values[3], values[4], values[5]);
        lines.push_back(number);
    }
    if (!header) throw FormatError(path + ": empty; expected the header '" + std::string(kHeader) + "' and point pairs");
}

nlohmann::json array3(const std::array<double, 3>& a) { return nlohmann::json::array({a[0], a[1], a[2]}); }

}  // namespace

int main(int argc, char** argv) {
    po::options_description options(
        "avatar-register: the camera-manipulator registration base = R vision + t from corresponding points");
    // clang-format off
    options.add_options()
        ("help,h", "show this help")
        ("points,p", po::value<std::string>(), "CSV of point pairs in mm, header vx,vy,vz,bx,by,bz")
        ("out,o", po::value<std::string>(), "the configuration to write the registration into (must exist: its calibration measured the vision points)")
        ("report,r", po::value<std::string>(), "write the JSON report here")
        ("method,m", po::value<std::string>()->default_value("closed-form"), "closed-form (least squares, the default) or iterative (thesis Figure 3-1)")
        ("keep-outliers", "use every point pair (no outlier rejection)")
        ("max-rotation-std-deg", po::value<double>()->default_value(1.0), "refuse a rotation more uncertain than this about any axis, degrees")
        ("seed", po::value<unsigned long long>()->default_value(1), "seed of the outlier search")
        ("log", po::value<std::string>()->default_value("warn"), "log priority: debug, info, notice, warn, error");
    // clang-format on
    po::variables_map vm;
    try {
        po::store(po::parse_command_line(argc, argv, options), vm);
        po::notify(vm);
    } catch (const po::error& e) {
        std::cerr << "avatar-register: " << e.what() << "\n" << options;
        return 2;
    }
    if (vm.count("help")) {
        std::cout << options;
        return 0;
    }
    for (const char* required : {"points", "out", "report"})
        if (!vm.count(required)) {
            std::cerr << "avatar-register: --" << required << " is required (see --help)\n";
            return 2;
        }
    RegistrationOptions registration;
    const std::string method = vm["method"].as<std::string>();
    if (method == "iterative") registration.method = RegistrationMethod::Iterative;
    else if (method != "closed-form") {
        std::cerr << "avatar-register: --method must be closed-form or iterative, got '" << method << "'\n";
        return 2;
    }
    registration.rejectOutliers = vm.count("keep-outliers") == 0;
    registration.robust.seed = vm["seed"].as<unsigned long long>();
    const double maxStdDeg = vm["max-rotation-std-deg"].as<double>();
    if (!(maxStdDeg > 0.0)) {
        std::cerr << "avatar-register: --max-rotation-std-deg must be > 0\n";
        return 2;
    }
    registration.maxRotationStdRad = maxStdDeg * M_PI / 180.0;

    try {
        logging::configure(logging::parsePriority(vm["log"].as<std::string>()));
        const std::string pointsPath = vm["points"].as<std::string>();
        const std::string outPath = vm["out"].as<std::string>();
        std::vector<cv::Point3d> vision, base;
        std::vector<int> lines;
        readPoints(pointsPath, vision, base, lines);
        AvatarConfig config;
        try {
            config = readConfigFile(outPath);
        } catch (const IoError& e) {
            throw IoError(std::string(e.what()) +
                          " (avatar-register writes the registration into the configuration whose calibration "
                          "measured the vision points; give an existing file)");
        }
        const PointRegistration r = registerPoints(vision, base, registration);
        config.stereo.baseTVision = r.baseTVision;
        writeConfigFile(config, outPath);

        const cv::Matx33d rotation = rotationMatrix(r.baseTVision);
        nlohmann::json report;
        report["method"] = method;
        report["points"] = vision.size();
        report["R"] = nlohmann::json::array();
        for (int i = 0; i < 3; ++i) report["R"].push_back({rotation(i, 0), rotation(i, 1), rotation(i, 2)});
        report["t"] = array3(r.baseTVision.translationMm);
        report["euler_zyx_rad"] = array3(eulerZyx(rotation));
        report["rms_mm"] = r.rmsMm;
        report["residuals_mm"] = r.residualsMm;
        report["inliers"] = r.inliers;
        std::size_t inlierCount = 0;
        for (const bool b : r.inliers) inlierCount += b;
        report["inlier_count"] = inlierCount;
        report["sigma_mm"] = r.uncertainty.sigmaMm;
        std::array<double, 3> rotationStdDeg{};
        for (std::size_t k = 0; k < 3; ++k) rotationStdDeg[k] = r.uncertainty.rotationStdRad[k] * 180.0 / M_PI;
        report["rotation_std_deg"] = array3(rotationStdDeg);
        report["worst_rotation_std_deg"] = r.uncertainty.worstRotationStdRad * 180.0 / M_PI;
        report["translation_std_mm"] = array3(r.uncertainty.translationStdMm);
        report["config"] = outPath;
        std::ofstream out(vm["report"].as<std::string>(), std::ios::trunc);
        out << report.dump(2) << "\n";
        out.close();
        if (!out) throw IoError("cannot write the report '" + vm["report"].as<std::string>() + "'");

        const auto euler = eulerZyx(rotation);
        std::printf("registration (%s) from %zu point pairs, %zu inliers: rms %.3f mm\n", method.c_str(), vision.size(),
                    inlierCount, r.rmsMm);
        std::printf("  t = (%.2f, %.2f, %.2f) mm, euler zyx = (%.5f, %.5f, %.5f) rad\n", r.baseTVision.translationMm[0],
                    r.baseTVision.translationMm[1], r.baseTVision.translationMm[2], euler[0], euler[1], euler[2]);
        std::printf("  uncertainty: rotation %.3f deg (worst axis), translation (%.2f, %.2f, %.2f) mm\n",
                    r.uncertainty.worstRotationStdRad * 180.0 / M_PI, r.uncertainty.translationStdMm[0],
                    r.uncertainty.translationStdMm[1], r.uncertainty.translationStdMm[2]);
        for (std::size_t i = 0; i < r.inliers.size(); ++i)
            if (!r.inliers[i])
                std::printf("  outlier: point pair %zu (%s:%d), residual %.1f mm\n", i + 1, pointsPath.c_str(), lines[i],
                            r.residualsMm[i]);
        std::printf("written into %s\n", outPath.c_str());
        return 0;
    } catch (const Error& e) {
        std::cerr << "avatar-register: " << e.what() << "\n";
        return 1;
    }
}
