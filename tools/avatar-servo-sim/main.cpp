// avatar-servo-sim: seeded sampling tasks in simulation, through the whole
// system: rendered stereo pairs -> the analysis -> TAUNet -> TAUUnit -> the
// visual servo -> a simulated arm. User guide: docs/servo.md.
//
//   avatar-servo-sim --runs N --seed S --registration-error-deg D --registration-error-mm M
//                    --arm-bias-mm B --out DIR [--scenario static|moving|lost|distractor]
//                    [--mode servo|hybrid] [--filter none|kalman] [--config FILE]
//                    [--move-ms T] [--registration-runs K] [--no-refine]

#include "Plot.h"
#include "ServoWorld.h"

#include <avatar/common/Error.h>
#include <avatar/common/Logging.h>
#include <avatar/common/Registration.h>
#include <avatar/config/ConfigXml.h>
#include <avatar/servo/AutoRegistration.h>

#include <boost/program_options.hpp>
#include <nlohmann/json.hpp>
#include <opencv2/imgcodecs.hpp>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <limits>
#include <string>
#include <vector>

extern const char* const kServoSimXml;

namespace po = boost::program_options;
namespace fs = std::filesystem;
using namespace avatar;
using namespace avatar::servosim;

namespace {

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();
constexpr double kPi = 3.14159265358979323846;

double round3(double v) {
    return std::isfinite(v) ? std::round(v * 1000.0) / 1000.0 : v;
}

struct Stats {
    double median{kNaN}, p95{kNaN}, min{kNaN}, max{kNaN}, mean{kNaN}, stddev{kNaN};
};

Stats stats(std::vector<double> v) {
    Stats s;
    if (v.empty()) return s;
    std::sort(v.begin(), v.end());
    const auto at = [&](double q) {
        const double pos = q * static_cast<double>(v.size() - 1);
        const std::size_t i = static_cast<std::size_t>(std::floor(pos));
        const std::size_t j = std::min(v.size() - 1, i + 1);
        return v[i] + (v[j] - v[i]) * (pos - static_cast<double>(i));
    };
    s.median = at(0.5);
    s.p95 = at(0.95);
    s.min = v.front();
    s.max = v.back();
    double sum = 0.0, sq = 0.0;
    for (double x : v) sum += x;
    s.mean = sum / static_cast<double>(v.size());
    for (double x : v) sq += (x - s.mean) * (x - s.mean);
    s.stddev = v.size() > 1 ? std::sqrt(sq / static_cast<double>(v.size() - 1)) : 0.0;
    return s;
}

nlohmann::json toJson(const Stats& s) {
    return {{"median", round3(s.median)}, {"p95", round3(s.p95)}, {"min", round3(s.min)},
            {"max", round3(s.max)},       {"mean", round3(s.mean)}, {"std", round3(s.stddev)}};
}

std::string xyz(const cv::Point3d& p) {
    char text[96];
    std::snprintf(text, sizeof text, "%.3f,%.3f,%.3f", p.x, p.y, p.z);
    return text;
}
std::string xyz(const std::optional<cv::Point3d>& p) {
    return p ? xyz(*p) : std::string(",,");
}

/// The per-step CSV of one run.
void writeRunCsv(const fs::path& path, const TaskOutcome& o) {
    std::ofstream out(path);
    out << "step,time_s,state,move,vision_iteration,telemetry_x,telemetry_y,telemetry_z,vision_tool_x,vision_tool_y,"
           "vision_tool_z,vision_sample_x,vision_sample_y,vision_sample_z,tool_estimate_x,tool_estimate_y,"
           "tool_estimate_z,sample_estimate_x,sample_estimate_y,sample_estimate_z,move_x,move_y,move_z,"
           "estimated_distance_mm,true_tool_x,true_tool_y,true_tool_z,true_error_mm,final_move,note\n";
    for (std::size_t i = 0; i < o.servo.steps.size(); ++i) {
        const servo::ServoStep& s = o.servo.steps[i];
        std::optional<cv::Point3d> move;
        if (s.commandedMoveMm) move = cv::Point3d((*s.commandedMoveMm)[0], (*s.commandedMoveMm)[1], (*s.commandedMoveMm)[2]);
        const std::string trueTool = i < o.servoLooks.size() ? xyz(o.servoLooks[i].toolTipBaseMm) : std::string(",,");
        std::string note = s.note;
        std::replace(note.begin(), note.end(), '"', '\'');
        char head[128];
        std::snprintf(head, sizeof head, "%zu,%.3f,%s,%d,%llu,", i, s.timeS, std::string(toString(s.state)).c_str(),
                      s.move, static_cast<unsigned long long>(s.visionIteration));
        out << head << xyz(s.telemetryToolMm) << ',' << xyz(s.visionToolMm) << ',' << xyz(s.visionSampleMm) << ','
            << xyz(s.toolEstimateMm) << ',' << xyz(s.sampleEstimateMm) << ',' << xyz(move) << ','
            << (s.distanceMm >= 0 ? std::to_string(s.distanceMm) : "") << ',' << trueTool << ','
            << (i < o.servoLooks.size() ? std::to_string(o.servoLooks[i].errorMm) : "") << ','
            << (s.finalMove ? 1 : 0) << ",\"" << note << "\"\n";
    }
    // The end: where the tool came to rest.
    out << o.servo.steps.size() << ",,end," << o.servo.moves << ",,,,,,,,,,,,,,,,,,,,," << xyz(o.servoFinal.toolTipBaseMm)
        << ',' << o.servoFinal.errorMm << ",0,\"" << toString(o.servo.finalState) << ' ' << o.servo.reason << "\"\n";
    if (!out) throw IoError("cannot write '" + path.string() + "'");
}

/// Figures 6-3 to 6-5: the tool's position relative to the sample, the
/// distance and the commanded moves per step.
void writeRunPlot(const fs::path& path, const TaskOutcome& o, std::uint64_t seed) {
    const std::size_t n = o.servo.steps.size() + 1;
    Series tx{"x", std::vector<double>(n, kNaN), {200, 60, 30}};
    Series ty{"y", std::vector<double>(n, kNaN), {40, 160, 40}};
    Series tz{"z", std::vector<double>(n, kNaN), {30, 30, 200}};
    Series trueError{"true error", std::vector<double>(n, kNaN), {30, 30, 200}};
    Series estimated{"estimated", std::vector<double>(n, kNaN), {200, 60, 30}};
    Series moves{"|move|", std::vector<double>(n, kNaN), {40, 140, 40}};
    for (std::size_t i = 0; i < n; ++i) {
        const WorldTruth& t = i < o.servoLooks.size() ? o.servoLooks[i] : o.servoFinal;
        tx.y[i] = t.toolTipBaseMm.x - t.sampleBaseMm.x;
        ty.y[i] = t.toolTipBaseMm.y - t.sampleBaseMm.y;
        tz.y[i] = t.toolTipBaseMm.z - t.sampleBaseMm.z;
        trueError.y[i] = t.errorMm;
        if (i < o.servo.steps.size()) {
            const servo::ServoStep& s = o.servo.steps[i];
            if (s.distanceMm >= 0) estimated.y[i] = s.distanceMm;
            if (s.commandedMoveMm) moves.y[i] = cv::norm(*s.commandedMoveMm);
        }
    }
    const std::string run = "seed " + std::to_string(seed) + ": ";
    const std::vector<Chart> charts = {
        {run + "true tool tip minus sample, per base-frame axis", "step", "mm", {tx, ty, tz}},
        {run + "distance tool tip - sample", "step", "mm", {trueError, estimated}},
        {run + "commanded move", "step", "mm", {moves}}};
    if (!cv::imwrite(path.string(), drawCharts(charts))) throw IoError("cannot write '" + path.string() + "'");
}

void writeJson(const fs::path& path, const nlohmann::json& value) {
    std::ofstream out(path);
    out << value.dump(2) << "\n";
    if (!out) throw IoError("cannot write '" + path.string() + "'");
}

ServoMode parseMode(const std::string& word) {
    if (word == "servo") return ServoMode::Servo;
    if (word == "hybrid") return ServoMode::Hybrid;
    throw InvalidArgument("--mode: expected servo or hybrid, got '" + word + "'");
}

ServoFilter parseFilter(const std::string& word) {
    if (word == "none") return ServoFilter::None;
    if (word == "kalman") return ServoFilter::Kalman;
    throw InvalidArgument("--filter: expected none or kalman, got '" + word + "'");
}

/// Table 6-6: the automated registration repeated, against the truth.
nlohmann::json registrationRuns(WorldSpec spec, int runs) {
    nlohmann::json out = nlohmann::json::array();
    std::vector<double> rotationErrors, translationErrors, before, after;
    std::vector<std::array<double, 3>> eulers, translations;
    for (int k = 0; k < runs; ++k) {
        spec.noiseSeed = static_cast<std::uint64_t>(k) + 1u;  // the same world, measured again
        ServoWorld world(spec);
        ServoConfig once = world.servoConfig();
        once.mode = ServoMode::DeadReckoning;
        servo::ServoTask task;
        task.sampleHintBaseMm = world.sampleHintBaseMm();
        const double deadBefore = [&] {
            servo::VisualServo dr(world.arm(), world.vision(), once);
            dr.run(task);
            return world.truth().errorMm;
        }();
        world.resetArm();
        const servo::MotionRegistration reg =
            servo::registerByMotion(world.arm(), world.vision(), world.registrationWaypoints(), world.servoConfig());
        // The arm's frame is the one its telemetry is in: the truth shifted by the arm's bias.
        const RigidTransform truth = world.trueRegistration();
        const cv::Vec3d bias = translationVector(world.arm().trueBaseTTool()) -
                               translationVector(world.arm().telemetry().baseTTool);
        const double rotationError =
            rotationAngleBetween(rotationMatrix(truth), rotationMatrix(reg.registration.baseTVision)) * 180.0 / kPi;
        const double translationError =
            cv::norm(translationVector(reg.registration.baseTVision) - (translationVector(truth) - bias));
        world.applyRegistration(reg.registration.baseTVision);
        world.resetArm();
        task.sampleHintBaseMm = world.sampleHintBaseMm();
        servo::VisualServo dr(world.arm(), world.vision(), once);
        dr.run(task);
        const double deadAfter = world.truth().errorMm;

        const std::array<double, 3> e = eulerZyx(rotationMatrix(reg.registration.baseTVision));
        const cv::Vec3d t = translationVector(reg.registration.baseTVision);
        eulers.push_back({e[0] * 180.0 / kPi, e[1] * 180.0 / kPi, e[2] * 180.0 / kPi});
        translations.push_back({t[0], t[1], t[2]});
        rotationErrors.push_back(rotationError);
        translationErrors.push_back(translationError);
        before.push_back(deadBefore);
        after.push_back(deadAfter);
        out.push_back({{"seed", spec.seed},
                       {"noise_seed", spec.noiseSeed},
                       {"points", reg.visionMm.size()},
                       {"skipped", reg.skipped},
                       {"rms_mm", round3(reg.registration.rmsMm)},
                       {"euler_zyx_deg", {round3(eulers.back()[0]), round3(eulers.back()[1]), round3(eulers.back()[2])}},
                       {"translation_mm", {round3(t[0]), round3(t[1]), round3(t[2])}},
                       {"rotation_error_deg", round3(rotationError)},
                       {"translation_error_mm", round3(translationError)},
                       {"dead_reckoning_error_mm_before", round3(deadBefore)},
                       {"dead_reckoning_error_mm_after", round3(deadAfter)}});
        std::cout << "registration " << k + 1 << "/" << runs << " (seed " << spec.seed << ", noise " << spec.noiseSeed
                  << "): " << reg.visionMm.size()
                  << " points, rotation error " << rotationError << " deg, translation error " << translationError
                  << " mm; dead reckoning " << deadBefore << " -> " << deadAfter << " mm" << std::endl;
    }
    nlohmann::json spread;
    for (int axis = 0; axis < 3; ++axis) {
        std::vector<double> ea, ta;
        for (std::size_t i = 0; i < eulers.size(); ++i) {
            ea.push_back(eulers[i][axis]);
            ta.push_back(translations[i][axis]);
        }
        spread["euler_deg"].push_back(toJson(stats(ea)));
        spread["translation_mm"].push_back(toJson(stats(ta)));
    }
    return {{"runs", out},
            {"repeatability", spread},
            {"rotation_error_deg", toJson(stats(rotationErrors))},
            {"translation_error_mm", toJson(stats(translationErrors))},
            {"dead_reckoning_error_mm_before", toJson(stats(before))},
            {"dead_reckoning_error_mm_after", toJson(stats(after))}};
}

}  // namespace

