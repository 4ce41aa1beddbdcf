#include "ImageReduce.h"

#include <opencv2/imgproc.hpp>

#include <cmath>
#include <cstdint>
#include <limits>
#include <vector>

namespace avatar::detail {
namespace {

/// One output row: the 4x4 block means of four input rows. Column sums
/// first (a loop GCC vectorises), then the four columns of each block.
template <typename S>
void blockRow(const cv::Mat& image, int outY, int channels, std::vector<std::uint32_t>& sums, S* out, int outCols) {
    const int n = image.cols * channels;
    const S* r0 = image.ptr<S>(4 * outY);
    const S* r1 = image.ptr<S>(4 * outY + 1);
    const S* r2 = image.ptr<S>(4 * outY + 2);
    const S* r3 = image.ptr<S>(4 * outY + 3);
    std::uint32_t* s = sums.data();
    for (int i = 0; i < n; ++i)
        s[i] = static_cast<std::uint32_t>(r0[i]) + r1[i] + r2[i] + r3[i];
    for (int x = 0; x < outCols; ++x) {
        const std::uint32_t* b = s + 4 * x * channels;
        for (int c = 0; c < channels; ++c) {
            const std::uint32_t sum = b[c] + b[channels + c] + b[2 * channels + c] + b[3 * channels + c];
            // sum / 16 rounded to nearest, ties to even (cvRound of sum * (1.f / 16)).
            const std::uint32_t q = sum >> 4, r = sum & 15u;
            out[x * channels + c] = static_cast<S>(q + ((r > 8u) | ((r == 8u) & (q & 1u))));
        }
    }
}

template <typename S>
std::int64_t countAtLeast(const cv::Mat& image, double threshold) {
    if (threshold <= 0.0) return static_cast<std::int64_t>(image.total());
    if (threshold > static_cast<double>(std::numeric_limits<S>::max())) return 0;
    const auto t = static_cast<S>(std::ceil(threshold));
    const int channels = image.channels();
    const int n = image.cols * channels;
    std::int64_t count = 0;
    cv::Mat below;
    for (int y = 0; y < image.rows; ++y) {
        const S* row = image.ptr<S>(y);
        // Saturation is rare: a plain pass over the samples (a loop GCC
        // vectorises) finds the rows without any; the others are counted by
        // cv::inRange, which is vectorised over interleaved channels (a
        // per-pixel loop over them is not: it cost 3 ms per 1280x960 pair).
        std::int32_t samples = 0;  // n <= 2^31: no overflow
        for (int i = 0; i < n; ++i) samples += row[i] >= t;
        if (samples == 0) continue;
        if (channels == 1) {
            count += samples;
            continue;
        }
        // A pixel has no saturated channel when all of them lie in [0, t).
        cv::inRange(image.row(y), cv::Scalar::all(0), cv::Scalar::all(static_cast<double>(t) - 1.0), below);
        count += image.cols - cv::countNonZero(below);
    }
    return count;
}

}  // namespace

void downsampleArea4(const cv::Mat& image, cv::Mat& out) {
    const int depth = image.depth();
    if (image.cols % 4 != 0 || image.rows % 4 != 0 || (depth != CV_8U && depth != CV_16U) || image.channels() > 4) {
        cv::resize(image, out, cv::Size(), 0.25, 0.25, cv::INTER_AREA);
        return;
    }
    const int outCols = image.cols / 4, outRows = image.rows / 4, channels = image.channels();
    out.create(outRows, outCols, image.type());
    std::vector<std::uint32_t> sums(static_cast<std::size_t>(image.cols) * static_cast<std::size_t>(channels));
    for (int y = 0; y < outRows; ++y) {
        if (depth == CV_8U)
            blockRow<std::uint8_t>(image, y, channels, sums, out.ptr<std::uint8_t>(y), outCols);
        else
            blockRow<std::uint16_t>(image, y, channels, sums, out.ptr<std::uint16_t>(y), outCols);
    }
}

std::int64_t countPixelsWithAnyAtLeast(const cv::Mat& image, double threshold) {
    if (image.depth() == CV_8U) return countAtLeast<std::uint8_t>(image, threshold);
    if (image.depth() == CV_16U) return countAtLeast<std::uint16_t>(image, threshold);
    std::vector<cv::Mat> planes;
    cv::split(image, planes);
    cv::Mat any = planes[0] >= threshold;
    for (std::size_t c = 1; c < planes.size(); ++c) any |= planes[c] >= threshold;
    return cv::countNonZero(any);
}

}  // namespace avatar::detail
