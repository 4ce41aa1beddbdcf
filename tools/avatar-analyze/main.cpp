// avatar-analyze: runs the AVATAR analysis on the pairs of a recorded session
// (ReplayAnalysis) and prints the targets of each iteration. User guide: docs/tools/avatar-analyze.md

#include <avatar/common/Error.h>
#include <avatar/common/Logging.h>
#include <avatar/common/StereoImagePairFileIO.h>
#include <avatar/config/ConfigXml.h>
#include <avatar/tau/ReplayAnalysis.h>

#include <boost/program_options.hpp>
#include <nlohmann/json.hpp>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <iostream>
#include <map>
#include <memory>
#include <optional>
#include <string>
#include <vector>

namespace po = boost::program_options;
using namespace avatar;

namespace {

void printTargets(const VisionTargets& r) {
    std::printf("iteration %llu (group %u member %u): %zu target(s), visibility %s%s%s\n",
                static_cast<unsigned long long>(r.iteration), r.acquisition.group, r.acquisition.member,
                r.targets.size(),
                r.visibility == Visibility::Good ? "good" : r.visibility == Visibility::Poor ? "POOR" : "unknown",
                r.visibilityReason.empty() ? "" : ": ", r.visibilityReason.c_str());
    for (const VisionTarget& t : r.targets) {
        std::printf("  %-12s %-22s", t.type.c_str(), targetFlagsText(t.flags).c_str());
        if (t.positionVisionMm)
            std::printf(" vision %8.1f %8.1f %8.1f mm", t.positionVisionMm->x, t.positionVisionMm->y,
                        t.positionVisionMm->z);
        if (t.positionBaseMm)
            std::printf("  base %8.1f %8.1f %8.1f mm", t.positionBaseMm->x, t.positionBaseMm->y, t.positionBaseMm->z);
        if (t.centroidLeftPx) std::printf("  L (%7.2f, %7.2f)", t.centroidLeftPx->x, t.centroidLeftPx->y);
        if (t.centroidRightPx) std::printf("  R (%7.2f, %7.2f)", t.centroidRightPx->x, t.centroidRightPx->y);
        if (t.flags & kTargetStereo) {
            std::printf("  model %s", std::string(toString(t.model)).c_str());
            if (t.covarianceVisionMm2) {
                const Covariance3& c = *t.covarianceVisionMm2;
                std::printf("  sigma %.2f %.2f %.2f mm", std::sqrt(std::max(c(0, 0), 0.0)),
                            std::sqrt(std::max(c(1, 1), 0.0)), std::sqrt(std::max(c(2, 2), 0.0)));
            }
        }
        std::printf("\n");
    }
    std::printf("  timings:");
    for (const StageTiming& s : r.timings) std::printf(" %s %.1f ms;", s.stage.c_str(), s.milliseconds);
    std::printf("\n");
}

/// Wall and CPU milliseconds of every analysis, per stage ("total" too), for --timings.
class TimingLog {
public:
    void add(const VisionTargets& result, const std::vector<StageTiming>& cpu) {
        for (const StageTiming& t : result.timings) entry(t.stage).wall.push_back(t.milliseconds);
        for (const StageTiming& t : cpu) entry(t.stage).cpu.push_back(t.milliseconds);
    }
    void pair() { ++pairs_; }

    /// {"pairs": n, "total": {...}, "stages": {name: {"wall_ms_median", "cpu_ms_median"}}}
    nlohmann::json json() const {
        nlohmann::json stages = nlohmann::json::object();
        nlohmann::json total;
        for (const auto& [name, e] : entries_) {
            const nlohmann::json j = {{"wall_ms_median", median(e.wall)}, {"cpu_ms_median", median(e.cpu)}};
            if (name == "total") total = j;
            else stages[name] = j;
        }
        return {{"pairs", pairs_}, {"total", total}, {"stages", stages}};
    }

private:
    struct Entry {
        std::vector<double> wall, cpu;
    };
    Entry& entry(const std::string& name) {
        for (auto& [n, e] : entries_)
            if (n == name) return e;
        entries_.emplace_back(name, Entry{});
        return entries_.back().second;
    }
    static nlohmann::json median(std::vector<double> v) {
        if (v.empty()) return nullptr;
        std::sort(v.begin(), v.end());
        const std::size_t n = v.size();
        return n % 2 ? v[n / 2] : 0.5 * (v[n / 2 - 1] + v[n / 2]);
    }
    std::vector<std::pair<std::string, Entry>> entries_;  ///< in the order of the timings
    std::size_t pairs_{0};
};

/// Equal but for the timings, which measure each run.
bool sameResult(VisionTargets a, VisionTargets b) {
    a.timings.clear();
    b.timings.clear();
    return a == b;
}

}  // namespace

