// Every kind of damage a session can suffer, each with the exact report a
// reader gives, and the proof that the intact rest is still read.
#include "RawImageFile.h"
#include "SessionLogTestUtil.h"
#include "TempDir.h"
#include "TestUtil.h"

#include <avatar/acquire/RawDataAcquire.h>
#include <avatar/acquire/SessionLog.h>
#include <avatar/common/Error.h>

#include <gtest/gtest.h>

#include <cctype>
#include <cstdio>
#include <ostream>
#include <string>
#include <vector>

using namespace avatar;
using namespace avatar::test;
namespace fs = std::filesystem;

namespace {

std::string hex8(std::uint32_t v) {
    char buf[9];
    std::snprintf(buf, sizeof buf, "%08x", v);
    return buf;
}

/// A record line with a correct line checksum, as a writer would produce it.
std::string withCrc(const std::string& body) { return body + " crc=" + hex8(crc32(body.data(), body.size())) + "\n"; }

std::vector<std::string> splitLines(const std::string& text) {
    std::vector<std::string> lines;
    std::size_t start = 0;
    for (std::size_t end; (end = text.find('\n', start)) != std::string::npos; start = end + 1)
        lines.push_back(text.substr(start, end - start));
    if (start < text.size()) lines.push_back(text.substr(start));
    return lines;
}

std::string replaceOnce(std::string text, const std::string& from, const std::string& to) {
    const auto pos = text.find(from);
    if (pos == std::string::npos) ADD_FAILURE() << "'" << from << "' not in '" << text << "'";
    else text.replace(pos, from.size(), to);
    return text;
}

/// The body of a record line (everything before " crc=").
std::string bodyOf(const std::string& line) { return line.substr(0, line.rfind(" crc=")); }

}  // namespace

/// A session of three records: iteration 1 (configuration 1 applied, result),
/// 2 (no result) and 3 (configuration 2 applied, result).
class DamagedSession : public ::testing::Test {
protected:
    void SetUp() override {
        SessionLogWriter writer(dir.path());
        for (std::uint32_t i = 1; i <= 3; ++i) {
            SessionRecord r;
            r.iteration = i;
            r.acquisition = acquisition(i < 3 ? 1 : 2, i < 3 ? i - 1 : 0, 1000 * i);
            r.files = writer.writePair(bayerPair(r.acquisition, i));
            r.configVersion = i < 3 ? 1 : 2;
            if (i != 2) {
                r.configXml = i == 1 ? kConfigXmlV1 : kConfigXmlV2;
                r.result = fullResult(i, r.acquisition);
            }
            writer.append(r);
            records.push_back(r);
        }
        log = dir / "session.log";
        text = readText(log);
        lines = splitLines(text);
        ASSERT_EQ(lines.size(), 4u);
        prefix = log.string() + ":";
    }

    /// Replaces line @p n (1-based) and writes the log back.
    void setLine(std::size_t n, const std::string& lineWithEnd) {
        std::string out;
        for (std::size_t i = 0; i < lines.size(); ++i) out += i + 1 == n ? lineWithEnd : lines[i] + "\n";
        writeText(log, out);
    }

    /// The reader's report for a log whose line 3 (iteration 2) is damaged; the
    /// other two records must still be read intact.
    std::string reportForLine3() {
        const SessionLogReader reader(dir.path());
        EXPECT_EQ(reader.entries().size(), 3u);
        if (reader.entries().size() != 3u) return "wrong number of entries";
        EXPECT_TRUE(reader.entries()[0].ok());
        EXPECT_TRUE(reader.entries()[2].ok());
        EXPECT_EQ(reader.records().size(), 2u);
        if (reader.records().size() == 2u) {
            expectSameRecord(reader.records()[0], records[0]);
            expectSameRecord(reader.records()[1], records[2]);
        }
        EXPECT_EQ(reader.entries()[1].line, 3u);
        EXPECT_FALSE(reader.entries()[1].record.has_value());
        EXPECT_EQ(reader.errors(), std::vector<std::string>{reader.entries()[1].error});
        return reader.entries()[1].error;
    }

    TempDir dir;
    std::vector<SessionRecord> records;
    fs::path log;
    std::string text;
    std::vector<std::string> lines;
    std::string prefix;
};

// ------------------------------------------------------------ the log file

