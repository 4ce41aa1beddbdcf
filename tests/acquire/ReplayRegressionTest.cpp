// The reference-file regression check of thesis 4.3: the bundled lab session
// (data/sessions/lab) replayed through this build's analysis, with the recorded
// configuration, must reproduce every recorded result exactly (doubles bit for
// bit); only the stage timings are not compared, as they measure each run.
//
// When this fails after an intended change of the analysis, read the
// differences below, and if they are what the change should do, regenerate the
// reference results (docs/tools/avatar-replay.md):
//   avatar-replay --session data/sessions/lab --write /tmp/lab-new
//   cp /tmp/lab-new/session.log data/sessions/lab/session.log
#include <avatar/acquire/RawDataAcquire.h>
#include <avatar/analyze/AnalyzeStereoImagePair.h>
#include <avatar/config/ConfigXml.h>

#include <gtest/gtest.h>

#include <memory>
#include <sstream>
#include <string>

using namespace avatar;

namespace {

const std::filesystem::path kLab = std::filesystem::path(AVATAR_DATA_DIR) / "sessions" / "lab";

std::string describe(const std::vector<ResultDifference>& diffs) {
    std::ostringstream out;
    for (const auto& d : diffs) out << "\n  " << d.field << ": recorded " << d.recorded << ", replayed " << d.replayed;
    out << "\nIf the change is intended, regenerate the reference results: avatar-replay --session "
        << kLab.string() << " --write /tmp/lab-new && cp /tmp/lab-new/session.log " << kLab.string() << "/";
    return out.str();
}

/// Replays the lab session; returns the number of iterations compared.
std::size_t replayLab(bool parallel) {
    RawDataAcquire replay(kLab);
    EXPECT_TRUE(replay.reader().errors().empty());
    std::unique_ptr<AnalyzeStereoImagePair> analyzer;
    std::size_t compared = 0;
    while (replay.status().state != AcquisitionStatus::State::Finished) {
        AcquiredPair acquired;
        try {
            acquired = replay.acquire();
        } catch (const AcquisitionError& e) {
            ADD_FAILURE() << e.what();
            continue;
        }
        const std::uint64_t iteration = acquired.recordedIteration.value();
        SCOPED_TRACE("iteration " + std::to_string(iteration));
        if (acquired.recordedConfigXml) {
            analyzer = std::make_unique<AnalyzeStereoImagePair>(
                readConfigString(*acquired.recordedConfigXml, "lab session config"), kLab);
            analyzer->setParallel(parallel);
        }
        if (!analyzer) {
            ADD_FAILURE() << "no configuration before this pair";
            continue;
        }
        if (!acquired.recordedResult) {
            ADD_FAILURE() << "the session has no recorded result to compare with; regenerate it" << describe({});
            continue;
        }
        // The reference is not vacuous: the lab scene has its sample and the arm marker in view.
        EXPECT_EQ(acquired.recordedResult->targets.size(), 2u);
        const VisionTargets result = analyzer->analyze(acquired.pair, iteration);
        const auto diffs = compareResults(*acquired.recordedResult, result);
        EXPECT_TRUE(diffs.empty()) << diffs.size() << " field(s) differ:" << describe(diffs);
        ++compared;
    }
    return compared;
}

}  // namespace

TEST(ReplayRegression, LabSessionReproducesItsRecordedResults) { EXPECT_EQ(replayLab(true), 3u); }

TEST(ReplayRegression, LabSessionReproducesItsRecordedResultsOnOneThread) { EXPECT_EQ(replayLab(false), 3u); }
