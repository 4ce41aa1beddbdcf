#include <avatar/common/Error.h>
#include <avatar/common/ImageUtils.h>

#include <opencv2/core.hpp>
#include <opencv2/imgproc.hpp>

#include <cstdint>

namespace avatar {
namespace {

// OpenCV names a mosaic by the 2nd and 3rd pixel of its second row; we name it
// by the first two pixels of the first row. Translate.
int cvBayerCode(BayerPattern pattern, DemosaicMethod method) {
    const bool ea = method == DemosaicMethod::EdgeAware;
    switch (pattern) {
        case BayerPattern::BG: return ea ? cv::COLOR_BayerRG2BGR_EA : cv::COLOR_BayerRG2BGR;
        case BayerPattern::GB: return ea ? cv::COLOR_BayerGR2BGR_EA : cv::COLOR_BayerGR2BGR;
        case BayerPattern::RG: return ea ? cv::COLOR_BayerBG2BGR_EA : cv::COLOR_BayerBG2BGR;
        case BayerPattern::GR: return ea ? cv::COLOR_BayerGB2BGR_EA : cv::COLOR_BayerGB2BGR;
    }
    throw InvalidArgument("demosaic: unknown Bayer pattern");
}

}  // namespace

int bayerSiteColour(BayerPattern pattern, int x, int y) {
    static constexpr int kSites[4][4] = {
        {0, 1, 1, 2},  // BG: B G / G R
        {1, 0, 2, 1},  // GB: G B / R G
        {2, 1, 1, 0},  // RG: R G / G B
        {1, 2, 0, 1},  // GR: G R / B G
    };
    return kSites[static_cast<int>(pattern)][(y & 1) * 2 + (x & 1)];
}

void swapEndian16(cv::Mat& image) {
    if (image.depth() != CV_16U)
        throw InvalidArgument("swapEndian16: image must have 16-bit samples");
    const int rowSamples = image.cols * image.channels();
    for (int y = 0; y < image.rows; ++y) {
        auto* row = image.ptr<std::uint16_t>(y);
        // A plain loop that GCC vectorises into byte shuffles at -O2 and above.
        for (int x = 0; x < rowSamples; ++x)
            row[x] = static_cast<std::uint16_t>((row[x] >> 8) | (row[x] << 8));
    }
}

cv::Mat demosaic(const cv::Mat& mosaic, BayerPattern pattern, DemosaicMethod method) {
    if (mosaic.empty() || mosaic.channels() != 1 ||
        (mosaic.depth() != CV_8U && mosaic.depth() != CV_16U))
        throw InvalidArgument("demosaic: need a non-empty one-channel 8- or 16-bit mosaic");
    if (mosaic.cols < 2 || mosaic.rows < 2)
        throw InvalidArgument("demosaic: mosaic must be at least 2x2, got " +
                              std::to_string(mosaic.cols) + "x" + std::to_string(mosaic.rows));
    cv::Mat bgr;
    cv::cvtColor(mosaic, bgr, cvBayerCode(pattern, method));
    return bgr;
}

StereoImagePair demosaic(const StereoImagePair& pair, DemosaicMethod method) {
    if (pair.layout().format != PixelFormat::Bayer)
        throw InvalidArgument("demosaic: pair is " + std::string(toString(pair.layout().format)) +
                              ", not bayer");
    PairLayout layout = pair.layout();
    layout.format = PixelFormat::Bgr;
    return StereoImagePair(demosaic(pair.left(), layout.bayerPattern, method),
                           demosaic(pair.right(), layout.bayerPattern, method), layout, pair.id());
}

cv::Mat toDisplay8(const cv::Mat& image, int bitDepth) {
    const int container = image.depth() == CV_8U ? 8 : image.depth() == CV_16U ? 16 : 0;
    if (container == 0)
        throw InvalidArgument("toDisplay8: image must have 8- or 16-bit samples");
    if (bitDepth < 1 || bitDepth > container)
        throw InvalidArgument("toDisplay8: bit depth " + std::to_string(bitDepth) +
                              " does not fit a " + std::to_string(container) + "-bit image");
    cv::Mat out;
    const double scale = 255.0 / static_cast<double>((1 << bitDepth) - 1);
    image.convertTo(out, CV_8U, scale);
    return out;
}

}  // namespace avatar