TEST_F(DamagedSession, IntactSessionHasNoErrors) {
    const SessionLogReader reader(dir.path());
    EXPECT_TRUE(reader.errors().empty());
    ASSERT_EQ(reader.records().size(), 3u);
    for (std::size_t i = 0; i < 3; ++i) expectSameRecord(reader.records()[i], records[i]);
}

TEST_F(DamagedSession, GarbageLine) {
    setLine(3, "hello world\n");
    EXPECT_EQ(reportForLine3(), prefix + "3: not a session record: 'hello world' does not start with 'iteration='");
}

TEST_F(DamagedSession, EmptyLine) {
    setLine(3, "\n");
    EXPECT_EQ(reportForLine3(), prefix + "3: not a session record: '' does not start with 'iteration='");
}

TEST_F(DamagedSession, TruncatedLastLine) {
    // A crash in the middle of writing the last record.
    const std::size_t kept = lines[3].size() - 9;
    writeText(log, text.substr(0, text.size() - 10));
    const SessionLogReader reader(dir.path());
    ASSERT_EQ(reader.entries().size(), 3u);
    expectSameRecord(*reader.entries()[0].record, records[0]);
    expectSameRecord(*reader.entries()[1].record, records[1]);
    EXPECT_FALSE(reader.entries()[2].ok());
    EXPECT_EQ(reader.entries()[2].line, 4u);
    EXPECT_EQ(reader.entries()[2].error, prefix + "4: truncated record: the last line has no line end (" +
                                             std::to_string(kept) + " bytes; writing was probably interrupted)");
    // The configuration applied by the lost record is unknown; the first one is not.
    EXPECT_EQ(reader.configXml(2), std::nullopt);
    EXPECT_EQ(reader.configXml(1), std::string(kConfigXmlV1));
}

TEST_F(DamagedSession, LastLineWithoutItsLineEnd) {
    writeText(log, text.substr(0, text.size() - 1));
    const SessionLogReader reader(dir.path());
    ASSERT_EQ(reader.entries().size(), 3u);
    EXPECT_EQ(reader.entries()[2].error, prefix + "4: truncated record: the last line has no line end (" +
                                             std::to_string(lines[3].size()) +
                                             " bytes; writing was probably interrupted)");
}

TEST_F(DamagedSession, LineChecksumMismatch) {
    const std::string changed = replaceOnce(lines[2], "leftTimeUs=2000", "leftTimeUs=2001");
    setLine(3, changed + "\n");
    const std::string body = bodyOf(changed);
    EXPECT_EQ(reportForLine3(), prefix + "3: line checksum mismatch: recorded " +
                                    changed.substr(changed.size() - 8) + ", computed " +
                                    hex8(crc32(body.data(), body.size())) + " (the line was altered or damaged)");
}

// Lines with intact checksums in the wrong order: iterations and acquisition
// times must increase, or the replay would serve iteration 2 after 3.
TEST_F(DamagedSession, ADuplicatedRecordIsDamage) {
    writeText(log, lines[0] + "\n" + lines[1] + "\n" + lines[2] + "\n" + lines[2] + "\n" + lines[3] + "\n");
    const SessionLogReader reader(dir.path());
    ASSERT_EQ(reader.entries().size(), 4u);
    EXPECT_EQ(reader.errors(), std::vector<std::string>{prefix + "4: iteration 2 does not follow iteration 2 of line 3 "
                                                                 "(a record repeated or out of order)"});
    ASSERT_EQ(reader.records().size(), 3u);
    for (std::size_t i = 0; i < 3; ++i) expectSameRecord(reader.records()[i], records[i]);
}

TEST_F(DamagedSession, TwoSwappedRecordsAreDamage) {
    writeText(log, lines[0] + "\n" + lines[1] + "\n" + lines[3] + "\n" + lines[2] + "\n");
    const SessionLogReader reader(dir.path());
    EXPECT_EQ(reader.errors(), std::vector<std::string>{prefix + "4: iteration 2 does not follow iteration 3 of line 3 "
                                                                 "(a record repeated or out of order)"});
    ASSERT_EQ(reader.records().size(), 2u);
    EXPECT_EQ(reader.records()[0].iteration, 1u);
    EXPECT_EQ(reader.records()[1].iteration, 3u);
}

