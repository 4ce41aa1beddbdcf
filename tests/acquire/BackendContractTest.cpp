// One contract, every acquisition backend that runs on this machine (issue 5).
//
// Each backend runs the same scenario and is held to the same expectations:
//
//   applyConfig(first); 5 pairs; applyConfig(changed); 2 pairs; [finite sources: acquire() twice more]
//
//  - the first pair is group 1 member 0 (a configuration applied before any
//    pair starts no group); the member counts up by one per pair; the group
//    counts up and the member restarts when the configuration changes and when
//    the member reaches the group size (3 here, where the backend takes one);
//  - both images have the geometry that is announced for them (width, height,
//    bit depth and container, channels, pixel format, Bayer pattern);
//  - the left and right camera ids are the ones the backend was given
//    (non-empty, different);
//  - every pair carries both capture times, epoch microseconds, and neither
//    goes back from one pair to the next;
//  - status() is Ok (with no message) while pairs come;
//  - a finite source says Finished as soon as its last pair is out, and every
//    later acquire() is an AcquisitionError naming the source, never a pair;
//  - the pair's numbers are the ones the base said the next pair would get
//    (nextGroup()/nextMember()).
//
// Where a backend legitimately differs, BackendCase says so field by field and
// why (replay keeps its recorded numbers; files carry no camera ids; ...).
//
// The backends: files (PNG files written here), replay (a session written
// here with SessionLogWriter), FireWire over the scripted bus of
// ScriptedFirewireBus.h, GenICam against two arv-fake-gv-camera-0.8 processes
// on a private loopback network (GenICamFakeCamera.h; skipped when no network
// namespace can be made), and the simulation (avatar::render).
#include "GenICamFakeCamera.h"
#include "ScriptedFirewireBus.h"
#include "TempDir.h"
#include "TestUtil.h"

#include <avatar/acquire/AcquireSIPFileLoader.h>
#include <avatar/acquire/AcquireSIPFirewire.h>
#include <avatar/acquire/AcquireSIPGenICam.h>
#include <avatar/acquire/AcquireStereoImagePair.h>
#include <avatar/acquire/RawDataAcquire.h>
#include <avatar/acquire/SessionLog.h>
#include <avatar/config/ConfigXml.h>
#include <avatar/acquire/AcquireSIPSimulation.h>

#include <gtest/gtest.h>
#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>

#include <chrono>
#include <cstdint>
#include <filesystem>
#include <functional>
#include <memory>
#include <optional>
#include <ostream>
#include <string>
#include <utility>
#include <vector>

namespace avatar {
namespace {

using State = AcquisitionStatus::State;
using test::messageOf;
using test::TempDir;

// ------------------------------------------------------------ the scenario

constexpr int kPairsBeforeChange = 5;
constexpr int kPairsAfterChange = 2;
constexpr std::size_t kPairs = kPairsBeforeChange + kPairsAfterChange;
/// The group size the test sets where a backend takes one.
constexpr std::uint32_t kGroupSize = 3;
/// 2001-09-09 in epoch microseconds: a capture time below it is not epoch microseconds.
constexpr std::int64_t kEpochUsFloor = 1'000'000'000'000'000;

using Numbers = std::pair<std::uint32_t, std::uint32_t>;  // group, member

/// The numbers of the scenario's pairs (docs/formats.md, "Image file names").
std::vector<Numbers> expectedNumbers(std::optional<std::uint32_t> groupSize) {
    if (groupSize == kGroupSize)  // members 0..2, rollover, 2 pairs, configuration change, 2 pairs
        return {{1, 0}, {1, 1}, {1, 2}, {2, 0}, {2, 1}, {3, 0}, {3, 1}};
    // the default group size (99,999) is not reached: only the configuration change starts a group
    return {{1, 0}, {1, 1}, {1, 2}, {1, 3}, {1, 4}, {2, 0}, {2, 1}};
}

// ------------------------------------------------------------ what is announced

struct Geometry {
    int width{0};
    int height{0};
    int bitDepth{0};
    int channels{0};
    PixelFormat format{PixelFormat::Mono};
    BayerPattern bayerPattern{BayerPattern::BG};  ///< only meaningful for Bayer

