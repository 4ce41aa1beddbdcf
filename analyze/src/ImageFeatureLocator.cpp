/// @file ImageFeatureLocator.cpp
/// Erode + feature-AND restore (thesis 3.3.2) and the feature locator with its
/// geometric filter (thesis 3.3.3, Table 3-1, Figure 3-13, Appendix C).
///
/// Both stages are built on cv::connectedComponents (8-connected), which is
/// iterative (no recursion, so no stack overflow on large features as the
/// thesis's recursive CheckConnectedPixels had) and linear in the image size.
/// Everything per feature is then gathered in one raster-order pass over the
/// label image with per-label accumulators, so the cost does not grow with the
/// number of features beyond the size of those accumulators.
///
/// cv::connectedComponentsWithStats is not used: its statistics are gathered
/// for every pixel, background included, and made it 3-8 times slower than
/// plain labelling on a 1280x960 mask; the pass below computes area, box and
/// centroid sums anyway, for the "on" pixels only.

#include <avatar/analyze/ImageFeatureLocator.h>

#include <avatar/common/Error.h>
#include <avatar/common/Logging.h>

#include <log4cpp/Category.hh>
#include <opencv2/core.hpp>
#include <opencv2/imgproc.hpp>

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

/// Calls @p f(x) for each non-zero byte of @p row, skipping zero runs eight
/// bytes at a time (filtered masks are mostly empty).
template <typename F>
inline void forEachNonZero(const std::uint8_t* row, int cols, F&& f) {
    int x = 0;
    for (; x + 8 <= cols; x += 8) {
        std::uint64_t word;
        std::memcpy(&word, row + x, sizeof word);
        if (word == 0) continue;
        for (int i = x; i < x + 8; ++i) {
            if (row[i] != 0) f(i);
        }
    }
    for (; x < cols; ++x) {
        if (row[x] != 0) f(x);
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

    /// Appendix C's update for pixel (x, y), simplified by the raster order
    /// of the scan: y never decreases and, within a row, x increases. So the
    /// first pixel fixes Y_top and point 1; a later pixel on the top row is
    /// the new point 2; a pixel below Y_bot starts a new bottom row (points 5
    /// and 6), one on it is the new point 5; a pixel left of X_l (right of
    /// X_r) restarts that column's points 7 and 8 (3 and 4), one on it is the
    /// new point 7 (4), being the lowest so far.
    void add(int x, int y) {
        if (area == 0) {
            top = bottom = y;
            left = right = x;
            topMinX = topMaxX = bottomMinX = bottomMaxX = x;
            leftMinY = leftMaxY = rightMinY = rightMaxY = y;
        } else {
            if (y == top) topMaxX = x;
            if (y > bottom) {
                bottom = y;
                bottomMinX = bottomMaxX = x;
            } else {
                bottomMaxX = x;
            }
            if (x < left) {
                left = x;
                leftMinY = leftMaxY = y;
            } else if (x == left) {
                leftMaxY = y;
            }
            if (x > right) {
                right = x;
                rightMinY = rightMaxY = y;
            } else if (x == right) {
                rightMaxY = y;
            }
        }
        ++area;
        sumX += x;
        sumY += y;
    }
};

/// Brightness weight R+G+B of one intensity pixel, or nothing.
struct NoIntensity {
    static constexpr bool kWeighted = false;
    static std::int64_t weight(const cv::Mat&, int, int) { return 0; }
};
template <typename Channel>
struct BgrIntensity {
    static constexpr bool kWeighted = true;
    static std::int64_t weight(const cv::Mat& image, int y, int x) {
        const Channel* p = image.ptr<Channel>(y) + 3 * x;
        return static_cast<std::int64_t>(p[0]) + p[1] + p[2];
    }
};

/// The single pass over the window: every "on" pixel updates the accumulator
/// of its label. @p order receives the labels in raster order of their first
/// pixel. @p intensity is the window's part of the intensity image (or empty).
template <typename Weight>
void accumulate(const cv::Mat& roi, const cv::Mat& labels, const cv::Mat& intensity,
                std::vector<Accumulator>& acc, std::vector<int>& order) {
    for (int y = 0; y < roi.rows; ++y) {
        const int* l = labels.ptr<int>(y);
        forEachNonZero(roi.ptr<std::uint8_t>(y), roi.cols, [&](int x) {
            const int label = l[x];
            Accumulator& a = acc[static_cast<std::size_t>(label)];
            if (a.area == 0) order.push_back(label);
            a.add(x, y);
            if constexpr (Weight::kWeighted) {
                const std::int64_t w = Weight::weight(intensity, y, x);
                a.sumW += w;
                a.sumWX += w * x;
                a.sumWY += w * y;
            }
        });
    }
}

Feature makeFeature(const Accumulator& a, const cv::Rect& window) {
    const int ox = window.x;
    const int oy = window.y;
    Feature f;
    f.area = a.area;
    const double n = static_cast<double>(a.area);
    f.centroid = {static_cast<double>(a.sumX) / n + ox, static_cast<double>(a.sumY) / n + oy};
    if (a.sumW > 0) {
        const double w = static_cast<double>(a.sumW);
        f.weightedCentroid = {static_cast<double>(a.sumWX) / w + ox,
                              static_cast<double>(a.sumWY) / w + oy};
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

cv::Mat erodeRestore(const cv::Mat& mask, int kernelSize) {
    requireMask(mask, "erodeRestore");
    if (kernelSize < 1 || kernelSize % 2 == 0) {
        throw InvalidArgument("erodeRestore: the erode kernel size must be odd and positive, got " +
                              std::to_string(kernelSize));
    }
    if (mask.empty()) return cv::Mat(mask.size(), CV_8UC1);

    // Pixels beyond the image edge count as "on" (OpenCV's default border for
    // erosion), so a feature cut by the edge is eroded only from its inside.
    cv::Mat eroded;
    cv::erode(mask, eroded, cv::getStructuringElement(cv::MORPH_RECT, {kernelSize, kernelSize}),
              cv::Point(-1, -1), 1, cv::BORDER_CONSTANT, cv::morphologyDefaultBorderValue());

    // Reconstruction: label the original, mark every label that still has an
    // eroded pixel, then keep exactly the pixels of the marked labels.
    cv::Mat labels;
    const int count = cv::connectedComponents(mask, labels, 8, CV_32S);
    std::vector<std::uint8_t> keep(static_cast<std::size_t>(count), 0);
    int survivors = 0;
    for (int y = 0; y < mask.rows; ++y) {
        const int* l = labels.ptr<int>(y);
        forEachNonZero(eroded.ptr<std::uint8_t>(y), mask.cols, [&](int x) {
            std::uint8_t& k = keep[static_cast<std::size_t>(l[x])];
            survivors += k == 0;
            k = 255;
        });
    }

    cv::Mat restored = cv::Mat::zeros(mask.size(), CV_8UC1);
    if (survivors > 0) {
        for (int y = 0; y < mask.rows; ++y) {
            const int* l = labels.ptr<int>(y);
            std::uint8_t* out = restored.ptr<std::uint8_t>(y);
            forEachNonZero(mask.ptr<std::uint8_t>(y), mask.cols,
                           [&](int x) { out[x] = keep[static_cast<std::size_t>(l[x])]; });
        }
    }
    log4cpp::Category& log = logger();
    if (log.isDebugEnabled()) {
        log.debugStream() << "erodeRestore: kernel " << kernelSize << ", " << survivors << " of "
                          << count - 1 << " components kept";
    }
    return restored;
}

std::vector<Feature> locateFeatures(const cv::Mat& mask, const cv::Mat& intensity,
                                    const TargetType& type, cv::Rect window) {
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
    cv::Mat labels;
    const int count = cv::connectedComponents(roi, labels, 8, CV_32S);

    std::vector<Accumulator> acc(static_cast<std::size_t>(count));
    std::vector<int> order;  // labels in raster order of their first pixel
    order.reserve(static_cast<std::size_t>(count - 1));
    if (intensity.empty()) {
        accumulate<NoIntensity>(roi, labels, cv::Mat(), acc, order);
    } else if (intensity.depth() == CV_8U) {
        accumulate<BgrIntensity<std::uint8_t>>(roi, labels, intensity(window), acc, order);
    } else {
        accumulate<BgrIntensity<std::uint16_t>>(roi, labels, intensity(window), acc, order);
    }

    std::vector<Feature> features;
    for (const int label : order) {
        Feature f = makeFeature(acc[static_cast<std::size_t>(label)], window);
        if (type.area.contains(f.area) && type.aspectRatio.contains(f.aspectRatio) &&
            type.areaRatio.contains(f.areaRatio)) {
            features.push_back(f);
        }
    }

    log4cpp::Category& log = logger();
    if (log.isDebugEnabled()) {
        log.debugStream() << "locateFeatures: type '" << type.name << "', window "
                          << describe(window) << ": " << count - 1 << " features, "
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
