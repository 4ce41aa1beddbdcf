#pragma once
// Internal to avatar::analyze: the fused front end. The per-pixel stages of
// the chain (lighting, demosaic, color_filter and visibility's measures) done
// in one pass over the rows of a raw mosaic, so that the image is read once
// and every intermediate row stays in cache (docs/benchmarks.md).
//
// The lighting correction is applied to the mosaic, each site by the factor
// of its own colour (LightingCorrector::apply's formula, one multiplication
// per site instead of three per pixel, a third of the factors to read), and
// the corrected mosaic is demosaiced: the correction of the sensor's samples
// before they are interpolated, which is the physically exact order (the
// interpolated colours of a pixel come from its neighbours, each under its
// own falloff). Otherwise the result is bit for bit what the stages give one
// after the other: the bilinear demosaic of cv::cvtColor, colorFilterMasks and
// measureVisibility (tests/analyze/FrontEndTest.cpp checks each against them).

#include "ColorFilterKernel.h"
#include "ImageReduce.h"
#include "MaskRows.h"

#include <avatar/analyze/ProcessStereoImagePair.h>
#include <avatar/analyze/Visibility.h>
#include <avatar/common/ImageFormat.h>

#include <opencv2/core/mat.hpp>

#include <array>
#include <memory>
#include <optional>
#include <vector>

namespace avatar::detail {

/// One raw image and what to do with it.
struct FrontEndInput {
    cv::Mat mosaic;  ///< CV_8UC1 or CV_16UC1 Bayer mosaic, at least 4x4 (handles())
    BayerPattern pattern{BayerPattern::BG};
    int bitDepth{16};         ///< significant bits (full scale 2^bitDepth - 1)
    bool endianSwap{false};   ///< swap the bytes of 16-bit samples first
    /// The lighting factor of every mosaic site, its colour's (CV_32FC1 of the
    /// image's size, or of two rows: the even and the odd rows' factors,
    /// LightingCorrector::mosaicFactors()); null: no correction.
    const cv::Mat* factors{nullptr};
    /// The colour tests, compiled for this size and depth; null: no filter.
    const std::vector<ColorTest>* tests{nullptr};
    bool visibility{false};   ///< measure the visibility statistics
    /// Write the BGR image (FrontEndResult::bgr); false: the masks and the
    /// visibility only, the image left as it is (a pass over regions always
    /// writes it).
    bool writeImage{true};
    /// The search regions of a tracking frame (AnalysisFrame::regions): when
    /// not null and not empty, only their pixels are computed, each bit for
    /// bit what the whole image gives there (its demosaic reads the mosaic
    /// around it); the rest of the image and masks is 0 and no visibility is
    /// measured. Rectangles inside the image, disjoint.
    const std::vector<cv::Rect>* regions{nullptr};
    /// The portable loops even where a CPU runs the AVX-512 ones (for the
    /// tests that hold the two to the same result).
    bool portableKernels{false};
};

/// The outputs. A buffer already of the right size and type (continuous) is
/// written in place, whoever else refers to it (the caller's BufferPool
/// decides which may be written); otherwise a new one is allocated.
struct FrontEndResult {
    cv::Mat bgr;                    ///< the demosaiced (and corrected) image
    std::vector<cv::Mat> masks;     ///< one per test, CV_8UC1 0/255
    std::optional<VisibilityMeasures> visibility;
    /// Per mask, where its on pixels lie (a whole-image pass only; a pass over
    /// regions leaves this empty).
    std::vector<MaskRows> maskRows;
    /// With regions: the caller's bgr or masks are known to be 0 outside them
    /// (else they are cleared first).
    bool bgrZeroOutsideRegions{false};
    bool masksZeroOutsideRegions{false};
    /// Per mask, where the caller's buffer may hold non-zero values before a
    /// whole-image pass (BufferPool::get()); it is 0 elsewhere, and the pass
    /// writes a row there only where the row's verdicts are not all 0. A mask
    /// without an entry, or a new buffer, is written whole.
    std::vector<std::vector<cv::Rect>> masksDirty;
};

/// What the 2x2-superpixel pass of coarse-to-fine gives (docs/config.md).
struct CoarseResult {
    std::vector<cv::Mat> masks;  ///< one per test, CV_8UC1 0/255, half the mosaic's size (rounded down)
    /// The superpixels (the mosaic's depth), kept only when the visibility is
    /// measured on them whole (a half size not divisible by 2); else empty.
    cv::Mat bgr;
    /// With FrontEndInput::visibility: the measures from the superpixels
    /// (saturated ones, and their 2x2 means as the whole pass's 4x4 ones).
    std::optional<VisibilityMeasures> visibility;
};

/// The coarse pass of coarse-to-fine: each 2x2 block of mosaic sites one
/// pixel, its red and its blue site and the mean of its two greens (rounded
/// half up), every site first corrected by its lighting factor as in
/// runFrontEnd(); @p tests, compiled for the half size (windows halved),
/// judge the superpixels. Only a search: where a target may be, found at a
/// quarter of the pixels. @p in's tests and regions are ignored.
void runCoarse(const FrontEndInput& in, const std::vector<ColorTest>& tests, CoarseResult& out);

/// Whether the fused pass takes this mosaic: 8 or 16-bit, one channel, at
/// least 4x4 pixels (smaller images go through the stages one by one).
bool frontEndHandles(const cv::Mat& mosaic);

/// The pass. Thread-safe: the left and right image may run at once.
void runFrontEnd(const FrontEndInput& in, FrontEndResult& out);

/// Both images of a pair on one thread, bit for bit what runFrontEnd() gives
/// each: whole-image passes take turns over strips of rows, so that each
/// strip of lighting factors is read from memory once for both (the factor
/// image, 4 bytes a site, is read for each image otherwise; at 5 MP it does
/// not stay in cache from one image to the next).
void runFrontEndPair(const FrontEndInput& left, FrontEndResult& outLeft, const FrontEndInput& right,
                     FrontEndResult& outRight);

/// The input that computes @p frame's working image of @p side again, the
/// image alone (no tests, no visibility), from its original mosaic with the
/// factors and byte order its front end used (AnalysisFrame::imagesAroundFeatures).
FrontEndInput imageInput(const AnalysisFrame& frame, Side side);

/// Lets the chain's first bilinear `demosaic` stage run the fused pass for the
/// built-in `lighting` and `color_filter` stages right after it and the first
/// `visibility` stage after those (when only built-in stages that leave the
/// images alone come between); those stages then keep only their non-pixel
/// work. A stage a registry replaced is never fused. (Stages.cpp)
void fuseFrontEnd(std::vector<std::unique_ptr<ProcessStereoImagePair>>& stages);

}  // namespace avatar::detail
