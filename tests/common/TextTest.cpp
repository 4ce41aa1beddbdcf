// The text and file helpers the libraries share (common/include/avatar/common/internal/),
// and the words of the result flags.
#include "TempDir.h"

#include <avatar/common/Error.h>
#include <avatar/common/VisionTargets.h>
#include <avatar/common/internal/FileUtil.h>
#include <avatar/common/internal/Text.h>

#include <gtest/gtest.h>

#include <array>
#include <charconv>
#include <cmath>
#include <fstream>
#include <limits>
#include <string>
#include <vector>

namespace avatar {
namespace {

TEST(Text, SplitKeepsEmptyFields) {
    using V = std::vector<std::string_view>;
    EXPECT_EQ(text::split("a,,b", ','), (V{"a", "", "b"}));
    EXPECT_EQ(text::split("", ','), (V{""}));
    EXPECT_EQ(text::split(",", ','), (V{"", ""}));
    EXPECT_EQ(text::split("L_00001_00002", '_'), (V{"L", "00001", "00002"}));
}

TEST(Text, FormatDoubleIsShortestAndReadsBackExactly) {
    EXPECT_EQ(text::formatDouble(1049.13), "1049.13");
    EXPECT_EQ(text::formatDouble(1e9), "1e+09");
    EXPECT_EQ(text::formatDouble(-0.0), "-0");
    EXPECT_EQ(text::formatDouble(std::numeric_limits<double>::infinity()), "inf");
    for (const double v : {0.1, 1.0 / 3.0, 2.2250738585072014e-308, -1.7976931348623157e308, 712.28 / 2}) {
        const std::string s = text::formatDouble(v);
        double back = 0.0;
        std::from_chars(s.data(), s.data() + s.size(), back);
        EXPECT_EQ(back, v) << s;
    }
    EXPECT_EQ(text::formatDoubles(std::array<double, 3>{-106.53, -2.58, 0.82}, 3), "-106.53 -2.58 0.82");
    EXPECT_EQ(text::formatDoubles(std::array<double, 2>{1, 2}, 1), "1");
    EXPECT_EQ(text::hex8(0x04C11DB7u), "04c11db7");
    EXPECT_EQ(text::hex8(0), "00000000");
}

TEST(VisionTargets, FlagsAreNamedInBitOrder) {
    EXPECT_EQ(targetFlagsText(0), "-");
    EXPECT_EQ(targetFlagsText(kTargetStereo | kTargetAtBorder), "stereo,border");
    EXPECT_EQ(targetFlagsText(kTargetRightOnly), "right-only");
    EXPECT_EQ(targetFlagsText(kTargetStereo | kTargetShapeCorrected), "stereo,shape-corrected");
    EXPECT_EQ(targetFlagsText(kTargetStereo | kTargetWhole | kTargetPoorVisibility), "stereo,whole,poor-visibility");
    EXPECT_EQ(targetFlagsText(kTargetStereo | kTargetCut | kTargetOccludedLeft | kTargetOccludedRight |
                              kTargetMerged | kTargetAmbiguous),
              "stereo,cut,occluded-left,occluded-right,merged,ambiguous");
    EXPECT_EQ(targetFlagsText(kTargetLeftOnly | (1u << 12) | (1u << 31)), "left-only,bit12,bit31");
    EXPECT_EQ(toString(ShapeModel::Disc), "disc");
    EXPECT_EQ(toString(ShapeModel::Composite), "composite");
}

TEST(DocumentError, CarriesItsFourFactsAndItsKind) {
    const DocumentError<FormatError> e("lab.xml", 12, "/scene/target[2]@radiusMm", "expected a number > 0");
    EXPECT_STREQ(e.what(), "lab.xml:12: /scene/target[2]@radiusMm: expected a number > 0");
    EXPECT_EQ(e.source(), "lab.xml");
    EXPECT_EQ(e.line(), 12);
    EXPECT_EQ(e.elementPath(), "/scene/target[2]@radiusMm");
    EXPECT_EQ(e.problem(), "expected a number > 0");
    const FormatError& kind = e;  // caught as the kind it was declared as
    EXPECT_STREQ(kind.what(), e.what());
}

TEST(FileUtil, DurableWritesNeverOverwriteAndLeaveNoTemporary) {
    test::TempDir dir;
    const auto path = dir / "pair.raw";
    const std::string data = "0123456789";
    fileutil::writeNewFileDurably(path, data.data(), data.size());
    const auto bytes = fileutil::readWholeFile(path, "image file");
    EXPECT_EQ(std::string(bytes.begin(), bytes.end()), data);
    try {
        fileutil::writeNewFileDurably(path, "x", 1);
        ADD_FAILURE() << "overwrote";
    } catch (const IoError& e) {
        EXPECT_NE(std::string(e.what()).find("exists already"), std::string::npos) << e.what();
    }
    try {
        fileutil::readWholeFile(dir / "missing.raw", "image file");
        ADD_FAILURE() << "read";
    } catch (const IoError& e) {
        EXPECT_EQ(std::string(e.what()), "image file " + (dir / "missing.raw").string() + " does not exist");
    }
    // Atomic replacement: the new content, and nothing else left in the directory.
    const auto config = dir / "avatar.xml";
    fileutil::replaceFileAtomically(config, "old", "config file");
    fileutil::replaceFileAtomically(config, "new", "config file");
    std::ifstream in(config);
    std::string content;
    in >> content;
    EXPECT_EQ(content, "new");
    int entries = 0;
    for ([[maybe_unused]] const auto& e : std::filesystem::directory_iterator(dir.path())) ++entries;
    EXPECT_EQ(entries, 2);
    // A directory that does not exist: the error names the file and its temporary.
    try {
        fileutil::replaceFileAtomically(dir / "no" / "such.xml", "x", "config file");
        ADD_FAILURE() << "wrote";
    } catch (const IoError& e) {
        EXPECT_EQ(std::string(e.what()).rfind("cannot write config file '" + (dir / "no" / "such.xml").string() + "'", 0),
                  0u)
            << e.what();
    }
}

}  // namespace
}  // namespace avatar
