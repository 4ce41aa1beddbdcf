// AcquireSIPFileLoader: 8-bit pairs from a list or a printf-style pattern, the
// end of the sequence, and every file that cannot be read; and the numbering
// rules of AcquireStereoImagePair, which every backend shares.
#include "TempDir.h"
#include "TestUtil.h"

#include <avatar/acquire/AcquireSIPFileLoader.h>
#include <avatar/common/Error.h>

#include <gtest/gtest.h>
#include <opencv2/imgcodecs.hpp>

#include <string>
#include <utility>
#include <vector>

using namespace avatar;
using namespace avatar::test;
namespace fs = std::filesystem;

namespace {

/// A 5x4 8-bit BGR image whose samples depend on @p seed.
cv::Mat image8(std::uint64_t seed) { return randomImage(4, 5, CV_8UC3, 8, seed); }

/// Writes a PNG (lossless, so the samples read back exactly).
void writePng(const fs::path& path, const cv::Mat& image) { ASSERT_TRUE(cv::imwrite(path.string(), image)); }

/// Writes pairs left_<i>.png/right_<i>.png for i in 0..n-1 and returns their paths.
std::vector<StereoFilePaths> writePairs(const TempDir& dir, int n) {
    std::vector<StereoFilePaths> paths;
    for (int i = 0; i < n; ++i) {
        StereoFilePaths p{dir / ("left_" + std::to_string(i) + ".png"), dir / ("right_" + std::to_string(i) + ".png")};
        writePng(p.left, image8(2 * i));
        writePng(p.right, image8(2 * i + 1));
        paths.push_back(p);
    }
    return paths;
}

std::pair<std::uint32_t, std::uint32_t> numbers(const AcquiredPair& a) {
    return {a.pair.id().group, a.pair.id().member};
}

}  // namespace

// ------------------------------------------------------------------ the list

TEST(AcquireSIPFileLoader, DeliversTheListInOrderAsBgr8ThenFinishes) {
    TempDir dir;
    AcquireSIPFileLoader loader(writePairs(dir, 3));
    EXPECT_EQ(loader.name(), "files");
    EXPECT_EQ(loader.status().state, AcquisitionStatus::State::Ok);
    for (int i = 0; i < 3; ++i) {
        SCOPED_TRACE(i);
        const AcquiredPair a = loader.acquire();
        EXPECT_TRUE(sameImage(a.pair.left(), image8(2 * i)));
        EXPECT_TRUE(sameImage(a.pair.right(), image8(2 * i + 1)));
        EXPECT_EQ(a.pair.layout().format, PixelFormat::Bgr);
        EXPECT_EQ(a.pair.layout().bitDepth, 8);
        EXPECT_EQ(numbers(a), std::make_pair(1u, static_cast<std::uint32_t>(i)));
        EXPECT_GT(a.pair.id().left.timestampUs, 0);
        EXPECT_EQ(a.pair.id().left.timestampUs, a.pair.id().right.timestampUs);
        EXPECT_FALSE(a.recordedIteration);
        EXPECT_FALSE(a.recordedResult);
    }
    // Finished as soon as the last pair is out, before anyone asks for more.
    EXPECT_EQ(loader.status().state, AcquisitionStatus::State::Finished);
    EXPECT_EQ(loader.status().message, "files: all pairs delivered (3 read, 0 unreadable)");
    const std::string error = messageOf<AcquisitionError>([&] { loader.acquire(); });
    EXPECT_EQ(error, "files: no more pairs: files: all pairs delivered (3 read, 0 unreadable)");
    EXPECT_EQ(loader.deliveredCount(), 3u);
    EXPECT_EQ(loader.status().state, AcquisitionStatus::State::Finished);
}

TEST(AcquireSIPFileLoader, EmptyListIsFinishedFromTheStart) {
    AcquireSIPFileLoader loader(std::vector<StereoFilePaths>{});
    EXPECT_EQ(loader.status().state, AcquisitionStatus::State::Finished);
    EXPECT_NE(messageOf<AcquisitionError>([&] { loader.acquire(); }).find("no more pairs"), std::string::npos);
}

TEST(AcquireSIPFileLoader, MissingFileIsReportedByNameAndTheNextPairFollows) {
    TempDir dir;
    auto paths = writePairs(dir, 3);
    fs::remove(paths[1].right);
    AcquireSIPFileLoader loader(paths);
    EXPECT_EQ(numbers(loader.acquire()), std::make_pair(1u, 0u));
    EXPECT_EQ(messageOf<AcquisitionError>([&] { loader.acquire(); }),
              "files: no such image file: " + paths[1].right.string());
    EXPECT_EQ(loader.status().state, AcquisitionStatus::State::Recovering);
    EXPECT_EQ(loader.status().message, "files: no such image file: " + paths[1].right.string());
    // The next pair: read, and numbered on (the failed pair took no number).
    const AcquiredPair third = loader.acquire();
    EXPECT_TRUE(sameImage(third.pair.left(), image8(4)));
    EXPECT_EQ(numbers(third), std::make_pair(1u, 1u));
    EXPECT_EQ(loader.status().state, AcquisitionStatus::State::Finished);
    EXPECT_EQ(loader.status().message, "files: all pairs delivered (2 read, 1 unreadable; last error: "
                                       "files: no such image file: " + paths[1].right.string() + ")");
    EXPECT_EQ(loader.failedCount(), 1u);
}

