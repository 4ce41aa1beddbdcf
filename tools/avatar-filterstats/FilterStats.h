#pragma once
/// @file FilterStats.h
/// avatar-filterstats (docs/tools/avatar-filterstats.md; thesis 3.3.1-3.3.2,
/// Figures 3-7 and 6-6 to 6-15): from labelled samples of a target and of its
/// background in one image, the colour statistics of each and a proposed
/// target type whose filter separates them, with the true- and false-positive
/// rates the real colour filter (colorFilterMasks) gives on the samples. The
/// image is read as the colour filter sees it by ToolImages.h
/// (tools::kForColourFilter).
///
/// Error policy: avatar::IoError / avatar::FormatError name the file at fault,
/// avatar::InvalidArgument the sample or option (an empty mask, masks of
/// another size than the image).

#include "ToolImages.h"

#include <avatar/config/TargetConfig.h>

#include <opencv2/core/mat.hpp>

#include <array>
#include <filesystem>
#include <functional>
#include <optional>
#include <string>
#include <vector>

namespace avatar::filterstats {

/// A sample mask: an 8-bit image, non-zero = sample. Must have @p size.
cv::Mat loadMask(const std::filesystem::path& path, cv::Size size);
/// A polygon file (one "x y" vertex per line, '#' comments) filled into a mask of @p size.
cv::Mat polygonMask(const std::filesystem::path& path, cv::Size size);
/// A point file (one "x y" point per line, '#' comments: the thesis's picked
/// points), each point with the pixels within @p radius of it, as a mask of
/// @p size. A point outside the image is an InvalidArgument naming it.
cv::Mat pointsMask(const std::filesystem::path& path, cv::Size size, int radius);

struct Options {
    std::string name{"target"};
    /// A background false positive costs this many target true positives when
    /// candidate filters are scored (score = TPR - weight * FPR).
    double falsePositiveWeight{10.0};
    /// Consider brightness bands when one range leaves more false positives than this.
    double bandsAbove{0.002};
    /// Samples used to choose (the rates reported use all of them).
    std::size_t maxSamples{200000};
    /// Called with (done, total) while candidates are evaluated.
    std::function<void(int, int)> progress;
    /// The site's haze backscatter colour (R, G, B as these cameras see it,
    /// docs/config.md, the veil): when set and the proposal is a single-range
    /// RGB-ratio filter, it takes the veil up to the largest share (steps of
    /// 0.02, at most 0.9) that passes at most veilFalsePositives more of the
    /// background samples.
    std::optional<std::array<double, 3>> veil;
    double veilFalsePositives{0.001};
    /// The site's murkiest water (k_R, k_G, k_B per metre of light path,
    /// docs/config.md, the water): when set and the proposal is a
    /// single-range RGB-ratio filter, it takes the water up to the longest
    /// path (steps of a tenth of waterPathM, at most that) that passes at
    /// most waterFalsePositives more of the background samples.
    std::optional<std::array<double, 3>> water;
    double waterPathM{5.0};
    double waterFalsePositives{0.001};
};

/// One candidate's rates on the samples, as the real filter gives them.
struct Rates {
    double truePositive{0};
    double falsePositive{0};
};

struct Proposal {
    TargetType type;     ///< the filter (ranges, bands), brightness range and minimum area
    Rates rates;         ///< on every sample
    Rates bestRatio;     ///< the best single-range RGB-ratio filter
    Rates bestHsv;       ///< the best HSV filter
    std::optional<Rates> bands;  ///< the best banded filter, when bands were tried
    std::string why;     ///< why this method (and bands) were chosen
    std::size_t targetSamples{0}, backgroundSamples{0};
    std::vector<double> targetAreas;     ///< features of the proposed filter over the target samples
    std::vector<double> lookAlikeAreas;  ///< features elsewhere in the image
    std::string areaWhy;
    std::string veilWhy;  ///< the veil's share and why (empty without --veil)
    std::string waterWhy;  ///< the water's path and why (empty without --water)
};

/// The statistics and the proposal. Throws avatar::InvalidArgument when a
/// mask is empty or the two overlap entirely.
Proposal propose(const tools::WorkingImage& image, const cv::Mat& targetMask, const cv::Mat& backgroundMask,
                 const Options& options);

/// The R/G, R/B, B/G and hue scatter plots against brightness M (target red,
/// background blue, the proposed limits as lines): rg.png, rb.png, bg.png, hue.png.
void writePlots(const std::filesystem::path& dir, const tools::WorkingImage& image, const cv::Mat& targetMask,
                const cv::Mat& backgroundMask, const Proposal& proposal);

}  // namespace avatar::filterstats