TEST_F(DamagedSession, AFirstRecordDamagedIsNamedWhenItsConfigurationIsMissing) {
    const std::string changed = replaceOnce(lines[1], "leftTimeUs=1000", "leftTimeUs=1001");
    setLine(2, changed + "\n");
    const RawDataAcquire replay(dir.path());
    try {
        replay.initialConfig();
        ADD_FAILURE() << "no error";
    } catch (const NotAvailable& e) {
        const std::string what = e.what();
        EXPECT_NE(what.find("does not hold configuration 1 of its first intact record (" + prefix + "3)"),
                  std::string::npos)
            << what;
        EXPECT_NE(what.find("damaged before it: " + prefix + "2: line checksum mismatch"), std::string::npos) << what;
    }
}

TEST_F(DamagedSession, MissingLineChecksum) {
    setLine(3, bodyOf(lines[2]) + "\n");
    EXPECT_EQ(reportForLine3(), prefix + "3: record has no line checksum: expected ' crc=<8 hexadecimal digits>' "
                                         "at the end, found 'config=1 result=none'");
}

TEST_F(DamagedSession, UpperCaseChecksumsAreAccepted) {
    const std::string crc = hex8(records[1].files.left.crc32);
    std::string upper = crc;
    for (char& ch : upper) ch = static_cast<char>(std::toupper(static_cast<unsigned char>(ch)));
    std::string body = replaceOnce(bodyOf(lines[2]), "leftCrc=" + crc, "leftCrc=" + upper);
    const std::uint32_t lineCrc = crc32(body.data(), body.size());
    std::string lineCrcUpper = hex8(lineCrc);
    for (char& ch : lineCrcUpper) ch = static_cast<char>(std::toupper(static_cast<unsigned char>(ch)));
    setLine(3, body + " crc=" + lineCrcUpper + "\n");
    const SessionLogReader reader(dir.path());
    EXPECT_TRUE(reader.errors().empty());
    ASSERT_EQ(reader.records().size(), 3u);
    expectSameRecord(reader.records()[1], records[1]);
}

// ------------------------------------------------------------ bad field values

struct BadField {
    const char* name;
    const char* from;  ///< text of line 3 (iteration 2) to replace
    const char* to;
    const char* problem;  ///< the report after "<log>:3: "
    friend void PrintTo(const BadField& c, std::ostream* os) { *os << c.name; }
};

class BadFieldValue : public DamagedSession, public ::testing::WithParamInterface<BadField> {};

TEST_P(BadFieldValue, IsReportedWithFieldAndValue) {
    const BadField& c = GetParam();
    setLine(3, withCrc(replaceOnce(bodyOf(lines[2]), c.from, c.to)));
    EXPECT_EQ(reportForLine3(), prefix + "3: " + c.problem);
}

