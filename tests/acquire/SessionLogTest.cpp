#include "SessionLogTestUtil.h"
#include "TempDir.h"
#include "TestUtil.h"

#include <avatar/acquire/SessionLog.h>
#include <avatar/common/Error.h>

#include <gtest/gtest.h>

#include <fstream>

#include <string>
#include <vector>

using namespace avatar;
using namespace avatar::test;
namespace fs = std::filesystem;

namespace {

/// Writes the pair and returns the record for it, without a result.
SessionRecord recordPair(SessionLogWriter& writer, std::uint64_t iteration, const AcquisitionId& id,
                         std::uint32_t configVersion, Compression compression = Compression::None,
                         ByteOrder order = ByteOrder::Little) {
    SessionRecord r;
    r.iteration = iteration;
    r.acquisition = id;
    r.files = writer.writePair(bayerPair(id, iteration * 10), compression, order);
    r.configVersion = configVersion;
    return r;
}

}  // namespace

TEST(SessionLog, RoundTripsEveryField) {
    TempDir dir;
    const fs::path session = dir / "dive-042";
    std::vector<SessionRecord> written;
    {
        SessionLogWriter writer(session);
        EXPECT_EQ(writer.directory(), session);

        // 1: first record, configuration applied, full result.
        SessionRecord r1 = recordPair(writer, 1, acquisition(1, 0, 1700000000000000), 1);
        r1.configXml = kConfigXmlV1;
        r1.result = fullResult(1, r1.acquisition);
        // 2: same configuration, no result (analysis not run), big-endian raw files.
        SessionRecord r2 = recordPair(writer, 2, acquisition(1, 1, 1700000002500000), 1,
                                      Compression::None, ByteOrder::Big);
        // 3: configuration change (new group), compressed files, empty result.
        SessionRecord r3 = recordPair(writer, 5, acquisition(2, 0, -42), 2, Compression::Png);
        r3.configXml = kConfigXmlV2;
        r3.result = VisionTargets{};
        r3.result->iteration = 5;
        r3.result->acquisition = r3.acquisition;
        // 4: camera ids with awkward bytes, empty strings.
        SessionRecord r4 = recordPair(writer, 6, {2, 1, {"", 0}, {"id with\ttab\nand newline%", 1}}, 2);
        r4.result = fullResult(6, r4.acquisition);
        r4.result->visibility = Visibility::Good;
        r4.result->visibilityReason.clear();
        r4.result->targets.clear();

        for (const auto* r : {&r1, &r2, &r3, &r4}) {
            writer.append(*r);
            written.push_back(*r);
        }
        EXPECT_EQ(writer.recordCount(), 4u);
    }
    EXPECT_EQ(written[2].files.left.name, "L_00002_00000_8x6_12b_1c_GB_le.png");
    EXPECT_EQ(written[1].files.right.name, "R_00001_00001_8x6_12b_1c_GB_be.raw");

    const SessionLogReader reader(session);
    EXPECT_EQ(reader.version(), 2);
    EXPECT_EQ(reader.logPath(), session / "session.log");
    EXPECT_TRUE(reader.errors().empty());
    ASSERT_EQ(reader.entries().size(), 4u);
    for (std::size_t i = 0; i < 4; ++i) {
        EXPECT_EQ(reader.entries()[i].line, i + 2);  // line 1 is the header
        ASSERT_TRUE(reader.entries()[i].ok()) << reader.entries()[i].error;
        expectSameRecord(*reader.entries()[i].record, written[i]);
    }
    ASSERT_EQ(reader.records().size(), 4u);
    EXPECT_EQ(reader.configXml(1), std::string(kConfigXmlV1));
    EXPECT_EQ(reader.configXml(2), std::string(kConfigXmlV2));
    EXPECT_EQ(reader.configXml(3), std::nullopt);

    // The pixels come back from both variants and both byte orders.
    const std::vector<SessionRecord> read = reader.records();
    for (std::size_t i = 0; i < 4; ++i) {
        const SessionRecord& r = read[i];
        const StereoImagePair expected = bayerPair(r.acquisition, r.iteration * 10);
        const StereoImagePair pair = reader.loadPair(r);
        EXPECT_TRUE(sameImage(pair.left(), expected.left())) << "iteration " << r.iteration;
        EXPECT_TRUE(sameImage(pair.right(), expected.right())) << "iteration " << r.iteration;
        EXPECT_EQ(pair.layout().format, PixelFormat::Bayer);
        EXPECT_EQ(pair.layout().bayerPattern, BayerPattern::GB);
        EXPECT_EQ(pair.layout().bitDepth, 12);
        expectSameAcquisition(pair.id(), r.acquisition, "loaded pair");
    }
}

