/// @file ImageFeatureLocator.cpp
/// Erode + feature-AND restore (thesis 3.3.2) and the feature locator with its
/// geometric filter (thesis 3.3.3, Table 3-1, Figure 3-13, Appendix C).
///
/// Both are built on one run-based 8-connected labelling (labelRuns below):
/// each mask row is cut into runs of "on" pixels, skipping empty stretches
/// eight bytes at a time, runs that touch a run of the row above (8-connected)
/// are joined in a union-find over runs, and components are numbered in
/// raster order of their first pixel. It is iterative (no recursion, so no
/// stack overflow on large features as the thesis's recursive
/// CheckConnectedPixels had), serial, writes no label image, and its cost is
/// one read of the mask plus a little per run: filtered masks are mostly
/// empty. Everything per feature is then gathered per run with per-component
/// accumulators.
///
/// cv::connectedComponents was used before: it writes a 32-bit label for every
/// pixel (4.9 MB per 1280x960 mask), and with OpenCV's thread pool it competes
/// with the orchestrator's own two threads. It cost about 35% of the
/// instructions of a whole analysis (callgrind); the run labelling, about 2%
/// (docs/benchmarks.md). cv::connectedComponentsWithStats is slower still: its
/// statistics are gathered for every pixel, background included.

#include <avatar/analyze/ImageFeatureLocator.h>

#include "KernelClones.h"
#include "MaskRows.h"

#include <avatar/common/Error.h>
#include <avatar/common/Logging.h>

#include <log4cpp/Category.hh>
#include <opencv2/core.hpp>
#include <opencv2/imgproc.hpp>

#include <algorithm>
#include <cstddef>
#include <cstdint>
#include <cstring>
#include <string>
#include <vector>