int main(int argc, char** argv) {
    po::options_description options("avatar-analyze: analyse the pairs of a recorded session");
    options.add_options()
        ("help,h", "show this help")
        ("session,s", po::value<std::string>(), "session directory (docs/formats.md)")
        ("config,c", po::value<std::string>(), "use this configuration instead of the recorded one")
        ("iterations,n", po::value<int>()->default_value(0), "analyse at most this many iterations (0: all)")
        ("marked", po::value<std::string>(), "write the marked images of each iteration into this directory")
        ("repeat", po::value<int>()->default_value(1), "analyse each pair this many times (to time the configuration)")
        ("timings", po::value<std::string>(), "write the medians of every stage's wall and CPU time here (JSON)")
        ("log", po::value<std::string>()->default_value("warn"), "log priority: debug, info, notice, warn, error");
    po::variables_map vm;
    try {
        po::store(po::parse_command_line(argc, argv, options), vm);
        po::notify(vm);
    } catch (const po::error& e) {
        std::cerr << "avatar-analyze: " << e.what() << "\n" << options;
        return 2;
    }
    if (vm.count("help") || !vm.count("session")) {
        std::cout << options;
        return vm.count("help") ? 0 : 2;
    }
    const int repeat = vm["repeat"].as<int>();
    if (repeat < 1) {
        std::cerr << "avatar-analyze: --repeat must be at least 1, got " << repeat << "\n";
        return 2;
    }
    int failures = 0;
    TimingLog timings;
    try {
        logging::configure(logging::parsePriority(vm["log"].as<std::string>()));
        std::optional<AvatarConfig> fixed;
        std::filesystem::path configDir;
        if (vm.count("config")) {
            const std::filesystem::path file = vm["config"].as<std::string>();
            fixed = readConfigFile(file);
            configDir = file.parent_path();
        }
        ReplayAnalysis replay(vm["session"].as<std::string>(), fixed, configDir);
        const int limit = vm["iterations"].as<int>();
        for (int done = 0; !replay.finished() && (limit == 0 || done < limit);) {
            const ReplayStep step = replay.next();
            if (step.damaged()) {
                std::cerr << "avatar-analyze: damaged record: " << step.damage << "\n";
                ++failures;
                continue;
            }
            ++done;
            if (!step.result) {
                std::cerr << "avatar-analyze: iteration " << step.iteration() << ": " << step.failure << "\n";
                ++failures;
                continue;
            }
            printTargets(*step.result);
            timings.pair();
            timings.add(*step.result, replay.analyzer()->lastCpuTimings());
            for (int k = 1; k < repeat; ++k) {
                const VisionTargets again = replay.analyzeAgain(step);
                timings.add(again, replay.analyzer()->lastCpuTimings());
                if (!sameResult(again, *step.result)) {
                    std::cerr << "avatar-analyze: iteration " << step.iteration() << ": run " << k + 1
                              << " gave another result than the first\n";
                    ++failures;
                }
            }
            if (vm.count("marked")) {
                const std::filesystem::path out = vm["marked"].as<std::string>();
                std::filesystem::create_directories(out);
                const auto marked = replay.analyzer()->markedImages();
                const std::string stem = "marked_" + std::to_string(step.iteration());
                const PairLayout layout{PixelFormat::Bgr, BayerPattern::BG, 8};
                StereoImagePairFileIO::writeDisplay(out / (stem + "_L.jpg"), marked.left(), layout);
                StereoImagePairFileIO::writeDisplay(out / (stem + "_R.jpg"), marked.right(), layout);
            }
        }
        if (vm.count("timings")) {
            const std::string path = vm["timings"].as<std::string>();
            std::ofstream out(path, std::ios::trunc);
            out << timings.json().dump(2) << "\n";
            out.close();
            if (!out) throw IoError("cannot write the timings file " + path);
        }
    } catch (const Error& e) {
        std::cerr << "avatar-analyze: " << e.what() << "\n";
        return 1;
    }
    return failures == 0 ? 0 : 1;
}