    bool operator==(const Geometry& o) const {
        return width == o.width && height == o.height && bitDepth == o.bitDepth && channels == o.channels &&
               format == o.format && (format != PixelFormat::Bayer || bayerPattern == o.bayerPattern);
    }
    bool operator!=(const Geometry& o) const { return !(*this == o); }
};

std::ostream& operator<<(std::ostream& os, const Geometry& g) {
    os << g.width << "x" << g.height << " " << g.bitDepth << "-bit " << g.channels << "c " << toString(g.format);
    if (g.format == PixelFormat::Bayer) os << " " << toString(g.bayerPattern);
    return os;
}

/// What the camera part of a configuration announces.
Geometry geometryOf(const CameraHardwareConfig& c) {
    const PixelFormat format = c.channels == 3 ? PixelFormat::Bgr : c.bayer ? PixelFormat::Bayer : PixelFormat::Mono;
    return {c.width, c.height, c.bitDepth, c.channels, format, c.bayerPattern};
}

/// Where the geometry of a backend's pairs is announced.
enum class GeometrySource {
    AppliedConfig,   ///< the camera part of the configuration applied last
    RecordedConfig,  ///< the configuration the recording applied (AcquiredPair::recordedConfigXml)
    Source,          ///< the source itself (Harness::sourceGeometry()); configurations have no say
};

/// Where the camera ids of a backend's pairs come from.
enum class CameraIds {
    Config,    ///< camera.leftCameraId / rightCameraId of the configuration applied last
    Recorded,  ///< the recording's ids (part of the recorded AcquisitionId)
    Backend,   ///< the backend's own setting (Harness::backendIds())
    None,      ///< there are none: both ids are empty
};

/// Where the group and member numbers of a backend's pairs come from.
enum class Numbering {
    Base,      ///< AcquireStereoImagePair numbers the pair: nextGroup()/nextMember() before acquire()
    Recorded,  ///< the pair keeps the numbers of its record (AcquiredPair::recordedIteration set)
};

const char* stateName(State s) {
    switch (s) {
        case State::Ok: return "Ok";
        case State::Recovering: return "Recovering";
        case State::Failed: return "Failed";
        case State::Finished: return "Finished";
    }
    return "?";
}

/// Every field of an acquisition, for comparisons that print readably.
std::string describe(const AcquisitionId& id) {
    return "group " + std::to_string(id.group) + " member " + std::to_string(id.member) + ", left '" +
           id.left.cameraId + "' at " + std::to_string(id.left.timestampUs) + " us, right '" + id.right.cameraId +
           "' at " + std::to_string(id.right.timestampUs) + " us";
}

::testing::AssertionResult contains(const std::string& text, const std::string& part) {
    if (!part.empty() && text.find(part) != std::string::npos) return ::testing::AssertionSuccess();
    return ::testing::AssertionFailure() << "'" << text << "'\n does not contain '" << part << "'";
}

// ------------------------------------------------------------ one backend under test

/// Builds one backend with its source (files, session, scripted bus, fake
/// cameras, scene) and answers what the test cannot know by itself.
class Harness {
public:
    virtual ~Harness() = default;
    /// Why the backend cannot run here (the test is skipped), or empty.
    virtual std::string unavailable() const { return {}; }
    virtual AcquireStereoImagePair& backend() = 0;
    /// The configuration applied before the first pair (0) and the changed one (1).
    virtual AvatarConfig config(int which) const = 0;
    /// GeometrySource::Source: the geometry of every pair.
    virtual Geometry sourceGeometry() const { return {}; }
    /// CameraIds::Backend: the ids the backend was set to give its pairs.
    virtual std::pair<std::string, std::string> backendIds() const { return {}; }
    /// Numbering::Recorded: the acquisition the recording gave pair @p index.
    virtual AcquisitionId recordedId(std::size_t /*index*/) const { return {}; }
    /// Finite sources: what the end-of-source message must name.
    virtual std::string sourceName() const { return {}; }
    /// Checks after the scenario (e.g. the scripted bus saw no misuse).
    virtual void verifyAfterRun() const {}
};

/// One backend and how it legitimately differs from the others.
struct BackendCase {
    std::string label;  ///< test name suffix
    std::string name;   ///< what name() says
    Numbering numbering{Numbering::Base};
    /// The group size the test gives the backend; nullopt when the backend has
    /// no such parameter (the default 99,999 is then not reached in this test).
    std::optional<std::uint32_t> groupSize;
    bool finite{false};  ///< a source that ends (files, a recording)
    GeometrySource geometry{GeometrySource::AppliedConfig};
    CameraIds ids{CameraIds::Config};
    std::function<std::unique_ptr<Harness>(const BackendCase&)> make;
};

// ------------------------------------------------------------ files

/// 7 pairs of 5x4 8-bit BGR PNG files (lossless).
class FilesHarness final : public Harness {
public:
    explicit FilesHarness(const BackendCase& c) {
        std::vector<StereoFilePaths> pairs;
        for (std::size_t i = 0; i < kPairs; ++i) {
            StereoFilePaths p{dir_ / ("left_" + std::to_string(i) + ".png"),
                              dir_ / ("right_" + std::to_string(i) + ".png")};
            if (!cv::imwrite(p.left.string(), test::randomImage(4, 5, CV_8UC3, 8, 2 * i)) ||
                !cv::imwrite(p.right.string(), test::randomImage(4, 5, CV_8UC3, 8, 2 * i + 1)))
                throw std::runtime_error("cannot write " + p.left.string());
            pairs.push_back(p);
        }
        loader_ = std::make_unique<AcquireSIPFileLoader>(pairs, c.groupSize.value_or(99999));
    }
    AcquireStereoImagePair& backend() override { return *loader_; }
    AvatarConfig config(int which) const override {
        AvatarConfig c;
        c.camera.width = which == 0 ? 5 : 7;  // a different configuration; the files stay what they are
        return c;
    }
    Geometry sourceGeometry() const override { return {5, 4, 8, 3, PixelFormat::Bgr, BayerPattern::BG}; }
    std::string sourceName() const override { return "files: all pairs delivered (7 read, 0 unreadable)"; }

private:
    TempDir dir_{"avatar-contract-files"};
    std::unique_ptr<AcquireSIPFileLoader> loader_;
};

// ------------------------------------------------------------ replay

/// A session as a live backend with group size 3 records this scenario: 5
/// pairs of 8x6 12-bit Bayer GB under configuration 1, then 2 pairs of 6x4
/// 8-bit mono under configuration 2, each configuration recorded in full
/// where it starts.
class ReplayHarness final : public Harness {
public:
    explicit ReplayHarness(const BackendCase& /*c*/) {
        SessionLogWriter writer(dir_.path());
        const std::vector<Numbers> numbers = expectedNumbers(kGroupSize);
        for (std::size_t i = 0; i < kPairs; ++i) {
            const int which = i < kPairsBeforeChange ? 0 : 1;
            const CameraHardwareConfig camera = config(which).camera;
            AcquisitionId id;
            id.group = numbers[i].first;
            id.member = numbers[i].second;
            const auto t = 1'790'000'000'000'000 + static_cast<std::int64_t>(i) * 500'000;
            id.left = {camera.leftCameraId, t};
            id.right = {camera.rightCameraId, t + 40};
            const int type = camera.bitDepth <= 8 ? CV_8UC1 : CV_16UC1;
            const StereoImagePair pair(
                test::randomImage(camera.height, camera.width, type, camera.bitDepth, 3 * i),
                test::randomImage(camera.height, camera.width, type, camera.bitDepth, 3 * i + 1),
                {camera.bayer ? PixelFormat::Bayer : PixelFormat::Mono, camera.bayerPattern, camera.bitDepth}, id);
            SessionRecord record;
            record.iteration = 100 + 2 * i;
            record.acquisition = id;
            record.files = writer.writePair(pair);
            record.configVersion = static_cast<std::uint32_t>(which + 1);
            if (i == 0 || i == kPairsBeforeChange) record.configXml = writeConfigString(config(which));
            writer.append(record);
            ids_.push_back(id);
        }
        replay_ = std::make_unique<RawDataAcquire>(dir_.path());
    }
    AcquireStereoImagePair& backend() override { return *replay_; }
    AvatarConfig config(int which) const override {
        // A recording carries complete, valid configurations: the bundled one with these cameras.
        AvatarConfig c = readConfigFile(std::filesystem::path(AVATAR_DATA_DIR) / "config" / "scorpion.xml");
        c.camera.width = which == 0 ? 8 : 6;
        c.camera.height = which == 0 ? 6 : 4;
        c.camera.bitDepth = which == 0 ? 12 : 8;
        c.camera.bayer = which == 0;
        c.camera.bayerPattern = BayerPattern::GB;
        c.camera.leftCameraId = "0x00b09d01004a2c1f";
        c.camera.rightCameraId = "0x00b09d01004a2c20";
        c.stereo.left.cc = c.stereo.right.cc = {c.camera.width / 2.0, c.camera.height / 2.0};  // in these images
        return c;
    }
    AcquisitionId recordedId(std::size_t index) const override { return ids_.at(index); }
    std::string sourceName() const override { return dir_.path().string(); }

private:
    TempDir dir_{"avatar-contract-replay"};
    std::vector<AcquisitionId> ids_;
    std::unique_ptr<RawDataAcquire> replay_;
};

// ------------------------------------------------------------ FireWire

constexpr FirewireGuid kLeftGuid = 0x00b09d01004a2c1f;
constexpr FirewireGuid kRightGuid = 0x00b09d01004a2c20;

/// Two cameras on the scripted bus, each with 7 frames in step at 20 frames/s.
class FirewireHarness final : public Harness {
public:
    explicit FirewireHarness(const BackendCase& c) {
        script_->enumerations = {test::found({kLeftGuid, kRightGuid})};
        for (std::size_t i = 0; i < kPairs; ++i) {
            const auto t = 1'700'000'000'000'000 + static_cast<std::int64_t>(i) * 50'000;
            script_->add(kLeftGuid, {test::frameAt(t, static_cast<std::uint16_t>(100 + i))});
            script_->add(kRightGuid, {test::frameAt(t + 300, static_cast<std::uint16_t>(500 + i))});
        }
        firewire_ = std::make_unique<AcquireSIPFirewire>(std::make_unique<test::ScriptedBus>(script_),
                                                         FirewireOptions{}, c.groupSize.value_or(99999),
                                                         [](std::chrono::milliseconds) {});
    }
    AcquireStereoImagePair& backend() override { return *firewire_; }
    AvatarConfig config(int which) const override {
        AvatarConfig c;
        c.camera.width = which == 0 ? 8 : 6;  // a region, depth and mosaic change: capture restarts
        c.camera.height = 4;
        c.camera.bitDepth = which == 0 ? 12 : 8;
        c.camera.bayer = which == 0;
        c.camera.bayerPattern = BayerPattern::GR;
        c.camera.leftCameraId = formatGuid(kLeftGuid);
        c.camera.rightCameraId = formatGuid(kRightGuid);
        return c;
    }
    void verifyAfterRun() const override {
        EXPECT_TRUE(script_->violations.empty()) << script_->violations.front();
        EXPECT_EQ(script_->outstanding(), 0) << "DMA buffers not given back";
    }

private:
    std::shared_ptr<test::BusScript> script_ = std::make_shared<test::BusScript>();
    std::unique_ptr<AcquireSIPFirewire> firewire_;
};

// ------------------------------------------------------------ GenICam

/// The fake cameras run on a private loopback network (GenICamFakeCamera.h).
[[maybe_unused]] const bool kLoopback = test::registerPrivateLoopback();

/// Two fake GigE Vision cameras (Mono8 and Mono16, 2048x2048 sensor) at 25 frames/s.
class GenICamHarness final : public Harness {
public:
    explicit GenICamHarness(const BackendCase& c) {
        if (!test::privateLoopbackProblem().empty()) return;
        left_.start();
        right_.start();
        GenICamOptions o;
        o.frameTimeout = std::chrono::milliseconds(1000);
        o.pairTolerance = std::chrono::microseconds(20000);  // half the frame period: free-running cameras
        o.pairTimeout = std::chrono::milliseconds(3000);
        o.bufferCount = 6;
        o.discoveryAttempts = 2;
        o.discoverySettle = std::chrono::milliseconds(100);
        o.frameRateHz = 25.0;
        genicam_ = std::make_unique<AcquireSIPGenICam>(config(0), o, c.groupSize.value_or(99999));
    }
    std::string unavailable() const override {
        const std::string& problem = test::privateLoopbackProblem();
        return problem.empty() ? "" : "no private loopback network: " + problem;
    }
    AcquireStereoImagePair& backend() override { return *genicam_; }
    AvatarConfig config(int which) const override {
        AvatarConfig c;
        c.camera.width = which == 0 ? 320 : 256;  // geometry and pixel format change: streams restart
        c.camera.height = which == 0 ? 240 : 128;
        c.camera.bitDepth = which == 0 ? 8 : 16;
        c.camera.bayer = false;
        c.camera.leftCameraId = left_.deviceId();
        c.camera.rightCameraId = right_.deviceId();
        c.camera.features.exposure = {10000.0, false};
        c.camera.features.gain = {0.0, false};
        return c;
    }

private:
    TempDir dir_{"avatar-contract-genicam"};
    test::FakeGvCamera left_{"127.0.0.1", "GV01", (dir_.path() / "GV01.log").string()};
    test::FakeGvCamera right_{"127.0.0.2", "GV02", (dir_.path() / "GV02.log").string()};
    std::unique_ptr<AcquireSIPGenICam> genicam_;  // destroyed before the cameras
};

// ------------------------------------------------------------ simulation

class SimulationHarness final : public Harness {
public:
    explicit SimulationHarness(const BackendCase& /*c*/) {
        render::Scene scene;
        scene.seabed.distanceMm = 1200;
        StereoSystemConfig stereo;
        stereo.left.fc = stereo.right.fc = {80.0, 80.0};
        stereo.left.cc = stereo.right.cc = {32.0, 24.0};
        render::RenderOptions options;
        options.sensor = render::sensorFormatFrom(config(0).camera);
        options.supersampling = 2;
        simulation_ = std::make_unique<AcquireSIPSimulation>(scene, stereo, options);
        simulation_->setCameraIds(backendIds().first, backendIds().second);
    }
    AcquireStereoImagePair& backend() override { return *simulation_; }
    AvatarConfig config(int which) const override {
        AvatarConfig c;
        c.camera.width = which == 0 ? 64 : 80;
        c.camera.height = which == 0 ? 48 : 60;
        c.camera.bitDepth = which == 0 ? 16 : 12;
        c.camera.bayer = which == 0;  // the changed configuration is a mono sensor
        c.camera.bayerPattern = BayerPattern::BG;
        c.camera.leftCameraId = "0x00b09d01004a2c1f";  // not used by the simulation (see BackendCase)
        c.camera.rightCameraId = "0x00b09d01004a2c20";
        return c;
    }
    std::pair<std::string, std::string> backendIds() const override { return {"sim-cam-L", "sim-cam-R"}; }

private:
    std::unique_ptr<AcquireSIPSimulation> simulation_;
};

// ------------------------------------------------------------ the backends

void PrintTo(const BackendCase& c, std::ostream* os) { *os << c.label; }

std::vector<BackendCase> allBackends() {
    std::vector<BackendCase> cases;
    {
        BackendCase c;
        c.label = "Files";
        c.name = "files";
        c.groupSize = kGroupSize;
        c.finite = true;
        // Ordinary image files, read as 8-bit BGR whatever the configuration says
        // (AcquireSIPFileLoader.h); the configuration has no camera part to apply.
        c.geometry = GeometrySource::Source;
        // The files hold no camera identity: documented empty ids (AcquireSIPFileLoader.h).
        c.ids = CameraIds::None;
        // Its end-of-source message names the backend and its counts, but neither
        // the file list nor a file (AcquireSIPFileLoader::finish()); the harness's
        // sourceName() is that text, so the end test asserts what is said.
        c.make = [](const BackendCase& b) { return std::make_unique<FilesHarness>(b); };
        cases.push_back(c);
    }
    {
        BackendCase c;
        c.label = "Replay";
        c.name = "replay";
        // A replayed pair keeps the group and member it was recorded with, and
        // applyConfig() does not renumber (RawDataAcquire.h). The recording was
        // numbered by a backend with group size 3 and changed its configuration
        // where this test applies the changed one, so its numbers are the same
        // sequence, but they are asserted as the recorded ones.
        c.numbering = Numbering::Recorded;
        c.groupSize = std::nullopt;  // RawDataAcquire takes none: the numbers are the recording's
        c.finite = true;
        // Pairs are handed over as recorded: the geometry is the recorded configuration's.
        c.geometry = GeometrySource::RecordedConfig;
        c.ids = CameraIds::Recorded;
        c.make = [](const BackendCase& b) { return std::make_unique<ReplayHarness>(b); };
        cases.push_back(c);
    }
    {
        BackendCase c;
        c.label = "Firewire";
        c.name = "firewire";
        c.groupSize = kGroupSize;
        c.make = [](const BackendCase& b) { return std::make_unique<FirewireHarness>(b); };
        cases.push_back(c);
    }
    {
        BackendCase c;
        c.label = "GenICam";
        c.name = "genicam";
        c.groupSize = kGroupSize;
        c.make = [](const BackendCase& b) { return std::make_unique<GenICamHarness>(b); };
        cases.push_back(c);
    }
    {
        BackendCase c;
        c.label = "Simulation";
        c.name = "simulation";
        c.groupSize = std::nullopt;  // AcquireSIPSimulation's constructor takes no group size
        // The simulated cameras' ids are set with setCameraIds(); configure()
        // adopts only the image format of the configuration (AcquireSIPSimulation.h).
        c.ids = CameraIds::Backend;
        c.make = [](const BackendCase& b) { return std::make_unique<SimulationHarness>(b); };
        cases.push_back(c);
    }
    return cases;
}

std::vector<BackendCase> backendsWhere(const std::function<bool(const BackendCase&)>& keep) {
    std::vector<BackendCase> out;
    for (const BackendCase& c : allBackends())
        if (keep(c)) out.push_back(c);
    return out;
}

std::string caseName(const ::testing::TestParamInfo<BackendCase>& info) { return info.param.label; }

// ------------------------------------------------------------ the fixture

/// One acquire() of the scenario and what surrounded it.
struct Step {
    std::uint32_t nextGroup{0};  ///< the base's numbers just before acquire()
    std::uint32_t nextMember{0};
    int config{0};  ///< the configuration applied (0: first, 1: changed)
    AcquiredPair acquired;
    AcquisitionStatus status;  ///< status() right after the pair
};

class BackendContract : public ::testing::TestWithParam<BackendCase> {
protected:
    void SetUp() override {
        harness_ = GetParam().make(GetParam());
        if (const std::string why = harness_->unavailable(); !why.empty()) GTEST_SKIP() << why;
    }
    void TearDown() override { harness_.reset(); }

