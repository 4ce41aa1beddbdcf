#pragma once
/// @file LightingCorrection.h
/// Lighting correction (thesis 3.2): frame-average gains (Figure 3-2) and the
/// strobe falloff template c * exp(e * d) per channel (Figures 3-3, 3-4),
/// folded into one per-pixel, per-channel factor so that correcting an image
/// costs one multiplication per channel and pixel.
///
/// Factor of channel k (B, G, R) at pixel (x, y):
///   gain_k * pattern_k(x, y)
/// gain_k is LightingConfig::gainsRgb (given in R, G, B order) when
/// frameAverageEnabled, else 1. pattern_k is 1 unless patternEnabled; then it is
/// the template image's value, or c_k * exp(e_k * d) with d the Euclidean
/// distance in pixels between (x, y) (column and row index) and
/// patternCentrePx. The thesis fits c, e to the ratio light/dark of similar
/// objects near and far from the strobe's centre (Figure 3-3), so the factor
/// is used as given: e > 0 brightens the periphery, e = 0 is a uniform gain c.

#include <avatar/common/ImageFormat.h>
#include <avatar/config/LightingConfig.h>

#include <opencv2/core/mat.hpp>

#include <array>
#include <filesystem>
#include <vector>

namespace avatar {

class LightingCorrector {
public:
    /// @param configDir resolves a relative LightingConfig::templateImagePath.
    /// The template (read when patternEnabled and the path is not empty) must
    /// be a 3-channel floating-point image (BGR) of finite factors >= 0, read
    /// with cv::imread: a 32-bit float TIFF written without compression
    /// (cv::IMWRITE_TIFF_COMPRESSION = 1; OpenCV's default for float RGB
    /// TIFF is the lossy LogLuv encoding) or a PFM file. Throws avatar::IoError naming a template
    /// image that is missing or cannot be decoded, avatar::FormatError naming
    /// one with the wrong channel count, depth or values, and ConfigError (an
    /// avatar::InvalidArgument) for a configuration that validateLightingConfig()
    /// rejects (a gain or coefficient not finite and > 0, an exponent or the
    /// pattern centre not finite), naming the element.
    explicit LightingCorrector(const LightingConfig& config, const std::filesystem::path& configDir = {});

    /// True when the configuration asks for any correction.
    bool enabled() const;

    /// Builds the factor image for @p size (once per size; later calls for the
    /// same size return at once). Not thread-safe; call before apply() is
    /// used from several threads. A template image must have this size
    /// (avatar::FormatError naming the file and both sizes otherwise).
    /// Factors are stored as float, clamped to [0, 2^17]. They are computed
    /// with an exp of the library's own from IEEE additions and
    /// multiplications only, so that they are the same bit for bit on every
    /// machine (a recorded session replays identically anywhere), vectorised.
    void prepare(cv::Size size);

    /// Multiplies every channel of every pixel of a BGR image (8 or 16 bit) by
    /// its factor, in place: sample' = min(round(sample * factor), 2^bitDepth - 1),
    /// the product taken in single precision. A no-op when !enabled().
    /// Otherwise prepare() must have been called for the image's size
    /// (avatar::InvalidArgument otherwise, and for a bit depth outside
    /// 1..8 / 1..16); avatar::FormatError for an image that is not CV_8UC3 or
    /// CV_16UC3. Thread-safe (const, reads only the factor image), so the left
    /// and right images can be corrected concurrently.
    void apply(cv::Mat& bgr, int bitDepth) const;

    /// The factor image (CV_32FC3, BGR) of the last prepare().
    const cv::Mat& factors() const { return factors_; }

    /// The factor of every site of a @p pattern mosaic of @p size, its
    /// colour's (CV_32FC1), for a correction applied to the mosaic before the
    /// demosaic (the fused front end); built once per size and pattern,
    /// without the three-channel image. Without a strobe pattern (gains
    /// alone) a site's factor depends on its row only through the row's
    /// parity: then two rows, of the even and the odd rows (row y's factors
    /// are row y % 2's, the very values), not a full image to read from
    /// memory per frame. Not thread-safe, like prepare().
    void prepareMosaic(cv::Size size, BayerPattern pattern);
    const cv::Mat& mosaicFactors() const { return mosaicFactors_; }

private:
    /// Factors of every pixel and channel (@p pattern null) or of every mosaic site.
    cv::Mat buildFactors(cv::Size size, const BayerPattern* pattern) const;

    LightingConfig config_;
    std::filesystem::path configDir_;
    std::filesystem::path templatePath_;  ///< resolved; empty: analytic falloff
    cv::Mat template_;                    ///< CV_32FC3, when templatePath_ is set
    cv::Mat factors_;
    cv::Mat mosaicFactors_;
    cv::Size mosaicSize_;  ///< the mosaic's the factors are for (two rows of it without a pattern)
    BayerPattern mosaicPattern_{BayerPattern::BG};
};

/// Per-channel frame-average gains of thesis Figure 3-2 from a raw image and
/// its corrected reference: sum(corrected) / sum(raw), in R, G, B order (the
/// order of LightingConfig::gainsRgb). Both images are 3-channel BGR of the
/// same size and type. An offline helper. Throws avatar::InvalidArgument for
/// mismatched images or a raw channel that sums to 0.
std::array<double, 3> frameAverageGains(const cv::Mat& rawBgr, const cv::Mat& correctedBgr);

/// The same over a set of image pairs (Figure 3-2 sums over every image of
/// the set): sums over all pairs, then the ratios.
std::array<double, 3> frameAverageGains(const std::vector<cv::Mat>& rawBgr,
                                        const std::vector<cv::Mat>& correctedBgr);

}  // namespace avatar
