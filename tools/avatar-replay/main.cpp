// avatar-replay: replays a recorded session through this build's analysis,
// with the recorded configuration changes, and compares every iteration's
// result with the recorded one (the reference-file regression check of thesis
// 4.3). Optionally records a new session with this build's results.
// User guide: docs/tools/avatar-replay.md

#include <avatar/acquire/SessionLog.h>
#include <avatar/tau/ReplayAnalysis.h>
#include <avatar/common/Error.h>
#include <avatar/common/Logging.h>
#include <avatar/common/StereoImagePairFileIO.h>
#include <avatar/config/ConfigXml.h>

#include <boost/program_options.hpp>

#include <unistd.h>

#include <cstdio>
#include <fstream>
#include <iostream>
#include <memory>
#include <optional>
#include <sstream>
#include <string>
#include <vector>

namespace po = boost::program_options;
using namespace avatar;

namespace {

/// Differences shown per iteration on the terminal; the report has all.
constexpr std::size_t kShownDifferences = 10;

struct Summary {
    std::size_t records{0};    ///< log lines after the header
    std::size_t replayed{0};   ///< pairs acquired and analysed
    std::size_t identical{0};
    std::size_t different{0};
    std::size_t damaged{0};    ///< records that could not be replayed (log or image damage)
    std::size_t failed{0};     ///< pairs the analysis could not run on (configuration, analysis error)
    std::size_t missingResult{0};  ///< replayed, but the recording has no result to compare with
};

/// Progress: a bar redrawn in place on a terminal, plain lines otherwise.
class Progress {
public:
    Progress(std::size_t total, bool tty) : total_(total), tty_(tty) {}

    /// One line about an iteration, kept on screen above the bar.
    void line(const std::string& text) {
        clear();
        std::cout << text << "\n";
        std::cout.flush();
    }
    void update(std::size_t done, const std::string& what) {
        if (!tty_) return;  // plain output: the per-iteration lines are the progress
        const int width = 30;
        const int filled = total_ == 0 ? width : static_cast<int>(done * width / total_);
        std::cout << "\r[" << std::string(static_cast<std::size_t>(filled), '#')
                  << std::string(static_cast<std::size_t>(width - filled), '.') << "] " << done << "/" << total_
                  << " " << what << "\033[K";
        std::cout.flush();
        shown_ = true;
    }
    void clear() {
        if (tty_ && shown_) std::cout << "\r\033[K";
        shown_ = false;
    }

private:
    std::size_t total_;
    bool tty_;
    bool shown_{false};
};

std::string identity(const StereoImagePair& pair, std::uint64_t iteration) {
    return "iteration " + std::to_string(iteration) + " (group " + std::to_string(pair.id().group) + " member " +
           std::to_string(pair.id().member) + ")";
}

/// The compression and raw byte order a recorded file name says.
std::pair<Compression, ByteOrder> storageOf(const std::string& fileName) {
    const bool png = fileName.size() > 4 && fileName.compare(fileName.size() - 4, 4, ".png") == 0;
    return {png ? Compression::Png : Compression::None, RawImageName::parse(fileName).geometry.byteOrder};
}

}  // namespace