    AcquireStereoImagePair& backend() { return harness_->backend(); }

    /// Runs the scenario; fatal failure if a pair cannot be had.
    void run() {
        const BackendCase& c = GetParam();
        ASSERT_EQ(backend().name(), c.name);
        ASSERT_EQ(backend().groupSize(), c.groupSize.value_or(99999));
        ASSERT_NO_FATAL_FAILURE(apply(0));
        for (int i = 0; i < kPairsBeforeChange; ++i) ASSERT_NO_FATAL_FAILURE(grab(0));
        ASSERT_NO_FATAL_FAILURE(apply(1));
        for (int i = 0; i < kPairsAfterChange; ++i) ASSERT_NO_FATAL_FAILURE(grab(1));
        harness_->verifyAfterRun();
    }

    void apply(int which) {
        try {
            backend().applyConfig(harness_->config(which));
        } catch (const std::exception& e) {
            FAIL() << "applyConfig(" << which << ") threw: " << e.what();
        }
        applyStatus_.push_back(backend().status());
    }

    void grab(int config) {
        Step s;
        s.nextGroup = backend().nextGroup();
        s.nextMember = backend().nextMember();
        s.config = config;
        try {
            s.acquired = backend().acquire();
        } catch (const std::exception& e) {
            FAIL() << "pair " << steps_.size() << " could not be acquired: " << e.what();
        }
        s.status = backend().status();
        steps_.push_back(std::move(s));
    }

