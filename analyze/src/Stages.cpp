// The built-in stages of the analysis pipeline, one class each, and the
// registry that names them. Thesis 3.2-3.4, 3.6.

#include <avatar/analyze/CameraModel.h>
#include <avatar/analyze/ImageColorFilter.h>
#include <avatar/analyze/ImageFeatureLocator.h>
#include <avatar/analyze/LightingCorrection.h>
#include <avatar/analyze/ProcessStereoImagePair.h>
#include <avatar/analyze/SIPFeatureMatcher.h>
#include <avatar/analyze/SphereSilhouette.h>
#include <avatar/analyze/StereoCoordinateCalculator.h>
#include <avatar/common/Error.h>
#include <avatar/common/ImageUtils.h>

#include "ImageReduce.h"

#include <opencv2/core.hpp>
#include <opencv2/imgproc.hpp>

#include <cstdio>

namespace avatar {
namespace {

double fullScale(const PairLayout& layout) { return static_cast<double>((1 << layout.bitDepth) - 1); }

// In-place stages must not write into the acquired pair (it may be a view of
// camera memory, and clients ask for the original images).
cv::Mat& writableImage(AnalysisFrame& frame, Side side) {
    cv::Mat& image = frame.at(side).image;
    if (image.data == frame.original.image(side).data) image = image.clone();
    return image;
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
    bool hasImageWork() const override { return true; }
    void processImage(AnalysisFrame& frame, Side side) override {
        ImageWork& work = frame.at(side);
        work.features.assign(types_.size(), {});
        if (work.masks.size() != types_.size())
            throw InvalidArgument("locate_features: no masks to search; put color_filter before it");
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
    void processPair(AnalysisFrame& frame) override {
        const auto& left = frame.at(Side::Left).features;
        const auto& right = frame.at(Side::Right).features;
        if (left.size() != types_ || right.size() != types_)
            throw InvalidArgument("match: no features to match; put locate_features before it");
        frame.matches.assign(types_, {});
        for (std::size_t t = 0; t < types_; ++t) frame.matches[t] = matcher_.match(left[t], right[t]);
    }

private:
    SIPFeatureMatcher matcher_;
    std::size_t types_;
};

/// Triangulation of every match, single-image features reported as such (thesis 3.4.2, 3.6.2).
class TriangulateStage final : public ProcessStereoImagePair {
public:
    explicit TriangulateStage(const StageContext& c)
        : calculator_(c.config.stereo),
          types_(c.config.targets.targets),
          weighted_(c.config.analysis.centroid == CentroidMode::IntensityWeighted),
          ninePoints_(c.config.analysis.triangulation == TriangulationMode::NinePoints) {}
    std::string_view name() const override { return "triangulate"; }

    void processPair(AnalysisFrame& frame) override {
        const ImageWork& L = frame.at(Side::Left);
        const ImageWork& R = frame.at(Side::Right);
        if (frame.matches.size() != types_.size())
            throw InvalidArgument("triangulate: no matches; put match before it");
        for (std::size_t t = 0; t < types_.size(); ++t) {
            std::vector<bool> usedLeft(L.features[t].size()), usedRight(R.features[t].size());
            for (const FeatureMatch& m : frame.matches[t]) {
                const Feature& fl = L.features[t][static_cast<std::size_t>(m.left)];
                const Feature& fr = R.features[t][static_cast<std::size_t>(m.right)];
                usedLeft[static_cast<std::size_t>(m.left)] = true;
                usedRight[static_cast<std::size_t>(m.right)] = true;
                frame.result.targets.push_back(stereoTarget(types_[t], fl, fr, L.masks[t], R.masks[t], m));
            }
            for (std::size_t i = 0; i < usedLeft.size(); ++i)
                if (!usedLeft[i]) frame.result.targets.push_back(singleTarget(types_[t], L.features[t][i], Side::Left));
            for (std::size_t i = 0; i < usedRight.size(); ++i)
                if (!usedRight[i]) frame.result.targets.push_back(singleTarget(types_[t], R.features[t][i], Side::Right));
        }
    }

private:
    cv::Point2d point(const Feature& f) const { return weighted_ ? f.weightedCentroid : f.centroid; }

    VisionTarget stereoTarget(const TargetType& type, const Feature& fl, const Feature& fr,
                              const cv::Mat& maskL, const cv::Mat& maskR, const FeatureMatch& m) const {
        VisionTarget target;
        target.type = type.name;
        target.flags = kTargetStereo;
        if (fl.touchesBorder || fr.touchesBorder) target.flags |= kTargetAtBorder;
        target.centroidLeftPx = point(fl);
        target.centroidRightPx = point(fr);
        target.areaLeftPx = fl.area;
        target.areaRightPx = fr.area;
        target.matchError = m.shapeError;

        std::optional<StereoPoint> p;
        if (type.shape == TargetShape::Sphere && !(target.flags & kTargetAtBorder)) {
            const auto& stereo = calculator_.config();
            const auto dl = sphereCentreDirection(stereo.left, featureOutline(maskL, fl));
            const auto dr = sphereCentreDirection(stereo.right, featureOutline(maskR, fr));
            if (dl && dr) {
                p = calculator_.triangulateNormalized(*dl, *dr);
                if (p) target.flags |= kTargetShapeCorrected;
            }
        }
        if (!p && ninePoints_) {
            const auto pl = fl.interestPoints(), pr = fr.interestPoints();
            cv::Point3d sumL(0, 0, 0);
            std::optional<cv::Point3d> sumBase;
            int n = 0;
            for (std::size_t i = 0; i < pl.size(); ++i) {
                // Point 8 is the centroid: use the configured kind.
                const auto q = calculator_.triangulate(i == 8 ? point(fl) : pl[i], i == 8 ? point(fr) : pr[i]);
                if (!q) continue;
                sumL += q->leftMm;
                if (q->baseMm) sumBase = sumBase.value_or(cv::Point3d(0, 0, 0)) + *q->baseMm;
                ++n;
            }
            if (n > 0) {
                StereoPoint avg;
                avg.leftMm = sumL * (1.0 / n);
                if (sumBase) avg.baseMm = *sumBase * (1.0 / n);
                p = avg;
            }
        }
        if (!p) p = calculator_.triangulate(point(fl), point(fr));
        if (p) {
            target.positionVisionMm = p->leftMm;
            target.positionBaseMm = p->baseMm;
        } else {
            target.flags &= ~static_cast<std::uint32_t>(kTargetStereo);  // parallel rays: no position
        }
        return target;
    }

    VisionTarget singleTarget(const TargetType& type, const Feature& f, Side side) const {
        VisionTarget target;
        target.type = type.name;
        target.flags = side == Side::Left ? kTargetLeftOnly : kTargetRightOnly;
        if (f.touchesBorder) target.flags |= kTargetAtBorder;
        if (side == Side::Left) {
            target.centroidLeftPx = point(f);
            target.areaLeftPx = f.area;
        } else {
            target.centroidRightPx = point(f);
            target.areaRightPx = f.area;
        }
        return target;
    }

    StereoCoordinateCalculator calculator_;
    std::vector<TargetType> types_;
    bool weighted_;
    bool ninePoints_;
};

/// Visibility measures and verdict (thesis 3.6.1). Measured on a 4x
/// downsampled image: the measures are global, so this costs little accuracy.
class VisibilityStage final : public ProcessStereoImagePair {
public:
    explicit VisibilityStage(const StageContext& c) : limits_(c.config.analysis.visibility) {}
    std::string_view name() const override { return "visibility"; }
    bool hasImageWork() const override { return true; }
    void processImage(AnalysisFrame& frame, Side side) override {
        requireBgr(frame, side, name());
        ImageWork& work = frame.at(side);
        const double full = fullScale(frame.layout);
        cv::Mat small, channels[3], luma, minChannel, maxChannel;
        detail::downsampleArea4(work.image, small);  // = cv::resize INTER_AREA, bit for bit, serial
        small.convertTo(small, CV_32F, 1.0 / full);
        cv::split(small, channels);
        luma = 0.114f * channels[0] + 0.587f * channels[1] + 0.299f * channels[2];
        cv::Scalar mean, stddev;
        cv::meanStdDev(luma, mean, stddev);
        work.contrast = stddev[0];
        minChannel = cv::min(cv::min(channels[0], channels[1]), channels[2]);
        work.haze = cv::mean(minChannel)[0];
        // Saturation is judged on the full image: downsampling averages it away.
        work.saturatedFraction = static_cast<double>(detail::countSamplesAtLeast(work.image, full)) /
                                 static_cast<double>(work.image.total());
    }
    void processPair(AnalysisFrame& frame) override {
        std::string reason;
        for (Side side : {Side::Left, Side::Right}) {
            const ImageWork& w = frame.at(side);
            const char* name = side == Side::Left ? "left" : "right";
            char buf[128];
            if (w.contrast < limits_.minContrast) {
                std::snprintf(buf, sizeof buf, "%s: contrast %.4f below %.4f", name, w.contrast, limits_.minContrast);
                reason += (reason.empty() ? "" : "; ") + std::string(buf);
            }
            if (w.saturatedFraction > limits_.maxSaturatedFraction) {
                std::snprintf(buf, sizeof buf, "%s: %.1f%% saturated, above %.1f%%", name,
                              100.0 * w.saturatedFraction, 100.0 * limits_.maxSaturatedFraction);
                reason += (reason.empty() ? "" : "; ") + std::string(buf);
            }
            if (w.haze > limits_.maxHaze) {
                std::snprintf(buf, sizeof buf, "%s: haze %.3f above %.3f", name, w.haze, limits_.maxHaze);
                reason += (reason.empty() ? "" : "; ") + std::string(buf);
            }
        }
        frame.result.visibility = reason.empty() ? Visibility::Good : Visibility::Poor;
        frame.result.visibilityReason = reason;
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