TEST(SessionLog, WritesTheDocumentedText) {
    // The example of docs/formats.md, byte for byte (checksums verified with zlib.crc32).
    TempDir dir;
    {
        SessionLogWriter writer(dir.path());
        SessionRecord r;
        r.iteration = 1;
        r.acquisition = {1, 0, {"camL", 1700000000000000}, {"camR", 1700000000000017}};
        const cv::Mat left = (cv::Mat_<std::uint8_t>(1, 2) << 1, 2);
        const cv::Mat right = (cv::Mat_<std::uint8_t>(1, 2) << 3, 4);
        r.files = writer.writePair(StereoImagePair(left, right, {PixelFormat::Mono, BayerPattern::BG, 8}, r.acquisition),
                                   Compression::None, ByteOrder::Little);
        r.configVersion = 1;
        r.configXml = "<avatar>\n  <camera width=\"2\"/>\n</avatar>";
        VisionTargets v;
        v.iteration = 1;
        v.acquisition = r.acquisition;
        v.visibility = Visibility::Good;
        v.visibilityReason = "all clear";
        v.timings = {{"total", 12.5}};
        VisionTarget t;
        t.type = "sample";
        t.flags = kTargetStereo;
        t.positionVisionMm = cv::Point3d(1, 2, 300.5);
        t.centroidLeftPx = cv::Point2d(10.5, 20);
        t.centroidRightPx = cv::Point2d(11.25, 20);
        t.areaLeftPx = 35;
        t.areaRightPx = 36;
        t.matchError = 0.25;
        t.model = ShapeModel::Disc;
        t.covarianceVisionMm2 = Covariance3(0.25, 0, 0.5, 0, 0.25, 0, 0.5, 0, 4);
        t.rayResidualMm = 0.5;
        t.rayResidualPx = 0.125;
        v.targets = {t};
        r.result = v;
        writer.append(r);

        SessionRecord r2;
        r2.iteration = 2;
        r2.acquisition = {1, 1, {"camL", 1700000002500000}, {"camR", 1700000002500017}};
        r2.files = writer.writePair(StereoImagePair(left, right, {PixelFormat::Mono, BayerPattern::BG, 8}, r2.acquisition),
                                    Compression::None, ByteOrder::Little);
        r2.configVersion = 1;
        writer.append(r2);
    }
    EXPECT_EQ(readText(dir / "session.log"),
              "AVATAR-SESSION-LOG 2\n"
              "iteration=1 group=1 member=0 leftCamera=camL leftTimeUs=1700000000000000 rightCamera=camR "
              "rightTimeUs=1700000000000017 leftFile=L_00001_00000_2x1_8b_1c_MONO_le.raw leftCrc=b6cc4292 "
              "rightFile=R_00001_00000_2x1_8b_1c_MONO_le.raw rightCrc=6d998525 config=1 "
              "configXml=<avatar>%0A%20%20<camera%20width=\"2\"/>%0A</avatar> result=good reason=all%20clear "
              "timing=total:12.5 target=sample,1,1;2;300.5,-,10.5;20,11.25;20,35,36,0.25,"
              "disc,0.25;0;0.5;0.25;0;4,-,0.5,0.125 crc=00b7280e\n"
              "iteration=2 group=1 member=1 leftCamera=camL leftTimeUs=1700000002500000 rightCamera=camR "
              "rightTimeUs=1700000002500017 leftFile=L_00001_00001_2x1_8b_1c_MONO_le.raw leftCrc=b6cc4292 "
              "rightFile=R_00001_00001_2x1_8b_1c_MONO_le.raw rightCrc=6d998525 config=1 result=none crc=9032e9ed\n");
}

