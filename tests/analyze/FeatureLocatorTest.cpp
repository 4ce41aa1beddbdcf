// Tests of erodeRestore, locateFeatures and searchWindow (thesis 3.3.2, 3.3.3,
// Table 3-1, Appendix C). Every expected value is written out by hand.

#include <avatar/analyze/ImageFeatureLocator.h>
#include <avatar/common/Error.h>

#include "MaskRows.h"  // internal: the labelling that reads only where a mask is on

#include <opencv2/core.hpp>
#include <opencv2/imgproc.hpp>

#include <gtest/gtest.h>

#include <array>
#include <cstddef>
#include <cstdint>
#include <initializer_list>
#include <string>
#include <vector>

namespace avatar {
namespace {

/// A mask from rows of text: '#' is on (255), anything else off.
cv::Mat maskFrom(std::initializer_list<const char*> rows) {
    const std::vector<std::string> lines(rows.begin(), rows.end());
    cv::Mat mask = cv::Mat::zeros(static_cast<int>(lines.size()),
                                  static_cast<int>(lines.front().size()), CV_8UC1);
    for (int y = 0; y < mask.rows; ++y) {
        for (int x = 0; x < mask.cols; ++x) {
            if (lines[static_cast<std::size_t>(y)][static_cast<std::size_t>(x)] == '#') {
                mask.at<std::uint8_t>(y, x) = 255;
            }
        }
    }
    return mask;
}

/// A type whose geometric filter keeps everything.
TargetType keepAll() {
    TargetType t;
    t.name = "test";
    t.area = {0.0, 1e9};
    t.aspectRatio = {0.0, 1e9};
    t.areaRatio = {0.0, 1.0};
    return t;
}

cv::Rect whole(const cv::Mat& m) { return {0, 0, m.cols, m.rows}; }

std::vector<Feature> locateAll(const cv::Mat& mask, const cv::Mat& intensity = cv::Mat()) {
    return locateFeatures(mask, intensity, keepAll(), whole(mask));
}

/// Expected points in Table 3-1 order: TL, TR, RT, RB, BR, BL, LB, LT.
void expectBoundary(const Feature& f, const std::array<cv::Point, 8>& expected) {
    static const char* const names[8] = {"1 top-left",     "2 top-right",   "3 right-top",
                                         "4 right-bottom", "5 bottom-right", "6 bottom-left",
                                         "7 left-bottom",  "8 left-top"};
    for (std::size_t i = 0; i < 8; ++i) {
        EXPECT_EQ(f.boundary[i], expected[i]) << "boundary point " << names[i];
    }
}

int differingPixels(const cv::Mat& a, const cv::Mat& b) {
    cv::Mat diff;
    cv::compare(a, b, diff, cv::CMP_NE);
    return cv::countNonZero(diff);
}

// ------------------------------------------------------------ locateFeatures

TEST(LocateFeatures, HandCheckedFiveByFive) {
    const cv::Mat mask = maskFrom({
        ".###.",  // y0
        "####.",  // y1
        "##.##",  // y2
        ".##..",  // y3
        "....#",  // y4: (4,4) has no on neighbour, a feature of its own
    });
    const auto f = locateAll(mask);
    ASSERT_EQ(f.size(), 2u);

    // A: 13 pixels. sum x = 6 + 6 + 8 + 3 = 23, sum y = 0*3 + 1*4 + 2*4 + 3*2 = 18.
    const Feature& a = f[0];
    EXPECT_EQ(a.area, 13);
    EXPECT_DOUBLE_EQ(a.centroid.x, 23.0 / 13.0);
    EXPECT_DOUBLE_EQ(a.centroid.y, 18.0 / 13.0);
    EXPECT_EQ(a.weightedCentroid, a.centroid);
    EXPECT_EQ(a.box, cv::Rect(0, 0, 5, 4));
    EXPECT_DOUBLE_EQ(a.aspectRatio, 1.25);  // 5 / 4
    EXPECT_DOUBLE_EQ(a.areaRatio, 0.65);    // 13 / 20
    EXPECT_TRUE(a.touchesBorder);
    // Top row y0: x 1..3. Right column x4: only (4,2). Bottom row y3: x 1..2.
    // Left column x0: y 1..2.
    expectBoundary(a, {cv::Point(1, 0), cv::Point(3, 0), cv::Point(4, 2), cv::Point(4, 2),
                       cv::Point(2, 3), cv::Point(1, 3), cv::Point(0, 2), cv::Point(0, 1)});
    const auto ip = a.interestPoints();
    EXPECT_EQ(ip[0], cv::Point2d(1, 0));
    EXPECT_EQ(ip[8], a.centroid);

    // B: the lone pixel (4,4).
    const Feature& b = f[1];
    EXPECT_EQ(b.area, 1);
    EXPECT_EQ(b.centroid, cv::Point2d(4, 4));
    EXPECT_EQ(b.box, cv::Rect(4, 4, 1, 1));
    EXPECT_DOUBLE_EQ(b.aspectRatio, 1.0);
    EXPECT_DOUBLE_EQ(b.areaRatio, 1.0);
    EXPECT_TRUE(b.touchesBorder);
    expectBoundary(b, {cv::Point(4, 4), cv::Point(4, 4), cv::Point(4, 4), cv::Point(4, 4),
                       cv::Point(4, 4), cv::Point(4, 4), cv::Point(4, 4), cv::Point(4, 4)});
}

TEST(LocateFeatures, TopRowTieTakesBothEndsOfAGappedRow) {
    // Appendix C: points 1/2 are the extreme x of all pixels on the global top
    // row, even when that row is not contiguous.
    const cv::Mat mask = maskFrom({
        ".........",
        ".#.....#.",
        ".#.....#.",
        ".#######.",
        ".........",
    });
    const auto f = locateAll(mask);
    ASSERT_EQ(f.size(), 1u);
    EXPECT_EQ(f[0].area, 11);
    EXPECT_EQ(f[0].box, cv::Rect(1, 1, 7, 3));
    EXPECT_FALSE(f[0].touchesBorder);
    expectBoundary(f[0], {cv::Point(1, 1), cv::Point(7, 1), cv::Point(7, 1), cv::Point(7, 3),
                          cv::Point(7, 3), cv::Point(1, 3), cv::Point(1, 3), cv::Point(1, 1)});
}

TEST(LocateFeatures, LocalExtremesAwayFromTheBoxCorners) {
    // Feature A: top row y0 holds only x 2..3, the right column x5 only (5,1),
    // the bottom row y5 only (1,5), the left column x0 only y 2..3.
    // (5,4) and (4,5) touch each other diagonally but nothing of A: feature B.
    const cv::Mat mask = maskFrom({
        "..##..",  // y0
        ".#..##",  // y1
        "##..#.",  // y2
        "#..#..",  // y3
        ".#...#",  // y4
        ".#..#.",  // y5
    });
    const auto f = locateAll(mask);
    ASSERT_EQ(f.size(), 2u);
    const Feature& a = f[0];
    EXPECT_EQ(a.area, 12);
    EXPECT_EQ(a.box, cv::Rect(0, 0, 6, 6));
    expectBoundary(a, {cv::Point(2, 0), cv::Point(3, 0), cv::Point(5, 1), cv::Point(5, 1),
                       cv::Point(1, 5), cv::Point(1, 5), cv::Point(0, 3), cv::Point(0, 2)});
    const Feature& b = f[1];
    EXPECT_EQ(b.area, 2);
    EXPECT_EQ(b.box, cv::Rect(4, 4, 2, 2));
    EXPECT_DOUBLE_EQ(b.areaRatio, 0.5);
    expectBoundary(b, {cv::Point(5, 4), cv::Point(5, 4), cv::Point(5, 4), cv::Point(5, 4),
                       cv::Point(4, 5), cv::Point(4, 5), cv::Point(4, 5), cv::Point(4, 5)});
}

TEST(LocateFeatures, GappedRightAndLeftColumns) {
    const cv::Mat mask = maskFrom({
        "......",
        ".####.",
        ".#....",
        ".####.",
        "....#.",
        ".####.",
        "......",
    });
    const auto f = locateAll(mask);
    ASSERT_EQ(f.size(), 1u);
    EXPECT_EQ(f[0].area, 14);
    EXPECT_EQ(f[0].box, cv::Rect(1, 1, 4, 5));
    // Right column x4: y1, y3, y4, y5. Left column x1: y1, y2, y3, y5.
    expectBoundary(f[0], {cv::Point(1, 1), cv::Point(4, 1), cv::Point(4, 1), cv::Point(4, 5),
                          cv::Point(4, 5), cv::Point(1, 5), cv::Point(1, 5), cv::Point(1, 1)});
}

TEST(LocateFeatures, DiagonalLineGivesCoincidentPoints) {
    const cv::Mat mask = maskFrom({
        "#....",
        ".#...",
        "..#..",
        "...#.",
    });
    const auto f = locateAll(mask);
    ASSERT_EQ(f.size(), 1u);
    EXPECT_EQ(f[0].area, 4);
    EXPECT_EQ(f[0].centroid, cv::Point2d(1.5, 1.5));
    EXPECT_DOUBLE_EQ(f[0].areaRatio, 0.25);
    expectBoundary(f[0], {cv::Point(0, 0), cv::Point(0, 0), cv::Point(3, 3), cv::Point(3, 3),
                          cv::Point(3, 3), cv::Point(3, 3), cv::Point(0, 0), cv::Point(0, 0)});
}

TEST(LocateFeatures, DiagonalNeighboursAreOneFeature) {
    const cv::Mat mask = maskFrom({
        "....",
        ".#..",
        "..#.",
        "....",
    });
    // Premise: 4-connectivity would see two features here.
    cv::Mat labels4;
    ASSERT_EQ(cv::connectedComponents(mask, labels4, 4, CV_32S), 3);

    const auto f = locateAll(mask);
    ASSERT_EQ(f.size(), 1u);
    EXPECT_EQ(f[0].area, 2);
    EXPECT_EQ(f[0].centroid, cv::Point2d(1.5, 1.5));
    EXPECT_EQ(f[0].box, cv::Rect(1, 1, 2, 2));
    EXPECT_FALSE(f[0].touchesBorder);
}

TEST(LocateFeatures, OnePixelFeature) {
    cv::Mat mask = cv::Mat::zeros(10, 10, CV_8UC1);
    mask.at<std::uint8_t>(3, 7) = 255;
    const auto f = locateAll(mask);
    ASSERT_EQ(f.size(), 1u);
    EXPECT_EQ(f[0].area, 1);
    EXPECT_EQ(f[0].centroid, cv::Point2d(7, 3));
    EXPECT_EQ(f[0].box, cv::Rect(7, 3, 1, 1));
    EXPECT_DOUBLE_EQ(f[0].aspectRatio, 1.0);
    EXPECT_DOUBLE_EQ(f[0].areaRatio, 1.0);
    EXPECT_FALSE(f[0].touchesBorder);
    for (const cv::Point& p : f[0].boundary) EXPECT_EQ(p, cv::Point(7, 3));
}

TEST(LocateFeatures, VeryLargeFeatureDoesNotOverflowTheStack) {
    cv::Mat mask = cv::Mat::zeros(1000, 1200, CV_8UC1);
    mask(cv::Rect(100, 50, 1000, 900)).setTo(255);
    const auto f = locateAll(mask);
    ASSERT_EQ(f.size(), 1u);
    EXPECT_EQ(f[0].area, 900000);
    EXPECT_DOUBLE_EQ(f[0].centroid.x, 599.5);  // 100 + 999 / 2
    EXPECT_DOUBLE_EQ(f[0].centroid.y, 499.5);  // 50 + 899 / 2
    EXPECT_EQ(f[0].box, cv::Rect(100, 50, 1000, 900));
    EXPECT_DOUBLE_EQ(f[0].aspectRatio, 1000.0 / 900.0);
    EXPECT_DOUBLE_EQ(f[0].areaRatio, 1.0);
    EXPECT_FALSE(f[0].touchesBorder);
    expectBoundary(f[0], {cv::Point(100, 50), cv::Point(1099, 50), cv::Point(1099, 50),
                          cv::Point(1099, 949), cv::Point(1099, 949), cv::Point(100, 949),
                          cv::Point(100, 949), cv::Point(100, 50)});
}

TEST(LocateFeatures, RasterOrderOfFirstPixel) {
    // The feature starting on row 0 comes first even though the other one is
    // further left; the two on row 2 come left to right.
    cv::Mat mask = cv::Mat::zeros(4, 30, CV_8UC1);
    mask.at<std::uint8_t>(0, 20) = 255;
    mask.at<std::uint8_t>(1, 20) = 255;
    mask.at<std::uint8_t>(1, 10) = 255;
    mask.at<std::uint8_t>(2, 3) = 255;
    mask.at<std::uint8_t>(3, 2) = 255;
    mask.at<std::uint8_t>(2, 25) = 255;
    const auto f = locateAll(mask);
    ASSERT_EQ(f.size(), 4u);
    EXPECT_EQ(f[0].boundary[kTopLeft], cv::Point(20, 0));
    EXPECT_EQ(f[1].boundary[kTopLeft], cv::Point(10, 1));
    EXPECT_EQ(f[2].boundary[kTopLeft], cv::Point(3, 2));
    EXPECT_EQ(f[2].area, 2);
    EXPECT_EQ(f[3].boundary[kTopLeft], cv::Point(25, 2));
}

TEST(LocateFeatures, EmptyMaskHasNoFeatures) {
    EXPECT_TRUE(locateAll(cv::Mat::zeros(8, 8, CV_8UC1)).empty());
}

TEST(LocateFeatures, NonBinaryMaskValuesCountAsOn) {
    cv::Mat mask = cv::Mat::zeros(5, 5, CV_8UC1);
    mask.at<std::uint8_t>(2, 2) = 1;
    mask.at<std::uint8_t>(2, 3) = 17;
    const auto f = locateAll(mask);
    ASSERT_EQ(f.size(), 1u);
    EXPECT_EQ(f[0].area, 2);
}

// ------------------------------------------------------------ geometric filter

/// Draws solid w x h rectangles side by side on one row, 2 pixels apart.
cv::Mat rectangles(const std::vector<cv::Size>& sizes) {
    cv::Mat mask = cv::Mat::zeros(12, 80, CV_8UC1);
    int x = 1;
    for (const cv::Size& s : sizes) {
        mask(cv::Rect(x, 1, s.width, s.height)).setTo(255);
        x += s.width + 2;
    }
    return mask;
}

std::vector<int> areas(const std::vector<Feature>& f) {
    std::vector<int> a;
    for (const Feature& x : f) a.push_back(x.area);
    return a;
}

TEST(GeometricFilter, AreaLimitsAreInclusive) {
    // Areas 3, 4, 6, 7 against [4, 6].
    const cv::Mat mask = rectangles({{3, 1}, {4, 1}, {6, 1}, {7, 1}});
    TargetType t = keepAll();
    t.area = {4.0, 6.0};
    const auto f = locateFeatures(mask, cv::Mat(), t, whole(mask));
    EXPECT_EQ(areas(f), (std::vector<int>{4, 6}));
}

TEST(GeometricFilter, AspectRatioLimitsAreInclusive) {
    // Aspect ratios 2/5 = 0.4 (out), 2/4 = 0.5 (in), 4/2 = 2 (in), 5/2 = 2.5 (out)
    // against [0.5, 2]; areas 10, 8, 8, 10 tell them apart with the order.
    const cv::Mat mask = rectangles({{2, 5}, {2, 4}, {4, 2}, {5, 2}});
    TargetType t = keepAll();
    t.aspectRatio = {0.5, 2.0};
    const auto f = locateFeatures(mask, cv::Mat(), t, whole(mask));
    ASSERT_EQ(f.size(), 2u);
    EXPECT_EQ(f[0].box.size(), cv::Size(2, 4));
    EXPECT_DOUBLE_EQ(f[0].aspectRatio, 0.5);
    EXPECT_EQ(f[1].box.size(), cv::Size(4, 2));
    EXPECT_DOUBLE_EQ(f[1].aspectRatio, 2.0);
}

TEST(GeometricFilter, AreaRatioLimitsAreInclusive) {
    // Against [0.5, 0.75], in raster order of first pixel:
    //   x 0..2:   7 of 3x3 = 0.778 (just above: out)
    //   x 5..6:   3 of 2x2 = 0.75  (the upper limit: in)
    //   x 9..10:  2 of 2x2 = 0.5   (the lower limit: in)
    //   x 13..15: 4 of 3x3 = 0.444 (just below: out)
    const cv::Mat mask = maskFrom({
        "###..##..#...#.#.",
        "###..#....#...#..",
        ".#...........#...",
    });
    ASSERT_EQ(locateAll(mask).size(), 4u);
    TargetType t = keepAll();
    t.areaRatio = {0.5, 0.75};
    const auto f = locateFeatures(mask, cv::Mat(), t, whole(mask));
    ASSERT_EQ(f.size(), 2u);
    EXPECT_EQ(f[0].box, cv::Rect(5, 0, 2, 2));
    EXPECT_DOUBLE_EQ(f[0].areaRatio, 0.75);
    EXPECT_EQ(f[1].box, cv::Rect(9, 0, 2, 2));
    EXPECT_DOUBLE_EQ(f[1].areaRatio, 0.5);
}

TEST(GeometricFilter, AllThreeMustPass) {
    // A 4x2 bar: area 8, aspect 2, area ratio 1.
    const cv::Mat mask = rectangles({{4, 2}});
    TargetType t = keepAll();
    EXPECT_EQ(locateFeatures(mask, cv::Mat(), t, whole(mask)).size(), 1u);
    t.area = {9.0, 100.0};
    EXPECT_TRUE(locateFeatures(mask, cv::Mat(), t, whole(mask)).empty());
    t = keepAll();
    t.aspectRatio = {0.0, 1.99};
    EXPECT_TRUE(locateFeatures(mask, cv::Mat(), t, whole(mask)).empty());
    t = keepAll();
    t.areaRatio = {0.0, 0.99};
    EXPECT_TRUE(locateFeatures(mask, cv::Mat(), t, whole(mask)).empty());
}

TEST(GeometricFilter, DefaultTypeDropsSmallFeatures) {
    // TargetType's default area range starts at 20 pixels.
    const cv::Mat mask = rectangles({{4, 5}, {19, 1}});
    const auto f = locateFeatures(mask, cv::Mat(), TargetType{}, whole(mask));
    ASSERT_EQ(f.size(), 1u);
    EXPECT_EQ(f[0].area, 20);
}

// ------------------------------------------------------------ search window

TEST(LocateFeatures, WindowOffsetsCoordinatesAndCutsFeatures) {
    cv::Mat mask = cv::Mat::zeros(15, 20, CV_8UC1);
    mask(cv::Rect(8, 6, 3, 2)).setTo(255);    // inside the window
    mask(cv::Rect(1, 1, 2, 2)).setTo(255);    // outside it
    mask(cv::Rect(13, 10, 4, 1)).setTo(255);  // crosses its right edge at x 14
    const cv::Rect window(5, 4, 10, 8);       // x 5..14, y 4..11
    const auto f = locateFeatures(mask, cv::Mat(), keepAll(), window);
    ASSERT_EQ(f.size(), 2u);

    EXPECT_EQ(f[0].area, 6);
    EXPECT_EQ(f[0].centroid, cv::Point2d(9.0, 6.5));
    EXPECT_EQ(f[0].box, cv::Rect(8, 6, 3, 2));
    EXPECT_FALSE(f[0].touchesBorder);
    expectBoundary(f[0], {cv::Point(8, 6), cv::Point(10, 6), cv::Point(10, 6), cv::Point(10, 7),
                          cv::Point(10, 7), cv::Point(8, 7), cv::Point(8, 7), cv::Point(8, 6)});

    EXPECT_EQ(f[1].area, 2);  // only x 13..14 are inside
    EXPECT_EQ(f[1].centroid, cv::Point2d(13.5, 10.0));
    EXPECT_EQ(f[1].box, cv::Rect(13, 10, 2, 1));
    EXPECT_TRUE(f[1].touchesBorder);
}

TEST(LocateFeatures, TouchesBorderOnEachWindowEdge) {
    cv::Mat mask = cv::Mat::zeros(20, 20, CV_8UC1);
    const cv::Rect window(2, 3, 14, 12);  // x 2..15, y 3..14
    mask.at<std::uint8_t>(8, 2) = 255;    // left edge
    mask.at<std::uint8_t>(3, 8) = 255;    // top edge
    mask.at<std::uint8_t>(9, 15) = 255;   // right edge
    mask.at<std::uint8_t>(14, 6) = 255;   // bottom edge
    mask.at<std::uint8_t>(10, 10) = 255;  // interior
    mask.at<std::uint8_t>(4, 3) = 255;    // one pixel in from the corner
    const auto f = locateFeatures(mask, cv::Mat(), keepAll(), window);
    ASSERT_EQ(f.size(), 6u);
    // Raster order: (8,3) top, (3,4), (2,8) left, (15,9) right, (10,10), (6,14) bottom.
    EXPECT_EQ(f[0].centroid, cv::Point2d(8, 3));
    EXPECT_TRUE(f[0].touchesBorder);
    EXPECT_EQ(f[1].centroid, cv::Point2d(3, 4));
    EXPECT_FALSE(f[1].touchesBorder);
    EXPECT_EQ(f[2].centroid, cv::Point2d(2, 8));
    EXPECT_TRUE(f[2].touchesBorder);
    EXPECT_EQ(f[3].centroid, cv::Point2d(15, 9));
    EXPECT_TRUE(f[3].touchesBorder);
    EXPECT_EQ(f[4].centroid, cv::Point2d(10, 10));
    EXPECT_FALSE(f[4].touchesBorder);
    EXPECT_EQ(f[5].centroid, cv::Point2d(6, 14));
    EXPECT_TRUE(f[5].touchesBorder);
}

TEST(LocateFeatures, RejectsBadArguments) {
    const cv::Mat mask = cv::Mat::zeros(10, 12, CV_8UC1);
    EXPECT_THROW(locateFeatures(mask, cv::Mat(), keepAll(), cv::Rect(5, 5, 10, 2)),
                 InvalidArgument);
    EXPECT_THROW(locateFeatures(mask, cv::Mat(), keepAll(), cv::Rect(0, 0, 0, 5)),
                 InvalidArgument);
    try {
        locateFeatures(mask, cv::Mat(), keepAll(), cv::Rect(-1, 0, 4, 4));
        ADD_FAILURE() << "no exception";
    } catch (const InvalidArgument& e) {
        EXPECT_NE(std::string(e.what()).find("x=-1"), std::string::npos) << e.what();
        EXPECT_NE(std::string(e.what()).find("12x10"), std::string::npos) << e.what();
    }
    EXPECT_THROW(locateFeatures(cv::Mat::zeros(10, 12, CV_16UC1), cv::Mat(), keepAll(),
                                cv::Rect(0, 0, 12, 10)),
                 FormatError);
    EXPECT_THROW(locateFeatures(mask, cv::Mat::zeros(10, 12, CV_32FC3), keepAll(), whole(mask)),
                 FormatError);
    EXPECT_THROW(locateFeatures(mask, cv::Mat::zeros(10, 11, CV_8UC3), keepAll(), whole(mask)),
                 InvalidArgument);
}

TEST(SearchWindow, UnsetIsTheWholeImage) {
    TargetType t = keepAll();
    EXPECT_EQ(searchWindow(t, {640, 480}), cv::Rect(0, 0, 640, 480));
    t.window = {10, 20, 0, 50};  // width 0: unset
    EXPECT_EQ(searchWindow(t, {640, 480}), cv::Rect(0, 0, 640, 480));
    t.window = {10, 20, 50, 0};
    EXPECT_EQ(searchWindow(t, {640, 480}), cv::Rect(0, 0, 640, 480));
}

TEST(SearchWindow, InsideIsUnchangedAndOverhangIsClipped) {
    TargetType t = keepAll();
    t.window = {10, 20, 30, 40};
    EXPECT_EQ(searchWindow(t, {100, 80}), cv::Rect(10, 20, 30, 40));
    t.window = {-5, 10, 20, 100};  // x -5..14, y 10..109 in a 100x50 image
    EXPECT_EQ(searchWindow(t, {100, 50}), cv::Rect(0, 10, 15, 40));
    t.window = {90, 45, 50, 50};
    EXPECT_EQ(searchWindow(t, {100, 50}), cv::Rect(90, 45, 10, 5));
}

TEST(SearchWindow, EntirelyOutsideThrowsNamingWindowAndImage) {
    TargetType t = keepAll();
    t.name = "sample";
    t.window = {100, 0, 20, 20};  // starts just right of a 100-wide image
    try {
        searchWindow(t, {100, 50});
        ADD_FAILURE() << "no exception";
    } catch (const InvalidArgument& e) {
        const std::string m = e.what();
        EXPECT_NE(m.find("x=100, y=0, width=20, height=20"), std::string::npos) << m;
        EXPECT_NE(m.find("100x50"), std::string::npos) << m;
        EXPECT_NE(m.find("sample"), std::string::npos) << m;
    }
    t.window = {-20, 0, 20, 20};  // ends just left of it
    EXPECT_THROW(searchWindow(t, {100, 50}), InvalidArgument);
    t.window = {0, 0, 20, 20};
    EXPECT_THROW(searchWindow(t, {0, 0}), InvalidArgument);
}

// ------------------------------------------------------------ weighted centroid

class WeightedCentroid : public ::testing::TestWithParam<int> {};

TEST_P(WeightedCentroid, KnownIntensityRamp) {
    // 3x2 block at x 2..4, y 1..2, searched in window x 1..6, y 1..3.
    // Pixel (B, G, R) = s * (10x, y, 1), so R+G+B = s * (10x + y + 1):
    //   y1: 22 32 42 (sum 96); y2: 23 33 43 (sum 99); total 195 (times s).
    //   sum w x = 2*45 + 3*65 + 4*85 = 625; sum w y = 96 + 2*99 = 294.
    const int depth = GetParam();
    const int s = depth == CV_8U ? 1 : 1000;  // 16-bit: larger values, same centroid
    cv::Mat mask = cv::Mat::zeros(5, 8, CV_8UC1);
    mask(cv::Rect(2, 1, 3, 2)).setTo(255);
    cv::Mat intensity(5, 8, CV_MAKETYPE(depth, 3));
    for (int y = 0; y < intensity.rows; ++y) {
        for (int x = 0; x < intensity.cols; ++x) {
            const cv::Scalar v(s * 10 * x, s * y, s);
            if (depth == CV_8U) {
                intensity.at<cv::Vec3b>(y, x) = cv::Vec3b(cv::saturate_cast<std::uint8_t>(v[0]),
                                                          cv::saturate_cast<std::uint8_t>(v[1]),
                                                          cv::saturate_cast<std::uint8_t>(v[2]));
            } else {
                intensity.at<cv::Vec3w>(y, x) = cv::Vec3w(cv::saturate_cast<std::uint16_t>(v[0]),
                                                          cv::saturate_cast<std::uint16_t>(v[1]),
                                                          cv::saturate_cast<std::uint16_t>(v[2]));
            }
        }
    }
    const auto f = locateFeatures(mask, intensity, keepAll(), cv::Rect(1, 1, 6, 3));
    ASSERT_EQ(f.size(), 1u);
    EXPECT_EQ(f[0].centroid, cv::Point2d(3.0, 1.5));
    EXPECT_DOUBLE_EQ(f[0].weightedCentroid.x, 625.0 / 195.0);  // 3.2051...
    EXPECT_DOUBLE_EQ(f[0].weightedCentroid.y, 294.0 / 195.0);  // 1.5077...
}

INSTANTIATE_TEST_SUITE_P(BitDepths, WeightedCentroid, ::testing::Values(CV_8U, CV_16U),
                         [](const ::testing::TestParamInfo<int>& param) {
                             return param.param == CV_8U ? std::string("Bgr8")
                                                        : std::string("Bgr16");
                         });

TEST(WeightedCentroidTest, BlackFeatureFallsBackToTheCentroid) {
    cv::Mat mask = cv::Mat::zeros(4, 4, CV_8UC1);
    mask(cv::Rect(1, 1, 2, 1)).setTo(255);
    const auto f = locateAll(mask, cv::Mat::zeros(4, 4, CV_8UC3));
    ASSERT_EQ(f.size(), 1u);
    EXPECT_EQ(f[0].weightedCentroid, cv::Point2d(1.5, 1.0));
}

// ------------------------------------------------------------ many features

TEST(LocateFeatures, OneThousandFeatures) {
    // 40 x 25 grid on a 1280x960 mask; feature i = 40 r + c is a rectangle at
    // (32c + 5, 38r + 7) of (3 + i % 5) x (3 + i % 4) pixels.
    cv::Mat mask = cv::Mat::zeros(960, 1280, CV_8UC1);
    for (int r = 0; r < 25; ++r) {
        for (int c = 0; c < 40; ++c) {
            const int i = 40 * r + c;
            mask(cv::Rect(32 * c + 5, 38 * r + 7, 3 + i % 5, 3 + i % 4)).setTo(255);
        }
    }
    const auto f = locateAll(mask);
    ASSERT_EQ(f.size(), 1000u);
    // Hand-computed: i 0 is 3x3 at (5,7); i 41 is 4x4 at (37,45);
    // i 999 (r 24, c 39) is 7x6 at (1253,919).
    EXPECT_EQ(f[0].centroid, cv::Point2d(6.0, 8.0));
    EXPECT_EQ(f[0].area, 9);
    EXPECT_EQ(f[41].centroid, cv::Point2d(38.5, 46.5));
    EXPECT_EQ(f[41].area, 16);
    EXPECT_EQ(f[999].centroid, cv::Point2d(1256.0, 921.5));
    EXPECT_EQ(f[999].area, 42);
    EXPECT_EQ(f[999].boundary[kBottomRight], cv::Point(1259, 924));
    for (int i = 0; i < 1000; ++i) {
        const int x = 32 * (i % 40) + 5;
        const int y = 38 * (i / 40) + 7;
        const int w = 3 + i % 5;
        const int h = 3 + i % 4;
        ASSERT_EQ(f[static_cast<std::size_t>(i)].box, cv::Rect(x, y, w, h)) << "feature " << i;
        ASSERT_EQ(f[static_cast<std::size_t>(i)].area, w * h) << "feature " << i;
    }
}

// ------------------------------------------------------------ against a reference

/// The thesis's algorithm written out plainly: an explicit-stack flood fill
/// (Figure 3-10 without the recursion) collects each feature's pixels in
/// discovery order, then Appendix C's update rules run over them literally
/// (with the local values initialised from the first pixel, which the
/// printed listing omits). Used to check the fast implementation.
std::vector<Feature> referenceLocate(const cv::Mat& mask, const cv::Rect& window) {
    const cv::Mat roi = mask(window);
    cv::Mat seen = cv::Mat::zeros(roi.size(), CV_8UC1);
    std::vector<Feature> out;
    for (int y = 0; y < roi.rows; ++y) {
        for (int x = 0; x < roi.cols; ++x) {
            if (roi.at<std::uint8_t>(y, x) == 0 || seen.at<std::uint8_t>(y, x) != 0) continue;
            std::vector<cv::Point> f;
            std::vector<cv::Point> stack{{x, y}};
            seen.at<std::uint8_t>(y, x) = 1;
            while (!stack.empty()) {
                const cv::Point p = stack.back();
                stack.pop_back();
                f.push_back(p);
                for (int dy = -1; dy <= 1; ++dy) {
                    for (int dx = -1; dx <= 1; ++dx) {
                        const cv::Point q(p.x + dx, p.y + dy);
                        if (q.x < 0 || q.y < 0 || q.x >= roi.cols || q.y >= roi.rows) continue;
                        if (roi.at<std::uint8_t>(q) == 0 || seen.at<std::uint8_t>(q) != 0) continue;
                        seen.at<std::uint8_t>(q) = 1;
                        stack.push_back(q);
                    }
                }
            }
            long totalX = 0;
            long totalY = 0;
            int xr = f[0].x, xl = f[0].x, ybot = f[0].y, ytop = f[0].y;
            int ybotXr = ybot, ytopXr = ytop, ybotXl = ybot, ytopXl = ytop;
            int xrYb = xr, xlYb = xl, xrYt = xr, xlYt = xl;
            for (const cv::Point& p : f) {
                totalX += p.x;
                totalY += p.y;
                if (p.x > xr) {
                    xr = p.x;
                    ybotXr = ytopXr = p.y;
                } else if (p.x == xr) {
                    if (p.y > ybotXr) ybotXr = p.y;
                    if (p.y < ytopXr) ytopXr = p.y;
                }
                if (p.x < xl) {
                    xl = p.x;
                    ybotXl = ytopXl = p.y;
                } else if (p.x == xl) {
                    if (p.y > ybotXl) ybotXl = p.y;
                    if (p.y < ytopXl) ytopXl = p.y;
                }
                if (p.y > ybot) {
                    ybot = p.y;
                    xrYb = xlYb = p.x;
                } else if (p.y == ybot) {
                    if (p.x > xrYb) xrYb = p.x;
                    if (p.x < xlYb) xlYb = p.x;
                }
                if (p.y < ytop) {
                    ytop = p.y;
                    xrYt = xlYt = p.x;
                } else if (p.y == ytop) {
                    if (p.x > xrYt) xrYt = p.x;
                    if (p.x < xlYt) xlYt = p.x;
                }
            }
            const cv::Point o = window.tl();
            Feature r;
            r.area = static_cast<int>(f.size());
            r.centroid = cv::Point2d(static_cast<double>(totalX) / r.area + o.x,
                                     static_cast<double>(totalY) / r.area + o.y);
            r.boundary = {cv::Point(xlYt, ytop) + o, cv::Point(xrYt, ytop) + o,
                          cv::Point(xr, ytopXr) + o, cv::Point(xr, ybotXr) + o,
                          cv::Point(xrYb, ybot) + o, cv::Point(xlYb, ybot) + o,
                          cv::Point(xl, ybotXl) + o, cv::Point(xl, ytopXl) + o};
            r.box = cv::Rect(xl + o.x, ytop + o.y, xr - xl + 1, ybot - ytop + 1);
            out.push_back(r);
        }
    }
    return out;
}

TEST(LocateFeatures, MatchesTheAppendixCReferenceOnRandomMasks) {
    cv::RNG rng(20240611);
    for (int trial = 0; trial < 60; ++trial) {
        const cv::Size size(rng.uniform(1, 60), rng.uniform(1, 45));
        cv::Mat noise(size, CV_32F);
        rng.fill(noise, cv::RNG::UNIFORM, 0.0, 1.0);
        const double density = 0.15 + 0.1 * (trial % 6);
        const cv::Mat mask = noise < density;
        cv::Rect window(0, 0, size.width, size.height);
        if (trial % 2 == 1) {
            window.x = rng.uniform(0, size.width);
            window.y = rng.uniform(0, size.height);
            window.width = rng.uniform(1, size.width - window.x + 1);
            window.height = rng.uniform(1, size.height - window.y + 1);
        }
        SCOPED_TRACE("trial " + std::to_string(trial));
        const auto expected = referenceLocate(mask, window);
        const auto actual = locateFeatures(mask, cv::Mat(), keepAll(), window);
        ASSERT_EQ(actual.size(), expected.size());
        for (std::size_t i = 0; i < actual.size(); ++i) {
            SCOPED_TRACE("feature " + std::to_string(i));
            EXPECT_EQ(actual[i].area, expected[i].area);
            EXPECT_NEAR(actual[i].centroid.x, expected[i].centroid.x, 1e-9);
            EXPECT_NEAR(actual[i].centroid.y, expected[i].centroid.y, 1e-9);
            EXPECT_EQ(actual[i].box, expected[i].box);
            EXPECT_EQ(actual[i].boundary, expected[i].boundary);
        }
    }
}

TEST(LocateFeatures, MatchesTheAppendixCReferenceOnLargeBlobMasks) {
    // Wide images with long runs and long empty stretches: the run labelling
    // skips both eight bytes at a time.
    cv::RNG rng(99);
    for (int trial = 0; trial < 8; ++trial) {
        const cv::Size size(rng.uniform(150, 330), rng.uniform(40, 120));
        cv::Mat noise(size, CV_32F);
        rng.fill(noise, cv::RNG::UNIFORM, 0.0, 1.0);
        cv::Mat mask = noise < 0.5;
        cv::blur(mask, mask, {9, 9});
        mask = mask > 120 + 2 * trial;
        const cv::Rect window = trial % 2 == 0 ? cv::Rect(0, 0, size.width, size.height)
                                               : cv::Rect(13, 5, size.width - 30, size.height - 9);
        SCOPED_TRACE("trial " + std::to_string(trial));
        const auto expected = referenceLocate(mask, window);
        const auto actual = locateFeatures(mask, cv::Mat(), keepAll(), window);
        ASSERT_EQ(actual.size(), expected.size());
        for (std::size_t i = 0; i < actual.size(); ++i) {
            SCOPED_TRACE("feature " + std::to_string(i));
            EXPECT_EQ(actual[i].area, expected[i].area);
            EXPECT_NEAR(actual[i].centroid.x, expected[i].centroid.x, 1e-9);
            EXPECT_NEAR(actual[i].centroid.y, expected[i].centroid.y, 1e-9);
            EXPECT_EQ(actual[i].box, expected[i].box);
            EXPECT_EQ(actual[i].boundary, expected[i].boundary);
        }
    }
}

/// Textbook morphological reconstruction: geodesic 3x3 dilation of the
/// eroded mask inside the original until nothing changes.
cv::Mat referenceErodeRestore(const cv::Mat& mask, int kernelSize) {
    cv::Mat marker;
    cv::erode(mask, marker, cv::Mat::ones(kernelSize, kernelSize, CV_8UC1));
    for (;;) {
        cv::Mat grown;
        cv::dilate(marker, grown, cv::Mat::ones(3, 3, CV_8UC1), cv::Point(-1, -1), 1,
                   cv::BORDER_CONSTANT, cv::Scalar(0));
        grown &= mask;
        if (differingPixels(grown, marker) == 0) return marker;
        marker = grown;
    }
}

/// A random mask of @p size, on with probability @p density; @p blobs:
/// blurred and thresholded again, which gives blobs of several sizes, not
/// just salt.
cv::Mat randomMask(cv::RNG& rng, cv::Size size, double density, bool blobs) {
    cv::Mat noise(size, CV_32F);
    rng.fill(noise, cv::RNG::UNIFORM, 0.0, 1.0);
    cv::Mat mask = noise < density;
    if (blobs) {
        cv::blur(mask, mask, {3, 3});
        mask = mask > 127;
    }
    return mask;
}

TEST(ErodeRestore, MatchesIterativeReconstructionOnRandomMasks) {
    cv::RNG rng(7);
    for (int trial = 0; trial < 40; ++trial) {
        const cv::Size size(rng.uniform(1, 80), rng.uniform(1, 60));
        const cv::Mat mask = randomMask(rng, size, 0.55 + 0.05 * (trial % 5), trial % 2 == 0);
        const int kernel = 3 + 2 * (trial % 3);
        SCOPED_TRACE("trial " + std::to_string(trial) + ", kernel " + std::to_string(kernel));
        EXPECT_EQ(differingPixels(erodeRestore(mask, kernel), referenceErodeRestore(mask, kernel)),
                  0);
    }
}

/// Each row's span of on pixels, as the front end hands it on.
detail::MaskRows rowsOf(const cv::Mat& mask) {
    detail::MaskRows rows;
    rows.data = mask.data;
    rows.begin.resize(static_cast<std::size_t>(mask.rows));
    rows.end.resize(static_cast<std::size_t>(mask.rows));
    for (int y = 0; y < mask.rows; ++y)
        detail::nonZeroSpan(mask.ptr<std::uint8_t>(y), mask.cols, rows.begin[static_cast<std::size_t>(y)],
                            rows.end[static_cast<std::size_t>(y)]);
    return rows;
}

TEST(MaskRows, NonZeroSpanIsTheFirstAndLastOnPixel) {
    // Rows wider than the eight bytes skipped at a time, on pixels at either end, in the middle, none.
    const cv::Mat mask = maskFrom({"#..................#", "........#...........", "....................",
                                   "..........#.#####...", "###################."});
    const detail::MaskRows rows = rowsOf(mask);
    EXPECT_EQ(rows.begin, (std::vector<int>{0, 8, 0, 10, 0}));
    EXPECT_EQ(rows.end, (std::vector<int>{20, 9, 0, 17, 19}));
    EXPECT_TRUE(rows.describes(mask));
    EXPECT_FALSE(rows.describes(mask.clone()));  // another buffer
}

TEST(ErodeRestore, InPlaceFromRowSpansMatchesTheReconstruction) {
    // The front end's path: the mask restored where it lies, reading only the
    // spans it was given; the spans it hands on cover exactly the kept pixels.
    cv::RNG rng(31);
    for (int trial = 0; trial < 40; ++trial) {
        const cv::Size size(rng.uniform(1, 200), rng.uniform(1, 60));
        cv::Mat mask = randomMask(rng, size, 0.55 + 0.05 * (trial % 5), true);
        mask(cv::Rect(0, 0, size.width, size.height / 3)).setTo(0);  // empty rows too
        const int kernel = 3 + 2 * (trial % 3);
        SCOPED_TRACE("trial " + std::to_string(trial) + ", kernel " + std::to_string(kernel));
        const cv::Mat expected = referenceErodeRestore(mask, kernel);
        const detail::MaskRows given = rowsOf(mask);
        detail::MaskRows kept;
        cv::Mat inPlace = mask;  // the same buffer
        detail::erodeRestoreInPlace(inPlace, kernel, &given, kept);
        EXPECT_EQ(inPlace.data, mask.data);
        EXPECT_EQ(differingPixels(inPlace, expected), 0);
        const detail::MaskRows tight = rowsOf(expected);
        EXPECT_EQ(kept.begin, tight.begin);
        EXPECT_EQ(kept.end, tight.end);
        EXPECT_TRUE(kept.describes(inPlace));
    }
}

TEST(LocateFeatures, ReadingOnlyTheRowSpansFindsTheSameFeatures) {
    cv::RNG rng(5);
    for (int trial = 0; trial < 20; ++trial) {
        const cv::Size size(rng.uniform(40, 300), rng.uniform(10, 80));
        cv::Mat noise(size, CV_32F);
        rng.fill(noise, cv::RNG::UNIFORM, 0.0, 1.0);
        cv::Mat mask = noise < 0.3;
        cv::blur(mask, mask, {5, 5});
        mask = mask > 100;
        const cv::Rect window = trial % 2 == 0 ? whole(mask) : cv::Rect(7, 3, size.width - 20, size.height - 6);
        SCOPED_TRACE("trial " + std::to_string(trial));
        const auto expected = referenceLocate(mask, window);
        const detail::MaskRows rows = rowsOf(mask);
        const auto actual = detail::locateFeatures(mask, cv::Mat(), keepAll(), window, &rows);
        ASSERT_EQ(actual.size(), expected.size());
        for (std::size_t i = 0; i < actual.size(); ++i) {
            EXPECT_EQ(actual[i].area, expected[i].area);
            EXPECT_EQ(actual[i].box, expected[i].box);
            EXPECT_EQ(actual[i].boundary, expected[i].boundary);
        }
        // Spans of another buffer are not this mask's: ignored, the whole mask read.
        detail::MaskRows stale = rows;
        std::fill(stale.end.begin(), stale.end.end(), 0);
        stale.data = nullptr;
        EXPECT_EQ(detail::locateFeatures(mask, cv::Mat(), keepAll(), window, &stale).size(), expected.size());
    }
}

// ------------------------------------------------------------ erodeRestore

TEST(ErodeRestore, RemovesNoiseAndKeepsTheBlob) {
    cv::Mat mask = cv::Mat::zeros(50, 50, CV_8UC1);
    mask(cv::Rect(20, 20, 10, 10)).setTo(255);
    cv::Mat expected = mask.clone();
    mask.at<std::uint8_t>(5, 5) = 255;
    mask.at<std::uint8_t>(40, 10) = 255;
    mask(cv::Rect(40, 40, 2, 2)).setTo(255);
    mask(cv::Rect(10, 30, 2, 1)).setTo(255);
    const cv::Mat out = erodeRestore(mask, 3);
    EXPECT_EQ(differingPixels(out, expected), 0);
    EXPECT_EQ(cv::countNonZero(out), 100);
}

TEST(ErodeRestore, ThinAppendageIsRestoredExactly) {
    // A 12x12 blob with a 1-pixel line sticking out of it and a diagonal
    // 1-pixel tail: erosion removes both, the restore brings them back.
    cv::Mat mask = cv::Mat::zeros(60, 60, CV_8UC1);
    mask(cv::Rect(10, 10, 12, 12)).setTo(255);
    mask(cv::Rect(22, 15, 20, 1)).setTo(255);
    for (int k = 1; k <= 15; ++k) mask.at<std::uint8_t>(21 + k, 21 + k) = 255;
    cv::Mat eroded;
    cv::erode(mask, eroded, cv::Mat::ones(3, 3, CV_8UC1));
    ASSERT_EQ(eroded.at<std::uint8_t>(15, 30), 0);  // premise: the line vanished

    const cv::Mat out = erodeRestore(mask, 3);
    EXPECT_EQ(differingPixels(out, mask), 0);
    EXPECT_EQ(cv::countNonZero(out), 144 + 20 + 15);
}

TEST(ErodeRestore, VanishingBlobsAreRemovedEntirely) {
    // Kernel 5: a 5x5 square keeps its centre and survives; a 4x4 square and a
    // 40-pixel line vanish.
    cv::Mat mask = cv::Mat::zeros(40, 60, CV_8UC1);
    mask(cv::Rect(5, 5, 5, 5)).setTo(255);
    cv::Mat expected = mask.clone();
    mask(cv::Rect(20, 5, 4, 4)).setTo(255);
    mask(cv::Rect(5, 30, 40, 1)).setTo(255);
    mask(cv::Rect(50, 5, 4, 30)).setTo(255);  // long but 4 wide
    const cv::Mat out = erodeRestore(mask, 5);
    EXPECT_EQ(differingPixels(out, expected), 0);

    const cv::Mat all = erodeRestore(maskFrom({"##..", "##..", "...."}), 3);
    EXPECT_EQ(cv::countNonZero(all), 4)
        << "2x2 in the corner survives: outside the image counts as on";
    const cv::Mat inner = erodeRestore(maskFrom({".....", ".##..", ".##..", "....."}), 3);
    EXPECT_EQ(cv::countNonZero(inner), 0) << "2x2 away from the edge vanishes";
}

TEST(ErodeRestore, ImageEdgeDoesNotErode) {
    // A 3-pixel-high band along the top edge survives a 5x5 kernel only
    // because the rows above the image count as on; a band 3 high in the middle
    // vanishes.
    cv::Mat mask = cv::Mat::zeros(30, 30, CV_8UC1);
    mask(cv::Rect(0, 0, 30, 3)).setTo(255);
    cv::Mat expected = mask.clone();
    mask(cv::Rect(5, 15, 20, 3)).setTo(255);
    EXPECT_EQ(differingPixels(erodeRestore(mask, 5), expected), 0);
}

TEST(ErodeRestore, KernelOneIsIdentityAndOutputIsBinary) {
    cv::Mat mask = cv::Mat::zeros(6, 6, CV_8UC1);
    mask.at<std::uint8_t>(2, 2) = 7;
    mask.at<std::uint8_t>(4, 1) = 255;
    const cv::Mat out = erodeRestore(mask, 1);
    EXPECT_EQ(out.at<std::uint8_t>(2, 2), 255);
    EXPECT_EQ(out.at<std::uint8_t>(4, 1), 255);
    EXPECT_EQ(cv::countNonZero(out), 2);
}

TEST(ErodeRestore, RejectsBadArguments) {
    const cv::Mat mask = cv::Mat::zeros(6, 6, CV_8UC1);
    EXPECT_THROW(erodeRestore(mask, 4), InvalidArgument);
    EXPECT_THROW(erodeRestore(mask, 0), InvalidArgument);
    EXPECT_THROW(erodeRestore(mask, -3), InvalidArgument);
    EXPECT_THROW(erodeRestore(cv::Mat::zeros(6, 6, CV_8UC3), 3), FormatError);
    try {
        erodeRestore(mask, 4);
    } catch (const InvalidArgument& e) {
        EXPECT_NE(std::string(e.what()).find('4'), std::string::npos) << e.what();
    }
}

TEST(ErodeRestore, ThenLocateFindsTheRestoredFeature) {
    // End to end: noise is gone and the restored blob has its full geometry.
    cv::Mat mask = cv::Mat::zeros(40, 40, CV_8UC1);
    mask(cv::Rect(10, 10, 6, 6)).setTo(255);
    mask(cv::Rect(16, 12, 5, 1)).setTo(255);  // appendage x 16..20 on y 12
    mask.at<std::uint8_t>(30, 30) = 255;
    const auto f = locateAll(erodeRestore(mask, 3));
    ASSERT_EQ(f.size(), 1u);
    EXPECT_EQ(f[0].area, 41);
    EXPECT_EQ(f[0].box, cv::Rect(10, 10, 11, 6));
    EXPECT_EQ(f[0].boundary[kRightTop], cv::Point(20, 12));
    EXPECT_EQ(f[0].boundary[kRightBottom], cv::Point(20, 12));
}

}  // namespace
}  // namespace avatar