TEST(AcquireSIPFileLoader, UndecodableFileIsReportedByName) {
    TempDir dir;
    auto paths = writePairs(dir, 1);
    writeText(paths[0].left, "this is not an image");
    AcquireSIPFileLoader loader(paths);
    EXPECT_EQ(messageOf<AcquisitionError>([&] { loader.acquire(); }),
              "files: cannot decode image file " + paths[0].left.string());
    EXPECT_EQ(loader.status().state, AcquisitionStatus::State::Finished);
}

TEST(AcquireSIPFileLoader, FilesOfDifferentSizeAreNotAPair) {
    TempDir dir;
    auto paths = writePairs(dir, 1);
    writePng(paths[0].right, randomImage(6, 5, CV_8UC3, 8, 9));
    AcquireSIPFileLoader loader(paths);
    EXPECT_EQ(messageOf<AcquisitionError>([&] { loader.acquire(); }),
              "files: " + paths[0].left.string() + " (5x4) and " + paths[0].right.string() +
                  " (5x6) are not the same size");
}

// --------------------------------------------------------------- the pattern

TEST(StereoFilePattern, ExpandsWidthZeroPaddingAndLiteralPercent) {
    StereoFilePattern p{"/d/left_%04d.jpg", "/d/100%%/right_%u.jpg", 7, std::nullopt};
    EXPECT_NO_THROW(p.validate());
    EXPECT_EQ(p.at(7).left, fs::path("/d/left_0007.jpg"));
    EXPECT_EQ(p.at(12345).left, fs::path("/d/left_12345.jpg"));
    EXPECT_EQ(p.at(7).right, fs::path("/d/100%/right_7.jpg"));
    StereoFilePattern spaces{"l%3d", "r%d", 0, std::nullopt};
    EXPECT_EQ(spaces.at(5).left, fs::path("l  5"));
}

TEST(StereoFilePattern, RejectsPatternsWithoutExactlyOneIntegerConversion) {
    auto message = [](std::string left) {
        return messageOf<InvalidArgument>([&] { StereoFilePattern{left, "r_%d", 0, std::nullopt}.validate(); });
    };
    EXPECT_EQ(message("left.png"), "file pattern (left) 'left.png': no integer conversion (such as %04d)");
    EXPECT_EQ(message("l_%s.png"),
              "file pattern (left) 'l_%s.png': conversion at offset 2 is not %d, %u, %<width>d or %0<width>d");
    EXPECT_EQ(message("l_%d_%d.png"), "file pattern (left) 'l_%d_%d.png': more than one conversion (only one "
                                      "integer conversion such as %04d is allowed)");
    EXPECT_EQ(message("l_%"), "file pattern (left) 'l_%': conversion at offset 2 is not %d, %u, %<width>d or "
                              "%0<width>d");
    EXPECT_THROW(AcquireSIPFileLoader(StereoFilePattern{"l_%d", "r_%x", 0, std::nullopt}), InvalidArgument);
}

class PatternLoader : public ::testing::Test {
protected:
    /// left_0007.png .. left_0009.png and the right images.
    void SetUp() override {
        for (int i = 7; i <= 9; ++i) {
            char l[32];
            char r[32];
            std::snprintf(l, sizeof l, "left_%04d.png", i);
            std::snprintf(r, sizeof r, "right_%04d.png", i);
            writePng(dir / l, image8(static_cast<std::uint64_t>(10 * i)));
            writePng(dir / r, image8(static_cast<std::uint64_t>(10 * i + 1)));
        }
    }
    StereoFilePattern pattern(std::optional<std::uint64_t> count = std::nullopt, std::uint64_t start = 7) const {
        return {(dir / "left_%04d.png").string(), (dir / "right_%04d.png").string(), start, count};
    }
    TempDir dir;
};

TEST_F(PatternLoader, OpenEndedSequenceEndsWhereBothFilesAreMissing) {
    AcquireSIPFileLoader loader(pattern());
    for (int i = 7; i <= 9; ++i) {
        const AcquiredPair a = loader.acquire();
        EXPECT_TRUE(sameImage(a.pair.left(), image8(static_cast<std::uint64_t>(10 * i))));
        EXPECT_TRUE(sameImage(a.pair.right(), image8(static_cast<std::uint64_t>(10 * i + 1))));
    }
    EXPECT_EQ(loader.status().state, AcquisitionStatus::State::Finished);
    EXPECT_THROW(loader.acquire(), AcquisitionError);
    EXPECT_EQ(loader.deliveredCount(), 3u);
}

TEST_F(PatternLoader, CountLimitsTheSequence) {
    AcquireSIPFileLoader loader(pattern(2));
    loader.acquire();
    EXPECT_EQ(loader.status().state, AcquisitionStatus::State::Ok);
    const AcquiredPair second = loader.acquire();
    EXPECT_TRUE(sameImage(second.pair.left(), image8(80)));
    EXPECT_EQ(loader.status().state, AcquisitionStatus::State::Finished);
}

