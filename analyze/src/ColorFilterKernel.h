#pragma once
// Internal to avatar::analyze: the colour filter of ImageColorFilter.h as row
// kernels over planar samples, shared by colorFilterMasks() and the fused
// front end (FrontEnd.h), so both give the same masks bit for bit.

#include <avatar/config/TargetConfig.h>

#include <opencv2/core/mat.hpp>

#include <cstdint>
#include <memory>

namespace avatar::detail {

/// One target type's colour test compiled for images of one size and sample
/// depth: its search window clipped to the image and its exact limits
/// (ImageColorFilter.h). Immutable; row() may run on several threads at once.
class ColorTest {
public:
    /// @param depth CV_8U or CV_16U, the samples' container
    /// @param bitDepth significant bits (HSV value is relative to 2^bitDepth - 1)
    /// Throws as colorFilterMasks() does for a type that does not validate or a
    /// window outside the image.
    ColorTest(const TargetType& type, cv::Size size, int depth, int bitDepth);

    /// The type's search window, clipped to the image.
    const cv::Rect& window() const;

    /// The verdicts (0 or 255) of @p n pixels given as three planes of floats
    /// holding the integer sample values. @p scratch: @p n bytes of the
    /// caller's, used by a type with brightness bands. Returns false when
    /// every verdict is 0; true when some may be 255 (the AVX-512 ratio test
    /// knows, the other kernels do not say).
    bool row(const float* b, const float* g, const float* r, std::uint8_t* out, int n, std::uint8_t* scratch) const;

    struct Plan;

private:
    std::shared_ptr<const Plan> plan_;
};

/// Interleaved BGR samples to three float planes.
void splitRow(const std::uint8_t* bgr, float* b, float* g, float* r, int n);
void splitRow(const std::uint16_t* bgr, float* b, float* g, float* r, int n);

/// Makes @p mask a CV_8UC1 of @p size that can be written in place: kept when
/// it is the caller's own continuous buffer of that size, new otherwise (a
/// mask still referenced elsewhere, e.g. by a display, is never overwritten).
void prepareMask(cv::Mat& mask, cv::Size size);

}  // namespace avatar::detail
