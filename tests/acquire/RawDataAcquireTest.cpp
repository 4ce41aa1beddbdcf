// RawDataAcquire over real session directories written with SessionLogWriter:
// pairs as recorded with their recorded numbers, configuration changes
// surfaced at the right iteration, every kind of damage reported precisely with
// the rest replayed; and the regression check compareResults().
#include "SessionLogTestUtil.h"
#include "TempDir.h"
#include "TestUtil.h"

#include <avatar/acquire/RawDataAcquire.h>
#include <avatar/acquire/SessionLog.h>
#include <avatar/common/Error.h>

#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <string>
#include <vector>

using namespace avatar;
using namespace avatar::test;
namespace fs = std::filesystem;
using State = AcquisitionStatus::State;

namespace {

struct Recorded {
    SessionRecord record;
    StereoImagePair pair;
};

/// One record per entry of @p plan: {group, member, configVersion}; the XML is
/// given where the version changes (or @p reapply names the iteration). Odd
/// iterations carry a result.
std::vector<Recorded> writeSession(const fs::path& dir,
                                   const std::vector<std::array<std::uint32_t, 3>>& plan,
                                   std::uint64_t reapply = 0) {
    SessionLogWriter writer(dir);
    std::vector<Recorded> out;
    std::optional<std::uint32_t> version;
    std::uint64_t iteration = 10;
    for (const auto& [group, member, config] : plan) {
        iteration += 1 + (iteration % 3);  // increasing, not contiguous
        Recorded r;
        r.pair = bayerPair(acquisition(group, member, 1700000000000000 + static_cast<std::int64_t>(iteration)),
                           iteration * 7);
        r.record.iteration = iteration;
        r.record.acquisition = r.pair.id();
        r.record.files = writer.writePair(r.pair);
        r.record.configVersion = config;
        if (version != config || iteration == reapply) r.record.configXml = config == 2 ? kConfigXmlV2 : kConfigXmlV1;
        version = config;
        if (out.size() % 2 == 0) r.record.result = fullResult(iteration, r.pair.id());
        writer.append(r.record);
        out.push_back(r);
    }
    return out;
}

void expectDelivered(const AcquiredPair& a, const Recorded& r) {
    SCOPED_TRACE("iteration " + std::to_string(r.record.iteration));
    ASSERT_TRUE(a.recordedIteration);
    EXPECT_EQ(*a.recordedIteration, r.record.iteration);
    EXPECT_EQ(a.pair.id(), r.record.acquisition);
    EXPECT_TRUE(sameImage(a.pair.left(), r.pair.left()));
    EXPECT_TRUE(sameImage(a.pair.right(), r.pair.right()));
    EXPECT_EQ(a.pair.layout().format, PixelFormat::Bayer);  // handed over as recorded: still a mosaic
    EXPECT_EQ(a.pair.layout().bayerPattern, BayerPattern::GB);
    EXPECT_EQ(a.pair.layout().bitDepth, 12);
    EXPECT_EQ(a.recordedResult, r.record.result);
}

/// The lines of a file, each without its line feed.
std::vector<std::string> linesOf(const fs::path& file) {
    std::vector<std::string> lines;
    const std::string text = readText(file);
    std::size_t start = 0;
    for (std::size_t end; (end = text.find('\n', start)) != std::string::npos; start = end + 1)
        lines.push_back(text.substr(start, end - start));
    return lines;
}

void writeLines(const fs::path& file, const std::vector<std::string>& lines) {
    std::string text;
    for (const auto& l : lines) text += l + "\n";
    writeText(file, text);
}

}  // namespace