namespace avatar {
namespace {

log4cpp::Category& logger() { return logging::category("analyze"); }

std::string describe(const cv::Rect& r) {
    return "(x=" + std::to_string(r.x) + ", y=" + std::to_string(r.y) +
           ", width=" + std::to_string(r.width) + ", height=" + std::to_string(r.height) + ")";
}

std::string describe(const cv::Size& s) {
    return std::to_string(s.width) + "x" + std::to_string(s.height);
}

void requireMask(const cv::Mat& mask, const char* function) {
    if (mask.type() != CV_8UC1) {
        throw FormatError(std::string(function) + ": the mask must be CV_8UC1, got " +
                          cv::typeToString(mask.type()) + " (" + describe(mask.size()) + ")");
    }
}

std::uint64_t load8(const std::uint8_t* p) {
    std::uint64_t word;
    std::memcpy(&word, p, sizeof word);
    return word;
}

/// True when one of the eight bytes of @p v is zero.
bool hasZeroByte(std::uint64_t v) {
    return ((v - 0x0101010101010101ULL) & ~v & 0x8080808080808080ULL) != 0;
}

/// A run of "on" pixels [x0, x1) of row y.
struct Run {
    int y;
    int x0;
    int x1;
};

/// The runs of a mask in raster order and their 8-connected components.
struct RunComponents {
    std::vector<Run> runs;
    std::vector<int> component;  ///< per run: 0 .. count-1, in raster order of the first pixel
    int count{0};
};

/// Appends the runs of one row.
void rowRuns(const std::uint8_t* row, int cols, int y, std::vector<Run>& runs) {
    int x = 0;
    while (x < cols) {
        while (x + 8 <= cols && load8(row + x) == 0) x += 8;
        while (x < cols && row[x] == 0) ++x;
        if (x >= cols) break;
        const int start = x;
        while (x + 8 <= cols && !hasZeroByte(load8(row + x))) x += 8;
        while (x < cols && row[x] != 0) ++x;
        runs.push_back({y, start, x});
    }
}

int findRoot(std::vector<int>& parent, int i) {
    int root = i;
    while (parent[static_cast<std::size_t>(root)] != root) root = parent[static_cast<std::size_t>(root)];
    while (parent[static_cast<std::size_t>(i)] != root) {  // path compression
        const int next = parent[static_cast<std::size_t>(i)];
        parent[static_cast<std::size_t>(i)] = root;
        i = next;
    }
    return root;
}

/// 8-connected components of @p mask (any non-zero byte is "on"). The root of
/// each component is its earliest run, so numbering the roots in run order
/// numbers the components in raster order of their first pixel.
/// @p rows, when not null: where the on pixels of the mask that @p mask is
/// the part at @p origin of lie; only those spans are read.
void labelRuns(const cv::Mat& mask, RunComponents& out, const detail::MaskRows* rows = nullptr,
               cv::Point origin = {}) {
    std::vector<Run>& runs = out.runs;
    runs.clear();
    std::vector<int> parent;
    std::size_t prevBegin = 0, prevEnd = 0;  // runs of the row above
    for (int y = 0; y < mask.rows; ++y) {
        const std::size_t begin = runs.size();
        if (rows == nullptr) {
            rowRuns(mask.ptr<std::uint8_t>(y), mask.cols, y, runs);
        } else {
            const auto r = static_cast<std::size_t>(origin.y + y);
            const int a = std::max(rows->begin[r] - origin.x, 0), b = std::min(rows->end[r] - origin.x, mask.cols);
            if (a < b) {
                rowRuns(mask.ptr<std::uint8_t>(y) + a, b - a, y, runs);
                for (std::size_t i = begin; i < runs.size(); ++i) {
                    runs[i].x0 += a;
                    runs[i].x1 += a;
                }
            }
        }
        const std::size_t end = runs.size();
        for (std::size_t i = begin; i < end; ++i) parent.push_back(static_cast<int>(i));
        if (prevEnd > prevBegin && runs[prevBegin].y == y - 1) {
            std::size_t p = prevBegin;
            for (std::size_t i = begin; i < end; ++i) {
                const Run& r = runs[i];
                // Above-row runs that end left of x0 - 1 touch neither this run nor later ones.
                while (p < prevEnd && runs[p].x1 < r.x0) ++p;
                for (std::size_t q = p; q < prevEnd && runs[q].x0 <= r.x1; ++q) {
                    const int a = findRoot(parent, static_cast<int>(i));
                    const int b = findRoot(parent, static_cast<int>(q));
                    if (a != b) parent[static_cast<std::size_t>(std::max(a, b))] = std::min(a, b);
                }
            }
        }
        if (end > begin) {
            prevBegin = begin;
            prevEnd = end;
        }
    }
    out.component.resize(runs.size());
    out.count = 0;
    for (std::size_t i = 0; i < runs.size(); ++i) {
        const int root = findRoot(parent, static_cast<int>(i));
        out.component[i] = root == static_cast<int>(i) ? out.count++ : out.component[static_cast<std::size_t>(root)];
    }
}

/// Per-feature sums gathered in the single pass over the label image. All
/// coordinates are relative to the search window until the feature is built.
/// The names follow Table 3-1 / Appendix C.
struct Accumulator {
    int area{0};
    int top{0};     ///< Y_top
    int bottom{0};  ///< Y_bot
    int left{0};    ///< X_l
    int right{0};   ///< X_r
    int topMinX{0};     ///< point 1: X_l,Ytop
    int topMaxX{0};     ///< point 2: X_r,Ytop
    int rightMinY{0};   ///< point 3: Y_top,Xr
    int rightMaxY{0};   ///< point 4: Y_bot,Xr
    int bottomMaxX{0};  ///< point 5: X_r,Ybot
    int bottomMinX{0};  ///< point 6: X_l,Ybot
    int leftMaxY{0};    ///< point 7: Y_bot,Xl
    int leftMinY{0};    ///< point 8: Y_top,Xl
    std::int64_t sumX{0};
    std::int64_t sumY{0};
    std::int64_t sumW{0};   ///< sum of R+G+B
    std::int64_t sumWX{0};  ///< sum of (R+G+B) x
    std::int64_t sumWY{0};  ///< sum of (R+G+B) y