// Logs recorded before version 2 stay readable: their targets have no shape
// model, covariances or ray residuals (docs/formats.md).
TEST(SessionLog, ReadsVersionOneLogs) {
    TempDir dir;
    std::string body =
        "iteration=1 group=1 member=0 leftCamera=camL leftTimeUs=1700000000000000 rightCamera=camR "
        "rightTimeUs=1700000000000017 leftFile=L_00001_00000_2x1_8b_1c_MONO_le.raw leftCrc=b6cc4292 "
        "rightFile=R_00001_00000_2x1_8b_1c_MONO_le.raw rightCrc=6d998525 config=1 "
        "configXml=<avatar>%0A%20%20<camera%20width=\"2\"/>%0A</avatar> result=good reason=all%20clear "
        "timing=total:12.5 target=sample,1,1;2;300.5,-,10.5;20,11.25;20,35,36,0.25";
    {
        std::ofstream out(dir / "session.log", std::ios::binary);
        out << "AVATAR-SESSION-LOG 1\n" << body << " crc=0b320739\n";
    }
    const SessionLogReader reader(dir.path());
    EXPECT_EQ(reader.version(), 1);
    EXPECT_TRUE(reader.errors().empty()) << reader.errors().front();
    ASSERT_EQ(reader.records().size(), 1u);
    ASSERT_TRUE(reader.records()[0].result);
    ASSERT_EQ(reader.records()[0].result->targets.size(), 1u);
    const VisionTarget& t = reader.records()[0].result->targets[0];
    EXPECT_EQ(t.flags, kTargetStereo);
    EXPECT_EQ(*t.positionVisionMm, cv::Point3d(1, 2, 300.5));
    EXPECT_EQ(t.matchError, 0.25);
    EXPECT_EQ(t.model, ShapeModel::None);
    EXPECT_FALSE(t.covarianceVisionMm2);
    EXPECT_EQ(t.rayResidualMm, 0.0);
}

TEST(SessionLog, EachRecordIsOnDiskWhenAppendReturns) {
    TempDir dir;
    SessionLogWriter writer(dir.path());
    SessionRecord r = recordPair(writer, 1, acquisition(1, 0, 5), 1);
    r.configXml = "<a/>";
    writer.append(r);
    // Read while the writer is still open, as after a crash.
    const SessionLogReader reader(dir.path());
    ASSERT_EQ(reader.records().size(), 1u);
    expectSameRecord(reader.records()[0], r);
}

TEST(SessionLog, HasNoRecordsRightAfterOpening) {
    TempDir dir;
    { SessionLogWriter writer(dir.path()); }
    EXPECT_EQ(readText(dir / "session.log"), "AVATAR-SESSION-LOG 2\n");
    const SessionLogReader reader(dir.path());
    EXPECT_TRUE(reader.entries().empty());
}

// ------------------------------------------------------------ writer refusals

class SessionLogWriterRefuses : public ::testing::Test {
protected:
    SessionRecord first() {
        SessionRecord r = recordPair(writer, 10, acquisition(3, 4, 100), 7);
        r.configXml = "<avatar/>";
        return r;
    }
    std::string where(std::uint64_t iteration) const {
        return "session log " + (dir / "session.log").string() + ", record of iteration " +
               std::to_string(iteration) + ": ";
    }
    TempDir dir;
    SessionLogWriter writer{dir.path()};
};

TEST_F(SessionLogWriterRefuses, AnExistingSession) {
    EXPECT_EQ(messageOf<IoError>([&] { SessionLogWriter again(dir.path()); }),
              "session log " + (dir / "session.log").string() +
                  " exists already; a session is never appended to or overwritten");
}

