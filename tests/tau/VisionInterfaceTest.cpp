// VisionInterface driven by the simulation backend: real rendering, real
// analysis, real threads.

#include "SphereScene.h"
#include "TempDir.h"

#include <avatar/acquire/RawDataAcquire.h>
#include <avatar/acquire/SessionLog.h>
#include <avatar/common/CameraModel.h>
#include <avatar/config/ConfigXml.h>
#include <avatar/acquire/AcquireSIPSimulation.h>
#include <avatar/tau/VisionInterface.h>

#include <gtest/gtest.h>

#include <algorithm>
#include <opencv2/core.hpp>

#include <filesystem>
#include <fstream>
#include <thread>

#include <unistd.h>

using namespace avatar;
using namespace std::chrono_literals;

namespace {

// The sphere scene of tests/support/SphereScene.h (640x480, one sphere).
using test::kSphereMm;

template <typename Predicate>
bool eventually(Predicate p, std::chrono::milliseconds limit = 30s) {
    const auto end = std::chrono::steady_clock::now() + limit;
    while (std::chrono::steady_clock::now() < end) {
        if (p()) return true;
        std::this_thread::sleep_for(20ms);
    }
    return p();
}

}  // namespace

TEST(VisionInterface, SnapshotLocatesTheSphereAndUpdatesTheBookkeeping) {
    VisionInterface vision(test::sphereSimulation(), test::sphereSceneConfig());
    EXPECT_EQ(vision.backendName(), "simulation");
    EXPECT_FALSE(vision.latestTargets().has_value());
    EXPECT_EQ(vision.images(ImageKind::Original).iteration, 0u);

    const VisionTargets result = vision.snapshot();
    EXPECT_EQ(result.iteration, 1u);
    EXPECT_EQ(result.acquisition.group, 1u);
    EXPECT_EQ(result.acquisition.member, 0u);
    EXPECT_EQ(result.acquisition.left.cameraId, "sim-left");
    ASSERT_EQ(result.targets.size(), 1u);
    const VisionTarget& t = result.targets[0];
    EXPECT_EQ(t.type, "sample");
    EXPECT_TRUE(t.flags & kTargetStereo);
    EXPECT_TRUE(t.flags & kTargetShapeCorrected);
    ASSERT_TRUE(t.positionVisionMm.has_value());
    EXPECT_LT(cv::norm(*t.positionVisionMm - kSphereMm), 3.0) << *t.positionVisionMm;

    const VisionStatus s = vision.status();
    EXPECT_EQ(s.state, VisionState::Idle);
    EXPECT_EQ(s.iteration, 1u);
    EXPECT_EQ(s.targetsIteration, 1u);
    EXPECT_EQ(s.imagesIteration, 1u);
    EXPECT_EQ(s.configVersion, 1u);
    EXPECT_EQ(s.configIteration, 1u);
    EXPECT_EQ(s.visibility, Visibility::Good);
    EXPECT_EQ(vision.latestTargets()->iteration, 1u);

    const VisionImages original = vision.images(ImageKind::Original);
    EXPECT_EQ(original.iteration, 1u);
    EXPECT_EQ(original.pair.size(), cv::Size(640, 480));
    EXPECT_EQ(original.pair.layout().format, PixelFormat::Bayer);
    const VisionImages marked = vision.images(ImageKind::Marked);
    EXPECT_EQ(marked.pair.left().type(), CV_8UC3);
    const VisionImages filtered = vision.images(ImageKind::Filtered);
    const auto px = *projectPoint(test::halfScorpion().left, kSphereMm);
    EXPECT_GT(cv::norm(filtered.pair.left().at<cv::Vec3w>(cvRound(px.y), cvRound(px.x))), 0.0);
    EXPECT_EQ(filtered.pair.left().at<cv::Vec3w>(5, 5), cv::Vec3w(0, 0, 0));
}