INSTANTIATE_TEST_SUITE_P(
    SessionLog, BadFieldValue,
    ::testing::Values(
        BadField{"NotAnInteger", "leftTimeUs=2000", "leftTimeUs=20x0",
                 "field 'leftTimeUs': '20x0' is not a signed 64-bit integer"},
        BadField{"NegativeGroup", "group=1", "group=-1", "field 'group': '-1' is not an unsigned 32-bit integer"},
        BadField{"ShortFileChecksum", "leftCrc=", "leftCrc=123 x=",
                 "field 'leftCrc': '123' is not 8 hexadecimal digits"},
        BadField{"UnknownResult", "result=none", "result=bad",
                 "field 'result': 'bad' is not none, unknown, good or poor"},
        BadField{"BadEscape", "leftCamera=0x00b09d01004a5e2c", "leftCamera=ab%2",
                 "field 'leftCamera': bad escape '%2' at character 3 (expected %XX, two hexadecimal digits)"},
        BadField{"FileOfOtherMember", "leftFile=L_00001_00001_", "leftFile=L_00001_00002_",
                 "field 'leftFile': 'L_00001_00002_8x6_12b_1c_GB_le.raw' is group 1 member 2 but the record is "
                 "group 1 member 1"},
        BadField{"FileOfOtherSide", "rightFile=R_", "rightFile=L_",
                 "field 'rightFile': 'L_00001_00001_8x6_12b_1c_GB_le.raw' is not a right (R_) image file"},
        BadField{"FileNameThatDoesNotParse", "leftFile=L_00001_00001_8x6", "leftFile=L_00001_00001_8by6",
                 "field 'leftFile': raw file name 'L_00001_00001_8by6_12b_1c_GB_le.raw': size '8by6' is not WxH"},
        BadField{"NonCanonicalFileName", "leftFile=L_00001_00001_8x6", "leftFile=L_00001_00001_08x6",
                 "field 'leftFile': raw file name 'L_00001_00001_08x6_12b_1c_GB_le.raw': width '08' has a "
                 "leading zero"},
        BadField{"MissingField", " member=1", "",
                 "expected field 'member=' after field 'group', found 'leftCamera=0x00b09d01004a5e2c'"},
        BadField{"RecordEndsEarly", " result=none", "", "record ends after field 'config'; expected field 'result='"},
        BadField{"UnexpectedField", "result=none", "result=none extra=1",
                 "unexpected field 'extra=1' after field 'result'"},
        BadField{"TimingWithoutMilliseconds", "result=none", "result=good reason= timing=abc",
                 "field 'timing[0]': 'abc' is not <stage>:<milliseconds>"},
        BadField{"TimingNotANumber", "result=none", "result=good reason= timing=abc:1.5.2",
                 "field 'timing[0].milliseconds': '1.5.2' is not a number"},
        BadField{"TargetWithTooFewValues", "result=none", "result=good reason= target=a,1,-,-,-,-,1,2",
                 "field 'target[0]': expected 14 comma-separated values (type,flags,positionVision,positionBase,"
                 "centroidLeft,centroidRight,areaLeft,areaRight,matchError,model,covarianceVision,covarianceBase,"
                 "rayResidualMm,rayResidualPx), got 8"},
        BadField{"TargetOfVersionOneInAVersionTwoLog", "result=none", "result=good reason= target=a,1,-,-,-,-,1,2,3",
                 "field 'target[0]': expected 14 comma-separated values (type,flags,positionVision,positionBase,"
                 "centroidLeft,centroidRight,areaLeft,areaRight,matchError,model,covarianceVision,covarianceBase,"
                 "rayResidualMm,rayResidualPx), got 9"},
        BadField{"TargetPositionOfTwoCoordinates", "result=none",
                 "result=good reason= target=a,1,-,-,-,-,1,2,3,none,-,-,0,0 target=b,1,1;2,-,-,-,1,2,3,none,-,-,0,0",
                 "field 'target[1].positionVision': '1;2' is not '-' or x;y;z"},
        BadField{"TargetFlagsTooLarge", "result=none", "result=good reason= target=a,4294967296,-,-,-,-,1,2,3,none,-,-,0,0",
                 "field 'target[0].flags': '4294967296' is not an unsigned 32-bit integer"},
        BadField{"TargetModelUnknown", "result=none", "result=good reason= target=a,1,-,-,-,-,1,2,3,cube,-,-,0,0",
                 "field 'target[0].model': 'cube' is not none, sphere, disc or composite"},
        BadField{"TargetCovarianceShort", "result=none",
                 "result=good reason= target=a,1,-,-,-,-,1,2,3,sphere,1;0;0;1;0,-,0,0",
                 "field 'target[0].covarianceVision': '1;0;0;1;0' is not '-' or xx;xy;xz;yy;yz;zz"},
        BadField{"TargetResidualNotANumber", "result=none",
                 "result=good reason= target=a,1,-,-,-,-,1,2,3,disc,-,-,0.5,x",
                 "field 'target[0].rayResidualPx': 'x' is not a number"}),
    [](const ::testing::TestParamInfo<BadField>& param) { return std::string(param.param.name); });

// ------------------------------------------------------------ the header

TEST_F(DamagedSession, UnknownVersion) {
    setLine(1, "AVATAR-SESSION-LOG 3\n");
    EXPECT_EQ(messageOf<FormatError>([&] { SessionLogReader r(dir.path()); }),
              prefix + "1: unsupported session log version 3; this reader reads versions 1 to 2");
}

TEST_F(DamagedSession, VersionThatIsNotANumber) {
    setLine(1, "AVATAR-SESSION-LOG 1.0\n");
    EXPECT_EQ(messageOf<FormatError>([&] { SessionLogReader r(dir.path()); }),
              prefix + "1: session log version '1.0' is not a positive integer");
}

