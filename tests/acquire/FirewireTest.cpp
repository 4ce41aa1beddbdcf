// AvatarCameras and AcquireSIPFirewire against a scripted FireWire bus
// (ScriptedFirewireBus.h), and the real libdc1394 bus on a machine without one.
#include "ScriptedFirewireBus.h"
#include "TempDir.h"
#include "TestUtil.h"

#include <avatar/acquire/AcquireSIPFirewire.h>
#include "AvatarCameras.h"
#include "FirewireBus.h"

#include <gtest/gtest.h>
#include <opencv2/core.hpp>

#include <sys/wait.h>
#include <unistd.h>

#include <chrono>
#include <filesystem>
#include <fstream>
#include <memory>
#include <string>
#include <vector>

using namespace avatar;
using avatar::test::BusScript;
using avatar::test::enumerationFails;
using avatar::test::expectedSample;
using avatar::test::found;
using avatar::test::frameAt;
using avatar::test::messageOf;
using avatar::test::ScriptedBus;
using avatar::test::timeoutEvent;
using State = AcquisitionStatus::State;
using std::chrono::milliseconds;

namespace {

constexpr FirewireGuid kLeft = 0x00b09d01004a2c1f;
constexpr FirewireGuid kRight = 0x00b09d01004a2c20;
constexpr FirewireGuid kOther = 0x00b09d0100000099;
const std::string L = "0x00b09d01004a2c1f";
const std::string R = "0x00b09d01004a2c20";
constexpr std::int64_t kT0 = 1'700'000'000'000'000;  // us since the epoch
constexpr std::int64_t kPeriod = 50'000;              // 20 frames/s

CameraHardwareConfig testCamera() {
    CameraHardwareConfig c;
    c.width = 8;
    c.height = 4;
    c.bitDepth = 12;
    c.channels = 1;
    c.bayer = true;
    c.bayerPattern = BayerPattern::GR;
    c.leftCameraId = L;
    c.rightCameraId = R;
    c.features.exposure = {300, false};
    c.features.shutter = {400, false};
    c.features.gain = {200, true};
    c.features.whiteBalance = {80, 60, false};
    c.features.brightness = {12, false};
    c.features.gamma = {1, true};
    return c;
}

AvatarConfig testConfig() {
    AvatarConfig c;
    c.camera = testCamera();
    return c;
}

/// The feature calls the bus must see for @p guid with testCamera()'s features.
std::vector<std::string> featureCalls(const std::string& guid, const std::string& gain = "200 auto") {
    return {"feature " + guid + " exposure 300 manual", "feature " + guid + " shutter 400 manual",
            "feature " + guid + " gain " + gain,         "feature " + guid + " brightness 12 manual",
            "feature " + guid + " gamma 1 auto",         "whitebalance " + guid + " 80/60 manual"};
}

std::vector<std::string> concat(std::vector<std::vector<std::string>> parts) {
    std::vector<std::string> out;
    for (auto& p : parts) out.insert(out.end(), p.begin(), p.end());
    return out;
}

::testing::AssertionResult contains(const std::string& text, const std::string& part) {
    if (text.find(part) != std::string::npos) return ::testing::AssertionSuccess();
    return ::testing::AssertionFailure() << "'" << text << "'\n does not contain '" << part << "'";
}

/// True when every sample of @p image is the scripted pattern for @p fill.
bool hasPattern(const cv::Mat& image, std::uint16_t fill) {
    const int bytes = image.depth() == CV_8U ? 1 : 2;
    for (int y = 0; y < image.rows; ++y)
        for (int x = 0; x < image.cols; ++x)
            for (int c = 0; c < image.channels(); ++c) {
                const std::uint32_t got = bytes == 1 ? image.ptr<std::uint8_t>(y)[x * image.channels() + c]
                                                     : image.ptr<std::uint16_t>(y)[x * image.channels() + c];
                // The pair is BGR; the camera sent RGB (channel 0 = red).
                const int sent = image.channels() == 3 ? 2 - c : c;
                if (got != expectedSample(fill, x, y, sent, bytes)) return false;
            }
    return true;
}

class FirewireTest : public ::testing::Test {
protected:
    FirewireTest() {
        options.settleDelay = milliseconds(7);
        options.settleRetries = 1;
        options.maxBusResets = 3;
        options.dequeueTimeout = milliseconds(100);
        options.timestampTolerance = std::chrono::microseconds(25'000);
        options.maxResyncDrops = 8;
        options.dmaBuffers = 4;
        options.maxRecoveryAttempts = 2;
        script->enumerations = {found({kLeft, kRight})};
    }
    void TearDown() override { EXPECT_TRUE(script->violations.empty()) << script->violations.front(); }

    AvatarCameras::SleepFunction sleeper() {
        return [this](milliseconds d) { sleeps.push_back(d); };
    }
    std::unique_ptr<AvatarCameras> makeCameras() {
        return std::make_unique<AvatarCameras>(std::make_unique<ScriptedBus>(script), options, sleeper());
    }
    std::unique_ptr<AcquireSIPFirewire> makeAcquisition() {
        return std::make_unique<AcquireSIPFirewire>(std::make_unique<ScriptedBus>(script), options, 99999,
                                                    sleeper());
    }
    /// @p n pairs in step, from frame @p first on: left fill 100 + i, right fill 500 + i.
    void steadyFrames(int first, int n) {
        for (int i = first; i < first + n; ++i) {
            script->add(kLeft, {frameAt(kT0 + i * kPeriod, static_cast<std::uint16_t>(100 + i))});
            script->add(kRight, {frameAt(kT0 + i * kPeriod + 300, static_cast<std::uint16_t>(500 + i))});
        }
    }

    std::shared_ptr<BusScript> script = std::make_shared<BusScript>();
    std::vector<milliseconds> sleeps;
    FirewireOptions options;
};

// ---- options, GUIDs, configuration checks -------------------------------------------------

TEST(FirewireOptions, DefaultsAreValidAndProblemsAreNamed) {
    EXPECT_EQ(FirewireOptions{}.validate(), "");
    FirewireOptions bad;
    bad.settleDelay = milliseconds(-1);
    bad.dmaBuffers = 0;
    bad.dequeueTimeout = milliseconds(0);
    EXPECT_EQ(bad.validate(),
              "settleDelay: must be >= 0 ms, got -1 ms; dequeueTimeout: must be > 0 ms, got 0 ms; "
              "dmaBuffers: must be 1..64, got 0");
    auto script = std::make_shared<BusScript>();
    EXPECT_EQ(messageOf<InvalidArgument>([&] { AvatarCameras c(std::make_unique<ScriptedBus>(script), bad); }),
              "FireWire options: " + bad.validate());
    EXPECT_EQ(messageOf<InvalidArgument>([&] { AvatarCameras c(nullptr); }), "AvatarCameras: no FireWire bus given");
}

TEST(FirewireGuid, ParsesAndFormatsTheConfigSpelling) {
    EXPECT_EQ(formatGuid(kLeft), L);
    EXPECT_EQ(formatGuid(0x1), "0x0000000000000001");
    EXPECT_EQ(parseGuid(L), kLeft);
    EXPECT_EQ(parseGuid("0XB09D01004A2C1F"), kLeft);
    EXPECT_EQ(parseGuid("0xffffffffffffffff"), 0xffffffffffffffffULL);
    for (const char* bad : {"", "0x", "00b09d01004a2c1f", "0x00b09d01004a2c1g", "0x100b09d01004a2c1f", " 0x1"})
        EXPECT_FALSE(parseGuid(bad).has_value()) << bad;
}

TEST_F(FirewireTest, UnusableConfigurationsAreRejectedBeforeTouchingTheBus) {
    auto cameras = makeCameras();
    CameraHardwareConfig c = testCamera();
    c.leftCameraId.clear();
    EXPECT_TRUE(contains(messageOf<InvalidArgument>([&] { cameras->configure(c); }),
                "FireWire needs camera.leftCameraId, the GUID of the left camera"));
    c = testCamera();
    c.rightCameraId = "cam2";
    EXPECT_EQ(messageOf<InvalidArgument>([&] { cameras->configure(c); }),
              "camera.rightCameraId 'cam2' is not an IIDC GUID (expected 0x and 1 to 16 hex digits, e.g. "
              "0x00b09d01004a2c1f)");
    c = testCamera();
    c.rightCameraId = "0xB09D01004A2C1F";  // the left camera, spelt differently
    EXPECT_EQ(messageOf<InvalidArgument>([&] { cameras->configure(c); }),
              "camera.leftCameraId and camera.rightCameraId name the same camera 0x00b09d01004a2c1f: a stereo "
              "pair needs two cameras");
    c = testCamera();
    c.features.gain.value = 300.5;
    EXPECT_EQ(messageOf<InvalidArgument>([&] { cameras->configure(c); }),
              "camera.features.gain.value must be an integer in 0..4095 (IIDC), got 300.5");
    c = testCamera();
    c.features.whiteBalance.redV = 5000;
    EXPECT_TRUE(contains(messageOf<InvalidArgument>([&] { cameras->configure(c); }),
                "whiteBalance.redV must be an integer in 0..4095 (IIDC), got 5000"));
    EXPECT_TRUE(script->calls.empty());
    EXPECT_FALSE(cameras->running());
}

TEST(FirewireFormat7, CodingFollowsChannelsBayerAndBitDepth) {
    CameraHardwareConfig c = testCamera();
    EXPECT_EQ(AvatarCameras::format7For(c), (Format7Settings{0, 0, 8, 4, PixelCoding::Raw16}));
    c.bitDepth = 8;
    EXPECT_EQ(AvatarCameras::format7For(c).coding, PixelCoding::Raw8);
    c.bayer = false;
    EXPECT_EQ(AvatarCameras::format7For(c).coding, PixelCoding::Mono8);
    c.bitDepth = 10;
    EXPECT_EQ(AvatarCameras::format7For(c).coding, PixelCoding::Mono16);
    c.channels = 3;
    EXPECT_EQ(AvatarCameras::format7For(c).coding, PixelCoding::Rgb16);
    c.bitDepth = 8;
    EXPECT_EQ(AvatarCameras::format7For(c).coding, PixelCoding::Rgb8);
}

// ---- start-up -----------------------------------------------------------------------------------

TEST_F(FirewireTest, StartsBothCamerasAndGrabsNumberedPairs) {
    auto acquisition = makeAcquisition();
    EXPECT_EQ(acquisition->name(), "firewire");
    EXPECT_EQ(acquisition->status().state, State::Failed);
    EXPECT_EQ(acquisition->status().message, "FireWire cameras not started: no configuration applied yet");

    acquisition->applyConfig(testConfig());
    EXPECT_EQ(acquisition->lastChange(), CameraChange::Cameras);
    EXPECT_EQ(script->calls, concat({{"enumerate", "open " + L, "open " + R, "format7 " + L + " 8x4 RAW16"},
                                     featureCalls(L),
                                     {"format7 " + R + " 8x4 RAW16"},
                                     featureCalls(R),
                                     {"start " + L + " 4", "start " + R + " 4"}}));
    EXPECT_TRUE(sleeps.empty());
    EXPECT_EQ(acquisition->status().state, State::Ok);

    steadyFrames(0, 2);
    const AcquiredPair first = acquisition->acquire();
    EXPECT_EQ(first.pair.id().group, 1u);
    EXPECT_EQ(first.pair.id().member, 0u);
    EXPECT_EQ(first.pair.id().left, (CameraStamp{L, kT0}));
    EXPECT_EQ(first.pair.id().right, (CameraStamp{R, kT0 + 300}));
    EXPECT_EQ(first.pair.size(), cv::Size(8, 4));
    EXPECT_EQ(first.pair.cvType(), CV_16UC1);
    EXPECT_EQ(first.pair.layout().format, PixelFormat::Bayer);
    EXPECT_EQ(first.pair.layout().bayerPattern, BayerPattern::GR);
    EXPECT_EQ(first.pair.layout().bitDepth, 12);
    EXPECT_TRUE(first.pair.ownsPixels());
    EXPECT_TRUE(hasPattern(first.pair.left(), 100));
    EXPECT_TRUE(hasPattern(first.pair.right(), 500));
    EXPECT_EQ(first.pair.left().at<std::uint16_t>(3, 7), 100 + 7 + 6);
    EXPECT_EQ(script->outstanding(), 0);  // copied, buffers given back at once

    const AcquiredPair second = acquisition->acquire();
    EXPECT_EQ(second.pair.id().member, 1u);
    EXPECT_EQ(second.pair.id().left.timestampUs, kT0 + kPeriod);
    EXPECT_TRUE(hasPattern(second.pair.left(), 101));
    EXPECT_TRUE(hasPattern(second.pair.right(), 501));
    EXPECT_TRUE(hasPattern(first.pair.left(), 100));  // the copy does not change under it
    EXPECT_EQ(acquisition->cameras().diagnostics().pairsGrabbed, 2u);
}

TEST_F(FirewireTest, GrabBeforeConfigureIsAnError) {
    auto cameras = makeCameras();
    EXPECT_EQ(messageOf<AcquisitionError>([&] { cameras->grabRawImagePair(); }),
              "FireWire cameras not started: apply a configuration first");
    EXPECT_TRUE(script->calls.empty());
}

TEST_F(FirewireTest, HotPlugWaitsForTheBusToSettle) {
    options.settleRetries = 2;
    script->enumerations = {enumerationFails(BusStatus::Code::Failure, "bus generation changed"), found({kLeft}),
                            found({kRight, kLeft})};
    auto cameras = makeCameras();
    EXPECT_EQ(cameras->configure(testCamera()), CameraChange::Cameras);
    EXPECT_EQ(script->callsFrom(0, "enumerate").size(), 3u);
    EXPECT_TRUE(script->callsFrom(0, "reset").empty());
    EXPECT_EQ(sleeps, (std::vector<milliseconds>{milliseconds(7), milliseconds(7)}));
    EXPECT_EQ(cameras->status().state, State::Ok);
    EXPECT_EQ(cameras->diagnostics().enumerations, 3u);
}

TEST_F(FirewireTest, BusResetNeededTwiceBeforeTheCamerasAppear) {
    script->enumerations = {found({}), found({}), found({kRight}), found({kLeft, kRight})};
    auto cameras = makeCameras();
    EXPECT_EQ(cameras->configure(testCamera()), CameraChange::Cameras);
    EXPECT_EQ(script->callsFrom(0, "e").size() + script->callsFrom(0, "r").size(), 6u);
    std::vector<std::string> order;
    for (const auto& c : script->calls)
        if (c == "enumerate" || c == "reset") order.push_back(c);
    EXPECT_EQ(order, (std::vector<std::string>{"enumerate", "enumerate", "reset", "enumerate", "reset", "enumerate"}));
    EXPECT_EQ(sleeps.size(), 3u);  // one settle retry, then a settle after each reset
    EXPECT_EQ(cameras->diagnostics().busResets, 2u);
    EXPECT_EQ(cameras->status().state, State::Ok);
}

TEST_F(FirewireTest, ResetsExhaustedMeansNoCamerasAndFailed) {
    script->enumerations = {found({})};
    auto acquisition = makeAcquisition();
    const std::string expected =
        "FireWire cameras not found after 5 enumeration(s) (1 settle retries, 3 bus resets, 7 ms settle delay): "
        "left camera 0x00b09d01004a2c1f and right camera 0x00b09d01004a2c20 not found; found: none";
    EXPECT_EQ(messageOf<AcquisitionError>([&] { acquisition->applyConfig(testConfig()); }), expected);
    EXPECT_EQ(acquisition->status().state, State::Failed);
    EXPECT_EQ(acquisition->status().message, expected);
    EXPECT_EQ(script->callsFrom(0, "reset").size(), 3u);
    EXPECT_TRUE(script->callsFrom(0, "open").empty());
    EXPECT_EQ(sleeps.size(), 4u);
    EXPECT_EQ(messageOf<AcquisitionError>([&] { acquisition->acquire(); }),
              "FireWire cameras not started: apply a configuration first");

    // Plugged in later: applying the configuration again starts them.
    script->enumerations = {found({kLeft, kRight})};
    acquisition->applyConfig(testConfig());
    EXPECT_EQ(acquisition->status().state, State::Ok);
}

TEST_F(FirewireTest, MissingCameraIsNamedWithWhatWasFound) {
    script->enumerations = {found({kLeft, kOther})};
    auto cameras = makeCameras();
    EXPECT_TRUE(contains(messageOf<AcquisitionError>([&] { cameras->configure(testCamera()); }),
                "right camera 0x00b09d01004a2c20 not found; found: 0x00b09d01004a2c1f, "
                          "0x00b09d0100000099"));
    EXPECT_EQ(cameras->status().state, State::Failed);
    EXPECT_TRUE(contains(cameras->status().message, "right camera 0x00b09d01004a2c20 not found"));
    EXPECT_FALSE(cameras->running());
}

TEST_F(FirewireTest, SameGuidTwiceOnTheBusIsAMisrecognitionThatAResetCanFix) {
    script->enumerations = {found({kLeft, kLeft, kRight})};
    auto cameras = makeCameras();
    EXPECT_TRUE(contains(messageOf<AcquisitionError>([&] { cameras->configure(testCamera()); }),
                "GUID 0x00b09d01004a2c1f appears 2 times on the bus (a misrecognised camera); found: "
                          "0x00b09d01004a2c1f, 0x00b09d01004a2c1f, 0x00b09d01004a2c20"));

    script->enumerations = {found({kLeft, kLeft, kRight}), found({kLeft, kLeft, kRight}), found({kLeft, kRight})};
    EXPECT_EQ(cameras->configure(testCamera()), CameraChange::Cameras);
    EXPECT_EQ(cameras->status().state, State::Ok);
}

TEST_F(FirewireTest, NoFireWireSupportIsNotRetried) {
    script->enumerations = {enumerationFails(BusStatus::Code::Unavailable, "dc1394_new failed")};
    auto cameras = makeCameras();
    EXPECT_EQ(messageOf<AcquisitionError>([&] { cameras->configure(testCamera()); }),
              "FireWire cameras not found after 1 enumeration(s) (0 settle retries, 0 bus resets, 7 ms settle "
              "delay): enumeration failed (unavailable): dc1394_new failed");
    EXPECT_TRUE(sleeps.empty());
}

// ---- lost cameras -----------------------------------------------------------------------------

TEST_F(FirewireTest, CameraTimingOutMidRunIsNamedRecoveredAndNumberingContinues) {
    auto acquisition = makeAcquisition();
    acquisition->applyConfig(testConfig());
    steadyFrames(0, 1);
    script->add(kLeft, {frameAt(kT0 + kPeriod, 101)});
    script->add(kRight, {timeoutEvent()});
    steadyFrames(5, 2);

    EXPECT_EQ(acquisition->acquire().pair.id().member, 0u);
    const std::size_t mark = script->calls.size();
    EXPECT_EQ(messageOf<AcquisitionError>([&] { acquisition->acquire(); }),
              "right camera 0x00b09d01004a2c20: no frame within 100 ms");
    EXPECT_EQ(acquisition->status().state, State::Recovering);
    EXPECT_EQ(acquisition->status().message,
              "right camera 0x00b09d01004a2c20: no frame within 100 ms; recovering at the next grab (attempt 1 of 2)");
    EXPECT_EQ(script->outstanding(), 0);  // the left frame went back
    EXPECT_EQ(script->callsFrom(mark),
              (std::vector<std::string>{"dequeue " + L, "dequeue " + R, "enqueue " + L + " 0"}));

    const std::size_t recoveryMark = script->calls.size();
    const AcquiredPair recovered = acquisition->acquire();
    const std::vector<std::string> recovery = script->callsFrom(recoveryMark);
    ASSERT_GE(recovery.size(), 7u);
    EXPECT_EQ(std::vector<std::string>(recovery.begin(), recovery.begin() + 7),
              (std::vector<std::string>{"stop " + L, "stop " + R, "close " + L, "close " + R, "reset", "enumerate",
                                        "open " + L}));
    EXPECT_EQ(recovered.pair.id().group, 1u);
    EXPECT_EQ(recovered.pair.id().member, 1u);
    EXPECT_TRUE(hasPattern(recovered.pair.left(), 105));
    EXPECT_TRUE(hasPattern(recovered.pair.right(), 505));
    EXPECT_EQ(acquisition->status().state, State::Ok);
    EXPECT_EQ(acquisition->status().message, "");
    EXPECT_EQ(acquisition->acquire().pair.id().member, 2u);
    EXPECT_EQ(acquisition->cameras().diagnostics().recoveries, 1u);
    EXPECT_EQ(acquisition->cameras().diagnostics().cameraFailures, 1u);
    EXPECT_EQ(sleeps.size(), 1u);  // the settle delay after the recovery's bus reset
}

TEST_F(FirewireTest, RecoveryIsBoundedThenFailedUntilReconfigured) {
    auto cameras = makeCameras();
    cameras->configure(testCamera());
    script->add(kLeft, {frameAt(kT0, 1)});
    script->add(kRight, {timeoutEvent()});
    EXPECT_EQ(messageOf<AcquisitionError>([&] { cameras->grabRawImagePair(); }),
              "right camera 0x00b09d01004a2c20: no frame within 100 ms");

    script->enumerations = {found({kLeft})};  // the loose cable: the right camera is gone
    EXPECT_TRUE(contains(messageOf<AcquisitionError>([&] { cameras->grabRawImagePair(); }),
                "recovery attempt 1 of 2 failed: FireWire cameras not found after 2 enumeration(s)"));
    EXPECT_EQ(cameras->status().state, State::Recovering);
    const std::string gaveUp = messageOf<AcquisitionError>([&] { cameras->grabRawImagePair(); });
    EXPECT_TRUE(contains(gaveUp, "gave up after 2 recovery attempt(s); lost right camera 0x00b09d01004a2c20: no "
                                  "frame within 100 ms; last attempt: FireWire cameras not found"));
    EXPECT_EQ(cameras->status().state, State::Failed);
    EXPECT_EQ(cameras->status().message, gaveUp);

    const std::size_t mark = script->calls.size();
    EXPECT_EQ(messageOf<AcquisitionError>([&] { cameras->grabRawImagePair(); }), gaveUp);
    EXPECT_EQ(script->calls.size(), mark);  // failed: no more bus traffic

    script->enumerations = {found({kLeft, kRight})};  // cable fixed, operator re-applies the configuration
    EXPECT_EQ(cameras->configure(testCamera()), CameraChange::Cameras);
    EXPECT_EQ(cameras->status().state, State::Ok);
    script->add(kLeft, {frameAt(kT0 + kPeriod, 2)});
    script->add(kRight, {frameAt(kT0 + kPeriod, 3)});
    EXPECT_EQ(cameras->grabRawImagePair().right.timestampUs, kT0 + kPeriod);
}

TEST_F(FirewireTest, CaptureErrorIsACameraFailureToo) {
    auto cameras = makeCameras();
    cameras->configure(testCamera());
    script->add(kLeft, {avatar::test::failureEvent("iso channel lost")});
    EXPECT_EQ(messageOf<AcquisitionError>([&] { cameras->grabRawImagePair(); }),
              "left camera 0x00b09d01004a2c1f: capture failed (failure): iso channel lost");
    EXPECT_EQ(cameras->status().state, State::Recovering);
}

// ---- pairing -------------------------------------------------------------------------------------

TEST_F(FirewireTest, MismatchedTimestampsAreResynchronised) {
    auto cameras = makeCameras();
    cameras->configure(testCamera());
    // The left camera is one frame ahead: its first frame has no partner.
    script->add(kLeft, {frameAt(kT0, 1), frameAt(kT0 + kPeriod, 2)});
    script->add(kRight, {frameAt(kT0 + kPeriod - 1000, 9)});
    const std::size_t mark = script->calls.size();
    const RawFramePair pair = cameras->grabRawImagePair();
    EXPECT_EQ(pair.left.timestampUs, kT0 + kPeriod);
    EXPECT_EQ(pair.right.timestampUs, kT0 + kPeriod - 1000);
    EXPECT_EQ(pair.leftGuid, kLeft);
    EXPECT_EQ(pair.rightGuid, kRight);
    EXPECT_EQ(script->callsFrom(mark), (std::vector<std::string>{"dequeue " + L, "dequeue " + R,
                                                                  "enqueue " + L + " 0", "dequeue " + L}));
    EXPECT_EQ(cameras->diagnostics().framesDroppedForSync, 1u);

    // Now the right camera is behind by two frames.
    script->add(kLeft, {frameAt(kT0 + 4 * kPeriod, 3)});
    script->add(kRight, {frameAt(kT0 + 2 * kPeriod, 10), frameAt(kT0 + 3 * kPeriod, 11),
                         frameAt(kT0 + 4 * kPeriod + 20'000, 12)});
    const RawFramePair later = cameras->grabRawImagePair();
    EXPECT_EQ(later.left.timestampUs, kT0 + 4 * kPeriod);
    EXPECT_EQ(later.right.timestampUs, kT0 + 4 * kPeriod + 20'000);  // within 25 ms
    EXPECT_EQ(cameras->diagnostics().framesDroppedForSync, 3u);
    EXPECT_EQ(cameras->status().state, State::Ok);
}

TEST_F(FirewireTest, NeverReturnsAMismatchedPair) {
    options.maxResyncDrops = 2;
    auto cameras = makeCameras();
    cameras->configure(testCamera());
    // Always half a period apart: no two frames belong together.
    script->add(kLeft, {frameAt(kT0, 1), frameAt(kT0 + 100'000, 2)});
    script->add(kRight, {frameAt(kT0 + 50'000, 3), frameAt(kT0 + 150'000, 4)});
    const std::string message = messageOf<AcquisitionError>([&] { cameras->grabRawImagePair(); });
    EXPECT_EQ(message, "left and right frames do not belong together: capture times " +
                           std::to_string(kT0 + 100'000) + " and " + std::to_string(kT0 + 150'000) +
                           " us differ by more than 25000 us after dropping 2 frame(s)");
    EXPECT_EQ(cameras->status().state, State::Recovering);
    EXPECT_EQ(cameras->status().message, message);
    EXPECT_EQ(script->outstanding(), 0);

    script->add(kLeft, {frameAt(kT0 + 200'000, 5)});
    script->add(kRight, {frameAt(kT0 + 200'100, 6)});
    EXPECT_EQ(cameras->grabRawImagePair().left.timestampUs, kT0 + 200'000);
    EXPECT_EQ(cameras->status().state, State::Ok);
}

// ---- configuration changes ----------------------------------------------------------------

TEST_F(FirewireTest, FeaturesAreSentWithExactValuesAndAutoFlags) {
    auto cameras = makeCameras();
    cameras->configure(testCamera());
    std::vector<std::string> leftFeatures = featureCalls(L);
    leftFeatures.pop_back();  // white balance
    EXPECT_EQ(script->callsFrom(0, "feature " + L), leftFeatures);
    EXPECT_EQ(script->callsFrom(0, "whitebalance"),
              (std::vector<std::string>{"whitebalance " + L + " 80/60 manual", "whitebalance " + R + " 80/60 manual"}));

    CameraHardwareConfig c = testCamera();
    c.features.exposure = {0, true};
    c.features.whiteBalance = {80, 60, true};
    c.features.gain = {4095, false};
    const std::size_t mark = script->calls.size();
    EXPECT_EQ(cameras->configure(c), CameraChange::Features);
    EXPECT_EQ(script->callsFrom(mark),
              (std::vector<std::string>{
                  "feature " + L + " exposure 0 auto", "feature " + L + " shutter 400 manual",
                  "feature " + L + " gain 4095 manual", "feature " + L + " brightness 12 manual",
                  "feature " + L + " gamma 1 auto", "whitebalance " + L + " 80/60 auto",
                  "feature " + R + " exposure 0 auto", "feature " + R + " shutter 400 manual",
                  "feature " + R + " gain 4095 manual", "feature " + R + " brightness 12 manual",
                  "feature " + R + " gamma 1 auto", "whitebalance " + R + " 80/60 auto"}));
    EXPECT_EQ(cameras->settings()->features, c.features);
}

TEST_F(FirewireTest, FeatureChangeKeepsCaptureRunningAndStartsANewGroup) {
    auto acquisition = makeAcquisition();
    acquisition->applyConfig(testConfig());
    steadyFrames(0, 3);
    acquisition->acquire();

    AvatarConfig c = testConfig();
    c.camera.features.gain = {250, false};
    const std::size_t mark = script->calls.size();
    acquisition->applyConfig(c);
    EXPECT_EQ(acquisition->lastChange(), CameraChange::Features);
    EXPECT_TRUE(script->callsFrom(mark, "stop").empty());
    EXPECT_TRUE(script->callsFrom(mark, "start").empty());
    EXPECT_TRUE(script->callsFrom(mark, "format7").empty());
    EXPECT_EQ(script->callsFrom(mark, "feature " + R + " gain"),
              (std::vector<std::string>{"feature " + R + " gain 250 manual"}));
    const AcquiredPair next = acquisition->acquire();
    EXPECT_EQ(next.pair.id().group, 2u);
    EXPECT_EQ(next.pair.id().member, 0u);
    EXPECT_TRUE(hasPattern(next.pair.left(), 101));
}

TEST_F(FirewireTest, RoiOrDepthChangeRestartsCapture) {
    auto acquisition = makeAcquisition();
    acquisition->applyConfig(testConfig());

    AvatarConfig c = testConfig();
    c.camera.width = 6;
    c.camera.bitDepth = 8;
    const std::size_t mark = script->calls.size();
    acquisition->applyConfig(c);
    EXPECT_EQ(acquisition->lastChange(), CameraChange::Capture);
    EXPECT_EQ(script->callsFrom(mark), concat({{"stop " + L, "stop " + R, "format7 " + L + " 6x4 RAW8"},
                                               featureCalls(L),
                                               {"format7 " + R + " 6x4 RAW8"},
                                               featureCalls(R),
                                               {"start " + L + " 4", "start " + R + " 4"}}));
    EXPECT_TRUE(script->callsFrom(mark, "enumerate").empty());  // same cameras, not reopened
    steadyFrames(0, 1);
    const AcquiredPair pair = acquisition->acquire();
    EXPECT_EQ(pair.pair.size(), cv::Size(6, 4));
    EXPECT_EQ(pair.pair.cvType(), CV_8UC1);
    EXPECT_EQ(pair.pair.layout().bitDepth, 8);
    EXPECT_TRUE(hasPattern(pair.pair.right(), 500));

    // 12 -> 16 significant bits: same RAW16 coding on the wire, nothing to tell the cameras.
    c = testConfig();
    c.camera.bitDepth = 16;
    acquisition->applyConfig(testConfig());
    const std::size_t noChange = script->calls.size();
    acquisition->applyConfig(c);
    EXPECT_EQ(acquisition->lastChange(), CameraChange::None);
    EXPECT_EQ(script->calls.size(), noChange);
    steadyFrames(1, 1);
    EXPECT_EQ(acquisition->acquire().pair.layout().bitDepth, 16);
}

TEST_F(FirewireTest, FeatureFailureKeepsTheOldSettings) {
    auto acquisition = makeAcquisition();
    acquisition->applyConfig(testConfig());
    steadyFrames(0, 2);
    acquisition->acquire();
    const std::uint32_t group = acquisition->nextGroup();
    const std::uint32_t member = acquisition->nextMember();

    script->failOn("feature " + R + " gain 777");
    AvatarConfig c = testConfig();
    c.camera.features.gain = {777, false};
    const std::size_t mark = script->calls.size();
    EXPECT_EQ(messageOf<AcquisitionError>([&] { acquisition->applyConfig(c); }),
              "right camera 0x00b09d01004a2c20: cannot set gain to 777: scripted: value out of range");
    // Left got 777, right refused; both are put back to the old set.
    EXPECT_EQ(script->callsFrom(mark, "feature " + L + " gain"),
              (std::vector<std::string>{"feature " + L + " gain 777 manual", "feature " + L + " gain 200 auto"}));
    EXPECT_EQ(script->callsFrom(mark, "feature " + R + " gain"),
              (std::vector<std::string>{"feature " + R + " gain 777 manual", "feature " + R + " gain 200 auto"}));
    EXPECT_EQ(acquisition->cameras().settings()->features, testCamera().features);
    EXPECT_EQ(acquisition->status().state, State::Ok);
    EXPECT_EQ(acquisition->nextGroup(), group);
    EXPECT_EQ(acquisition->nextMember(), member);
    EXPECT_EQ(acquisition->acquire().pair.id().member, 1u);
}

TEST_F(FirewireTest, RoiFailureRestartsCaptureWithTheOldRoi) {
    auto acquisition = makeAcquisition();
    acquisition->applyConfig(testConfig());
    script->failOn("format7 " + L + " 6x4");
    AvatarConfig c = testConfig();
    c.camera.width = 6;
    EXPECT_EQ(messageOf<AcquisitionError>([&] { acquisition->applyConfig(c); }),
              "left camera 0x00b09d01004a2c1f: Format7 6x4 RAW16 rejected: scripted: mode not supported");
    EXPECT_EQ(script->callsFrom(0, "format7 " + L).back(), "format7 " + L + " 8x4 RAW16");
    EXPECT_EQ(script->callsFrom(0, "start").size(), 4u);
    EXPECT_EQ(acquisition->cameras().settings()->width, 8);
    steadyFrames(0, 1);
    EXPECT_EQ(acquisition->acquire().pair.size(), cv::Size(8, 4));
    EXPECT_EQ(acquisition->status().state, State::Ok);
}

TEST_F(FirewireTest, FailedRestoreIsRecoveredAtTheNextGrab) {
    auto cameras = makeCameras();
    cameras->configure(testCamera());
    script->failOn("start " + R, 2);  // new settings and the restore both fail to start
    CameraHardwareConfig c = testCamera();
    c.height = 2;
    EXPECT_TRUE(contains(messageOf<AcquisitionError>([&] { cameras->configure(c); }),
                "right camera 0x00b09d01004a2c20: cannot start capture with 4 DMA buffers"));
    EXPECT_EQ(cameras->status().state, State::Recovering);
    EXPECT_TRUE(contains(cameras->status().message, "nor restore the previous ones"));
    steadyFrames(0, 1);
    const RawFramePair pair = cameras->grabRawImagePair();  // recovered with the old 8x4
    EXPECT_EQ(pair.left.height, 4);
    EXPECT_EQ(cameras->status().state, State::Ok);
}

// ---- pixel handling ---------------------------------------------------------------------------

TEST_F(FirewireTest, ZeroCopyViewLivesUntilTheNextAcquire) {
    options.zeroCopyViews = true;
    auto acquisition = makeAcquisition();
    acquisition->applyConfig(testConfig());
    steadyFrames(0, 2);
    const AcquiredPair view = acquisition->acquire();
    EXPECT_FALSE(view.pair.ownsPixels());
    EXPECT_EQ(view.pair.left().data, script->buffers[kLeft][0]);
    EXPECT_EQ(view.pair.left().step, 8u * 2u + 8u);  // the camera's padded stride
    EXPECT_TRUE(hasPattern(view.pair.left(), 100));
    EXPECT_TRUE(hasPattern(view.pair.right(), 500));
    const StereoImagePair kept = view.pair.clone();
    EXPECT_EQ(script->outstanding(), 2);  // held while the caller uses the view

    const std::size_t mark = script->calls.size();
    acquisition->acquire();
    EXPECT_EQ(script->callsFrom(mark, "enqueue"),
              (std::vector<std::string>{"enqueue " + L + " 0", "enqueue " + R + " 0"}));
    EXPECT_EQ(script->calls[mark], "enqueue " + L + " 0");  // given back before dequeuing again
    EXPECT_TRUE(hasPattern(kept.left(), 100));
}

TEST_F(FirewireTest, RgbFramesBecomeBgrCopies) {
    options.zeroCopyViews = true;  // not possible for RGB: converted anyway
    auto acquisition = makeAcquisition();
    AvatarConfig c = testConfig();
    c.camera.channels = 3;
    c.camera.bayer = false;
    c.camera.bitDepth = 8;
    acquisition->applyConfig(c);
    EXPECT_EQ(script->callsFrom(0, "format7 " + R), (std::vector<std::string>{"format7 " + R + " 8x4 RGB8"}));
    steadyFrames(0, 1);
    const AcquiredPair pair = acquisition->acquire();
    EXPECT_TRUE(pair.pair.ownsPixels());
    EXPECT_EQ(pair.pair.cvType(), CV_8UC3);
    EXPECT_EQ(pair.pair.layout().format, PixelFormat::Bgr);
    EXPECT_TRUE(hasPattern(pair.pair.left(), 100));
    EXPECT_EQ(pair.pair.left().at<cv::Vec3b>(0, 0), cv::Vec3b(120, 110, 100));  // B, G, R
    EXPECT_EQ(script->outstanding(), 0);
}

TEST_F(FirewireTest, StopReleasesTheCameras) {
    auto cameras = makeCameras();
    cameras->configure(testCamera());
    steadyFrames(0, 1);
    cameras->grabRawImagePair();
    cameras->stop();
    EXPECT_FALSE(cameras->running());
    EXPECT_EQ(script->callsFrom(0, "close").size(), 2u);
    EXPECT_EQ(script->outstanding(), 0);
    EXPECT_EQ(cameras->status().message, "FireWire cameras stopped");
}

// ---- features a camera lacks, feature readback, survey --------------------------------------------

TEST_F(FirewireTest, FeatureACameraLacksIsSkippedAndReportedNotAFailure) {
    script->absent[kRight] = {"gain", "whiteBalance", "exposure auto"};
    auto acquisition = makeAcquisition();
    CameraHardwareConfig c = testCamera();
    c.features.exposure = {0, true};  // the right camera has exposure, but no automatic exposure
    AvatarConfig config;
    config.camera = c;
    acquisition->applyConfig(config);  // does not throw
    EXPECT_EQ(acquisition->status().state, State::Ok);
    // Everything else still went to both cameras.
    EXPECT_EQ(script->callsFrom(0, "feature " + R + " brightness"),
              (std::vector<std::string>{"feature " + R + " brightness 12 manual"}));
    EXPECT_EQ(script->callsFrom(0, "feature " + R + " gamma"),
              (std::vector<std::string>{"feature " + R + " gamma 1 auto"}));

    const auto features = acquisition->readFeatures();
    EXPECT_EQ(features[0].side, Side::Left);
    EXPECT_EQ(features[0].cameraId, L);
    EXPECT_EQ(features[1].cameraId, R);
    ASSERT_EQ(features[0].features.size(), cameraFeatureNames().size());
    for (std::size_t i = 0; i < cameraFeatureNames().size(); ++i)
        EXPECT_EQ(features[1].features[i].name, cameraFeatureNames()[i]);
    // The left camera has everything, set as configured.
    const FeatureReading& leftWb = features[0].feature("whiteBalance");
    EXPECT_TRUE(leftWb.present);
    EXPECT_EQ(leftWb.value, 80.0);
    EXPECT_EQ(leftWb.redV, 60.0);
    EXPECT_FALSE(leftWb.automatic);
    EXPECT_TRUE(features[0].feature("exposure").automatic);
    EXPECT_EQ(features[0].feature("brightness").value, 12.0);
    // The right camera lacks gain and white balance (named), and has exposure without its automatic mode.
    const FeatureReading& gain = features[1].feature("gain");
    EXPECT_FALSE(gain.present);
    EXPECT_TRUE(contains(gain.note, "no gain feature"));
    EXPECT_FALSE(features[1].feature("whiteBalance").present);
    const FeatureReading& exposure = features[1].feature("exposure");
    EXPECT_TRUE(exposure.present);
    EXPECT_FALSE(exposure.autoAvailable);
    EXPECT_FALSE(exposure.automatic);
    EXPECT_EQ(features[1].feature("shutter").value, 400.0);
    EXPECT_NE(messageOf<InvalidArgument>([&] { features[1].feature("zoom"); }).find("'zoom'"), std::string::npos);
}

TEST_F(FirewireTest, AutomaticFeaturesReadBackWhatTheCameraChose) {
    script->autoValues[kLeft]["gain"] = {310, 320, 321};
    auto acquisition = makeAcquisition();
    acquisition->applyConfig(testConfig());  // gain automatic
    EXPECT_EQ(acquisition->readFeatures()[0].feature("gain").value, 310.0);
    EXPECT_EQ(acquisition->readFeatures()[0].feature("gain").value, 320.0);
    const auto settled = acquisition->readFeatures();
    EXPECT_EQ(settled[0].feature("gain").value, 321.0);
    EXPECT_TRUE(settled[0].feature("gain").automatic);
    EXPECT_TRUE(settled[0].feature("gain").autoAvailable);
}

TEST_F(FirewireTest, ReadingFeaturesBeforeTheCamerasStartIsAnError) {
    auto acquisition = makeAcquisition();
    EXPECT_TRUE(contains(messageOf<AcquisitionError>([&] { acquisition->readFeatures(); }), "not started"));
}

TEST_F(FirewireTest, SurveyListsTheCamerasAndChecksTheDeviceNodes) {
    avatar::test::TempDir dev("avatar-fw-dev");
    for (const char* node : {"fw0", "fw1", "fwx", "video0"}) std::ofstream(dev / node) << "";
    std::filesystem::permissions(dev / "fw0", std::filesystem::perms::owner_read | std::filesystem::perms::owner_write |
                                                  std::filesystem::perms::group_read |
                                                  std::filesystem::perms::group_write |
                                                  std::filesystem::perms::others_read |
                                                  std::filesystem::perms::others_write);
    std::filesystem::permissions(dev / "fw1", std::filesystem::perms::none);
    ScriptedBus bus(script);
    const BackendSurvey s = surveyFirewire(bus, dev.path());
    EXPECT_EQ(s.backend, "firewire");
    ASSERT_GE(s.checks.size(), 3u);
    EXPECT_EQ(s.checks[0].what, (dev / "fw0").string());  // fwx and video0 are not FireWire nodes
    EXPECT_TRUE(s.checks[0].ok) << s.checks[0].detail;
    EXPECT_TRUE(contains(s.checks[0].detail, "-rw-"));
    EXPECT_EQ(s.checks[1].what, (dev / "fw1").string());
    // fw1 (mode 000) fails for anyone but root, who may read and write anything: check it as an
    // unprivileged user in a child process when the test runs as root.
    const auto checkUnreadable = [&](const BackendSurvey& survey) {
        return survey.checks.size() > 1 && !survey.checks[1].ok &&
               survey.checks[1].detail.find("---------- ") != std::string::npos &&
               survey.checks[1].detail.find("cannot read and write it") != std::string::npos &&
               survey.checks[0].ok && !survey.ok();
    };
    if (::geteuid() != 0) {
        EXPECT_TRUE(checkUnreadable(s)) << s.checks[1].detail;
    } else {
        const pid_t child = ::fork();
        ASSERT_GE(child, 0);
        if (child == 0) {
            if (::setgid(65534) != 0 || ::setuid(65534) != 0) ::_exit(3);
            ScriptedBus childBus(script);
            ::_exit(checkUnreadable(surveyFirewire(childBus, dev.path())) ? 0 : 1);
        }
        int status = 0;
        ::waitpid(child, &status, 0);
        ASSERT_TRUE(WIFEXITED(status));
        if (WEXITSTATUS(status) == 3) GTEST_SKIP() << "cannot become an unprivileged user to check permissions";
        EXPECT_EQ(WEXITSTATUS(status), 0) << "as user 65534 the survey must say fw1 cannot be read and written";
    }
    EXPECT_EQ(s.checks[2].what, "scripted");
    EXPECT_TRUE(s.checks[2].ok);
    EXPECT_TRUE(contains(s.checks[2].detail, "2 camera(s) on the bus"));
    ASSERT_EQ(s.cameras.size(), 2u);
    EXPECT_EQ(s.cameras[0].id, L);
    EXPECT_EQ(s.cameras[1].id, R);
    EXPECT_EQ(s.cameras[0].model, "Scripted IIDC camera");
    EXPECT_TRUE(s.cameras[0].reachable);
    EXPECT_TRUE(script->violations.empty());

    // No nodes, no cameras: both are failed checks that say what to do.
    avatar::test::TempDir empty("avatar-fw-none");
    script->enumerations = {found({})};
    const BackendSurvey none = surveyFirewire(bus, empty.path());
    EXPECT_FALSE(none.ok());
    EXPECT_TRUE(contains(none.checks.front().detail, "modprobe firewire-ohci"));
    EXPECT_EQ(none.checks.back().what, "cameras");
    EXPECT_FALSE(none.checks.back().ok);
    EXPECT_TRUE(none.cameras.empty());
}

// ---- the real bus -------------------------------------------------------------------------------

TEST(Dc1394Bus, ReportsCleanlyThatThereAreNoCamerasHere) {
    std::unique_ptr<FirewireBus> bus = makeDc1394Bus();
    EXPECT_EQ(bus->name(), "libdc1394");
    const Enumeration e = bus->enumerate();
    RecordProperty("dc1394", e.status.isOk() ? "started; " + std::to_string(e.guids.size()) + " camera(s)"
                                             : "unavailable: " + e.status.detail());
    if (e.status.isOk()) {
        if (!e.guids.empty()) GTEST_SKIP() << "this machine has FireWire cameras";
        // libdc1394 started (a container without /dev/fw*): an empty, successful enumeration.
        const BusStatus reset = bus->resetBus();
        EXPECT_EQ(reset.code(), BusStatus::Code::NotFound);
        EXPECT_EQ(reset.detail(), "no camera on the bus to reset it through (libdc1394 resets via a camera)");
        const OpenResult open = bus->open(kLeft);
        EXPECT_EQ(open.status.code(), BusStatus::Code::NotFound);
        EXPECT_EQ(open.status.detail(), "dc1394_camera_new: no camera 0x00b09d01004a2c1f on the bus");
        EXPECT_EQ(open.camera, nullptr);
    } else {
        // dc1394_new failed: every call says there is no FireWire support.
        EXPECT_EQ(e.status.code(), BusStatus::Code::Unavailable);
        EXPECT_TRUE(contains(e.status.detail(), "dc1394_new failed"));
        EXPECT_EQ(bus->resetBus().code(), BusStatus::Code::Unavailable);
        EXPECT_EQ(bus->open(kLeft).status.code(), BusStatus::Code::Unavailable);
    }

    // The whole backend over the real bus: a named error and a Failed status, quickly.
    FirewireOptions options;
    options.settleDelay = milliseconds(1);
    options.settleRetries = 1;
    options.maxBusResets = 1;
    AcquireSIPFirewire acquisition(makeDc1394Bus(), options);
    const std::string message = messageOf<AcquisitionError>([&] { acquisition.applyConfig(testConfig()); });
    EXPECT_TRUE(contains(message, "FireWire cameras not found after"));
    EXPECT_TRUE(contains(message, e.status.isOk() ? "left camera 0x00b09d01004a2c1f and right camera "
                                                    "0x00b09d01004a2c20 not found; found: none"
                                                  : "no FireWire support"));
    EXPECT_EQ(acquisition.status().state, State::Failed);
    EXPECT_EQ(acquisition.status().message, message);
    EXPECT_EQ(messageOf<AcquisitionError>([&] { acquisition.acquire(); }),
              "FireWire cameras not started: apply a configuration first");
}

TEST(Dc1394Bus, SurveySaysWhatThisMachineLacks) {
    const BackendSurvey s = surveyFirewire();
    ASSERT_FALSE(s.checks.empty());
    bool nodes = false;
    for (const auto& entry : std::filesystem::directory_iterator("/dev")) {
        const std::string name = entry.path().filename().string();
        nodes = nodes || (name.size() > 2 && name.rfind("fw", 0) == 0 &&
                          name.find_first_not_of("0123456789", 2) == std::string::npos);
    }
    if (nodes) GTEST_SKIP() << "this machine has FireWire device nodes";
    EXPECT_FALSE(s.ok());
    EXPECT_EQ(s.checks.front().what, "/dev/fw*");
    EXPECT_TRUE(contains(s.checks.front().detail, "no FireWire device nodes"));
    EXPECT_TRUE(s.cameras.empty());
}

}  // namespace
