#pragma once
// Internal to avatar::analyze: three 16-bit planes to interleaved BGR samples
// and back, for the rows the front end writes and the silhouettes read.
//
// Not cv::hal::merge16u / split16u: those store with non-temporal
// (cache-bypassing) instructions whenever the destination is aligned, so a
// row written for a stage that reads it next, or a small scratch row read at
// once, came back from memory (perf: the stores and the loads after them were
// a tenth of a tracking frame). These keep what they write in the cache.

#include <cstdint>

namespace avatar::detail {

/// out[3 i + c] = plane c's sample i (c: 0 = @p b, 1 = @p g, 2 = @p r), i < @p n.
void interleave3(const std::uint16_t* b, const std::uint16_t* g, const std::uint16_t* r, std::uint16_t* out, int n);

/// The inverse: plane c's sample i = in[3 i + c], i < @p n.
void deinterleave3(const std::uint16_t* in, std::uint16_t* b, std::uint16_t* g, std::uint16_t* r, int n);

}  // namespace avatar::detail