TEST(RawDataAcquire, ReplaysEveryPairAsRecordedWithItsRecordedNumbers) {
    TempDir dir;
    // Numbers no live backend would give in this order: replay must keep them.
    const auto recorded = writeSession(dir.path(), {{7, 3, 1}, {7, 4, 1}, {9, 0, 1}, {9, 1, 1}});
    RawDataAcquire replay(dir.path());
    EXPECT_EQ(replay.name(), "replay");
    EXPECT_EQ(replay.entryCount(), 4u);
    EXPECT_EQ(replay.status().state, State::Ok);
    replay.applyConfig(AvatarConfig{});  // nothing to apply, and numbers stay recorded
    for (std::size_t i = 0; i < recorded.size(); ++i) {
        const AcquiredPair a = replay.acquire();
        expectDelivered(a, recorded[i]);
        ASSERT_TRUE(replay.lastRecord());
        EXPECT_EQ(replay.lastRecord()->files.left, recorded[i].record.files.left);
        EXPECT_EQ(a.recordedConfigXml.has_value(), i == 0);
        if (i + 1 < recorded.size()) {
            EXPECT_EQ(replay.status().state, State::Ok);
        }
    }
    EXPECT_EQ(replay.status().state, State::Finished);
    EXPECT_EQ(replay.status().message,
              "replay of " + dir.path().string() + " finished: 4 pairs replayed, 0 damaged records");
    EXPECT_EQ(messageOf<AcquisitionError>([&] { replay.acquire(); }),
              "replay: no more records: " + replay.status().message);
    EXPECT_EQ(replay.deliveredCount(), 4u);
    EXPECT_EQ(replay.damagedCount(), 0u);
}

TEST(RawDataAcquire, ConfigurationChangesSurfaceAtTheIterationsThatAppliedThem) {
    TempDir dir;
    // v1, v1, v2, v2, v1 (a change back), v1 applied again at the 6th record.
    const auto recorded =
        writeSession(dir.path(), {{1, 0, 1}, {1, 1, 1}, {2, 0, 2}, {2, 1, 2}, {3, 0, 1}, {3, 1, 1}, {3, 2, 1}}, 19);
    ASSERT_EQ(recorded[5].record.iteration, 19u);
    RawDataAcquire replay(dir.path());
    const std::vector<std::optional<std::string>> expected = {kConfigXmlV1, std::nullopt, kConfigXmlV2, std::nullopt,
                                                              kConfigXmlV1, kConfigXmlV1, std::nullopt};
    for (std::size_t i = 0; i < recorded.size(); ++i) {
        SCOPED_TRACE("record " + std::to_string(i));
        const AcquiredPair a = replay.acquire();
        EXPECT_EQ(*a.recordedIteration, recorded[i].record.iteration);
        EXPECT_EQ(a.recordedConfigXml, expected[i]);
        EXPECT_EQ(replay.lastRecord()->configVersion, recorded[i].record.configVersion);
    }
    EXPECT_EQ(replay.status().state, State::Finished);
}

