#pragma once
/// @file LightingCorrection.h
/// Lighting correction (thesis 3.2): frame-average gains (Figure 3-2) and the
/// strobe falloff template c * exp(e * d) per channel (Figures 3-3, 3-4),
/// folded into one per-pixel, per-channel factor so that correcting an image
/// costs one multiplication per channel and pixel.

#include <avatar/config/LightingConfig.h>

#include <opencv2/core/mat.hpp>

#include <array>
#include <filesystem>

namespace avatar {

class LightingCorrector {
public:
    /// @param configDir resolves a relative LightingConfig::templateImagePath.
    /// Throws avatar::IoError / avatar::FormatError naming a template image
    /// that cannot be read or is not 3-channel.
    explicit LightingCorrector(const LightingConfig& config, const std::filesystem::path& configDir = {});

    /// True when the configuration asks for any correction.
    bool enabled() const;

    /// Builds the factor image for @p size (once per size; later calls for the
    /// same size return at once). Not thread-safe; call before apply() is
    /// used from several threads. A template image must have this size.
    void prepare(cv::Size size);

    /// Multiplies every channel of every pixel of a BGR image (8 or 16 bit) by
    /// its factor, in place, saturating at full scale (2^bitDepth - 1).
    /// prepare() must have been called for the image's size. Thread-safe.
    void apply(cv::Mat& bgr, int bitDepth) const;

    /// The factor image (CV_32FC3, BGR) of the last prepare().
    const cv::Mat& factors() const { return factors_; }

private:
    LightingConfig config_;
    std::filesystem::path configDir_;
    cv::Mat factors_;
};

/// Per-channel frame-average gains of thesis Figure 3-2 from a raw image and
/// its corrected reference: sum(corrected) / sum(raw), in R, G, B order.
std::array<double, 3> frameAverageGains(const cv::Mat& rawBgr, const cv::Mat& correctedBgr);

}  // namespace avatar