TEST_F(DamagedSession, NotASessionLog) {
    setLine(1, "\x89PNG\r\n");
    EXPECT_EQ(messageOf<FormatError>([&] { SessionLogReader r(dir.path()); }),
              prefix + "1: not an AVATAR session log: expected the header 'AVATAR-SESSION-LOG <version>', "
                       "found '%89PNG%0D'");
}

TEST_F(DamagedSession, EmptyLogFile) {
    writeText(log, "");
    EXPECT_EQ(messageOf<FormatError>([&] { SessionLogReader r(dir.path()); }),
              prefix + "1: empty file; expected the header 'AVATAR-SESSION-LOG 2'");
}

TEST_F(DamagedSession, HeaderWithoutLineEnd) {
    writeText(log, "AVATAR-SESSION-LOG 1");
    EXPECT_EQ(messageOf<FormatError>([&] { SessionLogReader r(dir.path()); }),
              prefix + "1: the header line has no line end (writing was interrupted)");
}

TEST_F(DamagedSession, MissingLogFile) {
    fs::remove(log);
    EXPECT_EQ(messageOf<IoError>([&] { SessionLogReader r(dir.path()); }),
              "session log " + log.string() + " does not exist");
}

// ------------------------------------------------------------ the image files

TEST_F(DamagedSession, TruncatedImageFile) {
    const fs::path file = dir / records[1].files.right.name;
    fs::resize_file(file, 50);
    const SessionLogReader reader(dir.path());
    EXPECT_EQ(messageOf<FormatError>([&] { reader.loadPair(reader.records()[1]); }),
              "iteration 2: raw file " + file.string() +
                  " is truncated: 50 bytes, its name says 8x6 12-bit 1-channel = 96 bytes");
    // The other pairs still load.
    EXPECT_NO_THROW(reader.loadPair(reader.records()[0]));
    EXPECT_NO_THROW(reader.loadPair(reader.records()[2]));
}

TEST_F(DamagedSession, ImageFileOfTheWrongSizeForItsName) {
    const fs::path file = dir / records[1].files.left.name;
    fs::resize_file(file, 97);
    const SessionLogReader reader(dir.path());
    EXPECT_EQ(messageOf<FormatError>([&] { reader.loadPair(reader.records()[1]); }),
              "iteration 2: raw file " + file.string() +
                  " is too large: 97 bytes, its name says 8x6 12-bit 1-channel = 96 bytes");
}

TEST_F(DamagedSession, ImageFileWithABadChecksum) {
    const fs::path file = dir / records[1].files.left.name;
    auto bytes = readBytes(file);
    bytes[40] ^= 0x10;
    writeText(file, std::string(bytes.begin(), bytes.end()));
    const SessionLogReader reader(dir.path());
    EXPECT_EQ(messageOf<FormatError>([&] { reader.loadPair(reader.records()[1]); }),
              "iteration 2: image file " + file.string() + ": checksum mismatch: recorded " +
                  hex8(records[1].files.left.crc32) + ", computed " + hex8(crc32(bytes.data(), bytes.size())) +
                  " (the file was altered or damaged)");
}

TEST_F(DamagedSession, MissingImageFile) {
    const fs::path file = dir / records[2].files.right.name;
    fs::remove(file);
    const SessionLogReader reader(dir.path());
    EXPECT_EQ(messageOf<IoError>([&] { reader.loadPair(reader.records()[2]); }),
              "iteration 3: image file " + file.string() + " does not exist");
}

TEST_F(DamagedSession, PairWhoseNamesDisagree) {
    // Both files intact, but the right one is of another size than the left.
    SessionRecord r = records[1];
    const fs::path odd = dir / "R_00001_00001_4x6_12b_1c_GB_le.raw";
    writeText(odd, std::string(48, '\0'));
    r.files.right = {odd.filename().string(), crc32(std::string(48, '\0').data(), 48)};
    const SessionLogReader reader(dir.path());
    EXPECT_EQ(messageOf<FormatError>([&] { reader.loadPair(r); }),
              "iteration 2: L_00001_00001_8x6_12b_1c_GB_le.raw and R_00001_00001_4x6_12b_1c_GB_le.raw do not "
              "describe images of the same size and layout");
}