TEST(RawDataAcquire, EveryKindOfDamageIsReportedPreciselyAndTheRestIsReplayed) {
    TempDir dir;
    const auto r = writeSession(dir.path(), {{1, 0, 1}, {1, 1, 1}, {1, 2, 1}, {1, 3, 1}, {1, 4, 1}, {1, 5, 1}, {1, 6, 1}});
    const fs::path log = dir / "session.log";
    // Record 2 (line 3): truncated image.
    const fs::path truncated = dir / r[1].record.files.left.name;
    fs::resize_file(truncated, 50);
    // Record 3 (line 4): image altered, checksum mismatch.
    const fs::path altered = dir / r[2].record.files.right.name;
    auto bytes = readBytes(altered);
    bytes[10] ^= 0x01;
    writeText(altered, std::string(bytes.begin(), bytes.end()));
    // Record 4 (line 5): missing image.
    const fs::path missing = dir / r[3].record.files.right.name;
    fs::remove(missing);
    // A garbage line after record 5 (becomes line 7), and record 6 altered (line 8).
    auto lines = linesOf(log);
    ASSERT_EQ(lines.size(), 8u);
    lines.insert(lines.begin() + 6, "garbage from a broken editor");
    const auto pos = lines[7].find("member=5");
    ASSERT_NE(pos, std::string::npos);
    lines[7].replace(pos, 8, "member=8");
    writeLines(log, lines);

    RawDataAcquire replay(dir.path());
    EXPECT_EQ(replay.entryCount(), 8u);
    const std::string at = log.string() + ":";

    expectDelivered(replay.acquire(), r[0]);

    auto expectDamage = [&](const std::string& expected) {
        const std::string message = messageOf<AcquisitionError>([&] { replay.acquire(); });
        EXPECT_EQ(message, expected + " (replay goes on with the next record)");
        EXPECT_EQ(replay.status().state, State::Recovering);
        EXPECT_EQ(replay.status().message, expected);
    };
    expectDamage(at + "3: iteration " + std::to_string(r[1].record.iteration) + ": raw file " + truncated.string() +
                 " is truncated: 50 bytes, its name says 8x6 12-bit 1-channel = 96 bytes");
    const std::string crcText = messageOf<AcquisitionError>([&] { replay.acquire(); });
    EXPECT_EQ(crcText.rfind(at + "4: iteration " + std::to_string(r[2].record.iteration) + ": image file " +
                                altered.string() + ": checksum mismatch: recorded ",
                            0),
              0u)
        << crcText;
    EXPECT_EQ(replay.status().state, State::Recovering);
    expectDamage(at + "5: iteration " + std::to_string(r[3].record.iteration) + ": image file " + missing.string() +
                 " does not exist");

    expectDelivered(replay.acquire(), r[4]);
    EXPECT_EQ(replay.status().state, State::Ok);
    EXPECT_TRUE(replay.status().message.empty());

    const std::string garbage = messageOf<AcquisitionError>([&] { replay.acquire(); });
    EXPECT_EQ(garbage.rfind(at + "7: not a session record: ", 0), 0u) << garbage;
    const std::string lineCrc = messageOf<AcquisitionError>([&] { replay.acquire(); });
    EXPECT_EQ(lineCrc.rfind(at + "8: line checksum mismatch: recorded ", 0), 0u) << lineCrc;

    const AcquiredPair last = replay.acquire();
    expectDelivered(last, r[6]);
    // The configuration was surfaced on the first pair and has not changed since.
    EXPECT_FALSE(last.recordedConfigXml);
    EXPECT_EQ(replay.status().state, State::Finished);
    EXPECT_EQ(replay.deliveredCount(), 3u);
    EXPECT_EQ(replay.damagedCount(), 5u);
    EXPECT_NE(replay.status().message.find("3 pairs replayed, 5 damaged records"), std::string::npos);
}

TEST(RawDataAcquire, DamagedLastLineIsTheLastReportAndFinishes) {
    TempDir dir;
    const auto r = writeSession(dir.path(), {{1, 0, 1}, {1, 1, 1}});
    const fs::path log = dir / "session.log";
    std::string text = readText(log);
    text.resize(text.size() - 20);  // a crash while writing the last line
    writeText(log, text);
    RawDataAcquire replay(dir.path());
    expectDelivered(replay.acquire(), r[0]);
    const std::string message = messageOf<AcquisitionError>([&] { replay.acquire(); });
    EXPECT_EQ(message.rfind(log.string() + ":3: truncated record: the last line has no line end", 0), 0u) << message;
    EXPECT_EQ(replay.status().state, State::Finished);
    EXPECT_NE(replay.status().message.find("1 pairs replayed, 1 damaged records (last: " + log.string() + ":3:"),
              std::string::npos)
        << replay.status().message;
}

