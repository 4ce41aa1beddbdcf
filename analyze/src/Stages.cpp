// The built-in stages of the analysis pipeline, one class each, and the
// registry that names them. Thesis 3.2-3.4, 3.6.

#include "TargetAssembly.h"

#include <avatar/analyze/ImageColorFilter.h>
#include <avatar/analyze/ImageFeatureLocator.h>
#include <avatar/analyze/LightingCorrection.h>
#include <avatar/analyze/ProcessStereoImagePair.h>
#include <avatar/analyze/SIPFeatureMatcher.h>
#include <avatar/analyze/Visibility.h>
#include <avatar/common/Error.h>
#include <avatar/common/ImageUtils.h>

#include <opencv2/core.hpp>
#include <opencv2/imgproc.hpp>

namespace avatar {
namespace {

// In-place stages must not write into the acquired pair (it may be a view of
// camera memory, and clients ask for the original images).
cv::Mat& writableImage(AnalysisFrame& frame, Side side) {
    cv::Mat& image = frame.at(side).image;
    if (image.data == frame.original.image(side).data) image = image.clone();
    return image;
}

/// What a stage reads must be there for every target type; a stage declared
/// in needs() that ran but produced nothing (a replaced stage that does not
/// keep the frame's contract) would otherwise be read out of bounds.
void requirePerType(std::size_t have, std::size_t types, std::string_view stage, const char* what) {
    if (have != types)
        throw InvalidState(std::string(stage) + ": the frame holds " + std::to_string(have) + " " + what +
                           " for " + std::to_string(types) + " target types");
}

void requireBgr(const AnalysisFrame& frame, Side side, std::string_view stage) {
    if (frame.at(side).image.channels() != 3)
        throw InvalidArgument(std::string(stage) + ": needs a 3-channel image but the " +
                              (side == Side::Left ? "left" : "right") + " image has " +
                              std::to_string(frame.at(side).image.channels()) +
                              " (put demosaic before it for raw input)");
}

/// Endian swap and demosaic when the input is raw (thesis 2.2).
class DemosaicStage final : public ProcessStereoImagePair {
public:
    explicit DemosaicStage(const StageContext& c)
        : swap_(c.config.camera.endianSwap),
          method_(c.config.analysis.demosaic == DemosaicAlgorithm::EdgeAware ? DemosaicMethod::EdgeAware
                                                                             : DemosaicMethod::Bilinear) {}
    std::string_view name() const override { return "demosaic"; }
    bool hasImageWork() const override { return true; }
    void processImage(AnalysisFrame& frame, Side side) override {
        cv::Mat image = frame.original.image(side);
        if (swap_ && image.depth() == CV_16U) {
            image = image.clone();
            swapEndian16(image);
        }
        switch (frame.layout.format) {
            case PixelFormat::Bayer:
                frame.at(side).image = demosaic(image, frame.layout.bayerPattern, method_);
                break;
            case PixelFormat::Mono:
                cv::cvtColor(image, frame.at(side).image, cv::COLOR_GRAY2BGR);
                break;
            case PixelFormat::Bgr:
                frame.at(side).image = image;
                break;
        }
    }
    void processPair(AnalysisFrame& frame) override { frame.layout.format = PixelFormat::Bgr; }

private:
    bool swap_;
    DemosaicMethod method_;
};

/// Frame-average gains and strobe-falloff template (thesis 3.2).
class LightingStage final : public ProcessStereoImagePair {
public:
    explicit LightingStage(const StageContext& c) : corrector_(c.config.lighting, c.configDir) {}
    std::string_view name() const override { return "lighting"; }
    bool hasImageWork() const override { return corrector_.enabled(); }
    void prepare(AnalysisFrame& frame) override {
        if (corrector_.enabled()) corrector_.prepare(frame.original.size());
    }
    void processImage(AnalysisFrame& frame, Side side) override {
        requireBgr(frame, side, name());
        corrector_.apply(writableImage(frame, side), frame.layout.bitDepth);
    }

private:
    LightingCorrector corrector_;
};

/// RGB-ratio or HSV filter, all target types in one pass (thesis 3.3.2).
class ColorFilterStage final : public ProcessStereoImagePair {
public:
    explicit ColorFilterStage(const StageContext& c) : types_(c.config.targets.targets) {}
    std::string_view name() const override { return "color_filter"; }
    bool hasImageWork() const override { return true; }
    void processImage(AnalysisFrame& frame, Side side) override {
        requireBgr(frame, side, name());
        colorFilterMasks(frame.at(side).image, frame.layout.bitDepth, types_, frame.at(side).masks);
    }

private:
    std::vector<TargetType> types_;
};

/// Erode, then feature-AND restore, for the types that ask for it (thesis 3.3.2).
class ErodeRestoreStage final : public ProcessStereoImagePair {
public:
    explicit ErodeRestoreStage(const StageContext& c) : types_(c.config.targets.targets) {}
    std::string_view name() const override { return "erode_restore"; }
    std::vector<std::string_view> needs() const override { return {"color_filter"}; }
    bool hasImageWork() const override { return true; }
    void processImage(AnalysisFrame& frame, Side side) override {
        auto& masks = frame.at(side).masks;
        for (std::size_t t = 0; t < types_.size() && t < masks.size(); ++t)
            if (types_[t].erodeRestore) masks[t] = erodeRestore(masks[t], types_[t].erodeKernelSize);
    }

private:
    std::vector<TargetType> types_;
};

/// 8-connected features with the geometric filter (thesis 3.3.3).
class LocateFeaturesStage final : public ProcessStereoImagePair {
public:
    explicit LocateFeaturesStage(const StageContext& c)
        : types_(c.config.targets.targets),
          weighted_(c.config.analysis.centroid == CentroidMode::IntensityWeighted) {}
    std::string_view name() const override { return "locate_features"; }
    std::vector<std::string_view> needs() const override { return {"color_filter"}; }
    bool hasImageWork() const override { return true; }
    void processImage(AnalysisFrame& frame, Side side) override {
        ImageWork& work = frame.at(side);
        requirePerType(work.masks.size(), types_.size(), name(), "masks");
        work.features.assign(types_.size(), {});
        const cv::Mat intensity = weighted_ && work.image.channels() == 3 ? work.image : cv::Mat();
        for (std::size_t t = 0; t < types_.size(); ++t)
            work.features[t] = locateFeatures(work.masks[t], intensity, types_[t],
                                              searchWindow(types_[t], work.masks[t].size()));
    }

private:
    std::vector<TargetType> types_;
    bool weighted_;
};

/// Stereo matching per target type (thesis 3.4.1).
class MatchStage final : public ProcessStereoImagePair {
public:
    explicit MatchStage(const StageContext& c)
        : matcher_(c.config.match, c.config.stereo), types_(c.config.targets.targets.size()) {}
    std::string_view name() const override { return "match"; }
    std::vector<std::string_view> needs() const override { return {"locate_features"}; }
    void processPair(AnalysisFrame& frame) override {
        const auto& left = frame.at(Side::Left).features;
        const auto& right = frame.at(Side::Right).features;
        requirePerType(std::min(left.size(), right.size()), types_, name(), "feature lists");
        frame.matches.assign(types_, {});
        for (std::size_t t = 0; t < types_; ++t) frame.matches[t] = matcher_.match(left[t], right[t]);
    }

private:
    SIPFeatureMatcher matcher_;
    std::size_t types_;
};

/// Triangulation of every match with its completeness judged, single-image
/// features reported as such (thesis 3.4.2, 3.6.2; TargetAssembly.h).
class TriangulateStage final : public ProcessStereoImagePair {
public:
    explicit TriangulateStage(const StageContext& c)
        : assembler_(c.config), types_(c.config.targets.targets.size()) {}
    std::string_view name() const override { return "triangulate"; }
    std::vector<std::string_view> needs() const override { return {"match"}; }
    void processPair(AnalysisFrame& frame) override {
        requirePerType(frame.matches.size(), types_, name(), "match lists");
        for (const Side side : {Side::Left, Side::Right}) {
            requirePerType(frame.at(side).masks.size(), types_, name(), "masks");
            requirePerType(frame.at(side).features.size(), types_, name(), "feature lists");
        }
        assembler_.assemble(frame);
    }

private:
    detail::TargetAssembler assembler_;
    std::size_t types_;
};

/// Visibility measures and verdict (thesis 3.6.1).
class VisibilityStage final : public ProcessStereoImagePair {
public:
    explicit VisibilityStage(const StageContext& c) : limits_(c.config.analysis.visibility) {}
    std::string_view name() const override { return "visibility"; }
    bool hasImageWork() const override { return true; }
    void processImage(AnalysisFrame& frame, Side side) override {
        requireBgr(frame, side, name());
        frame.at(side).visibility = measureVisibility(frame.at(side).image, frame.layout.bitDepth);
    }
    void processPair(AnalysisFrame& frame) override {
        const VisibilityVerdict verdict =
            judgeVisibility(frame.at(Side::Left).visibility, frame.at(Side::Right).visibility, limits_);
        frame.result.visibility = verdict.visibility;
        frame.result.visibilityReason = verdict.reason;
        if (verdict.visibility == Visibility::Poor)
            for (VisionTarget& t : frame.result.targets) t.flags |= kTargetPoorVisibility;
    }

private:
    VisibilityConfig limits_;
};

template <typename Stage>
StageFactory factory() {
    return [](const StageContext& c) { return std::make_unique<Stage>(c); };
}

}  // namespace

StageRegistry StageRegistry::builtin() {
    StageRegistry r;
    r.add("demosaic", factory<DemosaicStage>());
    r.add("lighting", factory<LightingStage>());
    r.add("color_filter", factory<ColorFilterStage>());
    r.add("erode_restore", factory<ErodeRestoreStage>());
    r.add("locate_features", factory<LocateFeaturesStage>());
    r.add("match", factory<MatchStage>());
    r.add("triangulate", factory<TriangulateStage>());
    r.add("visibility", factory<VisibilityStage>());
    return r;
}

void StageRegistry::add(std::string name, StageFactory factory) { factories_[std::move(name)] = std::move(factory); }

std::unique_ptr<ProcessStereoImagePair> StageRegistry::create(const std::string& name,
                                                              const StageContext& context) const {
    const auto it = factories_.find(name);
    if (it == factories_.end()) {
        std::string known;
        for (const auto& n : names()) known += (known.empty() ? "" : ", ") + n;
        throw InvalidArgument("unknown analysis stage '" + name + "' (known: " + known + ")");
    }
    return it->second(context);
}

std::vector<std::string> StageRegistry::names() const {
    std::vector<std::string> out;
    for (const auto& kv : factories_) out.push_back(kv.first);
    return out;
}

}  // namespace avatar