int main(int argc, char** argv) {
    po::options_description options(
        "avatar-replay: replay a recorded session through this build's analysis and compare the results");
    options.add_options()
        ("help,h", "show this help")
        ("session,s", po::value<std::string>(), "session directory to replay (docs/formats.md)")
        ("report,r", po::value<std::string>(), "write the difference report to this file")
        ("write,w", po::value<std::string>(),
         "record a new session in this directory: the same pairs, ids and configuration changes, "
         "with this build's results")
        ("config,c", po::value<std::string>(), "analyse with this configuration instead of the recorded ones")
        ("log", po::value<std::string>()->default_value("error"),
         "log priority: debug, info, notice, warn, error");
    po::variables_map vm;
    try {
        po::store(po::parse_command_line(argc, argv, options), vm);
        po::notify(vm);
    } catch (const po::error& e) {
        std::cerr << "avatar-replay: " << e.what() << "\n" << options;
        return 2;
    }
    if (vm.count("help") || !vm.count("session")) {
        std::cout << options;
        return vm.count("help") ? 0 : 2;
    }

    Summary summary;
    std::ostringstream report;
    try {
        logging::configure(logging::parsePriority(vm["log"].as<std::string>()));
        const std::filesystem::path dir = vm["session"].as<std::string>();
        std::optional<AvatarConfig> fixed;
        std::filesystem::path configDir;
        if (vm.count("config")) {
            const std::filesystem::path file = vm["config"].as<std::string>();
            fixed = readConfigFile(file);
            configDir = file.parent_path();
        }
        std::optional<std::string> fixedXmlToWrite;
        if (fixed) fixedXmlToWrite = writeConfigString(*fixed);
        ReplayAnalysis replay(dir, fixed, configDir);
        summary.records = replay.replay().entryCount();
        std::unique_ptr<SessionLogWriter> writer;
        if (vm.count("write")) writer = std::make_unique<SessionLogWriter>(vm["write"].as<std::string>());

        report << "avatar-replay report\nsession: " << dir.string() << "\n"
               << "configuration: "
               << (fixed ? vm["config"].as<std::string>() + " (instead of the recorded ones)" : "as recorded")
               << "\ncompared: every field of each result, doubles bit for bit, and the stage names; "
                  "not the stage timings, which measure each run and can never match\n\n";

        Progress progress(summary.records, isatty(STDOUT_FILENO) == 1);
        progress.update(0, "");
        while (!replay.finished()) {
            const ReplayStep step = replay.next();
            if (step.damaged()) {
                ++summary.damaged;
                progress.line("DAMAGED: " + step.damage);
                report << "DAMAGED: " << step.damage << "\n";
                progress.update(replay.replay().position(), "");
                continue;
            }
            ++summary.replayed;
            const AcquiredPair& acquired = *step.acquired;
            const std::uint64_t iteration = step.iteration();
            const std::string who = identity(acquired.pair, iteration);
            const SessionRecord& record = *replay.replay().lastRecord();
            const std::optional<VisionTargets>& result = step.result;

            if (!result) {
                ++summary.failed;
                progress.line(who + ": FAILED: " + step.failure);
                report << who << ": FAILED: " << step.failure << "\n";
            } else if (!acquired.recordedResult) {
                ++summary.missingResult;
                progress.line(who + ": no recorded result to compare with (" + std::to_string(result->targets.size()) +
                              " targets now)");
                report << who << ": no recorded result to compare with\n";
            } else {
                const std::vector<ResultDifference> diffs = compareResults(*acquired.recordedResult, *result);
                if (diffs.empty()) {
                    ++summary.identical;
                    progress.line(who + ": identical");
                    report << who << ": identical\n";
                } else {
                    ++summary.different;
                    std::ostringstream shown;
                    shown << who << ": DIFFERENT in " << diffs.size() << " field(s)";
                    report << who << ": DIFFERENT in " << diffs.size() << " field(s)\n";
                    for (std::size_t i = 0; i < diffs.size(); ++i) {
                        const ResultDifference& d = diffs[i];
                        const std::string text =
                            "  " + d.field + ": recorded " + d.recorded + ", replayed " + d.replayed;
                        report << text << "\n";
                        if (i < kShownDifferences) shown << "\n" << text;
                    }
                    if (diffs.size() > kShownDifferences)
                        shown << "\n  ... " << diffs.size() - kShownDifferences << " more (see --report)";
                    progress.line(shown.str());
                }
            }

            if (writer) {
                SessionRecord out;
                out.iteration = iteration;
                out.acquisition = acquired.pair.id();
                if (fixed) {
                    out.configVersion = 1;
                    out.configXml = std::move(fixedXmlToWrite);  // on the first record only
                    fixedXmlToWrite.reset();
                } else {
                    out.configVersion = record.configVersion;
                    out.configXml = acquired.recordedConfigXml;
                }
                out.result = result;
                const auto [compression, byteOrder] = storageOf(record.files.left.name);
                out.files = writer->writePair(acquired.pair, compression, byteOrder);
                writer->append(out);
            }
            progress.update(replay.replay().position(), who);
        }
        progress.clear();
    } catch (const Error& e) {
        std::cerr << "avatar-replay: " << e.what() << "\n";
        return 1;
    }

    std::ostringstream totals;
    totals << "summary: " << summary.records << " records, " << summary.replayed << " iterations replayed: "
           << summary.identical << " identical, " << summary.different << " different, " << summary.damaged
           << " damaged, " << summary.failed << " failed, " << summary.missingResult << " without a recorded result";
    report << "\n" << totals.str() << "\n";
    std::cout << totals.str() << "\n";
    if (summary.missingResult > 0)
        std::cout << "note: " << summary.missingResult
                  << " iteration(s) had no recorded result, so nothing was compared for them\n";
    if (vm.count("report")) {
        std::ofstream file(vm["report"].as<std::string>(), std::ios::trunc);
        file << report.str();
        file.close();
        if (!file) {
            std::cerr << "avatar-replay: cannot write the report " << vm["report"].as<std::string>() << "\n";
            return 1;
        }
    }
    return summary.different + summary.damaged + summary.failed == 0 ? 0 : 1;
}