TEST_F(SessionLogWriterRefuses, AFirstRecordWithoutItsConfiguration) {
    SessionRecord r = first();
    r.configXml.reset();
    EXPECT_EQ(messageOf<InvalidArgument>([&] { writer.append(r); }),
              where(10) + "configuration version 7 is the first but the record does not carry its XML (configXml)");
}

TEST_F(SessionLogWriterRefuses, AConfigurationChangeWithoutItsXml) {
    writer.append(first());
    SessionRecord r = recordPair(writer, 11, acquisition(4, 0, 200), 8);
    EXPECT_EQ(messageOf<InvalidArgument>([&] { writer.append(r); }),
              where(11) + "configuration version 8 differs from the previous record's 7 but the record "
                          "does not carry its XML (configXml)");
}

TEST_F(SessionLogWriterRefuses, AnIterationThatDoesNotIncrease) {
    writer.append(first());
    SessionRecord r = recordPair(writer, 10, acquisition(3, 5, 200), 7);
    EXPECT_EQ(messageOf<InvalidArgument>([&] { writer.append(r); }),
              where(10) + "iteration does not follow the previous record's 10");
}

TEST_F(SessionLogWriterRefuses, FilesOfAnotherSideOrAcquisition) {
    const SessionRecord base = first();
    SessionRecord r = base;
    std::swap(r.files.left, r.files.right);
    EXPECT_EQ(messageOf<InvalidArgument>([&] { writer.append(r); }),
              where(10) + "field 'leftFile': 'R_00003_00004_8x6_12b_1c_GB_le.raw' is not a left (L_) image file");
    r = base;
    r.acquisition.member = 6;
    EXPECT_EQ(messageOf<InvalidArgument>([&] { writer.append(r); }),
              where(10) + "field 'leftFile': 'L_00003_00004_8x6_12b_1c_GB_le.raw' is group 3 member 4 but the "
                          "record is group 3 member 6");
    EXPECT_EQ(writer.recordCount(), 0u);
    writer.append(base);  // a refused record leaves the writer usable
    EXPECT_EQ(writer.recordCount(), 1u);
}

TEST_F(SessionLogWriterRefuses, FilesThatAreNotThere) {
    SessionRecord r = first();
    fs::remove(dir / r.files.right.name);
    EXPECT_EQ(messageOf<InvalidArgument>([&] { writer.append(r); }),
              where(10) + "image file " + (dir / r.files.right.name).string() + " does not exist");
}

TEST_F(SessionLogWriterRefuses, AResultOfAnotherPair) {
    SessionRecord r = first();
    r.result = fullResult(9, r.acquisition);
    EXPECT_EQ(messageOf<InvalidArgument>([&] { writer.append(r); }), where(10) + "the result is of iteration 9");
    r.result = fullResult(10, acquisition(3, 4, 101));
    EXPECT_EQ(messageOf<InvalidArgument>([&] { writer.append(r); }),
              where(10) + "the result's acquisition (group 3 member 4, camera stamps) differs from the record's");
}

TEST_F(SessionLogWriterRefuses, ToOverwriteAPairAlreadyRecorded) {
    const SessionRecord r = first();
    const fs::path left = dir / r.files.left.name;
    EXPECT_EQ(messageOf<IoError>([&] { writer.writePair(bayerPair(r.acquisition, 0)); }),
              "file " + left.string() + " exists already; recorded files are never overwritten");
}

TEST_F(SessionLogWriterRefuses, AGroupBeyondFiveDigits) {
    EXPECT_EQ(messageOf<InvalidArgument>([&] { writer.writePair(bayerPair(acquisition(100000, 0, 0), 0)); }),
              "raw file name: group 100000 member 0 exceed the five digits of the name");
}

TEST_F(SessionLogWriterRefuses, AnEmptyPair) {
    EXPECT_EQ(messageOf<InvalidArgument>([&] { writer.writePair(StereoImagePair()); }),
              "session " + dir.path().string() + ": cannot record an empty pair");
}
