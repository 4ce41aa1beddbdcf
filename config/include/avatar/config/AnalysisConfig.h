#pragma once
/// @file AnalysisConfig.h
/// How the analysis pipeline runs (thesis 4.2.3): which stages, in which order,
/// and the choices the thesis left open.

#include <string>
#include <vector>

namespace avatar {

/// Which 2-D point of a feature is triangulated as its position.
enum class CentroidMode {
    Pixel,              ///< mean pixel position (thesis Figure 3-13)
    IntensityWeighted,  ///< brightness-weighted mean: follows the shading of a lit target
    Coverage            ///< the area the sub-pixel outline encloses: each edge where the colour is half-way
};

/// How a matched feature pair without a fitting shape model becomes a 3-D
/// point (thesis 3.4.2). The thesis's nine-point average is gone: on ducks it
/// was twice as far from the truth as the centroids (docs/accuracy.md).
enum class TriangulationMode {
    Centroid  ///< triangulate the centroids
};

enum class DemosaicAlgorithm { Bilinear, EdgeAware };

/// Thresholds of the visibility verdict (thesis 3.6.1). An image is poor when
/// its contrast is below minContrast, or more than maxSaturatedFraction of its
/// pixels are saturated, or its haze (mean of the per-pixel minimum channel,
/// relative to full scale) is above maxHaze.
struct VisibilityConfig {
    double minContrast{0.02};           ///< RMS contrast: std(luma) / full scale
    double maxSaturatedFraction{0.25};  ///< of pixels with any channel at full scale
    double maxHaze{0.6};                ///< dark-channel mean / full scale
    bool operator==(const VisibilityConfig& o) const {
        return minContrast == o.minContrast && maxSaturatedFraction == o.maxSaturatedFraction &&
               maxHaze == o.maxHaze;
    }
};

/// Region-of-interest tracking (the thesis's search windows, made automatic):
/// after a whole-image search, a frame is searched only in regions around the
/// whole stereo targets found before, until a target is lost or flagged
/// partial, or fullFrameEvery frames have passed (docs/config.md "tracking").
struct TrackingConfig {
    bool enabled{false};
    int fullFrameEvery{30};  ///< a whole-image search at least this often (frames)
    int marginPx{48};        ///< how far a region reaches beyond a target's feature box
    bool operator==(const TrackingConfig& o) const {
        return enabled == o.enabled && fullFrameEvery == o.fullFrameEvery && marginPx == o.marginPx;
    }
};

/// Coarse-to-fine search: a whole-image frame is first searched on 2x2
/// superpixels (a quarter of the pixels, no demosaic), then at full
/// resolution only in regions around what that found, each its box widened
/// by marginPx (docs/config.md "coarseToFine").
struct CoarseToFineConfig {
    bool enabled{false};
    int marginPx{16};  ///< how far a full-resolution region reaches beyond a coarse feature's box
    bool operator==(const CoarseToFineConfig& o) const { return enabled == o.enabled && marginPx == o.marginPx; }
};

struct AnalysisConfig {
    /// Stage names in order; see docs/config.md for the list and their rules.
    std::vector<std::string> stages{"demosaic",        "lighting", "color_filter", "erode_restore",
                                    "locate_features", "match",    "triangulate",  "visibility"};
    DemosaicAlgorithm demosaic{DemosaicAlgorithm::Bilinear};
    CentroidMode centroid{CentroidMode::Coverage};
    TriangulationMode triangulation{TriangulationMode::Centroid};
    VisibilityConfig visibility;
    TrackingConfig tracking;
    CoarseToFineConfig coarseToFine;
    /// Threads per pair: 1 runs both images on the calling thread (the least
    /// CPU per pair), 2 runs the right image's share of each stage on a
    /// second thread (lower latency, about 10 % more CPU: docs/benchmarks.md).
    int threads{1};

    bool operator==(const AnalysisConfig& o) const {
        return stages == o.stages && demosaic == o.demosaic && centroid == o.centroid &&
               triangulation == o.triangulation && visibility == o.visibility && tracking == o.tracking &&
               coarseToFine == o.coarseToFine && threads == o.threads;
    }
};

}  // namespace avatar