TEST(RawDataAcquire, PairsWhoseConfigurationIsLostAreReportedNotReplayedWithAnother) {
    TempDir dir;
    const auto r = writeSession(dir.path(), {{1, 0, 1}, {1, 1, 1}, {2, 0, 2}, {2, 1, 2}});
    const fs::path log = dir / "session.log";
    auto lines = linesOf(log);
    lines[1].replace(lines[1].find("member=0"), 8, "member=9");  // the record that applied configuration 1
    writeLines(log, lines);
    RawDataAcquire replay(dir.path());
    EXPECT_NE(messageOf<AcquisitionError>([&] { replay.acquire(); }).find(":2: line checksum mismatch"),
              std::string::npos);
    EXPECT_EQ(messageOf<AcquisitionError>([&] { replay.acquire(); }),
              log.string() + ":3: iteration " + std::to_string(r[1].record.iteration) +
                  ": configuration 1 is not in the log (the record that applied it is damaged); the pair is not "
                  "replayed without its configuration (replay goes on with the next record)");
    const AcquiredPair third = replay.acquire();
    expectDelivered(third, r[2]);
    EXPECT_EQ(third.recordedConfigXml, std::optional<std::string>(kConfigXmlV2));
    const AcquiredPair fourth = replay.acquire();
    EXPECT_FALSE(fourth.recordedConfigXml);
    EXPECT_EQ(replay.status().state, State::Finished);
}

TEST(RawDataAcquire, AConfigurationIsSurfacedOnTheFirstPairDeliveredWhenTheOneThatAppliedItIsDamaged) {
    TempDir dir;
    const auto r = writeSession(dir.path(), {{1, 0, 1}, {1, 1, 1}, {1, 2, 1}});
    fs::remove(dir / r[0].record.files.left.name);  // the log line is intact, its image is not
    RawDataAcquire replay(dir.path());
    EXPECT_THROW(replay.acquire(), AcquisitionError);
    const AcquiredPair second = replay.acquire();
    expectDelivered(second, r[1]);
    EXPECT_EQ(second.recordedConfigXml, std::optional<std::string>(kConfigXmlV1));
}

TEST(RawDataAcquire, HeaderOnlySessionIsFinishedAtOnce) {
    TempDir dir;
    { SessionLogWriter writer(dir.path()); }
    RawDataAcquire replay(dir.path());
    EXPECT_EQ(replay.status().state, State::Finished);
    EXPECT_THROW(replay.acquire(), AcquisitionError);
}

TEST(RawDataAcquire, MissingOrForeignLogIsRefusedAtConstruction) {
    TempDir dir;
    const std::string message = messageOf<IoError>([&] { RawDataAcquire replay(dir / "nowhere"); });
    EXPECT_NE(message.find((dir / "nowhere").string()), std::string::npos) << message;
    writeText(dir / "session.log", "SOMETHING-ELSE 1\n");
    EXPECT_THROW(RawDataAcquire replay(dir.path()), FormatError);
}

// ------------------------------------------------------------ compareResults

namespace {

VisionTargets sample() { return fullResult(42, acquisition(3, 4, 1700000000000000)); }

}  // namespace

TEST(CompareResults, IdenticalResultsDifferOnlyInTimingsWhichAreNotCompared) {
    VisionTargets a = sample();
    VisionTargets b = sample();
    for (StageTiming& t : b.timings) t.milliseconds *= 3.0;
    EXPECT_TRUE(compareResults(a, b).empty());
    EXPECT_TRUE(compareResults(a, a).empty());
}

TEST(CompareResults, StageNamesAreCompared) {
    VisionTargets a = sample();
    VisionTargets b = sample();
    b.timings.pop_back();
    const auto d = compareResults(a, b);
    ASSERT_EQ(d.size(), 1u);
    EXPECT_EQ(d[0].field, "timings.stages");
    EXPECT_EQ(d[0].recorded, "acquire colour filter match:stereo");
    EXPECT_EQ(d[0].replayed, "acquire colour filter");
}

TEST(CompareResults, OneUlpIsADifferenceWithBothValuesExact) {
    VisionTargets a = sample();
    VisionTargets b = sample();
    b.targets[0].positionVisionMm->z = std::nextafter(a.targets[0].positionVisionMm->z, 0.0);
    const auto d = compareResults(a, b);
    ASSERT_EQ(d.size(), 1u);
    EXPECT_EQ(d[0].field, "targets[0].positionVisionMm.z");
    EXPECT_EQ(d[0].recorded, "1234.5678901234567");
    EXPECT_EQ(d[0].replayed, "1234.5678901234564");
}

