#pragma once
// Internal to avatar::analyze: one row of lighting factors (LightingCorrector),
// computed the same bit for bit on every machine.

namespace avatar::detail {

/// Factors are clamped to this (LightingCorrection.h): any factor above 2^16
/// already saturates every non-zero sample, and inf * 0 would be NaN.
constexpr float kMaxFactor = 131072.0f;

/// Element i of a row of @p n: pixel xs[i]'s factor of the channel whose
/// exponent and gain * coefficient are e[i] and m[i], times t[i] (a
/// template's factor, else 1): m * exp(e * d) * t with d the distance from
/// (ox, oy) to (xs[i], y) (@p dy2 = (y - oy)^2), clamped to [0, kMaxFactor].
void lightingFactorRow(const double* xs, const double* e, const double* m, const double* t, double dy2, double ox,
                       float* out, int n);

}  // namespace avatar::detail
