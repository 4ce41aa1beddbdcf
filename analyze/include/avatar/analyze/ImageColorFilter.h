#pragma once
/// @file ImageColorFilter.h
/// The colour filters of thesis 3.3.2 (Figure 3-8) and the hue/saturation/value
/// alternative it proposes, applied to one BGR image for several target types
/// in one pass.

#include <avatar/config/TargetConfig.h>

#include <opencv2/core/mat.hpp>

#include <vector>

namespace avatar {

/// Computes one mask per target type (CV_8UC1, 255 where the pixel passes that
/// type's filter, 0 elsewhere) from an 8- or 16-bit BGR image, in one pass over
/// the pixels. Only pixels inside each type's search window are tested; the
/// rest of its mask is 0.
///
/// RGB-ratio filter: R/G, R/B and B/G each within [min, max], and R+G+B within
/// the brightness range when one is set. Ratios are evaluated without division
/// (min * G <= R <= max * G); a ratio whose numerator and denominator are both
/// zero is undefined and fails, a zero denominator under a non-zero numerator
/// is +infinity and fails any finite max. So black pixels never pass, and no
/// NaN or division by zero can occur.
///
/// HSV filter: hue in degrees [0, 360) (a range with min > max wraps through 0),
/// saturation and value in [0, 1] relative to the image's full scale.
///
/// @param bgr      8- or 16-bit, 3 channels
/// @param bitDepth significant bits of the samples (full scale = 2^bitDepth - 1)
/// @param types    the target types, in order
/// @param masks    resized to types.size(); each (re)allocated to the image size
void colorFilterMasks(const cv::Mat& bgr, int bitDepth, const std::vector<TargetType>& types,
                      std::vector<cv::Mat>& masks);

/// The filtered image of thesis Figure 3-9 (b): @p bgr where @p mask is set, 0 elsewhere.
cv::Mat applyMask(const cv::Mat& bgr, const cv::Mat& mask);

}  // namespace avatar
