#pragma once
/// @file LightingConfig.h
/// Lighting correction (thesis 3.2): frame-average gains and the strobe
/// falloff pattern.

#include <array>
#include <string>

namespace avatar {

/// Per-channel c * exp(e * d), d the pixel distance from the pattern centre.
struct FalloffChannel {
    double coefficient{1.0};
    double exponent{0.0};
    bool operator==(const FalloffChannel& o) const {
        return coefficient == o.coefficient && exponent == o.exponent;
    }
};

struct LightingConfig {
    /// Frame-averaging (Figure 3-2): per-channel gains, in R, G, B order.
    bool frameAverageEnabled{false};
    std::array<double, 3> gainsRgb{1.0, 1.0, 1.0};

    /// Strobe pattern (Figures 3-3, 3-4): either the analytic falloff or a template image.
    bool patternEnabled{false};
    std::array<double, 2> patternCentrePx{640.0, 480.0};
    FalloffChannel red;
    FalloffChannel green;
    FalloffChannel blue;
    /// When not empty, a 3-channel 32-bit float image (BGR) of per-pixel factors
    /// used instead of the analytic falloff; relative paths are relative to the config file.
    std::string templateImagePath;

    bool operator==(const LightingConfig& o) const {
        return frameAverageEnabled == o.frameAverageEnabled && gainsRgb == o.gainsRgb &&
               patternEnabled == o.patternEnabled && patternCentrePx == o.patternCentrePx &&
               red == o.red && green == o.green && blue == o.blue &&
               templateImagePath == o.templateImagePath;
    }
};

}  // namespace avatar
