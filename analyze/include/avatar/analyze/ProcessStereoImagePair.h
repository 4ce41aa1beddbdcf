#pragma once
/// @file ProcessStereoImagePair.h
/// The stage interface of the analysis pipeline (thesis 4.2.3, Figure 4-5)
/// and the frame the stages work on.
///
/// The thesis's stages take a SIP and give a SIP. Ours take an AnalysisFrame,
/// which holds the pair being transformed plus what the later stages need
/// (one mask and one feature list per target type and image, the matches, the
/// result), so that a stage that produces features or targets fits the same
/// interface as one that produces pixels.

#include <avatar/analyze/Feature.h>
#include <avatar/analyze/SIPFeatureMatcher.h>
#include <avatar/analyze/Visibility.h>
#include <avatar/common/StereoImagePair.h>
#include <avatar/common/VisionTargets.h>
#include <avatar/config/AvatarConfig.h>

#include <opencv2/core/mat.hpp>

#include <array>
#include <functional>
#include <map>
#include <memory>
#include <string>
#include <string_view>
#include <vector>

namespace avatar {

/// Work products of one image of the pair.
struct ImageWork {
    cv::Mat image;                                  ///< the working image (BGR after demosaic)
    std::vector<cv::Mat> masks;                     ///< per target type, CV_8UC1 0/255
    std::vector<std::vector<Feature>> features;     ///< per target type
    VisibilityMeasures visibility;                  ///< set by the visibility stage
};

/// Everything the stages of one iteration read and write.
struct AnalysisFrame {
    StereoImagePair original;                       ///< as acquired, never modified
    PairLayout layout;                              ///< of the working images
    std::array<ImageWork, 2> images;                ///< indexed by Side
    std::vector<std::vector<FeatureMatch>> matches; ///< per target type
    VisionTargets result;
    /// A tracking frame's search regions per side (indexed by Side): disjoint
    /// rectangles inside the image, apart by at least one pixel, around the
    /// targets of the frames before (AnalyzeStereoImagePair, docs/config.md
    /// "tracking"). Only their pixels are searched: the stages compute the
    /// images and masks there only (0 elsewhere), and features are located in
    /// each region as in a search window. Empty: the whole image.
    std::array<std::vector<cv::Rect>, 2> regions;
    /// A whole-image frame searched coarse-to-fine (docs/config.md
    /// "coarseToFine"): the demosaic stage searches each image on 2x2
    /// superpixels first and sets that side's regions to what it found, so
    /// the stages after it work at full resolution only there.
    bool coarse{false};
    /// Whether a whole-image frame's working images must be computed whole
    /// (AnalyzeStereoImagePair::setKeepWholeImages()). When false, the fused
    /// front end may compute them only around the features found and leave
    /// the rest 0, as a tracking frame does (the masks, features and results
    /// are the same): writing a whole 16-bit BGR image costs about a sixth of
    /// the front end (docs/benchmarks.md).
    bool wholeImagesWanted{true};
    /// Set when the working images hold only the pixels around the features
    /// (their boxes and kImageMarginPx more) and 0 elsewhere;
    /// AnalyzeStereoImagePair::workingImages() computes them whole from the
    /// original with what follows.
    bool imagesAroundFeatures{false};
    /// The lighting factor of every mosaic site the front end used (empty: no
    /// correction; two rows, even and odd, without a strobe pattern:
    /// LightingCorrector::mosaicFactors()) and whether it swapped the samples' bytes: what
    /// AnalyzeStereoImagePair::workingImages() needs to compute the images again.
    cv::Mat mosaicLightingFactors;
    bool samplesByteSwapped{false};
    /// The margin around each feature's box within which its working image is
    /// computed when imagesAroundFeatures (the silhouettes read 6 px beyond a feature's box).
    static constexpr int kImageMarginPx = 8;

    ImageWork& at(Side side) { return images[side == Side::Left ? 0 : 1]; }
    const ImageWork& at(Side side) const { return images[side == Side::Left ? 0 : 1]; }
    const std::vector<cv::Rect>& regionsOf(Side side) const { return regions[side == Side::Left ? 0 : 1]; }
    /// Set by the orchestrator when the sides' processImage() calls run one
    /// after the other on one thread, the left first
    /// (AnalyzeStereoImagePair::setParallel(false)): a stage may then do the
    /// right image's work in the left's call as well (the fused front end
    /// shares each row of lighting factors between the two), writing the
    /// right's ImageWork only in the right's call.
    bool sidesInTurn{false};
    /// Whether this is a tracking frame (some side has search regions).
    bool tracking() const { return !regions[0].empty() || !regions[1].empty(); }
};

/// One stage. For each frame the orchestrator calls prepare() once, then
/// processImage() for the left and the right image concurrently (two threads,
/// only when hasImageWork()), then processPair() once. processImage() may only
/// touch the ImageWork of its side and must not change shared state.
class ProcessStereoImagePair {
public:
    virtual ~ProcessStereoImagePair() = default;
    /// The name the configuration uses for this stage.
    virtual std::string_view name() const = 0;
    /// The stages that must come before this one in the chain, because it
    /// reads what they produce (e.g. match needs locate_features). The
    /// orchestrator refuses a chain that breaks this.
    virtual std::vector<std::string_view> needs() const { return {}; }
    virtual bool hasImageWork() const { return false; }
    /// True when the orchestrator may batch this stage with its neighbours
    /// that say the same: their prepare() all first, then each image's work
    /// of all of them in a row on one thread, then their processPair(). A
    /// stage may say so when its prepare() reads only the acquired pair and
    /// its layout, and its processPair() writes nothing that another stage's
    /// processImage() reads. The default, false, keeps the stage on its own.
    virtual bool independentSides() const { return false; }
    virtual void prepare(AnalysisFrame& /*frame*/) {}
    virtual void processImage(AnalysisFrame& /*frame*/, Side /*side*/) {}
    virtual void processPair(AnalysisFrame& /*frame*/) {}
};

/// What a stage factory gets: the whole configuration (stages keep what they
/// need) and the directory relative paths in it are resolved against.
struct StageContext {
    const AvatarConfig& config;
    std::string configDir;
};

using StageFactory = std::function<std::unique_ptr<ProcessStereoImagePair>(const StageContext&)>;

/// Stage names to factories. Registration is explicit (no self-registering
/// statics, which a static library can lose at link time).
class StageRegistry {
public:
    /// A registry holding the built-in stages: demosaic, lighting,
    /// color_filter, erode_restore, locate_features, match, triangulate, visibility.
    static StageRegistry builtin();

    /// Adds or replaces a stage.
    void add(std::string name, StageFactory factory);
    bool contains(const std::string& name) const { return factories_.count(name) != 0; }
    /// Throws avatar::InvalidArgument naming an unknown stage and the known ones.
    std::unique_ptr<ProcessStereoImagePair> create(const std::string& name, const StageContext& context) const;
    std::vector<std::string> names() const;

private:
    std::map<std::string, StageFactory> factories_;
};

}  // namespace avatar
