// What the backends report about their cameras (CameraReport.h): the survey
// of what a backend can reach (surveyBackend()) and the feature readback
// (readFeatures()) of the backends that run without hardware: replay (the
// bundled lab session), simulation (the lab scene) and files. FireWire is
// covered in FirewireTest.cpp (scripted bus), GenICam in GenICamTest.cpp
// (fake cameras).
#include "TempDir.h"
#include "TestUtil.h"

#include <avatar/acquire/AcquireSIPSimulation.h>
#include <avatar/acquire/AcquisitionBackends.h>
#include <avatar/acquire/CameraReport.h>
#include <avatar/acquire/RawDataAcquire.h>
#include <avatar/config/ConfigXml.h>

#include <gtest/gtest.h>

#include <filesystem>
#include <string>

namespace avatar {
namespace {

using test::messageOf;

const std::filesystem::path kData = AVATAR_DATA_DIR;

BackendRequest replayRequest(const std::filesystem::path& session) {
    BackendRequest r;
    r.name = "replay";
    r.session = session;
    return r;
}

TEST(CameraReport, FeatureNamesAreTheConfigElementsInDocumentOrder) {
    EXPECT_EQ(cameraFeatureNames(),
              (std::vector<std::string>{"exposure", "shutter", "gain", "whiteBalance", "brightness", "gamma"}));
}

TEST(CameraReport, ReplayReportsTheRecordedFeatureSet) {
    RawDataAcquire replay(kData / "sessions" / "lab");
    const auto before = replay.readFeatures();  // the initial configuration
    replay.acquire();
    const auto after = replay.readFeatures();  // the configuration of the pair delivered
    for (const auto* readback : {&before, &after}) {
        for (const CameraFeatureReadback& r : *readback) {
            EXPECT_EQ(r.cameraId, "");  // the lab session recorded no camera ids
            ASSERT_EQ(r.features.size(), 6u);
            EXPECT_EQ(r.feature("exposure").value, 300.0);
            EXPECT_EQ(r.feature("shutter").value, 400.0);
            EXPECT_EQ(r.feature("gain").value, 200.0);
            EXPECT_EQ(r.feature("whiteBalance").value, 80.0);
            EXPECT_EQ(r.feature("whiteBalance").redV, 60.0);
            EXPECT_EQ(r.feature("gamma").value, 1.0);
            for (const FeatureReading& f : r.features) {
                EXPECT_TRUE(f.present) << f.name;
                EXPECT_FALSE(f.autoAvailable) << f.name;
                EXPECT_FALSE(f.automatic) << f.name;
            }
        }
        EXPECT_EQ((*readback)[0].side, Side::Left);
        EXPECT_EQ((*readback)[1].side, Side::Right);
    }
}

TEST(CameraReport, SimulationHasNoAdjustableFeature) {
    const AvatarConfig config = readConfigFile(kData / "config" / "scorpion.xml");
    BackendRequest r;
    r.name = "simulation";
    r.scene = kData / "scenes" / "lab.xml";
    r.config = kData / "config" / "scorpion.xml";
    Backend b = makeBackend(r);
    const auto features = b.acquisition->readFeatures();
    EXPECT_EQ(features[0].cameraId, "sim-left");
    EXPECT_EQ(features[1].cameraId, "sim-right");
    for (const CameraFeatureReadback& c : features) {
        ASSERT_EQ(c.features.size(), 6u);
        for (const FeatureReading& f : c.features) {
            EXPECT_FALSE(f.present) << f.name;
            EXPECT_NE(f.note.find("simulated camera has no " + f.name), std::string::npos) << f.note;
        }
    }
    // Applying a configuration with automatic features is no error either.
    AvatarConfig automatic = config;
    automatic.camera.features.exposure.automatic = true;
    automatic.camera.features.whiteBalance.automatic = true;
    b.acquisition->applyConfig(automatic);
}

TEST(CameraReport, FilesBackendHasNoCamerasToReadFeaturesFrom) {
    test::TempDir dir;
    BackendRequest r;
    r.name = "files";
    r.leftFiles = (dir / "left_%04d.png").string();
    r.rightFiles = (dir / "right_%04d.png").string();
    r.config = kData / "config" / "scorpion.xml";
    Backend b = makeBackend(r);
    const std::string m = messageOf<NotAvailable>([&] { b.acquisition->readFeatures(); });
    EXPECT_NE(m.find("the files backend has no cameras"), std::string::npos) << m;
}

TEST(CameraReport, ReplaySurveyChecksTheSessionAndListsTheRecordedCameras) {
    const BackendSurvey s = surveyBackend(replayRequest(kData / "sessions" / "lab"));
    EXPECT_EQ(s.backend, "replay");
    EXPECT_TRUE(s.ok());
    ASSERT_EQ(s.checks.size(), 2u);
    EXPECT_NE(s.checks[0].detail.find("3 intact record(s), 0 damaged"), std::string::npos) << s.checks[0].detail;
    EXPECT_EQ(s.checks[1].detail, "all 6 present");
    ASSERT_EQ(s.cameras.size(), 2u);  // one left and one right id (both empty in the lab session)
    EXPECT_EQ(s.cameras[0].model, "recorded");
    EXPECT_NE(s.cameras[0].detail.find("left camera of 3 record(s)"), std::string::npos) << s.cameras[0].detail;
    EXPECT_NE(s.cameras[1].detail.find("right camera of 3 record(s)"), std::string::npos);

    // A session with a missing image file, and one that is not there at all.
    test::TempDir dir;
    std::filesystem::copy(kData / "sessions" / "lab", dir / "lab");
    std::filesystem::remove(dir / "lab" / "R_00001_00001_1280x960_16b_1c_BG_le.png");
    const BackendSurvey damaged = surveyBackend(replayRequest(dir / "lab"));
    EXPECT_FALSE(damaged.ok());
    EXPECT_NE(damaged.checks[1].detail.find("1 of 6 missing"), std::string::npos) << damaged.checks[1].detail;
    EXPECT_NE(damaged.checks[1].detail.find("R_00001_00001_1280x960_16b_1c_BG_le.png"), std::string::npos);
    const BackendSurvey absent = surveyBackend(replayRequest(dir / "nowhere"));
    EXPECT_FALSE(absent.ok());
    EXPECT_NE(absent.checks[0].detail.find("nowhere"), std::string::npos) << absent.checks[0].detail;
}

TEST(CameraReport, SimulationAndFilesSurveys) {
    BackendRequest sim;
    sim.name = "simulation";
    sim.scene = kData / "scenes" / "lab.xml";
    const BackendSurvey s = surveyBackend(sim);
    EXPECT_TRUE(s.ok());
    ASSERT_EQ(s.cameras.size(), 2u);
    EXPECT_EQ(s.cameras[0].id, "sim-left");
    EXPECT_EQ(s.cameras[1].id, "sim-right");
    EXPECT_EQ(s.cameras[0].model.rfind("simulated (scene ", 0), 0u) << s.cameras[0].model;
    sim.scene = kData / "scenes" / "no-such-scene.xml";
    const BackendSurvey noScene = surveyBackend(sim);
    EXPECT_FALSE(noScene.ok());
    EXPECT_NE(noScene.checks[0].detail.find("no-such-scene.xml"), std::string::npos);

    test::TempDir dir;
    BackendRequest files;
    files.name = "files";
    files.leftFiles = (dir / "left_%04d.png").string();
    files.rightFiles = (dir / "right_%04d.png").string();
    const BackendSurvey f = surveyBackend(files);
    EXPECT_FALSE(f.ok());
    ASSERT_EQ(f.checks.size(), 2u);
    EXPECT_EQ(f.checks[0].what, (dir / "left_0000.png").string());
    EXPECT_NE(f.checks[0].detail.find("does not exist"), std::string::npos);
    EXPECT_TRUE(f.cameras.empty());
    files.leftFiles = (dir / "left.png").string();  // no conversion: a bad pattern is a failed check
    EXPECT_FALSE(surveyBackend(files).ok());
}

TEST(CameraReport, UnknownBackendOrMissingOptionIsAnInvalidArgument) {
    BackendRequest r;
    r.name = "usb";
    const std::string m = messageOf<InvalidArgument>([&] { surveyBackend(r); });
    EXPECT_NE(m.find("unknown backend 'usb' (one of: replay, files, firewire, genicam, simulation)"),
              std::string::npos)
        << m;
    r.name = "replay";
    EXPECT_NE(messageOf<InvalidArgument>([&] { surveyBackend(r); }).find("--session DIR"), std::string::npos);
}

}  // namespace
}  // namespace avatar
