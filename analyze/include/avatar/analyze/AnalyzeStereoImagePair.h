#pragma once
/// @file AnalyzeStereoImagePair.h
/// The analysis orchestrator (thesis 4.2.3): builds the stage chain from the
/// configuration, runs it on each stereo pair with the left and right images
/// processed in parallel, times every stage, keeps the images clients may ask
/// for, and produces VisionTargets.

#include <avatar/analyze/ProcessStereoImagePair.h>
#include <avatar/common/StereoImagePair.h>
#include <avatar/common/VisionTargets.h>
#include <avatar/config/AvatarConfig.h>

#include <cstdint>
#include <filesystem>
#include <memory>
#include <string>
#include <vector>

namespace avatar {

namespace detail {
class RegionTracker;
}

class AnalyzeStereoImagePair {
public:
    /// Validates @p config (ConfigError naming the element, as validateConfig())
    /// and builds the chain named by config.analysis.stages from @p registry.
    /// Throws avatar::InvalidArgument for an unknown stage or an order that
    /// breaks a stage's needs() (e.g. match before locate_features), naming it;
    /// the stages' own errors (a lighting template that cannot be read) as they are.
    explicit AnalyzeStereoImagePair(const AvatarConfig& config,
                                    const std::filesystem::path& configDir = {},
                                    const StageRegistry& registry = StageRegistry::builtin());
    ~AnalyzeStereoImagePair();
    AnalyzeStereoImagePair(const AnalyzeStereoImagePair&) = delete;
    AnalyzeStereoImagePair& operator=(const AnalyzeStereoImagePair&) = delete;

    /// Analyses one pair. Results are identical whether the two images are
    /// processed in parallel or not. With config.analysis.tracking enabled, a
    /// pair may be searched only in regions around the targets of the pairs
    /// before (lastFrame().regions; docs/config.md "tracking"); there the
    /// result is what a search of the whole image gives. Throws
    /// avatar::InvalidArgument when the pair does not fit the configured
    /// camera (size, channels).
    VisionTargets analyze(const StereoImagePair& pair, std::uint64_t iteration);

    /// Overrides config.analysis.threads: true runs the right image's share
    /// of each stage on a second thread (started when first needed), false
    /// runs both images on the calling thread. The results are the same.
    void setParallel(bool parallel) { parallel_ = parallel; }

    /// Whether every whole-image frame's working images are computed whole
    /// (default false: the fused front end computes them around the features
    /// only, the rest 0, when no stage after it needs more; workingImages(),
    /// filteredImages() and markedImages() compute them whole when asked).
    /// Tools that read lastFrame()'s images directly set it.
    void setKeepWholeImages(bool keep) { keepWholeImages_ = keep; }

    /// The last frame analysed (images, masks, features, matches, result). Its
    /// working images may hold only the pixels around the features
    /// (AnalysisFrame::imagesAroundFeatures; workingImages() gives them whole).
    /// Every analyze() builds a new frame with new image buffers, so a copy of
    /// this frame (cv::Mat copies share pixels) stays valid and unchanged after
    /// later analyses: another thread may keep one.
    const AnalysisFrame& lastFrame() const { return frame_; }
    /// The pair as acquired.
    const StereoImagePair& originalImages() const { return frame_.original; }
    /// The working images with everything outside the union of the target masks set to 0.
    StereoImagePair filteredImages() const { return filteredImages(frame_); }
    /// The working images with features, boundary points, centroids and matches drawn.
    StereoImagePair markedImages() const { return markedImages(frame_); }

    /// The same for any analysed frame (e.g. a copy kept by another thread).
    static StereoImagePair filteredImages(const AnalysisFrame& frame);
    static StereoImagePair markedImages(const AnalysisFrame& frame);

    /// The frame's working images (BGR after demosaic), whole: computed again
    /// from the original when the frame kept them only around its features
    /// (AnalysisFrame::imagesAroundFeatures), else the frame's own.
    static StereoImagePair workingImages(const AnalysisFrame& frame);

    const std::vector<std::string>& stageNames() const { return names_; }

    /// The CPU time of each stage in the last analyze() (both threads'), in
    /// the order of VisionTargets::timings and with its "total": what the
    /// wall times of those timings cost the machine.
    const std::vector<StageTiming>& lastCpuTimings() const { return cpuTimings_; }

private:
    class Worker;
    AvatarConfig config_;
    std::vector<std::unique_ptr<ProcessStereoImagePair>> stages_;
    std::vector<std::string> names_;
    std::unique_ptr<Worker> worker_;
    std::unique_ptr<detail::RegionTracker> tracker_;
    bool keepWholeImages_{false};
    AnalysisFrame frame_;
    std::vector<StageTiming> cpuTimings_;
    bool parallel_{false};  ///< config.analysis.threads == 2, or setParallel()
};

}  // namespace avatar