int main(int argc, char** argv) {
    po::options_description options(
        "avatar-servo-sim: seeded visual-servo sampling tasks through the whole system in simulation\n"
        "(docs/servo.md). Options");
    // clang-format off
    options.add_options()
        ("help,h", "show this help")
        ("runs", po::value<int>()->default_value(20), "sampling tasks (seeds S, S+1, ...)")
        ("seed", po::value<unsigned long long>()->default_value(1), "seed of the first task")
        ("registration-error-deg", po::value<double>()->default_value(5.0), "rotation error of the registration the vision system is given")
        ("registration-error-mm", po::value<double>()->default_value(20.0), "translation error of that registration")
        ("arm-bias-mm", po::value<double>()->default_value(20.0), "static accuracy error of the arm (its tool is this far from its telemetry)")
        ("repeatability-mm", po::value<double>()->default_value(0.5), "per-axis standard deviation of where each move ends")
        ("out", po::value<std::string>(), "output directory (created): summary.json, report.json, run_<seed>.csv and .png")
        ("scenario", po::value<std::string>()->default_value("static"), "static, moving, lost or distractor")
        ("speed-mm", po::value<double>()->default_value(1.0), "moving: how far the sample drifts per look")
        ("mode", po::value<std::string>()->default_value(""), "servo or hybrid (default: the configuration's <servo><mode>)")
        ("filter", po::value<std::string>()->default_value(""), "none or kalman (default: the configuration's <servo><filter>)")
        ("no-refine", "do not refine the registration during runs (<servo><refineRegistration> false)")
        ("config", po::value<std::string>(), "AVATAR configuration with the true calibration, registration and <servo> (default: data/config/servo-sim.xml, built in)")
        ("move-ms", po::value<int>()->default_value(0), "duration of a simulated arm move")
        ("supersampling", po::value<int>()->default_value(2), "rendering: samples per edge pixel per axis")
        ("registration-runs", po::value<int>()->default_value(0), "also run the automated registration K times on the world of --seed, each with fresh sensor and arm noise (registration.json: repeatability as Table 6-6, errors against the truth)")
        ("log-level", po::value<std::string>()->default_value("warn"), "debug, info, notice, warn, error");
    // clang-format on
    po::variables_map vm;
    try {
        po::store(po::parse_command_line(argc, argv, options), vm);
        po::notify(vm);
    } catch (const po::error& e) {
        std::cerr << "avatar-servo-sim: " << e.what() << "\n" << options;
        return 2;
    }
    if (vm.count("help")) {
        std::cout << options;
        return 0;
    }
    if (!vm.count("out")) {
        std::cerr << "avatar-servo-sim: --out DIR is required\n" << options;
        return 2;
    }
    const int runs = vm["runs"].as<int>();
    const int registrationRunCount = vm["registration-runs"].as<int>();
    if (runs < 0 || registrationRunCount < 0 || (runs == 0 && registrationRunCount == 0)) {
        std::cerr << "avatar-servo-sim: --runs must be >= 0 and, with --registration-runs, not both 0\n";
        return 2;
    }
    try {
        logging::configure(logging::parsePriority(vm["log-level"].as<std::string>()));
        WorldSpec spec;
        spec.config = vm.count("config") ? readConfigFile(vm["config"].as<std::string>())
                                         : readConfigString(kServoSimXml, "servo-sim.xml (built in)");
        if (!spec.config.servo) {
            throw InvalidArgument("the configuration has no <servo> section (docs/config.md)");
        }
        if (!vm["mode"].as<std::string>().empty()) spec.config.servo->mode = parseMode(vm["mode"].as<std::string>());
        if (!vm["filter"].as<std::string>().empty())
            spec.config.servo->filter = parseFilter(vm["filter"].as<std::string>());
        if (vm.count("no-refine")) spec.config.servo->refineRegistration = false;
        spec.registrationErrorDeg = vm["registration-error-deg"].as<double>();
        spec.registrationErrorMm = vm["registration-error-mm"].as<double>();
        spec.armBiasMm = vm["arm-bias-mm"].as<double>();
        spec.repeatabilityMm = vm["repeatability-mm"].as<double>();
        spec.scenario = parseScenario(vm["scenario"].as<std::string>());
        spec.sampleSpeedMmPerLook = vm["speed-mm"].as<double>();
        spec.moveDuration = std::chrono::milliseconds(vm["move-ms"].as<int>());
        spec.supersampling = vm["supersampling"].as<int>();
        for (double v : {spec.registrationErrorDeg, spec.registrationErrorMm, spec.armBiasMm, spec.repeatabilityMm}) {
            if (!std::isfinite(v) || v < 0.0) throw InvalidArgument("error sizes must be finite and >= 0");
        }
        if (spec.moveDuration.count() < 0) throw InvalidArgument("--move-ms must be >= 0");
        const fs::path out = vm["out"].as<std::string>();
        fs::create_directories(out);
        const auto firstSeed = vm["seed"].as<unsigned long long>();

        nlohmann::json summary = {{"runs", nlohmann::json::array()}};
        std::vector<double> finals, deads, iterations;
        int converged = 0, within5 = 0;
        for (int i = 0; i < runs; ++i) {
            spec.seed = firstSeed + static_cast<unsigned long long>(i);
            const TaskOutcome o = runSamplingTask(spec);
            const bool ok = o.servo.converged();
            summary["runs"].push_back({{"seed", spec.seed},
                                       {"converged", ok},
                                       {"iterations", o.servo.moves},
                                       {"final_error_mm", round3(o.servoFinal.errorMm)},
                                       {"dead_reckoning_error_mm", round3(o.deadReckoningFinal.errorMm)}});
            const std::string stem = "run_" + std::to_string(spec.seed);
            writeRunCsv(out / (stem + ".csv"), o);
            writeRunPlot(out / (stem + ".png"), o, spec.seed);
            converged += ok ? 1 : 0;
            within5 += ok && o.servoFinal.errorMm <= 5.0 ? 1 : 0;
            finals.push_back(o.servoFinal.errorMm);
            deads.push_back(o.deadReckoningFinal.errorMm);
            iterations.push_back(o.servo.moves);
            std::cout << "run " << i + 1 << "/" << runs << " (seed " << spec.seed << "): "
                      << toString(o.servo.finalState) << " after " << o.servo.moves << " moves, final error "
                      << o.servoFinal.errorMm << " mm; dead reckoning " << o.deadReckoningFinal.errorMm << " mm"
                      << (o.servo.reason.empty() ? "" : " (" + o.servo.reason + ")") << std::endl;
        }
        if (runs > 0) {
            writeJson(out / "summary.json", summary);
            const nlohmann::json report = {
                {"scenario", toString(spec.scenario)},
                {"mode", spec.config.servo->mode == ServoMode::Hybrid ? "hybrid" : "servo"},
                {"filter", spec.config.servo->filter == ServoFilter::Kalman ? "kalman" : "none"},
                {"refine_registration", spec.config.servo->refineRegistration},
                {"registration_error_deg", spec.registrationErrorDeg},
                {"registration_error_mm", spec.registrationErrorMm},
                {"arm_bias_mm", spec.armBiasMm},
                {"runs", runs},
                {"converged", converged},
                {"within_5_mm", within5},
                {"final_error_mm", toJson(stats(finals))},
                {"iterations", toJson(stats(iterations))},
                {"dead_reckoning_error_mm", toJson(stats(deads))}};
            writeJson(out / "report.json", report);
            const Stats f = stats(finals), d = stats(deads), it = stats(iterations);
            std::cout << converged << "/" << runs << " converged, " << within5 << " within 5 mm; final error median "
                      << f.median << " mm, max " << f.max << " mm; iterations median " << it.median << ", max "
                      << it.max << "; dead reckoning median " << d.median << " mm, min " << d.min << " mm\n";
        }
        if (registrationRunCount > 0) {
            spec.seed = firstSeed;
            spec.scenario = Scenario::Static;
            const nlohmann::json registration = registrationRuns(spec, registrationRunCount);
            writeJson(out / "registration.json", registration);
        }
        return 0;
    } catch (const Error& e) {
        std::cerr << "avatar-servo-sim: " << e.what() << "\n";
        return 1;
    } catch (const std::exception& e) {
        std::cerr << "avatar-servo-sim: " << e.what() << "\n";
        return 1;
    }
}