    /// Appendix C's update for the pixels x = a .. b (inclusive) of row y,
    /// taken one after the other, in O(1). Simplified by the raster order of
    /// the scan: y never decreases and, within a row, x increases. So the
    /// first pixel fixes Y_top and point 1; a later pixel on the top row is
    /// the new point 2; a pixel below Y_bot starts a new bottom row (points 5
    /// and 6), one on it is the new point 5; a pixel left of X_l (right of
    /// X_r) restarts that column's points 7 and 8 (3 and 4), one on it is the
    /// new point 7 (4), being the lowest so far. Within a run only its first
    /// pixel can be left of or on X_l, and its last decides X_r.
    void addRun(int a, int b, int y) {
        if (area == 0) {
            top = bottom = y;
            left = topMinX = bottomMinX = a;
            right = topMaxX = bottomMaxX = b;
            leftMinY = leftMaxY = rightMinY = rightMaxY = y;
        } else {
            if (y == top) topMaxX = b;
            if (y > bottom) {
                bottom = y;
                bottomMinX = a;
            }
            bottomMaxX = b;
            if (a < left) {
                left = a;
                leftMinY = leftMaxY = y;
            } else if (a == left) {
                leftMaxY = y;
            }
            if (b > right) {
                right = b;
                rightMinY = rightMaxY = y;
            } else if (b == right) {
                rightMaxY = y;
            }
        }
        const std::int64_t n = b - a + 1;
        area += static_cast<int>(n);
        sumX += (static_cast<std::int64_t>(a) + b) * n / 2;
        sumY += static_cast<std::int64_t>(y) * n;
    }
};

/// Adds the brightness weights R+G+B of the pixels x = a .. b of one
/// intensity row to @p acc.
template <typename Channel>
void addWeights(Accumulator& acc, const cv::Mat& intensity, int a, int b, int y) {
    const Channel* p = intensity.ptr<Channel>(y);
    std::int64_t sumW = 0, sumWX = 0;
    for (int x = a; x <= b; ++x) {
        const std::int64_t w = static_cast<std::int64_t>(p[3 * x]) + p[3 * x + 1] + p[3 * x + 2];
        sumW += w;
        sumWX += w * x;
    }
    acc.sumW += sumW;
    acc.sumWX += sumWX;
    acc.sumWY += sumW * y;
}

/// Every run updates the accumulator of its component. @p intensity is the
/// window's part of the intensity image (or empty).
void accumulate(const RunComponents& c, const cv::Mat& intensity, std::vector<Accumulator>& acc) {
    for (std::size_t i = 0; i < c.runs.size(); ++i) {
        const Run& r = c.runs[i];
        Accumulator& a = acc[static_cast<std::size_t>(c.component[i])];
        a.addRun(r.x0, r.x1 - 1, r.y);
        if (intensity.empty()) continue;
        if (intensity.depth() == CV_8U)
            addWeights<std::uint8_t>(a, intensity, r.x0, r.x1 - 1, r.y);
        else
            addWeights<std::uint16_t>(a, intensity, r.x0, r.x1 - 1, r.y);
    }
}

Feature makeFeature(const Accumulator& a, const cv::Rect& window) {
    const int ox = window.x;
    const int oy = window.y;
    Feature f;
    f.area = a.area;
    const double n = static_cast<double>(a.area);
    // The sums moved to image coordinates exactly (integers) and divided once:
    // a feature's centroid is the same whatever window it was found in (a
    // type's window, a tracking frame's region, the whole image).
    const std::int64_t area = a.area;
    f.centroid = {static_cast<double>(a.sumX + area * ox) / n, static_cast<double>(a.sumY + area * oy) / n};
    if (a.sumW > 0) {
        const double w = static_cast<double>(a.sumW);
        f.weightedCentroid = {static_cast<double>(a.sumWX + a.sumW * ox) / w,
                              static_cast<double>(a.sumWY + a.sumW * oy) / w};
    } else {
        f.weightedCentroid = f.centroid;
    }
    f.boundary[kTopLeft] = {a.topMinX + ox, a.top + oy};
    f.boundary[kTopRight] = {a.topMaxX + ox, a.top + oy};
    f.boundary[kRightTop] = {a.right + ox, a.rightMinY + oy};
    f.boundary[kRightBottom] = {a.right + ox, a.rightMaxY + oy};
    f.boundary[kBottomRight] = {a.bottomMaxX + ox, a.bottom + oy};
    f.boundary[kBottomLeft] = {a.bottomMinX + ox, a.bottom + oy};
    f.boundary[kLeftBottom] = {a.left + ox, a.leftMaxY + oy};
    f.boundary[kLeftTop] = {a.left + ox, a.leftMinY + oy};
    f.box = cv::Rect(a.left + ox, a.top + oy, a.right - a.left + 1, a.bottom - a.top + 1);
    f.aspectRatio = static_cast<double>(f.box.width) / f.box.height;
    f.areaRatio = n / (static_cast<double>(f.box.width) * f.box.height);
    f.touchesBorder = a.left == 0 || a.top == 0 || a.right == window.width - 1 ||
                      a.bottom == window.height - 1;
    return f;
}

}  // namespace

namespace {

/// Whether the run @p r of @p mask holds a pixel that survives the erosion by
/// a square of 2 @p radius + 1, pixels beyond the image edge counting as "on"
/// (cv::erode with its default border). Only pixels of the mask can survive,
/// and in the run's row the run is all there is, so the erosion is decided
/// on the run alone: the columns of the run that are "on" in every row of the
/// square's height (@p column, the caller's scratch), then a stretch of them
/// wide enough for the square (narrower where it meets the image edge).
bool runSurvivesErosion(const cv::Mat& mask, const Run& r, int radius, std::vector<std::uint8_t>& column) {
    const int width = r.x1 - r.x0;
    const bool atLeft = r.x0 == 0, atRight = r.x1 == mask.cols;
    if (width < 2 * radius + 1 && !atLeft && !atRight) return false;  // too narrow whatever the rows say
    std::uint8_t* v = column.data();
    std::memset(v, 1, static_cast<std::size_t>(width));
    for (int y = std::max(0, r.y - radius); y <= std::min(mask.rows - 1, r.y + radius); ++y) {
        const std::uint8_t* row = mask.ptr<std::uint8_t>(y) + r.x0;
        for (int i = 0; i < width; ++i) v[i] &= static_cast<std::uint8_t>(row[i] != 0);
    }
    // Stretches [s, e) of columns "on" in every row: a surviving pixel x needs
    // [max(0, x - radius), min(cols - 1, x + radius)] inside one.
    int i = 0;
    while (i < width) {
        while (i < width && v[i] == 0) ++i;
        const int s = r.x0 + i;
        while (i < width && v[i] != 0) ++i;
        const int e = r.x0 + i;
        if (e <= s) break;
        const int lo = s == 0 ? s : s + radius;
        const int hi = e == mask.cols ? e - 1 : e - 1 - radius;
        if (lo <= hi) return true;
    }
    return false;
}

}  // namespace

cv::Mat erodeRestore(const cv::Mat& mask, int kernelSize) {
    cv::Mat out;
    erodeRestore(mask, kernelSize, out);
    return out;
}

namespace {

/// Labels @p mask (its on pixels where @p rows says, when not null) into
/// @p c and marks in @p keep (255) the components with a pixel that survives
/// the erosion by a square of @p kernelSize. Returns how many.
int survivingComponents(const cv::Mat& mask, int kernelSize, const detail::MaskRows* rows, RunComponents& c,
                        std::vector<std::uint8_t>& keep) {
    labelRuns(mask, c, rows);
    keep.assign(static_cast<std::size_t>(c.count), 0);
    std::vector<std::uint8_t> column(static_cast<std::size_t>(mask.cols));
    const int radius = kernelSize / 2;
    int survivors = 0;
    for (std::size_t i = 0; i < c.runs.size(); ++i) {
        std::uint8_t& k = keep[static_cast<std::size_t>(c.component[i])];
        if (k != 0) continue;
        if (runSurvivesErosion(mask, c.runs[i], radius, column)) {
            k = 255;
            ++survivors;
        }
    }
    return survivors;
}

void requireKernel(int kernelSize) {
    if (kernelSize < 1 || kernelSize % 2 == 0) {
        throw InvalidArgument("erodeRestore: the erode kernel size must be odd and positive, got " +
                              std::to_string(kernelSize));
    }
}

void logKept(int kernelSize, int survivors, int count) {
    log4cpp::Category& log = logger();
    if (log.isDebugEnabled()) {
        log.debugStream() << "erodeRestore: kernel " << kernelSize << ", " << survivors << " of " << count
                          << " components kept";
    }
}

}  // namespace

void erodeRestore(const cv::Mat& mask, int kernelSize, cv::Mat& out) {
    requireMask(mask, "erodeRestore");
    requireKernel(kernelSize);
    if (out.data == mask.data && !mask.empty())
        throw InvalidArgument("erodeRestore: the output must not share the mask's buffer");
    if (out.type() != CV_8UC1 || out.size() != mask.size()) out.create(mask.size(), CV_8UC1);
    if (mask.empty()) return;

    // Reconstruction: label the mask, keep every component that has a pixel
    // surviving the erosion (decided run by run, without an eroded image),
    // then write exactly the kept components' runs.
    RunComponents c;
    std::vector<std::uint8_t> keep;
    const int survivors = survivingComponents(mask, kernelSize, nullptr, c, keep);
    out.setTo(0);
    for (std::size_t i = 0; i < c.runs.size(); ++i) {
        const Run& r = c.runs[i];
        if (keep[static_cast<std::size_t>(c.component[i])] != 0)
            std::memset(out.ptr<std::uint8_t>(r.y) + r.x0, 255, static_cast<std::size_t>(r.x1 - r.x0));
    }
    logKept(kernelSize, survivors, c.count);
}

namespace {

/// Whether any of @p n bytes is non-zero: an OR over the row that GCC
/// vectorises (the front end asks it of every mask row it writes, most of
/// them empty).
AVATAR_KERNEL_CLONES bool anyNonZero(const std::uint8_t* __restrict row, int n) {
    std::uint8_t any = 0;
    for (int i = 0; i < n; ++i) any = static_cast<std::uint8_t>(any | row[i]);
    return any != 0;
}

}  // namespace

void detail::nonZeroSpan(const std::uint8_t* row, int n, int& begin, int& end) {
    begin = end = 0;
    if (!anyNonZero(row, n)) return;
    int x = 0;
    while (x + 8 <= n && load8(row + x) == 0) x += 8;
    while (x < n && row[x] == 0) ++x;
    if (x >= n) return;
    begin = x;
    int e = n;
    while (e - 8 >= x && load8(row + e - 8) == 0) e -= 8;
    while (row[e - 1] == 0) --e;
    end = e;
}

std::vector<cv::Rect> detail::nonZeroBands(const MaskRows& rows, int width) {
    std::vector<cv::Rect> bands;
    const int h = static_cast<int>(rows.begin.size());
    for (int y = 0; y < h;) {
        if (rows.end[static_cast<std::size_t>(y)] <= rows.begin[static_cast<std::size_t>(y)]) {
            ++y;
            continue;
        }
        const int y0 = y;
        while (y < h && rows.end[static_cast<std::size_t>(y)] > rows.begin[static_cast<std::size_t>(y)]) ++y;
        bands.emplace_back(0, y0, width, y - y0);
    }
    return bands;
}

int detail::erodeRestoreInPlace(cv::Mat& mask, int kernelSize, const MaskRows* rows, MaskRows& kept) {
    requireMask(mask, "erodeRestore");
    requireKernel(kernelSize);
    if (rows != nullptr && !rows->describes(mask)) rows = nullptr;
    RunComponents c;
    std::vector<std::uint8_t> keep;
    const int survivors = survivingComponents(mask, kernelSize, rows, c, keep);
    kept.data = mask.data;
    kept.begin.assign(static_cast<std::size_t>(mask.rows), 0);
    kept.end.assign(static_cast<std::size_t>(mask.rows), 0);
    for (std::size_t i = 0; i < c.runs.size(); ++i) {
        const Run& r = c.runs[i];
        if (keep[static_cast<std::size_t>(c.component[i])] == 0) {
            std::memset(mask.ptr<std::uint8_t>(r.y) + r.x0, 0, static_cast<std::size_t>(r.x1 - r.x0));
            continue;
        }
        const auto y = static_cast<std::size_t>(r.y);
        if (kept.begin[y] == kept.end[y]) kept.begin[y] = r.x0;  // runs of a row come left to right
        kept.end[y] = r.x1;
    }
    logKept(kernelSize, survivors, c.count);
    return survivors;
}

std::vector<Feature> locateFeatures(const cv::Mat& mask, const cv::Mat& intensity,
                                    const TargetType& type, cv::Rect window) {
    return detail::locateFeatures(mask, intensity, type, window, nullptr);
}

std::vector<Feature> detail::locateFeatures(const cv::Mat& mask, const cv::Mat& intensity, const TargetType& type,
                                            cv::Rect window, const MaskRows* rows) {
    requireMask(mask, "locateFeatures");
    const cv::Rect image(0, 0, mask.cols, mask.rows);
    if (window.empty() || (window & image) != window) {
        throw InvalidArgument("locateFeatures: the search window " + describe(window) +
                              " of type '" + type.name + "' is empty or not inside the " +
                              describe(mask.size()) + " mask");
    }
    if (!intensity.empty()) {
        if (intensity.type() != CV_8UC3 && intensity.type() != CV_16UC3) {
            throw FormatError(
                "locateFeatures: the intensity image must be CV_8UC3 or CV_16UC3, got " +
                cv::typeToString(intensity.type()));
        }
        if (intensity.size() != mask.size()) {
            throw InvalidArgument("locateFeatures: the intensity image is " +
                                  describe(intensity.size()) + " but the mask is " +
                                  describe(mask.size()));
        }
    }

    const cv::Mat roi = mask(window);
    RunComponents c;
    labelRuns(roi, c, rows != nullptr && rows->describes(mask) ? rows : nullptr, window.tl());
    std::vector<Accumulator> acc(static_cast<std::size_t>(c.count));
    accumulate(c, intensity.empty() ? cv::Mat() : intensity(window), acc);

    // Components are numbered in raster order of their first pixel.
    std::vector<Feature> features;
    for (const Accumulator& a : acc) {
        Feature f = makeFeature(a, window);
        if (type.area.contains(f.area) && type.aspectRatio.contains(f.aspectRatio) &&
            type.areaRatio.contains(f.areaRatio)) {
            features.push_back(f);
        }
    }

    log4cpp::Category& log = logger();
    if (log.isDebugEnabled()) {
        log.debugStream() << "locateFeatures: type '" << type.name << "', window "
                          << describe(window) << ": " << c.count << " features, "
                          << features.size() << " within the geometric limits";
    }
    return features;
}

cv::Rect searchWindow(const TargetType& type, cv::Size size) {
    if (size.width <= 0 || size.height <= 0) {
        throw InvalidArgument("searchWindow: the image size " + describe(size) + " of type '" +
                              type.name + "' is empty");
    }
    const cv::Rect image(0, 0, size.width, size.height);
    if (type.window.wholeImage()) return image;
    const cv::Rect requested(type.window.x, type.window.y, type.window.width, type.window.height);
    const cv::Rect clipped = requested & image;
    if (clipped.empty()) {
        throw InvalidArgument("searchWindow: the search window " + describe(requested) +
                              " of type '" + type.name + "' lies entirely outside the " +
                              describe(size) + " image");
    }
    if (clipped != requested) {
        log4cpp::Category& log = logger();
        if (log.isDebugEnabled()) {
            log.debugStream() << "searchWindow: type '" << type.name << "' window "
                              << describe(requested) << " clipped to " << describe(clipped);
        }
    }
    return clipped;
}

}  // namespace avatar