// The heartbeat has its own timer (docs/protocol.md: at least 10 a second):
// it beats on while one slow iteration (every pixel supersampled 8 x 8)
// holds the vision loop.
TEST(VisionInterface, TheHeartbeatBeatsTenTimesASecondDuringASlowIteration) {
    render::RenderOptions options;
    options.sensor.width = 640;
    options.sensor.height = 480;
    options.supersampling = 8;
    options.adaptive = false;
    VisionInterface vision(std::make_unique<AcquireSIPSimulation>(test::sphereScene(), test::halfScorpion(), options),
                           test::sphereSceneConfig());
    vision.startSearching();
    std::this_thread::sleep_for(200ms);
    const VisionStatus a = vision.status();
    const auto t0 = std::chrono::steady_clock::now();
    std::this_thread::sleep_for(1500ms);
    const VisionStatus b = vision.status();
    const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    vision.stopSearching();
    EXPECT_GE(static_cast<double>(b.heartbeat - a.heartbeat) / seconds, 10.0);
    EXPECT_LE(b.iteration - a.iteration, 2u);  // the loop itself was busy rendering
}

TEST(VisionInterface, SearchingRunsUntilStoppedAndTheHeartbeatBeats) {
    VisionInterface vision(test::sphereSimulation(), test::sphereSceneConfig());
    const auto idleBeat = vision.status().heartbeat;
    std::this_thread::sleep_for(350ms);
    EXPECT_GE(vision.status().heartbeat, idleBeat + 5);  // 20 a second

    vision.startSearching();
    ASSERT_TRUE(eventually([&] { return vision.status().iteration >= 3; }));
    EXPECT_EQ(vision.status().state, VisionState::Searching);
    vision.stopSearching();
    ASSERT_TRUE(eventually([&] { return vision.status().state == VisionState::Idle; }));
    const auto stoppedAt = vision.status().iteration;
    std::this_thread::sleep_for(300ms);
    EXPECT_EQ(vision.status().iteration, stoppedAt);
    EXPECT_EQ(vision.latestTargets()->iteration, stoppedAt);
    // Members count up within the first group.
    EXPECT_EQ(vision.latestTargets()->acquisition.member, stoppedAt - 1);
}

TEST(VisionInterface, RejectedConfigurationKeepsTheOldOne) {
    VisionInterface vision(test::sphereSimulation(), test::sphereSceneConfig());
    const std::string before = vision.configXml();
    std::string bad = before;
    bad.replace(bad.find("<width>640</width>"), 18, "<width>wide</width>");
    try {
        vision.applyConfig(bad);
        FAIL() << "accepted";
    } catch (const ConfigError& e) {
        EXPECT_EQ(e.elementPath(), "/avatar/camera/width");
        EXPECT_NE(std::string(e.what()).find("expected"), std::string::npos) << e.what();
    }
    EXPECT_EQ(vision.configXml(), before);
    EXPECT_EQ(vision.status().configVersion, 1u);
    // Still works with the old configuration.
    EXPECT_EQ(vision.snapshot().targets.size(), 1u);
}

TEST(VisionInterface, AppliedConfigurationStartsANewGroupAndVersion) {
    VisionInterface vision(test::sphereSimulation(), test::sphereSceneConfig());
    vision.snapshot();
    vision.snapshot();
    AvatarConfig narrower = test::sphereSceneConfig();
    narrower.targets.targets[0].area = {100, 200};  // the sphere is larger: filtered out
    EXPECT_EQ(vision.applyConfig(writeConfigString(narrower)), 2u);
    const VisionStatus s = vision.status();
    EXPECT_EQ(s.configVersion, 2u);
    EXPECT_EQ(s.configIteration, 3u);
    EXPECT_EQ(vision.config(), narrower);
    const VisionTargets third = vision.snapshot();
    EXPECT_EQ(third.iteration, 3u);
    EXPECT_EQ(third.acquisition.group, 2u);
    EXPECT_EQ(third.acquisition.member, 0u);
    EXPECT_TRUE(third.targets.empty());
}