TEST(CompareResults, DoublesAreComparedBitForBit) {
    VisionTargets a = sample();
    VisionTargets b = sample();
    b.targets[0].positionBaseMm->x = 0.0;  // recorded -0
    a.targets[1].matchError = std::numeric_limits<double>::quiet_NaN();
    b.targets[1].matchError = std::numeric_limits<double>::quiet_NaN();  // NaN == NaN here
    const auto d = compareResults(a, b);
    ASSERT_EQ(d.size(), 1u);
    EXPECT_EQ(d[0].field, "targets[0].positionBaseMm.x");
    EXPECT_EQ(d[0].recorded, "-0");
    EXPECT_EQ(d[0].replayed, "0");
}

TEST(CompareResults, EveryFieldIsNamed) {
    VisionTargets a = sample();
    VisionTargets b = sample();
    b.iteration = 43;
    b.acquisition.member = 5;
    b.acquisition.right.cameraId = "other";
    b.visibility = Visibility::Good;
    b.visibilityReason = "";
    b.targets[0].type = "arm";
    b.targets[0].flags = kTargetLeftOnly;
    b.targets[0].positionBaseMm.reset();
    b.targets[1].centroidLeftPx->y = 2.75;
    b.targets[1].areaLeftPx = 78;
    b.targets[2].areaRightPx = 1;
    b.targets[0].model = ShapeModel::Disc;
    (*b.targets[0].covarianceVisionMm2)(1, 2) = 0.5;
    b.targets[0].covarianceBaseMm2.reset();
    b.targets[0].rayResidualPx = 2.0;
    std::vector<std::string> fields;
    for (const auto& d : compareResults(a, b)) fields.push_back(d.field);
    EXPECT_EQ(fields, (std::vector<std::string>{"iteration", "acquisition.member", "acquisition.right.cameraId",
                                                "visibility", "visibilityReason", "targets[0].type",
                                                "targets[0].flags", "targets[0].positionBaseMm",
                                                "targets[0].model", "targets[0].covarianceVisionMm2(1,2)",
                                                "targets[0].covarianceBaseMm2", "targets[0].rayResidualPx",
                                                "targets[1].centroidLeftPx.y", "targets[1].areaLeftPx",
                                                "targets[2].areaRightPx"}));
    const auto d = compareResults(a, b);
    EXPECT_EQ(d[3].recorded, "poor");
    EXPECT_EQ(d[3].replayed, "good");
    EXPECT_EQ(d[7].recorded, "-0;1e-300;1.7976931348623157e+308");
    EXPECT_EQ(d[7].replayed, "-");
}

TEST(CompareResults, MissingAndExtraTargetsAreListedWholly) {
    VisionTargets a = sample();
    VisionTargets b = sample();
    b.targets.erase(b.targets.begin() + 1, b.targets.end());
    auto d = compareResults(a, b);
    ASSERT_EQ(d.size(), 3u);
    EXPECT_EQ(d[0].field, "targets.size");
    EXPECT_EQ(d[0].recorded, "3");
    EXPECT_EQ(d[0].replayed, "1");
    EXPECT_EQ(d[1].field, "targets[1]");
    EXPECT_EQ(d[1].recorded, "arm, end-effector: IEEM 50%,10,-,-,1.5;2.5,-,77.75,0,0,composite,-,-,0,0");
    EXPECT_EQ(d[1].replayed, "-");
    d = compareResults(b, a);
    ASSERT_EQ(d.size(), 3u);
    EXPECT_EQ(d[2].field, "targets[2]");
    EXPECT_EQ(d[2].recorded, "-");
    EXPECT_EQ(d[2].replayed, ",4294967295,-,-,-,-,0,inf,-inf,none,-,-,0,0");
}
