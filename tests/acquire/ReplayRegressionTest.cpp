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
#include <avatar/tau/ReplayAnalysis.h>

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
    ReplayAnalysis replay(kLab);
    replay.setParallel(parallel);
    EXPECT_TRUE(replay.replay().reader().errors().empty());
    std::size_t compared = 0;
    while (!replay.finished()) {
        const ReplayStep step = replay.next();
        if (step.damaged()) {
            ADD_FAILURE() << step.damage;
            continue;
        }
        SCOPED_TRACE("iteration " + std::to_string(step.iteration()));
        if (!step.result) {
            ADD_FAILURE() << step.failure;
            continue;
        }
        const AcquiredPair& acquired = *step.acquired;
        if (!acquired.recordedResult) {
            ADD_FAILURE() << "the session has no recorded result to compare with; regenerate it" << describe({});
            continue;
        }
        // The reference is not vacuous: the lab scene has its sample and the arm marker in view.
        EXPECT_EQ(acquired.recordedResult->targets.size(), 2u);
        const auto diffs = compareResults(*acquired.recordedResult, *step.result);
        EXPECT_TRUE(diffs.empty()) << diffs.size() << " field(s) differ:" << describe(diffs);
        ++compared;
    }
    return compared;
}

}  // namespace

TEST(ReplayRegression, LabSessionReproducesItsRecordedResults) { EXPECT_EQ(replayLab(true), 3u); }

TEST(ReplayRegression, LabSessionReproducesItsRecordedResultsOnOneThread) { EXPECT_EQ(replayLab(false), 3u); }