TEST(VisionInterface, AnalysisThatCannotBeBuiltIsRejectedWhole) {
    VisionInterface vision(test::sphereSimulation(), test::sphereSceneConfig());
    AvatarConfig broken = test::sphereSceneConfig();
    broken.analysis.stages = {"demosaic", "match"};
    EXPECT_THROW(vision.applyConfig(writeConfigString(broken)), InvalidArgument);
    EXPECT_EQ(vision.config(), test::sphereSceneConfig());
    EXPECT_EQ(vision.status().configVersion, 1u);
}

// A sent configuration that validates but cannot be applied is a rejected
// configuration, typed as such, naming the part that refused it.
TEST(VisionInterface, SentConfigurationsThatCannotBeAppliedAreConfigErrors) {
    VisionInterface vision(test::sphereSimulation(), test::sphereSceneConfig());
    AvatarConfig order = test::sphereSceneConfig();
    order.analysis.stages = {"demosaic", "match"};
    const std::string orderXml = writeConfigString(order);
    const std::string before = orderXml.substr(0, orderXml.find("<stages>"));
    const int stagesLine = 1 + static_cast<int>(std::count(before.begin(), before.end(), '\n'));
    try {
        vision.applyConfig(orderXml);
        ADD_FAILURE() << "applied";
    } catch (const ConfigError& e) {
        // The documented form, at the line of <stages> in the document sent.
        EXPECT_EQ(std::string(e.what()), "sent configuration:" + std::to_string(stagesLine) +
                                             ": /avatar/analysis/stages: analysis stage 'match' needs "
                                             "'locate_features' before it");
    }
    AvatarConfig lamp = test::sphereSceneConfig();
    lamp.lighting.patternEnabled = true;
    lamp.lighting.templateImagePath = "/nonexistent/strobe-template.tif";
    try {
        vision.applyConfig(writeConfigString(lamp));
        ADD_FAILURE() << "applied";
    } catch (const ConfigError& e) {
        EXPECT_EQ(e.elementPath(), "/avatar/lighting/pattern/templateImage");
        EXPECT_NE(e.problem().find("/nonexistent/strobe-template.tif"), std::string::npos) << e.what();
    }
    EXPECT_EQ(vision.config(), test::sphereSceneConfig());
    EXPECT_EQ(vision.status().configVersion, 1u);
    // The interface is still whole: it analyses with the old configuration.
    EXPECT_EQ(vision.snapshot().ofType("sample").size(), 1u);
}

// A client that sends configurations cannot learn which files exist on the
// vision computer: a template outside the data directory, missing, a device
// or unreadable is refused with one message; one inside that is not an image
// is refused when the analysis is built.
TEST(VisionInterface, SentLightingTemplatesStayInTheDataDirectoryAndTellNothing) {
    const test::TempDir data;
    std::filesystem::create_directories(data.path() / "sub");
    { std::ofstream(data.path() / "sub" / "junk.tif") << "not an image"; }
    VisionOptions options;
    options.configDirectory = data.path();
    VisionInterface vision(test::sphereSimulation(), test::sphereSceneConfig(), options);
    const auto refusal = [&](const std::string& path) {
        AvatarConfig c = test::sphereSceneConfig();
        c.lighting.patternEnabled = true;
        c.lighting.templateImagePath = path;
        try {
            vision.applyConfig(writeConfigString(c));
        } catch (const ConfigError& e) {
            return e.elementPath() + ": " + e.problem();
        }
        return std::string("applied");
    };
    const auto expected = [](const std::string& path) {
        return "/avatar/lighting/pattern/templateImage: cannot be used: '" + path +
               "' is not a readable lighting template in the data directory";
    };
    for (const std::string path : {"/etc/passwd", "/etc/no-such-file", "/dev/zero", "../outside.tif", "missing.tif",
                                   "sub", "sub/../../x.tif"}) {
        EXPECT_EQ(refusal(path), expected(path)) << path;
    }
    // Inside and a file: it is read, and its contents are what is wrong.
    const std::string inside = refusal("sub/junk.tif");
    EXPECT_EQ(inside.rfind("/avatar/analysis: cannot be applied: ", 0), 0u) << inside;
    EXPECT_EQ(vision.status().configVersion, 1u);
}

