#include "Silhouette.h"

#include "Interleave.h"
#include "KernelClones.h"
#include "MaskRows.h"

#include <opencv2/core.hpp>
#include <opencv2/imgproc.hpp>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstring>

namespace avatar::detail {

namespace {

// Labels of the region around the feature.
constexpr std::uint8_t kBackground = 0;
constexpr std::uint8_t kFeature = 1;
constexpr std::uint8_t kOther = 2;    ///< another target's pixels
constexpr std::uint8_t kOutside = 3;  ///< background connected to the region's frame (holes are not)
constexpr std::uint8_t kFragment = 4; ///< mask pixels of no feature: neither this target nor another

constexpr int kMargin = 4;  ///< region = feature box + this on every side

struct Direction {
    int dx, dy;
};
constexpr std::array<Direction, 4> kDirections{{{1, 0}, {-1, 0}, {0, 1}, {0, -1}}};

/// One channel's sums over a row of the region: of the target's pixels
/// (@p target 1), of the background's (@p background 1), and of the squared
/// differences of target pixels two apart (@p pair 1 at x: x and x + 2 are
/// the target's). Each square is the float square the definition takes:
/// exact up to 2^24, rounded to float above (and still below 2^32).
AVATAR_KERNEL_CLONES void channelSums(const std::uint16_t* __restrict p, const std::uint8_t* __restrict target,
                                      const std::uint8_t* __restrict background,
                                      const std::uint8_t* __restrict pair, int n, std::int64_t* __restrict sums) {
    std::uint64_t t = 0, b = 0, d = 0;
    // In 32 bits over at most 65536 samples (below 2^32), so that the loop
    // vectorises with as many lanes as the samples.
    for (int x0 = 0; x0 < n; x0 += 65536) {
        const int x1 = std::min(n, x0 + 65536);
        std::uint32_t t32 = 0, b32 = 0;
        for (int x = x0; x < x1; ++x) {
            t32 += static_cast<std::uint32_t>(target[x]) * p[x];
            b32 += static_cast<std::uint32_t>(background[x]) * p[x];
        }
        t += t32;
        b += b32;
    }
    for (int x = 0; x + 2 < n; ++x) {
        const float e = static_cast<float>(p[x]) - static_cast<float>(p[x + 2]);  // exact
        d += static_cast<std::uint32_t>(pair[x]) * static_cast<std::uint32_t>(e * e);
    }
    sums[0] += static_cast<std::int64_t>(t);
    sums[1] += static_cast<std::int64_t>(b);
    sums[2] += static_cast<std::int64_t>(d);
}

// The per-pixel passes over a region's rows below, as kernels on restrict
// pointers with the width in a register: written inline, the byte stores
// could alias everything (the width too), and GCC kept them scalar.

/// Whether any of the @p n bytes of @p row is non-zero.
AVATAR_KERNEL_CLONES bool anyOn(const std::uint8_t* __restrict row, int n) {
    std::uint8_t any = 0;
    for (int x = 0; x < n; ++x) any = static_cast<std::uint8_t>(any | row[x]);
    return any != 0;
}

/// Whether any of the @p n bytes of @p row is @p value.
AVATAR_KERNEL_CLONES bool anyEqual(const std::uint8_t* __restrict row, int n, std::uint8_t value) {
    std::uint8_t any = 0;
    for (int x = 0; x < n; ++x) any = static_cast<std::uint8_t>(any | (row[x] == value));
    return any != 0;
}

/// A row of the labels from the own mask: 255 where it is on, background elsewhere.
AVATAR_KERNEL_CLONES void markRow(const std::uint8_t* __restrict mask, std::uint8_t* __restrict labels, int n) {
    for (int x = 0; x < n; ++x) labels[x] = mask[x] != 0 ? 255 : kBackground;
}

/// Another mask's pixels (or, @p ownType, the own mask's that the seed's
/// flood did not reach) into a row of the labels: another target's inside a
/// feature's box (@p inBoxes) or where already marked so, a fragment elsewhere.
AVATAR_KERNEL_CLONES void markOthersRow(const std::uint8_t* __restrict mask, const std::uint8_t* __restrict inBoxes,
                                        std::uint8_t* __restrict labels, int n, bool ownType) {
    for (int x = 0; x < n; ++x) {
        const std::uint8_t v = labels[x];
        const bool pixel = ownType ? v == 255 : (mask[x] != 0 && v != kFeature);
        const std::uint8_t marked = (inBoxes[x] != 0 || v == kOther) ? kOther : kFragment;
        labels[x] = pixel ? marked : v;
    }
}

/// After the flood of the outside: background left is holes, which join the
/// feature; a compound's union apart from its seed's part (255) becomes a
/// fragment. Writes the feature's and the holes' 0/255 rows; returns
/// whether the row has a hole.
AVATAR_KERNEL_CLONES bool settleRow(std::uint8_t* __restrict labels, std::uint8_t* __restrict feature,
                                    std::uint8_t* __restrict holes, int n) {
    std::uint8_t any = 0;
    for (int x = 0; x < n; ++x) {
        const std::uint8_t v = labels[x];
        const std::uint8_t hole = v == kBackground ? 255 : 0;
        const std::uint8_t joined = hole != 0 ? kFeature : (v == 255 ? kFragment : v);
        labels[x] = joined;
        holes[x] = hole;
        feature[x] = joined == kFeature ? 255 : 0;
        any = static_cast<std::uint8_t>(any | hole);
    }
    return any != 0;
}

/// The roles of a row's pixels as 0/1 weights: the target's away from its
/// edge (@p inner), the background's away from it (outside @p near, in the
/// outside), and the target's pixels two apart (0 in the last two). Their
/// counts into @p counts.
AVATAR_KERNEL_CLONES void rolesRow(const std::uint8_t* __restrict inner, const std::uint8_t* __restrict near,
                                   const std::uint8_t* __restrict labels, std::uint8_t* __restrict isTarget,
                                   std::uint8_t* __restrict isBackground, std::uint8_t* __restrict isPair, int n,
                                   int* __restrict counts) {
    // Bitwise, not &&: a short-circuit reads near[] and labels[] only on
    // some pixels, and GCC then kept the loop scalar.
    int tc = 0, bc = 0, dc = 0;
    for (int x = 0; x < n; ++x) {
        const std::uint8_t t = inner[x] != 0;
        const std::uint8_t b = static_cast<std::uint8_t>((inner[x] == 0) & (near[x] == 0) & (labels[x] == kOutside));
        isTarget[x] = t;
        isBackground[x] = b;
        tc += t;
        bc += b;
    }
    for (int x = 0; x + 2 < n; ++x) {
        const std::uint8_t d = static_cast<std::uint8_t>((inner[x] != 0) & (inner[x + 2] != 0));
        isPair[x] = d;
        dc += d;
    }
    for (int x = std::max(n - 2, 0); x < n; ++x) isPair[x] = 0;
    counts[0] = tc;
    counts[1] = bc;
    counts[2] = dc;
}

/// A row of the feature's labels: its pixels counted, their x summed, and
/// @p edge set (1) at those with a 4-neighbour that is not the feature's,
/// the ones whose edges are looked at. The labels have a frame of one pixel
/// (never the feature's) all round, so x - 1, x + 1 and the rows above and
/// below exist.
AVATAR_KERNEL_CLONES int featureRow(const std::uint8_t* __restrict above, const std::uint8_t* __restrict row,
                                    const std::uint8_t* __restrict below, std::uint8_t* __restrict edge, int n,
                                    std::int64_t& sumX) {
    int count = 0, sum = 0;  // sum < n^2 / 2, n a region's width
    for (int x = 0; x < n; ++x) {
        const int own = row[x] == kFeature;
        const int inside = (row[x - 1] == kFeature) & (row[x + 1] == kFeature) & (above[x] == kFeature) &
                           (below[x] == kFeature);
        edge[x] = static_cast<std::uint8_t>(own & (1 - inside));
        count += own;
        sum += own * x;
    }
    sumX += sum;
    return count;
}

/// cv::erode (@p erode) or cv::dilate of a 0/255 mask with a 5x5 square and
/// OpenCV's default border (outside pixels never erode nor dilate), as two
/// separable passes of plain loops: the region is small and cv::erode's
/// parallel_for_ costs more than the work here.
void boxMorphology5(const cv::Mat& src, cv::Mat& dst, bool erode) {
    const int w = src.cols, h = src.rows;
    const std::uint8_t border = erode ? 255 : 0;
    cv::Mat horizontal(h + 4, w, CV_8UC1, cv::Scalar(border));  // two rows of border above and below
    std::vector<std::uint8_t> padded(static_cast<std::size_t>(w) + 4, border);
    for (int y = 0; y < h; ++y) {
        std::copy_n(src.ptr<std::uint8_t>(y), w, padded.begin() + 2);
        std::uint8_t* out = horizontal.ptr<std::uint8_t>(y + 2);
        const std::uint8_t* p = padded.data();
        if (erode)
            for (int x = 0; x < w; ++x)
                out[x] = std::min(std::min(std::min(p[x], p[x + 1]), std::min(p[x + 2], p[x + 3])), p[x + 4]);
        else
            for (int x = 0; x < w; ++x)
                out[x] = std::max(std::max(std::max(p[x], p[x + 1]), std::max(p[x + 2], p[x + 3])), p[x + 4]);
    }
    dst.create(h, w, CV_8UC1);
    for (int y = 0; y < h; ++y) {
        const std::uint8_t* r[5];
        for (int k = 0; k < 5; ++k) r[k] = horizontal.ptr<std::uint8_t>(y + k);
        std::uint8_t* out = dst.ptr<std::uint8_t>(y);
        if (erode)
            for (int x = 0; x < w; ++x)
                out[x] = std::min(std::min(std::min(r[0][x], r[1][x]), std::min(r[2][x], r[3][x])), r[4][x]);
        else
            for (int x = 0; x < w; ++x)
                out[x] = std::max(std::max(std::max(r[0][x], r[1][x]), std::max(r[2][x], r[3][x])), r[4][x]);
    }
}

}  // namespace

// A scanline fill on the region's own labels: cv::floodFill without a mask
// cleared a buffer of the region's size for every call (a third of its time here).
void fillComponent(cv::Mat& labels, cv::Point seed, std::uint8_t from, std::uint8_t to, bool eight,
                   std::vector<cv::Point>& stack) {
    const int w = labels.cols, h = labels.rows;
    if (from == to || labels.at<std::uint8_t>(seed) != from) return;
    stack.assign(1, seed);
    while (!stack.empty()) {
        const cv::Point p = stack.back();
        stack.pop_back();
        std::uint8_t* row = labels.ptr<std::uint8_t>(p.y);
        if (row[p.x] != from) continue;  // filled since it was pushed
        int left = p.x, right = p.x;
        while (left > 0 && row[left - 1] == from) --left;
        while (right + 1 < w && row[right + 1] == from) ++right;
        std::fill(row + left, row + right + 1, to);
        // Every run of the seed's value touching this one in the rows above and below.
        const int x0 = eight ? std::max(left - 1, 0) : left, x1 = eight ? std::min(right + 1, w - 1) : right;
        for (const int ny : {p.y - 1, p.y + 1}) {
            if (ny < 0 || ny >= h) continue;
            const std::uint8_t* next = labels.ptr<std::uint8_t>(ny);
            for (int x = x0; x <= x1; ++x)
                if (next[x] == from && (x == x0 || next[x - 1] != from)) stack.push_back({x, ny});
        }
    }
}

EdgeKind Silhouette::probe(const cv::Point2d& px, const cv::Size& image, const cv::Rect& window, bool& own) const {
    own = false;
    if (px.x < -0.5 || px.y < -0.5 || px.x > image.width - 0.5 || px.y > image.height - 0.5) return EdgeKind::ImageEdge;
    if (px.x < window.x - 0.5 || px.y < window.y - 0.5 || px.x > window.x + window.width - 0.5 ||
        px.y > window.y + window.height - 0.5)
        return EdgeKind::WindowEdge;
    const int x = static_cast<int>(std::lround(px.x)) - region.x, y = static_cast<int>(std::lround(px.y)) - region.y;
    if (labels.empty() || x < 0 || y < 0 || x >= labels.cols || y >= labels.rows) return EdgeKind::Free;
    const std::uint8_t l = labels.at<std::uint8_t>(y, x);
    own = l == kFeature;
    return l == kOther ? EdgeKind::Contact : l == kFragment ? EdgeKind::Fragment : EdgeKind::Free;
}

std::vector<Silhouette::Fragment> Silhouette::fragments() const {
    std::vector<Fragment> out;
    if (labels.empty()) return out;
    const cv::Mat fragment = labels == kFragment;
    if (cv::countNonZero(fragment) == 0) return out;
    cv::Mat components, stats, centroids;
    const int n = cv::connectedComponentsWithStats(fragment, components, stats, centroids, 8, CV_32S);
    for (int i = 1; i < n; ++i) {
        const cv::Rect local(stats.at<int>(i, cv::CC_STAT_LEFT), stats.at<int>(i, cv::CC_STAT_TOP),
                             stats.at<int>(i, cv::CC_STAT_WIDTH), stats.at<int>(i, cv::CC_STAT_HEIGHT));
        out.push_back({local + region.tl(), components(local) == i});
    }
    return out;
}

Silhouette measureSilhouette(const ImageWork& work, std::size_t ownIndex, const Feature& feature,
                             const cv::Rect& window, double correlation, const cv::Mat& ownOverride) {
    Silhouette out;
    const cv::Mat& bgr = work.image;
    const std::vector<cv::Mat>& masks = work.masks;
    const cv::Mat& ownMask = ownOverride.empty() ? masks.at(ownIndex) : ownOverride;
    const cv::Rect imageRect(0, 0, ownMask.cols, ownMask.rows);
    const cv::Rect box = feature.box;
    const cv::Rect roi = cv::Rect(box.x - kMargin, box.y - kMargin, box.width + 2 * kMargin,
                                  box.height + 2 * kMargin) & imageRect;
    if (roi.empty()) return out;

    // Labels, with a one-pixel frame around the region so that the flood of
    // the background reaches around the feature. Plain loops over the
    // region's rows (each a cv::compare and a masked setTo before, with their
    // temporaries: the region is small and this runs for every view of every
    // target, every frame).
    cv::Mat frame(roi.height + 2, roi.width + 2, CV_8UC1, cv::Scalar(kBackground));
    cv::Mat lab = frame(cv::Rect(1, 1, roi.width, roi.height));
    for (int y = 0; y < roi.height; ++y)
        markRow(ownMask.ptr<std::uint8_t>(roi.y + y) + roi.x, lab.ptr<std::uint8_t>(y), roi.width);
    const cv::Point seed = feature.boundary[kTopLeft] - roi.tl();
    if (!cv::Rect(0, 0, roi.width, roi.height).contains(seed) || lab.at<std::uint8_t>(seed) != 255) return out;
    std::vector<cv::Point> stack;
    fillComponent(lab, seed, 255, kFeature, true, stack);
    // Pixels of every mask: another target's inside a feature's box (not
    // this feature's), a fragment elsewhere.
    cv::Mat inBoxes(roi.size(), CV_8UC1);
    for (std::size_t m = 0; m < masks.size(); ++m) {
        const bool ownType = m == ownIndex && ownOverride.empty();
        // Another type's mask with nothing in the region marks nothing (the
        // own mask's pixels the flood did not reach are always looked for).
        if (!ownType) {
            bool any = false;
            for (int y = 0; y < roi.height && !any; ++y)
                any = anyOn(masks[m].ptr<std::uint8_t>(roi.y + y) + roi.x, roi.width);
            if (!any) continue;
        }
        inBoxes.setTo(cv::Scalar(0));
        if (m < work.features.size())
            for (const Feature& f : work.features[m]) {
                if (ownType && f.box == feature.box && f.area == feature.area) continue;
                const cv::Rect r = f.box & roi;
                if (!r.empty()) inBoxes(r - roi.tl()).setTo(cv::Scalar(255));
            }
        const cv::Mat& mask = masks[m];
        for (int y = 0; y < roi.height; ++y)
            markOthersRow(mask.ptr<std::uint8_t>(roi.y + y) + roi.x, inBoxes.ptr<std::uint8_t>(y),
                          lab.ptr<std::uint8_t>(y), roi.width, ownType);
    }
    // The background connected to the frame; what is left of it is holes.
    fillComponent(frame, cv::Point(0, 0), kBackground, kOutside, false, stack);
    cv::Mat isFeature(roi.size(), CV_8UC1), holes(roi.size(), CV_8UC1);
    bool anyHole = false;
    std::vector<std::uint8_t> holeRow(static_cast<std::size_t>(roi.height));  // 1: the row has a hole pixel
    for (int y = 0; y < roi.height; ++y) {
        holeRow[static_cast<std::size_t>(y)] = settleRow(lab.ptr<std::uint8_t>(y), isFeature.ptr<std::uint8_t>(y),
                                                         holes.ptr<std::uint8_t>(y), roi.width);
        anyHole = anyHole || holeRow[static_cast<std::size_t>(y)] != 0;
    }
    // Holes: 8-connected, numbered in raster order of their first pixel (as
    // cv::connectedComponents numbers them; label 0 is no hole). A hole next
    // to another target's or a fragment's pixels (one of its 3x3
    // neighbours) is the seam of mixed pixels between two touching objects,
    // not a hole. A flood per hole: they are few and small, and the OpenCV
    // labelling and dilation woke the thread pool for each region.
    cv::Mat holeLabels;
    std::vector<int> holeAreas{0};
    std::vector<bool> seam{false};
    // One hole from (x, y): the 8-connected pixels @p take(x, y) accepts
    // (each once: it marks what it accepts), labelled, counted, and whether
    // it is a seam.
    const auto labelHole = [&](int x, int y, const auto& take) {
        if (holeLabels.empty()) holeLabels = cv::Mat::zeros(roi.size(), CV_32S);
        const int label = static_cast<int>(holeAreas.size());
        holeAreas.push_back(0);
        seam.push_back(false);
        stack.assign(1, cv::Point(x, y));
        while (!stack.empty()) {
            const cv::Point p = stack.back();
            stack.pop_back();
            ++holeAreas.back();
            holeLabels.at<int>(p.y, p.x) = label;
            holeRow[static_cast<std::size_t>(p.y)] = 1;
            for (int dy = -1; dy <= 1; ++dy)
                for (int dx = -1; dx <= 1; ++dx) {
                    const int qx = p.x + dx, qy = p.y + dy;
                    if (qx < 0 || qy < 0 || qx >= roi.width || qy >= roi.height) continue;
                    const std::uint8_t l = lab.at<std::uint8_t>(qy, qx);
                    if (l == kOther || l == kFragment) seam.back() = true;
                    if (take(qx, qy)) stack.push_back({qx, qy});
                }
        }
    };
    if (anyHole) {
        holeLabels = cv::Mat::zeros(roi.size(), CV_32S);
        const auto take = [&](int x, int y) {
            if (holes.at<std::uint8_t>(y, x) == 0 || holeLabels.at<int>(y, x) != 0) return false;
            holeLabels.at<int>(y, x) = -1;  // labelled when it is popped
            return true;
        };
        for (int y = 0; y < roi.height; ++y)
            for (int x = 0; x < roi.width && holeRow[static_cast<std::size_t>(y)] != 0; ++x)
                if (take(x, y)) labelHole(x, y, take);
    }
    // Pockets: background inside the outline that reaches the outside only
    // through a mouth of at most two pixels, where the filter cut open the
    // mixed rim between the target and something just inside its outline
    // (a speck of silt: seeds 32, 42 and 49 of the trust report, 5-35 px
    // hidden, passed as whole). With every pixel next to the feature (3x3)
    // closed, what the outside no longer reaches is a hole as well, of the
    // pixels two or more from the feature ("open"). Only open pixels within
    // the closed pixels' span of their row and of their column can be cut
    // off (from any other one a straight line leads out), so only those are
    // flooded: a convex target has next to none.
    {
        const int w = roi.width, h = roi.height;
        // Each row's feature span [first, last], and the closed pixels'
        // (lo, hi): the feature's in the rows either side, one wider.
        std::vector<int> spans(4 * static_cast<std::size_t>(h));
        int* first = spans.data();
        int* last = first + h;
        int* lo = last + h;
        int* hi = lo + h;
        for (int y = 0; y < h; ++y) {
            int a = 0, b = 0;
            nonZeroSpan(isFeature.ptr<std::uint8_t>(y), w, a, b);
            first[y] = b > a ? a : w;
            last[y] = b > a ? b - 1 : -1;
        }
        for (int y = 0; y < h; ++y) {
            int a = w, b = -1;
            for (int k = std::max(0, y - 1); k <= std::min(h - 1, y + 1); ++k) {
                a = std::min(a, first[k]);
                b = std::max(b, last[k]);
            }
            lo[y] = a - 1;
            hi[y] = b + 1;
        }
        const auto open = [&](int x, int y) {
            if (lab.at<std::uint8_t>(y, x) != kOutside) return false;
            for (int k = std::max(0, y - 1); k <= std::min(h - 1, y + 1); ++k)
                for (int j = std::max(0, x - 1); j <= std::min(w - 1, x + 1); ++j)
                    if (lab.at<std::uint8_t>(k, j) == kFeature) return false;
            return true;
        };
        // The closed pixels' span of a column (top, bottom), found when first
        // asked: open pixels within the rows' spans are few.
        std::vector<int> columns;
        const auto within = [&](int x, int y) {
            if (x <= lo[y] || x >= hi[y]) return false;
            if (columns.empty()) columns.assign(2 * static_cast<std::size_t>(w), -2);
            int& top = columns[2 * static_cast<std::size_t>(x)];
            int& bottom = columns[2 * static_cast<std::size_t>(x) + 1];
            if (top == -2) {
                top = h;
                bottom = -1;
                for (int k = 0; k < h; ++k)
                    if (lo[k] <= x && x <= hi[k]) {
                        top = std::min(top, k);
                        bottom = k;
                    }
            }
            return y > top && y < bottom;
        };
        // 0 unseen, 1 seen, 2 a pocket's (until labelled), 3 labelled.
        cv::Mat seen;
        bool anyPocket = false;
        std::vector<cv::Point> component, flood;
        const auto look = [&](int x, int y) {
            if ((!seen.empty() && seen.at<std::uint8_t>(y, x) != 0) || !open(x, y) || !within(x, y)) return;
            if (seen.empty()) seen = cv::Mat::zeros(roi.size(), CV_8UC1);
            // The open pixels 4-connected to it; cut off unless one of
            // them is outside the spans or at the region's edge.
            bool leaks = false;
            component.clear();
            flood.assign(1, cv::Point(x, y));
            seen.at<std::uint8_t>(y, x) = 1;
            while (!flood.empty()) {
                const cv::Point p = flood.back();
                flood.pop_back();
                component.push_back(p);
                for (const Direction& d : kDirections) {
                    const int qx = p.x + d.dx, qy = p.y + d.dy;
                    if (qx < 0 || qy < 0 || qx >= w || qy >= h) {
                        leaks = true;
                        continue;
                    }
                    if (seen.at<std::uint8_t>(qy, qx) != 0 || !open(qx, qy)) continue;
                    if (!within(qx, qy)) {
                        leaks = true;
                        continue;
                    }
                    seen.at<std::uint8_t>(qy, qx) = 1;
                    flood.push_back({qx, qy});
                }
            }
            if (leaks) return;
            anyPocket = true;
            for (const cv::Point& p : component) seen.at<std::uint8_t>(p) = 2;
        };
        for (int y = 1; y + 1 < h; ++y) {
            const std::uint8_t* r = lab.ptr<std::uint8_t>(y);
            const int a = first[y], b = last[y];
            const int x0 = std::max(1, lo[y] + 1), x1 = std::min(w - 1, hi[y]);  // x1 exclusive
            // Either end of the row beside the feature; between them, only
            // where the row has any of the outside's pixels.
            const bool inner = b > a && anyEqual(r + a, b - a, kOutside);
            for (int x = x0; x < x1; ++x) {
                if (x == a + 1 && !inner) x = std::max(x, b);
                if (r[x] == kOutside) look(x, y);
            }
        }
        if (anyPocket) {  // labelled in raster order, as the holes
            const auto take = [&](int x, int y) {
                std::uint8_t& s = seen.at<std::uint8_t>(y, x);
                if (s != 2) return false;
                s = 3;
                return true;
            };
            for (int y = 0; y < h; ++y)
                for (int x = 0; x < w; ++x)
                    if (take(x, y)) labelHole(x, y, take);
        }
    }
    const int holeCount = static_cast<int>(holeAreas.size());

    // 16-bit samples are read where they are (as floats, the same values a
    // converted copy holds); any other depth through a float copy.
    const bool wide = bgr.type() == CV_16UC3;
    cv::Mat image;
    if (!wide) bgr(roi).convertTo(image, CV_32FC3);
    const auto label = [&](int x, int y) -> int {  // region coordinates; -1 outside the region
        if (x < 0 || y < 0 || x >= roi.width || y >= roi.height) return -1;
        return lab.at<std::uint8_t>(y, x);
    };
    const auto colour = [&](int x, int y) -> cv::Vec3f {
        if (wide) {
            const cv::Vec3w& p = bgr.at<cv::Vec3w>(roi.y + y, roi.x + x);
            return {static_cast<float>(p[0]), static_cast<float>(p[1]), static_cast<float>(p[2])};
        }
        return image.at<cv::Vec3f>(y, x);
    };

    // The target's and the background's colours away from the edge, and the
    // noise of one pixel inside the target (pixels two apart, which
    // demosaicing leaves nearly independent).
    cv::Mat inner, near;
    boxMorphology5(isFeature, inner, true);
    boxMorphology5(isFeature, near, false);
    cv::Vec3d targetSum(0, 0, 0), backgroundSum(0, 0, 0), diffSq(0, 0, 0);
    int targetCount = 0, backgroundCount = 0, diffCount = 0;
    if (wide) {
        // Integer samples: every term below is an integer (a square rounded
        // to float is one too) and every sum stays below 2^53, so integer
        // sums give the very doubles of the float path, in any order.
        // Per row: the samples split into planes and the pixels' roles into 0/1
        // weights, so that the sums are plain vectorised loops.
        const auto n = static_cast<std::size_t>(roi.width);
        std::vector<std::uint16_t> planes(3 * n);
        std::vector<std::uint8_t> roles(3 * n);
        std::uint8_t* isTarget = roles.data();
        std::uint8_t* isBackground = isTarget + n;
        std::uint8_t* isPair = isBackground + n;
        std::int64_t sums[3][3] = {};  // [channel][target, background, pairs]
        for (int y = 0; y < roi.height; ++y) {
            int counts[3];
            rolesRow(inner.ptr<std::uint8_t>(y), near.ptr<std::uint8_t>(y), lab.ptr<std::uint8_t>(y), isTarget,
                     isBackground, isPair, roi.width, counts);
            const int tc = counts[0], bc = counts[1], dc = counts[2];
            targetCount += tc;
            backgroundCount += bc;
            diffCount += dc;
            if (tc + bc == 0) continue;
            std::uint16_t* plane[3] = {planes.data(), planes.data() + n, planes.data() + 2 * n};
            // Not cv::hal::split16u: its aligned stores bypass the cache, and these rows are read at once.
            deinterleave3(bgr.ptr<std::uint16_t>(roi.y + y) + 3 * roi.x, plane[0], plane[1], plane[2], roi.width);
            for (int c = 0; c < 3; ++c) channelSums(plane[c], isTarget, isBackground, isPair, roi.width, sums[c]);
        }
        std::int64_t ts[3], bs[3], ds[3];
        for (int c = 0; c < 3; ++c) {
            ts[c] = sums[c][0];
            bs[c] = sums[c][1];
            ds[c] = sums[c][2];
        }
        for (int c = 0; c < 3; ++c) {
            targetSum[c] = static_cast<double>(ts[c]);
            backgroundSum[c] = static_cast<double>(bs[c]);
            diffSq[c] = static_cast<double>(ds[c]);
        }
    }
    for (int y = 0; y < (wide ? 0 : roi.height); ++y) {
        const std::uint8_t* in = inner.ptr<std::uint8_t>(y);
        const std::uint8_t* nr = near.ptr<std::uint8_t>(y);
        const std::uint8_t* lb = lab.ptr<std::uint8_t>(y);
        const cv::Vec3f* px = image.ptr<cv::Vec3f>(y);
        for (int x = 0; x < roi.width; ++x) {
            if (in[x]) {
                targetSum += cv::Vec3d(px[x]);
                ++targetCount;
                if (x + 2 < roi.width && in[x + 2]) {
                    const cv::Vec3f d = px[x] - px[x + 2];
                    diffSq += cv::Vec3d(d[0] * d[0], d[1] * d[1], d[2] * d[2]);
                    ++diffCount;
                }
            } else if (!nr[x] && lb[x] == kOutside) {
                backgroundSum += cv::Vec3d(px[x]);
                ++backgroundCount;
            }
        }
    }
    const cv::Vec3d noiseVar = diffCount > 0 ? diffSq * (0.5 / diffCount) : cv::Vec3d(0, 0, 0);
    const cv::Vec3f targetMean = targetCount > 0 ? cv::Vec3f(targetSum * (1.0 / targetCount)) : cv::Vec3f();
    const cv::Vec3f backgroundMean =
        backgroundCount > 0 ? cv::Vec3f(backgroundSum * (1.0 / backgroundCount)) : cv::Vec3f();
    const bool haveColours = targetCount > 0 && backgroundCount > 0;
    out.colour = targetMean;
    if (holeCount > 1 && targetMean[1] > 0.f) {
        std::vector<cv::Vec3d> sums(static_cast<std::size_t>(holeCount), cv::Vec3d(0, 0, 0));
        std::vector<cv::Rect> boxes(static_cast<std::size_t>(holeCount));
        for (int y = 0; y < roi.height; ++y) {
            if (holeRow[static_cast<std::size_t>(y)] == 0) continue;
            const int* c = holeLabels.ptr<int>(y);
            for (int x = 0; x < roi.width; ++x)
                if (c[x] > 0) {
                    const auto i = static_cast<std::size_t>(c[x]);
                    sums[i] += cv::Vec3d(colour(x, y));
                    boxes[i] = boxes[i].empty() ? cv::Rect(x, y, 1, 1) : boxes[i] | cv::Rect(x, y, 1, 1);
                }
        }
        const auto ratios = [](const cv::Vec3d& c) {
            const double g = std::max(c[1], 1e-3);
            return cv::Vec2d(std::log(std::max(c[2], 1e-3) / g), std::log(std::max(c[0], 1e-3) / g));
        };
        const cv::Vec2d own = ratios(cv::Vec3d(targetMean));
        // One pixel's noise in log R/G and log B/G (relative variances add).
        const auto rel = [&](int c) {
            const double m = targetMean[c];
            return noiseVar[c] / std::max(1e-6, m * m);
        };
        const cv::Vec2d pixelLog(std::sqrt(rel(2) + rel(1)), std::sqrt(rel(0) + rel(1)));
        // The target's colour and one pixel's noise in log around a hole:
        // from the target's pixels away from the edge within kRing of it
        // (pixels two apart, as above), where there are enough of them. The
        // target's mean holds for its bright middle; near a dim limb, where
        // the filter leaves the noise's tail out (a dark frame's blue under
        // an orange target), one pixel's log ratios stray several times as
        // far (trust report: holes of 5-19 px, 0.5-0.76 from an orange
        // sphere's colour, in dark frames of seeds 40-57 called whole
        // spheres hidden).
        constexpr int kRing = 5;
        constexpr int kMinPairs = 8;
        struct Around {
            cv::Vec2d ratios, pixelLog;
        };
        const auto around = [&](const cv::Rect& hole) {
            const cv::Rect ring =
                cv::Rect(hole.x - kRing, hole.y - kRing, hole.width + 2 * kRing, hole.height + 2 * kRing) &
                cv::Rect(0, 0, roi.width, roi.height);
            cv::Vec3d sum(0, 0, 0), sq(0, 0, 0);
            int count = 0, pairs = 0;
            for (int y = ring.y; y < ring.y + ring.height; ++y) {
                const std::uint8_t* in = inner.ptr<std::uint8_t>(y);  // holes are the feature there
                const int* labelled = holeLabels.ptr<int>(y);
                for (int x = ring.x; x + 2 < ring.x + ring.width; ++x) {
                    if (!in[x] || labelled[x] != 0) continue;
                    const cv::Vec3f a = colour(x, y);
                    sum += cv::Vec3d(a);
                    ++count;
                    if (!in[x + 2] || labelled[x + 2] != 0) continue;
                    const cv::Vec3f d = a - colour(x + 2, y);
                    sq += cv::Vec3d(d[0] * d[0], d[1] * d[1], d[2] * d[2]);
                    ++pairs;
                }
            }
            if (pairs < kMinPairs) return Around{own, pixelLog};
            const cv::Vec3d mean = sum * (1.0 / count), var = sq * (0.5 / pairs);
            const auto local = [&](int c) { return var[c] / std::max(1e-6, mean[c] * mean[c]); };
            return Around{ratios(mean), cv::Vec2d(std::sqrt(local(2) + local(1)), std::sqrt(local(0) + local(1)))};
        };
        // A Bayer mosaic samples red and blue at one pixel in four and the
        // demosaic spreads each sample over its neighbours: a hole's n
        // pixels hold about n / 4 samples of them, and pixels two apart
        // share samples too: its mean's noise is about twice one pixel's
        // (as those pairs measure it) over the root of n (1.7-2.5 for
        // holes of 5-20 px in a simulated mosaic of white noise).
        constexpr double kMosaicFactor = 2.0;
        for (int i = 1; i < holeCount; ++i) {
            if (seam[static_cast<std::size_t>(i)]) continue;
            const int n = holeAreas[static_cast<std::size_t>(i)];
            const cv::Vec2d r = ratios(sums[static_cast<std::size_t>(i)] * (1.0 / n));
            const Around a = around(boxes[static_cast<std::size_t>(i)]);
            const cv::Vec2d noise = a.pixelLog * (kMosaicFactor / std::sqrt(static_cast<double>(n)));
            out.holes.push_back({n, std::max(std::abs(r[0] - own[0]), std::abs(r[1] - own[1])),
                                 std::max(noise[0], noise[1]), r, r - a.ratios, noise});
        }
    }

    /// The noise of a coverage estimate along w = (T - B) / |T - B|^2.
    const auto coverageVariance = [&](const cv::Vec3f& w) {
        return w[0] * w[0] * noiseVar[0] + w[1] * w[1] * noiseVar[1] + w[2] * w[2] * noiseVar[2];
    };
    if (haveColours) {
        const cv::Vec3f d = targetMean - backgroundMean;
        const double n2 = d.dot(d);
        if (n2 > 0.0) out.coverageNoise = std::sqrt(coverageVariance(d * static_cast<float>(1.0 / n2)));
    }
    // Sub-pixel edges need the colours to differ well above the noise.
    const bool subPixel = haveColours && out.coverageNoise < 0.15;
    out.subPixel = subPixel;

    // Pixel counts and coordinate sums are integers: counted as such (the
    // doubles they become are the sums a double accumulator gives exactly).
    std::int64_t pixelCount = 0, pixelSumX = 0, pixelSumY = 0;
    double addedArea = 0.0, addedX = 0.0, addedY = 0.0;
    struct FreeEdge {
        cv::Point2d mid;
        double variance;
    };
    std::vector<FreeEdge> freeEdges;
    // About one outline point per pixel edge along the box's perimeter.
    const auto perimeter = static_cast<std::size_t>(4 * (box.width + box.height));
    out.outline.reserve(perimeter);
    freeEdges.reserve(perimeter);
    const int wx0 = window.x - roi.x, wy0 = window.y - roi.y;
    const int wx1 = wx0 + window.width, wy1 = wy0 + window.height;
    // Beyond the region (region coordinates): background when inside the
    // image and in no mask; its colour read where it is.
    const auto freeBeyondRegion = [&](int x, int y) {
        const int gx = roi.x + x, gy = roi.y + y;
        if (gx < 0 || gy < 0 || gx >= imageRect.width || gy >= imageRect.height) return false;
        if (ownMask.at<std::uint8_t>(gy, gx) != 0) return false;
        for (const cv::Mat& m : masks)
            if (m.at<std::uint8_t>(gy, gx) != 0) return false;
        return true;
    };
    const auto colourBeyondRegion = [&](int x, int y) -> cv::Vec3f {
        const int gx = roi.x + x, gy = roi.y + y;
        switch (bgr.type()) {
            case CV_16UC3: return cv::Vec3f(bgr.at<cv::Vec3w>(gy, gx));
            case CV_8UC3: return cv::Vec3f(bgr.at<cv::Vec3b>(gy, gx));
            case CV_32FC3: return bgr.at<cv::Vec3f>(gy, gx);
            default: {
                cv::Mat pixel;
                bgr(cv::Rect(gx, gy, 1, 1)).convertTo(pixel, CV_32FC3);
                return pixel.at<cv::Vec3f>(0, 0);
            }
        }
    };
    // What the sub-pixel edge at the free edge of pixel (x, y) towards d is
    // computed from: the target's colour next to it (up to three pixels two
    // steps inside) and the colours of the five pixels across it (one inside
    // the mask, three beyond it: where the target darkens towards its limb,
    // the filter may stop a pixel or two short of the edge).
    struct EdgeSamples {
        cv::Vec3d target;
        std::array<cv::Vec3d, 5> colours;  ///< k = -1 .. 3
        std::array<bool, 5> unmixed{};     ///< false: beyond the region or another target (the mask's side)
        /// Its own pixels again beyond the edge: the wall of a notch where
        /// the filter dropped a pixel or two (a limb in shadow, whose mixed
        /// pixels the demosaic gives false colours; haze; noise), looked
        /// across along the outline, not out of it (OutlinePoint::wall). Its
        /// coverage sum would move the point up to 2.5 px along the
        /// outline; the notch's floor, looked out of, places the outline.
        bool wall{false};
    };
    const auto samplesAt = [&](int x, int y, const Direction& d, bool rim) {
        EdgeSamples s;
        const int tx = -d.dy, ty = d.dx;  // along the edge
        cv::Vec3f t(0, 0, 0);
        int nt = 0;
        for (int k = -1; k <= 1; ++k) {
            const int ix = x - 2 * d.dx + k * tx, iy = y - 2 * d.dy + k * ty;
            if (label(ix, iy) == kFeature) {
                t += colour(ix, iy);
                ++nt;
            }
        }
        s.target = cv::Vec3d(nt > 0 ? t * (1.0f / nt) : targetMean);
        for (int k = -1; k <= 3; ++k) {
            const int sx = x + k * d.dx, sy = y + k * d.dy;
            const int ls = label(sx, sy);
            const auto i = static_cast<std::size_t>(k + 1);
            s.wall = s.wall || (k >= 1 && ls == kFeature);
            s.unmixed[i] = ls == kFeature || ls == kBackground || ls == kOutside || (rim && ls == kFragment);
            if (s.unmixed[i]) s.colours[i] = cv::Vec3d(colour(sx, sy));
        }
        return s;
    };
    // The background's colour next to the edge: up to three pixels
    // @p steps beyond it; false (and the region's mean) when none is free.
    const auto backgroundAt = [&](int x, int y, const Direction& d, int steps, cv::Vec3d& b) {
        const int tx = -d.dy, ty = d.dx;
        cv::Vec3f sum(0, 0, 0);
        int n = 0;
        for (int k = -1; k <= 1; ++k) {
            const int ox = x + steps * d.dx + k * tx, oy = y + steps * d.dy + k * ty;
            const int lo = label(ox, oy);
            if (lo == kOutside || lo == kBackground) {
                sum += colour(ox, oy);
                ++n;
            } else if (lo == -1 && freeBeyondRegion(ox, oy)) {
                sum += colourBeyondRegion(ox, oy);
                ++n;
            }
        }
        b = cv::Vec3d(n > 0 ? sum * (1.0f / n) : backgroundMean);
        return n > 0;
    };
    struct Unmixed {
        bool ok{false};  ///< false: the colours are too close here (the pixel edge is used)
        double sum{0.0}, edgeVar{0.0};
    };
    // Unmixing: a pixel that sees coverage a of the target and 1 - a of the
    // background has colour v = beta t + (1 - a) b, where beta = a c takes
    // the target's shading c at the very edge (darker than t two pixels
    // inside, on a sphere's limb): with M = [t | -b], (beta, a) = M^+ (v - b).
    // The target's colour differs from the background's in its ratios (that
    // is what the filter found), so t and b are not parallel. The edge lies
    // at e = sum of a - 1.5 pixels from the edge pixel's centre.
    const auto unmix = [&](const EdgeSamples& s, const cv::Vec3d& bv) {
        Unmixed u;
        const cv::Vec3d& tv = s.target;
        const double mtt = tv.dot(tv), mtb = -tv.dot(bv), mbb = bv.dot(bv);
        const double det = mtt * mbb - mtb * mtb;
        if (!(det > 1e-6 * mtt * mbb)) return u;  // colours (nearly) parallel
        // Row of M^+ that gives a: (-mtb t^T + mtt (-b)^T) / det.
        const cv::Vec3d w = (tv * (-mtb) - bv * mtt) * (1.0 / det);
        const double var = w[0] * w[0] * noiseVar[0] + w[1] * w[1] * noiseVar[1] + w[2] * w[2] * noiseVar[2];
        if (var > 0.15 * 0.15) return u;  // too little contrast here
        double previous = 1.0;
        for (int k = -1; k <= 3; ++k) {
            // The fifth pixel only while the edge has not been crossed.
            if (k == 3 && previous < 0.25) break;
            const auto i = static_cast<std::size_t>(k + 1);
            double a;
            if (s.unmixed[i]) {
                a = (s.colours[i] - bv).dot(w);
                u.edgeVar += a > 0.0 && a < 1.0 ? var : 0.0;  // no branch: it is mispredicted
                a = std::clamp(a, 0.0, 1.0);
            } else {
                a = k <= 0 ? 1.0 : 0.0;
            }
            u.sum += a;
            previous = a;
        }
        u.ok = true;
        return u;
    };
    // Whether the fragment beyond own pixel (x, y) is a rim: across the
    // outline, at most three pixels of fragment, then background. Across is
    // the outline's normal (away from the feature's pixels in the 5x5 around,
    // to the nearest of eight directions), not the pixel edge's direction,
    // which runs along the rim where the outline is steep; three, because a
    // rim two pixels deep is crossed in up to three steps of a direction
    // 22.5 deg off its normal.
    const auto rimAt = [&](int x, int y) {
        cv::Point2d n(0.0, 0.0);
        for (int j = -2; j <= 2; ++j)
            for (int i = -2; i <= 2; ++i)
                if (label(x + i, y + j) != kFeature) n += cv::Point2d(i, j);
        if (n.x == 0.0 && n.y == 0.0) return false;
        const double sector = std::round(std::atan2(n.y, n.x) / (M_PI / 4.0)) * (M_PI / 4.0);
        const int sx = static_cast<int>(std::lround(std::cos(sector)));
        const int sy = static_cast<int>(std::lround(std::sin(sector)));
        for (int k = 1; k <= 4; ++k) {
            const int l = label(x + k * sx, y + k * sy);
            if (l == kBackground || l == kOutside) return true;
            if (l != kFragment) return false;
        }
        return false;
    };
    std::vector<std::uint8_t> edges(static_cast<std::size_t>(roi.width));
    for (int y = 0; y < roi.height; ++y) {
        // Most of the feature's pixels are inside: only its edge pixels are looked at.
        const int count = featureRow(frame.ptr<std::uint8_t>(y) + 1, lab.ptr<std::uint8_t>(y),
                                     frame.ptr<std::uint8_t>(y + 2) + 1, edges.data(), roi.width, pixelSumX);
        pixelCount += count;
        pixelSumY += static_cast<std::int64_t>(count) * y;
        for (int x = 0; x < roi.width; ++x) {
            if (edges[static_cast<std::size_t>(x)] == 0) {
                // Skip the inside and the background eight pixels a step.
                std::uint64_t word = 0;
                while (x + 9 <= roi.width &&
                       (std::memcpy(&word, edges.data() + x + 1, sizeof word), word == 0))
                    x += 8;
                continue;
            }
            for (const Direction& d : kDirections) {
                const int qx = x + d.dx, qy = y + d.dy;
                const cv::Point2d mid(roi.x + x + 0.5 * d.dx, roi.y + y + 0.5 * d.dy);
                const int gx = roi.x + qx, gy = roi.y + qy;
                if (gx < 0 || gy < 0 || gx >= imageRect.width || gy >= imageRect.height) {
                    out.outline.push_back({mid, EdgeKind::ImageEdge, 0.0});
                    ++out.imageEdgePoints;
                    continue;
                }
                const int lq = label(qx, qy);
                if (lq == kFeature) continue;
                if (qx < wx0 || qy < wy0 || qx >= wx1 || qy >= wy1) {
                    out.outline.push_back({mid, EdgeKind::WindowEdge, 0.0});
                    ++out.windowEdgePoints;
                    continue;
                }
                if (lq == kOther || label(qx + d.dx, qy + d.dy) == kOther) {
                    out.outline.push_back({mid, EdgeKind::Contact, 0.0});
                    ++out.contactPoints;
                    continue;
                }
                // A rim (rimAt): the edge's own mixed pixels, where their colour
                // passes another filter (a yellow's edge over a green seabed
                // under water passes orange's); the outline is there, found
                // as at a free edge with the rim's pixels unmixed.
                const bool rim = lq == kFragment && rimAt(x, y);
                if (lq == kFragment && !rim) {
                    out.outline.push_back({mid, EdgeKind::Fragment, 0.0});
                    ++out.fragmentPoints;
                    continue;
                }
                ++out.freePoints;
                if (!subPixel) {
                    out.outline.push_back({mid, EdgeKind::Free, std::sqrt(1.0 / 12.0), false, rim});
                    freeEdges.push_back({mid, 1.0 / 12.0});
                    continue;
                }
                const EdgeSamples samples = samplesAt(x, y, d, rim);
                cv::Vec3d background;
                backgroundAt(x, y, d, 3, background);
                Unmixed u = unmix(samples, background);
                if (samples.wall) {
                    // At its pixel edge, with the noise its pixels' coverages
                    // carry (as before walls were told apart; the pixel
                    // edge's 1/12 px^2 tripled the covariance of a marker's
                    // centroid at 0.64 m in data/sessions/lab).
                    const double variance = u.ok ? u.edgeVar : 1.0 / 12.0;
                    out.outline.push_back({mid, EdgeKind::Free, std::sqrt(variance), true, rim});
                    freeEdges.push_back({mid, variance});
                    continue;
                }
                // The background's colour must come from beyond the edge's
                // blur (the pixel's own extent and the demosaic's pixel on
                // either side): where the filter stopped short of the edge (a
                // sphere's limb in shadow, whose mixed pixels the demosaic
                // gives false colours), three pixels beyond the mask are
                // still within it, the background taken there carries some
                // of the target's colour, and every coverage it gives is too
                // low. Measured again beyond the edge found: on a Bayer
                // mosaic, a sphere lit from one side had its shadowed limb
                // pulled in by 0.15-0.19 px and its centre 0.03-0.09 px
                // towards the lamp (docs/accuracy.md, "The thirteenth round"). Where the
                // colours three pixels beyond were too close to the target's
                // to unmix at all, they may be the mixed pixels too.
                const double e0 = u.sum - 1.5;
                if (!u.ok || e0 > 0.5) {
                    const int further = u.ok ? std::min(2, static_cast<int>(std::ceil(e0 - 0.5))) : 2;
                    if (backgroundAt(x, y, d, 3 + further, background)) {
                        const Unmixed again = unmix(samples, background);
                        if (again.ok) u = again;
                    }
                }
                if (!u.ok) {
                    out.outline.push_back({mid, EdgeKind::Free, std::sqrt(1.0 / 12.0), false, rim});
                    freeEdges.push_back({mid, 1.0 / 12.0});
                    continue;
                }
                const double sum = u.sum, edgeVar = u.edgeVar;
                const double e = std::clamp(sum - 1.5, -0.5, 2.5);
                const double delta = e - 0.5;  // outwards from the mask's edge
                const cv::Point2d p(roi.x + x + e * d.dx, roi.y + y + e * d.dy);
                out.outline.push_back({p, EdgeKind::Free, std::sqrt(edgeVar), false, rim});
                addedArea += delta;
                const double along = 0.5 + 0.5 * delta;
                addedX += delta * (roi.x + x + along * d.dx);
                addedY += delta * (roi.y + y + along * d.dy);
                freeEdges.push_back({mid, edgeVar});
            }
        }
    }
    out.region = roi;
    out.labels = lab;  // a view of the frame, which nothing else keeps
    const double binaryArea = static_cast<double>(pixelCount);
    const double sumX = static_cast<double>(pixelSumX), sumY = static_cast<double>(pixelSumY);
    if (binaryArea <= 0.0) return out;
    out.area = binaryArea + addedArea;
    if (!(out.area > 0.0)) out.area = binaryArea;
    const double cx = (roi.x * binaryArea + sumX + addedX) / out.area;
    const double cy = (roi.y * binaryArea + sumY + addedY) / out.area;
    out.centroid = {cx, cy};
    // Moving an edge by delta moves the centroid by delta (m - c) / A.
    cv::Matx22d cov(0, 0, 0, 0);
    for (const FreeEdge& f : freeEdges) {
        const double dx = f.mid.x - cx, dy = f.mid.y - cy;
        cov(0, 0) += f.variance * dx * dx;
        cov(0, 1) += f.variance * dx * dy;
        cov(1, 1) += f.variance * dy * dy;
    }
    cov(1, 0) = cov(0, 1);
    out.centroidCovariance = cov * (correlation / (out.area * out.area));
    return out;
}

}  // namespace avatar::detail