    /// The numbers the scenario's pairs must carry.
    std::vector<Numbers> expected() const {
        if (GetParam().numbering == Numbering::Base) return expectedNumbers(GetParam().groupSize);
        std::vector<Numbers> out;
        for (std::size_t i = 0; i < kPairs; ++i)
            out.emplace_back(harness_->recordedId(i).group, harness_->recordedId(i).member);
        return out;
    }

    static Numbers numbersOf(const Step& s) { return {s.acquired.pair.id().group, s.acquired.pair.id().member}; }

    std::unique_ptr<Harness> harness_;
    std::vector<Step> steps_;
    std::vector<AcquisitionStatus> applyStatus_;
};

/// The sources that end (files, recordings).
class FiniteSourceContract : public BackendContract {};
/// The backends whose group size the test sets.
class GroupSizeContract : public BackendContract {};

// ------------------------------------------------------------ numbering

TEST_P(BackendContract, FirstPairIsGroupOneMemberZero) {
    ASSERT_NO_FATAL_FAILURE(run());
    // A configuration applied before any pair starts no group.
    EXPECT_EQ(numbersOf(steps_.front()), (Numbers{1, 0}));
}

TEST_P(BackendContract, NumbersFollowTheDocumentedSequence) {
    ASSERT_NO_FATAL_FAILURE(run());
    const std::vector<Numbers> want = expected();
    ASSERT_EQ(steps_.size(), want.size());
    for (std::size_t i = 0; i < steps_.size(); ++i)
        EXPECT_EQ(numbersOf(steps_[i]), want[i]) << "pair " << i << " (group, member)";
    // Within a group the member counts up by one per pair.
    for (std::size_t i = 1; i < steps_.size(); ++i)
        if (numbersOf(steps_[i]).first == numbersOf(steps_[i - 1]).first) {
            EXPECT_EQ(numbersOf(steps_[i]).second, numbersOf(steps_[i - 1]).second + 1) << "pair " << i;
        } else {
            EXPECT_EQ(numbersOf(steps_[i]).first, numbersOf(steps_[i - 1]).first + 1) << "pair " << i;
            EXPECT_EQ(numbersOf(steps_[i]).second, 0u) << "pair " << i;
        }
}

TEST_P(BackendContract, ConfigurationChangeStartsAGroup) {
    ASSERT_NO_FATAL_FAILURE(run());
    const Step& before = steps_[kPairsBeforeChange - 1];
    const Step& after = steps_[kPairsBeforeChange];
    EXPECT_EQ(numbersOf(after), (Numbers{numbersOf(before).first + 1, 0}));
    EXPECT_EQ(numbersOf(steps_[kPairsBeforeChange + 1]), (Numbers{numbersOf(before).first + 1, 1}));
    if (GetParam().numbering == Numbering::Recorded) {
        // The group changed where the recording's configuration changed, which
        // the replay surfaces on that pair (and on the first one) only.
        for (std::size_t i = 0; i < steps_.size(); ++i)
            EXPECT_EQ(steps_[i].acquired.recordedConfigXml.has_value(), i == 0 || i == kPairsBeforeChange)
                << "pair " << i;
    }
}

TEST_P(GroupSizeContract, GroupRollsOverAtTheGroupSize) {
    ASSERT_NO_FATAL_FAILURE(run());
    const std::uint32_t size = *GetParam().groupSize;
    ASSERT_LT(size, static_cast<std::uint32_t>(kPairsBeforeChange));
    EXPECT_EQ(numbersOf(steps_[size - 1]), (Numbers{1, size - 1}));
    EXPECT_EQ(numbersOf(steps_[size]), (Numbers{2, 0}));  // member would reach the size: new group
    EXPECT_EQ(numbersOf(steps_[size + 1]), (Numbers{2, 1}));
}

TEST_P(BackendContract, AcquisitionIdIsWhatTheNumberingSays) {
    ASSERT_NO_FATAL_FAILURE(run());
    for (std::size_t i = 0; i < steps_.size(); ++i) {
        SCOPED_TRACE("pair " + std::to_string(i));
        const Step& s = steps_[i];
        if (GetParam().numbering == Numbering::Base) {
            EXPECT_EQ(numbersOf(s), (Numbers{s.nextGroup, s.nextMember}))
                << "the pair is not numbered as nextGroup()/nextMember() announced";
            EXPECT_FALSE(s.acquired.recordedIteration.has_value());
        } else {
            EXPECT_TRUE(s.acquired.recordedIteration.has_value());
            EXPECT_EQ(describe(s.acquired.pair.id()), describe(harness_->recordedId(i)))
                << "not the recorded acquisition";
        }
    }
}

// ------------------------------------------------------------ images

TEST_P(BackendContract, ImagesHaveTheAnnouncedGeometry) {
    ASSERT_NO_FATAL_FAILURE(run());
    const GeometrySource source = GetParam().geometry;
    if (source != GeometrySource::Source) {
        // Else the test could not tell a backend that ignores the change.
        ASSERT_NE(geometryOf(harness_->config(0).camera), geometryOf(harness_->config(1).camera));
    }
    std::optional<std::string> recordedXml;
    for (std::size_t i = 0; i < steps_.size(); ++i) {
        SCOPED_TRACE("pair " + std::to_string(i));
        const Step& s = steps_[i];
        const StereoImagePair& p = s.acquired.pair;
        Geometry want;
        switch (source) {
            case GeometrySource::AppliedConfig: want = geometryOf(harness_->config(s.config).camera); break;
            case GeometrySource::Source: want = harness_->sourceGeometry(); break;
            case GeometrySource::RecordedConfig:
                if (s.acquired.recordedConfigXml) recordedXml = s.acquired.recordedConfigXml;
                ASSERT_TRUE(recordedXml.has_value()) << "no recorded configuration came with the first pair";
                want = geometryOf(readConfigString(*recordedXml, "recorded configuration").camera);
                break;
        }
        ASSERT_FALSE(p.empty());
        const Geometry got{p.size().width, p.size().height, p.layout().bitDepth, p.channels(), p.layout().format,
                           p.layout().bayerPattern};
        EXPECT_EQ(got, want);
        EXPECT_EQ(p.containerBits(), want.bitDepth <= 8 ? 8 : 16);
        EXPECT_EQ(p.left().size(), p.right().size());
        EXPECT_EQ(p.left().type(), p.right().type());
    }
}

TEST_P(BackendContract, CameraIdsAreTheGivenOnes) {
    ASSERT_NO_FATAL_FAILURE(run());
    for (std::size_t i = 0; i < steps_.size(); ++i) {
        SCOPED_TRACE("pair " + std::to_string(i));
        const AcquisitionId& id = steps_[i].acquired.pair.id();
        std::pair<std::string, std::string> want;
        switch (GetParam().ids) {
            case CameraIds::Config: {
                const CameraHardwareConfig camera = harness_->config(steps_[i].config).camera;
                want = {camera.leftCameraId, camera.rightCameraId};
                break;
            }
            case CameraIds::Recorded:
                want = {harness_->recordedId(i).left.cameraId, harness_->recordedId(i).right.cameraId};
                break;
            case CameraIds::Backend: want = harness_->backendIds(); break;
            case CameraIds::None: want = {"", ""}; break;
        }
        EXPECT_EQ(id.left.cameraId, want.first);
        EXPECT_EQ(id.right.cameraId, want.second);
        if (GetParam().ids != CameraIds::None) {
            EXPECT_FALSE(id.left.cameraId.empty());
            EXPECT_FALSE(id.right.cameraId.empty());
            EXPECT_NE(id.left.cameraId, id.right.cameraId);
        }
    }
}

TEST_P(BackendContract, TimestampsArePresentAndNeverGoBack) {
    ASSERT_NO_FATAL_FAILURE(run());
    for (std::size_t i = 0; i < steps_.size(); ++i) {
        SCOPED_TRACE("pair " + std::to_string(i));
        const AcquisitionId& id = steps_[i].acquired.pair.id();
        EXPECT_GT(id.left.timestampUs, kEpochUsFloor) << "not epoch microseconds";
        EXPECT_GT(id.right.timestampUs, kEpochUsFloor) << "not epoch microseconds";
        if (i == 0) continue;
        const AcquisitionId& previous = steps_[i - 1].acquired.pair.id();
        EXPECT_GE(id.left.timestampUs, previous.left.timestampUs);
        EXPECT_GE(id.right.timestampUs, previous.right.timestampUs);
    }
}

// ------------------------------------------------------------ status and the end

TEST_P(BackendContract, StatusIsOkWhileDelivering) {
    ASSERT_NO_FATAL_FAILURE(run());
    for (std::size_t i = 0; i < applyStatus_.size(); ++i) {
        EXPECT_STREQ(stateName(applyStatus_[i].state), "Ok") << "after applyConfig " << i;
        EXPECT_EQ(applyStatus_[i].message, "") << "after applyConfig " << i;
    }
    // A finite source says Finished with its last pair (FiniteSourceContract).
    const std::size_t delivering = GetParam().finite ? steps_.size() - 1 : steps_.size();
    for (std::size_t i = 0; i < delivering; ++i) {
        EXPECT_STREQ(stateName(steps_[i].status.state), "Ok") << "after pair " << i;
        EXPECT_EQ(steps_[i].status.message, "") << "after pair " << i;
    }
}

TEST_P(FiniteSourceContract, EndIsFinishedAndAnErrorNamingTheSourceNeverAPair) {
    ASSERT_NO_FATAL_FAILURE(run());
    const AcquisitionStatus atEnd = steps_.back().status;
    EXPECT_STREQ(stateName(atEnd.state), "Finished") << "as soon as the last pair is out";
    EXPECT_TRUE(contains(atEnd.message, harness_->sourceName()));
    const std::uint32_t group = backend().nextGroup();
    const std::uint32_t member = backend().nextMember();
    for (int attempt = 0; attempt < 2; ++attempt) {
        SCOPED_TRACE("acquire() after the end, attempt " + std::to_string(attempt + 1));
        const std::string message = messageOf<AcquisitionError>([&] { backend().acquire(); });
        EXPECT_EQ(message.rfind(GetParam().name + ": no more", 0), 0u) << message;
        EXPECT_TRUE(contains(message, harness_->sourceName()));
        EXPECT_STREQ(stateName(backend().status().state), "Finished");
        EXPECT_EQ(backend().status().message, atEnd.message);
        EXPECT_EQ(backend().nextGroup(), group) << "no pair, no number";
        EXPECT_EQ(backend().nextMember(), member) << "no pair, no number";
    }
}

INSTANTIATE_TEST_SUITE_P(Backends, BackendContract, ::testing::ValuesIn(allBackends()), caseName);
INSTANTIATE_TEST_SUITE_P(Backends, FiniteSourceContract,
                         ::testing::ValuesIn(backendsWhere([](const BackendCase& c) { return c.finite; })),
                         caseName);
INSTANTIATE_TEST_SUITE_P(Backends, GroupSizeContract,
                         ::testing::ValuesIn(backendsWhere([](const BackendCase& c) {
                             return c.groupSize.has_value();
                         })),
                         caseName);

}  // namespace
}  // namespace avatar