TEST(VisionInterface, FailuresAreTypedByKind) {
    // A timed-out snapshot is TimedOut: nothing can be acquired in 0 ms.
    VisionInterface vision(test::sphereSimulation(), test::sphereSceneConfig());
    EXPECT_THROW(vision.snapshot(std::chrono::milliseconds(0)), TimedOut);
    // Searching on a source that has no more pairs is InvalidState.
    const auto dir = std::filesystem::temp_directory_path() / ("avatar-vision-typed-" + std::to_string(::getpid()));
    std::filesystem::remove_all(dir);
    {
        VisionOptions options;
        options.recordDirectory = dir;
        VisionInterface recorder(test::sphereSimulation(), test::sphereSceneConfig(), options);
        recorder.snapshot();
        ASSERT_TRUE(eventually([&] { return recorder.status().recorded == 1; }));
    }
    VisionInterface replay(std::make_unique<RawDataAcquire>(dir), test::sphereSceneConfig());
    replay.snapshot();
    EXPECT_THROW(replay.snapshot(), AcquisitionError);  // the recording is over
    try {
        replay.startSearching();
        ADD_FAILURE() << "searching";
    } catch (const InvalidState& e) {
        EXPECT_NE(std::string(e.what()).find("has no more pairs"), std::string::npos) << e.what();
    }
    std::filesystem::remove_all(dir);
}

TEST(VisionInterface, RecordsEveryPairAndReplaysItBitForBit) {
    const auto dir = std::filesystem::temp_directory_path() /
                     ("avatar-vision-record-" + std::to_string(::getpid()));
    std::filesystem::remove_all(dir);
    std::vector<VisionTargets> live;
    {
        VisionOptions options;
        options.recordDirectory = dir;
        options.recordPng = true;
        VisionInterface vision(test::sphereSimulation(), test::sphereSceneConfig(), options);
        for (int i = 0; i < 3; ++i) live.push_back(vision.snapshot());
        AvatarConfig changed = test::sphereSceneConfig();
        changed.targets.targets[0].area = {100, 2e6};
        vision.applyConfig(writeConfigString(changed));
        live.push_back(vision.snapshot());
        ASSERT_TRUE(eventually([&] { return vision.status().recorded == 4; }));
        EXPECT_EQ(vision.status().unrecorded, 0u);
        EXPECT_EQ(vision.status().recordBacklog, 0u);
    }
    const SessionLogReader reader(dir);
    const auto records = reader.records();
    ASSERT_EQ(records.size(), 4u);
    EXPECT_TRUE(reader.errors().empty());
    EXPECT_TRUE(records[0].configXml.has_value());
    EXPECT_FALSE(records[1].configXml.has_value());
    EXPECT_EQ(records[3].configVersion, 2u);
    EXPECT_TRUE(records[3].configXml.has_value());
    EXPECT_EQ(records[3].acquisition.group, 2u);

    // Replaying the recording through a new VisionInterface gives the same targets.
    VisionInterface replay(std::make_unique<RawDataAcquire>(dir), test::sphereSceneConfig());
    for (std::size_t i = 0; i < live.size(); ++i) {
        const VisionTargets again = replay.snapshot();
        EXPECT_EQ(again.iteration, live[i].iteration);
        const auto differences = compareResults(live[i], again);
        EXPECT_TRUE(differences.empty()) << "iteration " << again.iteration << ": " << differences.front().field;
    }
    EXPECT_EQ(replay.status().configVersion, 2u);  // the recorded change was applied again
    EXPECT_THROW(replay.snapshot(), AcquisitionError);  // the recording is over
    EXPECT_EQ(replay.status().acquisition.state, AcquisitionStatus::State::Finished);
    std::filesystem::remove_all(dir);
}
