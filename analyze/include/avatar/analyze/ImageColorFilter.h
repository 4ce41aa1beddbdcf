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
/// the pixels (row by row; each row is tested for every type while it is in
/// cache). Only pixels inside each type's search window are tested; the rest
/// of its mask is 0. The window is clipped to the image exactly as
/// searchWindow() does (unset window: the whole image; a window entirely
/// outside the image throws avatar::InvalidArgument).
///
/// RGB-ratio filter: R/G, R/B and B/G each within [min, max], and R+G+B within
/// the brightness range when one is set. With brightness bands, a pixel whose
/// M = R+G+B lies in a band is judged by that band's three ranges, any other by
/// the type's own (thesis 3.3.2). Ratios are evaluated without division
/// (min * G <= R <= max * G), so no NaN or division by zero can occur. Clipped
/// channels (a saturated red at (240, 0, 0)): a zero denominator under a
/// non-zero numerator is +infinity, which passes every min and passes a max only
/// when the range is open, max >= 65536 (above every finite ratio of 8- or
/// 16-bit samples; the default 1e9 is open); 0/0 (both channels zero) says
/// nothing about that ratio and passes it, the other two deciding; a black
/// pixel (0, 0, 0) fails every ratio filter. The comparison is exact for the double limits: a pixel
/// passes if and only if its rational ratio lies in the closed interval of the
/// limits' exact binary values (so a limit of 0.25 includes 1/4, while the
/// double nearest 0.1 lies just above 1/10 and a min of 0.1 excludes R/G = 1/10).
/// Consequently images that are multiples of each other (an 8-bit image and
/// the same image times 257 in 16 bits) give identical masks. Internally each
/// limit is replaced once by an equivalent value between the neighbouring
/// fractions p/q (p, q <= 255 or 65535), so each pixel costs one multiplication
/// and one comparison per limit, in float when that is provably exact (always
/// for 8-bit images) and in double otherwise. Brightness limits are compared
/// with the integer sum (fractional limits round inwards).
///
/// A type with a veil (TargetConfig.h, Veil) also passes the pixels with
/// G > 0 whose (R/G, B/G) lies in the convex hull of its veil's ranges'
/// region and that region moved towards the veil's colour by its maxShare,
/// with R+G+B in its brightness range: first the hull's bounding box with
/// the exact ratio test above (its limits widened by 1e-5, so float rounding
/// never cuts the hull), then the hull's edges in single precision (points
/// within rounding of an edge may fall either way). A type with a water
/// (TargetConfig.h, Water) passes the same way (exactly) the pixels its
/// water's ranges pass with each ratio's far end moved by the water over its
/// longest path, R/B unchecked, within its brightness range.
///
/// HSV filter: hue in degrees [0, 360) (a range with min > max wraps through 0),
/// saturation and value in [0, 1] relative to the image's full scale, as
/// cv::cvtColor defines them: V = max(R,G,B) / (2^bitDepth - 1),
/// S = (max - min) / max (0 for black), hue 0 for grey pixels. Hue is computed
/// in single precision with one division; S and V limits are exact like the
/// ratio limits. All limits are inclusive.
///
/// Masks are written in place when masks[i] is already a CV_8UC1 of the
/// image's size whose buffer nothing else refers to; otherwise a new buffer
/// is allocated (a mask still held elsewhere, e.g. by a display, is never
/// overwritten).
///
/// Throws avatar::FormatError for an image that is not CV_8UC3 / CV_16UC3,
/// avatar::InvalidArgument for a bit depth outside 1..8 / 1..16, and
/// ConfigError (an InvalidArgument) for a type that validateTargetType()
/// rejects (a NaN limit, a range with min > max, hue excepted), naming the type.
///
/// @param bgr      8- or 16-bit, 3 channels
/// @param bitDepth significant bits of the samples (full scale = 2^bitDepth - 1)
/// @param types    the target types, in order
/// @param masks    resized to types.size(); each (re)allocated to the image size
void colorFilterMasks(const cv::Mat& bgr, int bitDepth, const std::vector<TargetType>& types,
                      std::vector<cv::Mat>& masks);

/// The filtered image of thesis Figure 3-9 (b): @p bgr where @p mask is set
/// (non-zero), 0 elsewhere; a new image of @p bgr's type. Throws
/// avatar::FormatError when @p mask is not CV_8UC1 and avatar::InvalidArgument
/// when the sizes differ.
cv::Mat applyMask(const cv::Mat& bgr, const cv::Mat& mask);

}  // namespace avatar