TEST_F(PatternLoader, CountRequiresEveryFile) {
    AcquireSIPFileLoader loader(pattern(4));  // 7..10, and 10 does not exist
    for (int i = 0; i < 3; ++i) loader.acquire();
    EXPECT_EQ(messageOf<AcquisitionError>([&] { loader.acquire(); }),
              "files: no such image file: " + (dir / "left_0010.png").string());
    EXPECT_EQ(loader.status().state, AcquisitionStatus::State::Finished);
}

TEST_F(PatternLoader, OneSideMissingIsAnErrorNotTheEnd) {
    fs::remove(dir / "right_0008.png");
    AcquireSIPFileLoader loader(pattern());
    loader.acquire();
    EXPECT_EQ(messageOf<AcquisitionError>([&] { loader.acquire(); }),
              "files: no such image file: " + (dir / "right_0008.png").string());
    EXPECT_EQ(loader.status().state, AcquisitionStatus::State::Recovering);
    const AcquiredPair last = loader.acquire();
    EXPECT_TRUE(sameImage(last.pair.left(), image8(90)));
    EXPECT_EQ(loader.status().state, AcquisitionStatus::State::Finished);
}

TEST_F(PatternLoader, StartBeyondTheFilesIsFinishedAtOnce) {
    AcquireSIPFileLoader loader(pattern(std::nullopt, 100));
    EXPECT_EQ(loader.status().state, AcquisitionStatus::State::Finished);
}

// -------------------------------------------- numbering (AcquireStereoImagePair)

TEST(AcquisitionNumbering, FirstPairIsGroupOneMemberZero) {
    TempDir dir;
    AcquireSIPFileLoader loader(writePairs(dir, 1));
    EXPECT_EQ(loader.nextGroup(), 1u);
    EXPECT_EQ(loader.nextMember(), 0u);
    EXPECT_EQ(numbers(loader.acquire()), std::make_pair(1u, 0u));
    EXPECT_EQ(loader.groupSize(), 99999u);
}

TEST(AcquisitionNumbering, GroupRollsOverAtTheGroupSize) {
    TempDir dir;
    AcquireSIPFileLoader loader(writePairs(dir, 7), 3);
    const std::vector<std::pair<std::uint32_t, std::uint32_t>> expected = {{1, 0}, {1, 1}, {1, 2}, {2, 0},
                                                                           {2, 1}, {2, 2}, {3, 0}};
    for (const auto& e : expected) EXPECT_EQ(numbers(loader.acquire()), e);
    EXPECT_EQ(loader.nextGroup(), 3u);
    EXPECT_EQ(loader.nextMember(), 1u);
}

TEST(AcquisitionNumbering, GroupSizeOneGivesEveryPairItsOwnGroup) {
    TempDir dir;
    AcquireSIPFileLoader loader(writePairs(dir, 3), 1);
    EXPECT_EQ(numbers(loader.acquire()), std::make_pair(1u, 0u));
    EXPECT_EQ(numbers(loader.acquire()), std::make_pair(2u, 0u));
    EXPECT_EQ(numbers(loader.acquire()), std::make_pair(3u, 0u));
}

TEST(AcquisitionNumbering, ConfigurationChangeStartsANewGroup) {
    TempDir dir;
    AcquireSIPFileLoader loader(writePairs(dir, 6), 10);
    // Applied before the first pair: nothing to close, the first pair is still 1/0.
    loader.applyConfig(AvatarConfig{});
    EXPECT_EQ(numbers(loader.acquire()), std::make_pair(1u, 0u));
    EXPECT_EQ(numbers(loader.acquire()), std::make_pair(1u, 1u));
    loader.applyConfig(AvatarConfig{});
    EXPECT_EQ(loader.nextGroup(), 2u);
    EXPECT_EQ(loader.nextMember(), 0u);
    // A second change before any pair of the new group does not skip a group.
    loader.applyConfig(AvatarConfig{});
    EXPECT_EQ(numbers(loader.acquire()), std::make_pair(2u, 0u));
    EXPECT_EQ(numbers(loader.acquire()), std::make_pair(2u, 1u));
    loader.applyConfig(AvatarConfig{});
    EXPECT_EQ(numbers(loader.acquire()), std::make_pair(3u, 0u));
}

TEST(AcquisitionNumbering, GroupSizeOutsideFiveDigitsIsRejected) {
    EXPECT_EQ(messageOf<InvalidArgument>([] { AcquireSIPFileLoader(std::vector<StereoFilePaths>{}, 0); }),
              "acquisition group size 0 outside 1..99999");
    EXPECT_EQ(messageOf<InvalidArgument>([] { AcquireSIPFileLoader(std::vector<StereoFilePaths>{}, 100000); }),
              "acquisition group size 100000 outside 1..99999");
    EXPECT_NO_THROW(AcquireSIPFileLoader(std::vector<StereoFilePaths>{}, 99999));
}
