// The built-in stages of the analysis pipeline, one class each, and the
// registry that names them. Thesis 3.2-3.4, 3.6.

#include "BufferPool.h"
#include "FrontEnd.h"
#include "MaskRows.h"
#include "RegionTracker.h"
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

#include <algorithm>
#include <iterator>
#include <optional>

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

class LightingStage;
class ColorFilterStage;
class VisibilityStage;

/// Endian swap and demosaic when the input is raw (thesis 2.2). When the
/// chain lets it (fuseFrontEnd()), it is also the fused front end: the
/// lighting, color_filter and visibility stages that follow hand their
/// per-pixel work to it, and a raw mosaic goes through all of them in one pass
/// (FrontEnd.h): the lighting correction applied to the mosaic's sites before
/// the demosaic, the rest bit for bit as one stage after the other. Its time
/// is then theirs too; theirs is what is left (a verdict, a preparation).
class DemosaicStage final : public ProcessStereoImagePair {
public:
    bool independentSides() const override { return true; }
    explicit DemosaicStage(const StageContext& c)
        : swap_(c.config.camera.endianSwap),
          coarse_(c.config.analysis.coarseToFine.enabled),
          coarseMargin_(c.config.analysis.coarseToFine.marginPx),
          method_(c.config.analysis.demosaic == DemosaicAlgorithm::EdgeAware ? DemosaicMethod::EdgeAware
                                                                             : DemosaicMethod::Bilinear) {}
    std::string_view name() const override { return "demosaic"; }
    bool hasImageWork() const override { return true; }
    void prepare(AnalysisFrame& frame) override;
    void processImage(AnalysisFrame& frame, Side side) override;
    void processPair(AnalysisFrame& frame) override { frame.layout.format = PixelFormat::Bgr; }

    /// Only the bilinear demosaic is fused (the edge-aware one is OpenCV's own).
    bool canFuse() const { return method_ == DemosaicMethod::Bilinear; }
    /// No stage after this one reads a whole-image frame's working image
    /// except around the features: the fused pass may leave the image out
    /// (unless the frame wants it whole), and featuresFound() fills it in.
    void allowImagesAroundFeatures() { imagesAroundFeatures_ = true; }
    /// Once @p side's features are found: the share of the image around them
    /// (their boxes and AnalysisFrame::kImageMarginPx) noted for the next
    /// frame's choice, and when the pass left the image out
    /// (AnalysisFrame::imagesAroundFeatures), the image there computed, 0 elsewhere.
    void featuresFound(AnalysisFrame& frame, Side side);
    /// Where the on pixels of the mask of type @p t that this frame's pass
    /// wrote for @p side lie, when @p mask is that mask; else null.
    const detail::MaskRows* maskRows(Side side, std::size_t t, const cv::Mat& mask) const {
        const auto& rows = maskRows_[side == Side::Left ? 0 : 1];
        return t < rows.size() && rows[t].describes(mask) ? &rows[t] : nullptr;
    }
    /// Whether @p mask is the mask of type @p t that this frame's pass wrote
    /// for @p side (a buffer of its own that no one else has seen).
    bool wroteMask(Side side, std::size_t t, const cv::Mat& mask) const {
        const auto& written = written_[side == Side::Left ? 0 : 1];
        return t < written.size() && mask.data != nullptr && written[t] == mask.data;
    }
    void fuse(LightingStage* lighting, ColorFilterStage* filter, VisibilityStage* visibility) {
        lighting_ = lighting;
        filter_ = filter;
        visibility_ = visibility;
    }

private:
    /// The stage's own work: demosaic alone.
    void demosaicOnly(AnalysisFrame& frame, Side side) const;
    bool fusedFor(const AnalysisFrame& frame) const {
        return canFuse() && frame.layout.format == PixelFormat::Bayer && detail::frontEndHandles(frame.original.image(Side::Left));
    }

    /// The coarse pass of a coarse frame: @p side's regions from what it finds
    /// (none found: the whole image), and the visibility from its superpixels.
    void searchCoarse(AnalysisFrame& frame, Side side, const detail::FrontEndInput& in);
    /// The fused pass's input for @p side, and its output buffers in @p out.
    detail::FrontEndInput fusedInput(AnalysisFrame& frame, Side side, detail::FrontEndResult& out);
    /// The pass's results into @p side's ImageWork.
    void storeFused(AnalysisFrame& frame, Side side, detail::FrontEndResult& out);

    bool swap_;
    bool imagesAroundFeatures_{false};
    bool coarse_;  ///< whole-image frames coarse-to-fine: the half-size tests are built
    int coarseMargin_;
    DemosaicMethod method_;
    LightingStage* lighting_{nullptr};
    ColorFilterStage* filter_{nullptr};
    VisibilityStage* visibility_{nullptr};
    // Built in prepare() for the frame's geometry, read by both sides.
    std::vector<detail::ColorTest> tests_;
    std::vector<detail::ColorTest> coarseTests_;  ///< the same at half the size (windows halved)
    std::vector<TargetType> coarseTypes_;         ///< the types with what a coarse feature needs
    cv::Size testsSize_;
    int testsDepth_{-1}, testsBits_{-1};
    // Per side: buffers reused across frames.
    std::array<detail::BufferPool, 2> images_;
    std::array<detail::BufferPool, 2> masks_{detail::BufferPool(16), detail::BufferPool(16)};
    /// The right image's pass, run with the left's when the sides take turns
    /// on one thread (AnalysisFrame::sidesInTurn), until its processImage().
    std::optional<detail::FrontEndResult> pendingRight_;
    std::array<detail::CoarseResult, 2> coarsePass_;
    /// The share of each side's image that its last frame's image around the
    /// features covered (featuresFound()).
    std::array<double, 2> aroundShare_{0.0, 0.0};
    std::array<std::vector<detail::MaskRows>, 2> maskRows_;  ///< of the last pass, per side and type
    std::array<std::vector<const std::uint8_t*>, 2> written_;  ///< the masks of the last pass, likewise
};

/// Frame-average gains and strobe-falloff template (thesis 3.2).
class LightingStage final : public ProcessStereoImagePair {
public:
    bool independentSides() const override { return true; }
    explicit LightingStage(const StageContext& c) : corrector_(c.config.lighting, c.configDir) {}
    std::string_view name() const override { return "lighting"; }
    bool hasImageWork() const override { return corrector_.enabled() && !covered_; }
    void prepare(AnalysisFrame& frame) override {
        // Covered: the front end prepares what it needs (the factors of the mosaic's sites).
        if (corrector_.enabled() && !covered_) corrector_.prepare(frame.original.size());
    }
    void processImage(AnalysisFrame& frame, Side side) override { work(frame, side); }

    /// The fused front end does this stage's per-pixel work from now on.
    void cover() { covered_ = true; }
    void work(AnalysisFrame& frame, Side side) const {
        if (!corrector_.enabled()) return;
        requireBgr(frame, side, name());
        corrector_.apply(writableImage(frame, side), frame.layout.bitDepth);
    }
    const LightingCorrector& corrector() const { return corrector_; }
    LightingCorrector& corrector() { return corrector_; }

private:
    LightingCorrector corrector_;
    bool covered_{false};
};

/// RGB-ratio or HSV filter, all target types in one pass (thesis 3.3.2).
class ColorFilterStage final : public ProcessStereoImagePair {
public:
    bool independentSides() const override { return true; }
    explicit ColorFilterStage(const StageContext& c) : types_(c.config.targets.targets) {}
    std::string_view name() const override { return "color_filter"; }
    bool hasImageWork() const override { return !covered_; }
    void processImage(AnalysisFrame& frame, Side side) override { work(frame, side); }

    void cover() { covered_ = true; }
    void work(AnalysisFrame& frame, Side side) const {
        requireBgr(frame, side, name());
        colorFilterMasks(frame.at(side).image, frame.layout.bitDepth, types_, frame.at(side).masks);
    }
    const std::vector<TargetType>& types() const { return types_; }

private:
    std::vector<TargetType> types_;
    bool covered_{false};
};

/// Erode, then feature-AND restore, for the types that ask for it (thesis 3.3.2).
class ErodeRestoreStage final : public ProcessStereoImagePair {
public:
    bool independentSides() const override { return true; }
    explicit ErodeRestoreStage(const StageContext& c) : types_(c.config.targets.targets) {}
    std::string_view name() const override { return "erode_restore"; }
    std::vector<std::string_view> needs() const override { return {"color_filter"}; }
    bool hasImageWork() const override { return true; }
    /// The masks come straight from @p frontEnd's pass (fuseFrontEnd()): a
    /// mask it wrote in this frame is restored in place, reading only where
    /// its on pixels lie.
    void takeMasksFrom(const DemosaicStage* frontEnd) { frontEnd_ = frontEnd; }
    /// Where the on pixels of @p side's mask of type @p t lie, when @p mask
    /// is the one this frame's processImage() restored in place; else null.
    const detail::MaskRows* maskRows(Side side, std::size_t t, const cv::Mat& mask) const {
        const auto& rows = rows_[side == Side::Left ? 0 : 1];
        return t < rows.size() && rows[t].describes(mask) ? &rows[t] : nullptr;
    }
    void processImage(AnalysisFrame& frame, Side side) override {
        auto& masks = frame.at(side).masks;
        detail::BufferPool& pool = pools_[side == Side::Left ? 0 : 1];
        std::vector<detail::MaskRows>& rows = rows_[side == Side::Left ? 0 : 1];
        rows.assign(masks.size(), {});
        const std::vector<cv::Rect>& regions = frame.regionsOf(side);
        for (std::size_t t = 0; t < types_.size() && t < masks.size(); ++t) {
            if (!types_[t].erodeRestore) continue;
            const int kernel = types_[t].erodeKernelSize;
            if (frontEnd_ != nullptr && frontEnd_->wroteMask(side, t, masks[t])) {
                // The pass's own buffer, seen by no one else yet: restored in
                // place, where its on pixels lie (a whole-image frame), or
                // each region as its own image as below.
                if (regions.empty()) {
                    detail::erodeRestoreInPlace(masks[t], kernel, frontEnd_->maskRows(side, t, masks[t]), rows[t]);
                } else {
                    detail::MaskRows kept;
                    for (const cv::Rect& region : regions) {
                        cv::Mat part = masks[t](region);
                        detail::erodeRestoreInPlace(part, kernel, nullptr, kept);
                    }
                }
                continue;
            }
            if (regions.empty()) {
                cv::Mat restored = pool.get(masks[t].size(), CV_8UC1);
                erodeRestore(masks[t], kernel, restored);
                masks[t] = std::move(restored);
                continue;
            }
            // Each region as its own image: a feature inside it erodes as in
            // the whole mask (one reaching the region's edge is cut there anyway).
            cv::Mat restored = pool.getZeroedOutside(masks[t].size(), CV_8UC1, regions);
            for (const cv::Rect& region : regions) {
                cv::Mat part = restored(region);
                erodeRestore(masks[t](region), kernel, part);
            }
            masks[t] = std::move(restored);
        }
    }

private:
    std::vector<TargetType> types_;
    std::array<detail::BufferPool, 2> pools_{detail::BufferPool(16), detail::BufferPool(16)};  ///< per side
    const DemosaicStage* frontEnd_{nullptr};
    std::array<std::vector<detail::MaskRows>, 2> rows_;  ///< per side and type, of the last frame
};

/// 8-connected features with the geometric filter (thesis 3.3.3).
class LocateFeaturesStage final : public ProcessStereoImagePair {
public:
    bool independentSides() const override { return true; }
    explicit LocateFeaturesStage(const StageContext& c)
        : types_(c.config.targets.targets),
          weighted_(c.config.analysis.centroid == CentroidMode::IntensityWeighted) {}
    std::string_view name() const override { return "locate_features"; }
    std::vector<std::string_view> needs() const override { return {"color_filter"}; }
    bool hasImageWork() const override { return true; }
    /// Whether it reads the image (the intensity-weighted centroid).
    bool readsImage() const { return weighted_; }
    /// Once the features are found, @p frontEnd fills in the image around them
    /// when its pass left the image out (DemosaicStage::allowImagesAroundFeatures()).
    void fillImagesWith(DemosaicStage* frontEnd) { frontEnd_ = frontEnd; }
    /// The masks come straight from @p frontEnd's pass, through @p erode
    /// (may be null) when it comes between (fuseFrontEnd()): only where their
    /// on pixels lie is read.
    void takeMasksFrom(const DemosaicStage* frontEnd, const ErodeRestoreStage* erode) {
        maskWriter_ = frontEnd;
        eroder_ = erode;
    }
    void processImage(AnalysisFrame& frame, Side side) override {
        locate(frame, side);
        if (frontEnd_ != nullptr) frontEnd_->featuresFound(frame, side);
    }

private:
    void locate(AnalysisFrame& frame, Side side) {
        ImageWork& work = frame.at(side);
        requirePerType(work.masks.size(), types_.size(), name(), "masks");
        work.features.assign(types_.size(), {});
        const cv::Mat intensity = weighted_ && work.image.channels() == 3 ? work.image : cv::Mat();
        const std::vector<cv::Rect>& regions = frame.regionsOf(side);
        for (std::size_t t = 0; t < types_.size(); ++t) {
            const cv::Rect window = searchWindow(types_[t], work.masks[t].size());
            if (regions.empty()) {
                const detail::MaskRows* rows = eroder_ != nullptr ? eroder_->maskRows(side, t, work.masks[t]) : nullptr;
                if (rows == nullptr && maskWriter_ != nullptr) rows = maskWriter_->maskRows(side, t, work.masks[t]);
                work.features[t] = detail::locateFeatures(work.masks[t], intensity, types_[t], window, rows);
                continue;
            }
            // Each region within the type's window is a search window of its
            // own; the features in raster order of their first pixel, as one
            // search of the whole image gives them.
            std::vector<Feature>& found = work.features[t];
            for (const cv::Rect& region : regions) {
                const cv::Rect within = region & window;
                if (within.empty()) continue;
                std::vector<Feature> part = locateFeatures(work.masks[t], intensity, types_[t], within);
                found.insert(found.end(), std::make_move_iterator(part.begin()), std::make_move_iterator(part.end()));
            }
            std::stable_sort(found.begin(), found.end(), [](const Feature& a, const Feature& b) {
                const cv::Point& p = a.boundary[kTopLeft];
                const cv::Point& q = b.boundary[kTopLeft];
                return p.y != q.y ? p.y < q.y : p.x < q.x;
            });
        }
    }

    std::vector<TargetType> types_;
    bool weighted_;
    DemosaicStage* frontEnd_{nullptr};
    const DemosaicStage* maskWriter_{nullptr};
    const ErodeRestoreStage* eroder_{nullptr};
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
    bool hasImageWork() const override { return !covered_; }
    void processImage(AnalysisFrame& frame, Side side) override { work(frame, side); }

    void cover() { covered_ = true; }
    void work(AnalysisFrame& frame, Side side) const {
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
    bool covered_{false};
};

// ---- the fused front end ----------------------------------------------------

void DemosaicStage::demosaicOnly(AnalysisFrame& frame, Side side) const {
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

void DemosaicStage::prepare(AnalysisFrame& frame) {
    if (!fusedFor(frame)) {
        // The stages one by one: the corrector works on the demosaiced image.
        if (lighting_ != nullptr && lighting_->corrector().enabled()) lighting_->corrector().prepare(frame.original.size());
        return;
    }
    const cv::Size size = frame.original.size();
    if (lighting_ != nullptr && lighting_->corrector().enabled()) {
        lighting_->corrector().prepareMosaic(size, frame.layout.bayerPattern);  // once per size and pattern
    }
    const int depth = frame.original.image(Side::Left).depth();
    if (filter_ != nullptr && (size != testsSize_ || depth != testsDepth_ || frame.layout.bitDepth != testsBits_)) {
        tests_.clear();
        coarseTests_.clear();
        coarseTypes_.clear();
        const cv::Size half(size.width / 2, size.height / 2);
        for (const TargetType& t : filter_->types()) {
            tests_.emplace_back(t, size, depth, frame.layout.bitDepth);
            if (!coarse_ || half.width < 1 || half.height < 1) continue;
            // A coarse feature only says where to look: a sixteenth of the
            // least area (a quarter of the pixels, and the edges' mixed
            // superpixels), any shape, in the window halved.
            TargetType c = t;
            if (!c.window.wholeImage()) {
                c.window = {c.window.x / 2, c.window.y / 2, (c.window.x + c.window.width + 1) / 2 - c.window.x / 2,
                            (c.window.y + c.window.height + 1) / 2 - c.window.y / 2};
            }
            c.area = {std::max(1.0, t.area.min / 16.0), 1e18};
            c.aspectRatio = {0.0, 1e18};
            c.areaRatio = {0.0, 1.0};
            coarseTests_.emplace_back(c, half, depth, frame.layout.bitDepth);
            coarseTypes_.push_back(c);
        }
        testsSize_ = size;
        testsDepth_ = depth;
        testsBits_ = frame.layout.bitDepth;
    }
    // A whole-image frame's working images only around its features, when
    // nothing needs them whole (the visibility then comes from the pass's
    // 4x4 sums, which need sides that are multiples of 4).
    // Computing the image around the features is a second pass over those
    // parts (loading, correcting and demosaicing the mosaic again), against a
    // sixth of the whole pass for writing the whole image in it: worth it
    // while they cover less than a third of the image. The last frame's share
    // says what to expect (the result is the same either way).
    frame.imagesAroundFeatures = imagesAroundFeatures_ && std::max(aroundShare_[0], aroundShare_[1]) < 1.0 / 3.0 &&
                                 !frame.wholeImagesWanted && filter_ != nullptr &&
                                 !frame.tracking() && !frame.coarse &&
                                 (visibility_ == nullptr || (size.width % 4 == 0 && size.height % 4 == 0));
    if (frame.imagesAroundFeatures) {
        if (lighting_ != nullptr && lighting_->corrector().enabled())
            frame.mosaicLightingFactors = lighting_->corrector().mosaicFactors();
        frame.samplesByteSwapped = swap_;
    }
}

void DemosaicStage::processImage(AnalysisFrame& frame, Side side) {
    maskRows_[side == Side::Left ? 0 : 1].clear();
    written_[side == Side::Left ? 0 : 1].clear();
    if (!fusedFor(frame)) {
        // What the fused pass does not take goes through the stages one by one.
        demosaicOnly(frame, side);
        if (lighting_ != nullptr) lighting_->work(frame, side);
        if (filter_ != nullptr) filter_->work(frame, side);
        if (visibility_ != nullptr) visibility_->work(frame, side);
        return;
    }
    if (side == Side::Right && pendingRight_) {  // computed with the left image's (runFrontEndPair)
        detail::FrontEndResult out = std::move(*pendingRight_);
        pendingRight_.reset();
        storeFused(frame, side, out);
        return;
    }
    pendingRight_.reset();
    detail::FrontEndResult out;
    const detail::FrontEndInput in = fusedInput(frame, side, out);
    if (side == Side::Left && frame.sidesInTurn && !frame.coarse && !frame.tracking()) {
        detail::FrontEndResult right;
        const detail::FrontEndInput inRight = fusedInput(frame, Side::Right, right);
        detail::runFrontEndPair(in, out, inRight, right);
        pendingRight_ = std::move(right);
    } else {
        detail::runFrontEnd(in, out);
    }
    storeFused(frame, side, out);
}

detail::FrontEndInput DemosaicStage::fusedInput(AnalysisFrame& frame, Side side, detail::FrontEndResult& out) {
    const std::size_t i = side == Side::Left ? 0 : 1;
    const cv::Mat& mosaic = frame.original.image(side);
    detail::FrontEndInput in;
    in.mosaic = mosaic;
    in.pattern = frame.layout.bayerPattern;
    in.bitDepth = frame.layout.bitDepth;
    in.endianSwap = swap_;
    in.factors = lighting_ != nullptr && lighting_->corrector().enabled() ? &lighting_->corrector().mosaicFactors()
                                                                           : nullptr;
    in.tests = filter_ != nullptr ? &tests_ : nullptr;
    in.visibility = visibility_ != nullptr;
    if (frame.coarse && frame.regionsOf(side).empty() && in.tests != nullptr && !tests_.empty() &&
        coarseTests_.size() == tests_.size())
        searchCoarse(frame, side, in);
    const std::vector<cv::Rect>& regions = frame.regionsOf(side);
    in.regions = &regions;
    const auto buffer = [&](detail::BufferPool& pool, int type) {
        return regions.empty() ? pool.get(mosaic.size(), type) : pool.getZeroedOutside(mosaic.size(), type, regions);
    };
    in.writeImage = !frame.imagesAroundFeatures;
    if (in.writeImage) out.bgr = buffer(images_[i], CV_MAKETYPE(mosaic.depth(), 3));
    out.bgrZeroOutsideRegions = out.masksZeroOutsideRegions = true;
    out.masks.resize(tests_.size());
    out.masksDirty.clear();
    if (in.tests != nullptr) {
        if (regions.empty()) out.masksDirty.resize(tests_.size());  // where each buffer is not 0 yet
        for (std::size_t t = 0; t < out.masks.size(); ++t)
            out.masks[t] = regions.empty() ? masks_[i].get(mosaic.size(), CV_8UC1, out.masksDirty[t])
                                           : buffer(masks_[i], CV_8UC1);
    }
    return in;
}

void DemosaicStage::storeFused(AnalysisFrame& frame, Side side, detail::FrontEndResult& out) {
    const std::size_t i = side == Side::Left ? 0 : 1;
    ImageWork& work = frame.at(side);
    work.image = std::move(out.bgr);
    if (filter_ != nullptr) work.masks = std::move(out.masks);
    if (out.visibility) work.visibility = *out.visibility;
    else if (frame.coarse && !frame.regionsOf(side).empty() && coarsePass_[i].visibility)
        work.visibility = *coarsePass_[i].visibility;
    if (filter_ != nullptr) {
        maskRows_[i] = std::move(out.maskRows);
        for (std::size_t t = 0; t < work.masks.size(); ++t) {
            written_[i].push_back(work.masks[t].data);
            // A whole-image pass: the pool learns the bands of rows it left
            // non-zero (the stages after it only clear mask pixels).
            if (t < maskRows_[i].size() && maskRows_[i][t].describes(work.masks[t]))
                masks_[i].wrote(work.masks[t], detail::nonZeroBands(maskRows_[i][t], work.masks[t].cols));
        }
    }
}

void DemosaicStage::featuresFound(AnalysisFrame& frame, Side side) {
    const std::size_t i = side == Side::Left ? 0 : 1;
    const cv::Mat& mosaic = frame.original.image(side);
    ImageWork& work = frame.at(side);
    std::vector<cv::Rect> boxes;
    for (const std::vector<Feature>& features : work.features)
        for (const Feature& f : features) boxes.push_back(f.box);
    const std::vector<cv::Rect> regions =
        detail::regionsAround(boxes, AnalysisFrame::kImageMarginPx, mosaic.size());
    double covered = 0.0;
    for (const cv::Rect& r : regions) covered += r.area();
    aroundShare_[i] = covered / static_cast<double>(mosaic.total());
    if (!frame.imagesAroundFeatures) return;
    detail::FrontEndResult out;
    out.bgr = images_[i].getZeroedOutside(mosaic.size(), CV_MAKETYPE(mosaic.depth(), 3), regions);
    out.bgrZeroOutsideRegions = true;
    if (!regions.empty()) {  // no regions: a pass would compute the whole image
        detail::FrontEndInput in = detail::imageInput(frame, side);
        in.regions = &regions;
        detail::runFrontEnd(in, out);
    }
    work.image = std::move(out.bgr);
}

void DemosaicStage::searchCoarse(AnalysisFrame& frame, Side side, const detail::FrontEndInput& in) {
    const std::size_t i = side == Side::Left ? 0 : 1;
    detail::CoarseResult& coarse = coarsePass_[i];
    detail::runCoarse(in, coarseTests_, coarse);
    std::vector<cv::Rect> boxes;
    for (std::size_t t = 0; t < coarseTests_.size(); ++t)
        for (const Feature& f : locateFeatures(coarse.masks[t], cv::Mat(), coarseTypes_[t], coarseTests_[t].window()))
            boxes.emplace_back(2 * f.box.x, 2 * f.box.y, 2 * f.box.width, 2 * f.box.height);
    frame.regions[i] = detail::regionsAround(boxes, coarseMargin_, frame.original.size());
}

}  // namespace

void detail::fuseFrontEnd(std::vector<std::unique_ptr<ProcessStereoImagePair>>& stages) {
    const auto is = [&](std::size_t k, auto* type) {
        return k < stages.size() && dynamic_cast<decltype(type)>(stages[k].get()) != nullptr;
    };
    for (std::size_t i = 0; i < stages.size(); ++i) {
        auto* demosaic = dynamic_cast<DemosaicStage*>(stages[i].get());
        if (demosaic == nullptr) continue;
        if (!demosaic->canFuse()) return;
        std::size_t j = i + 1;
        LightingStage* lighting = is(j, static_cast<LightingStage*>(nullptr))
                                      ? static_cast<LightingStage*>(stages[j++].get()) : nullptr;
        ColorFilterStage* filter = is(j, static_cast<ColorFilterStage*>(nullptr))
                                       ? static_cast<ColorFilterStage*>(stages[j++].get()) : nullptr;
        VisibilityStage* visibility = nullptr;
        for (std::size_t k = j; k < stages.size(); ++k) {
            if (is(k, static_cast<VisibilityStage*>(nullptr))) {
                visibility = static_cast<VisibilityStage*>(stages[k].get());
                break;
            }
            // Stages that read the images but never change them.
            if (!is(k, static_cast<ErodeRestoreStage*>(nullptr)) && !is(k, static_cast<LocateFeaturesStage*>(nullptr)) &&
                !is(k, static_cast<MatchStage*>(nullptr)) && !is(k, static_cast<TriangulateStage*>(nullptr)))
                break;
        }
        if (lighting != nullptr) lighting->cover();
        if (filter != nullptr) filter->cover();
        if (visibility != nullptr) visibility->cover();
        demosaic->fuse(lighting, filter, visibility);
        // The working image can wait for the features when every stage after
        // the demosaic is a built-in one that reads it only around them: the
        // fused ones, erode_restore, a locate_features that does not weigh by
        // intensity (which then fills it in), match and triangulate.
        LocateFeaturesStage* locate = nullptr;
        bool aroundFeatures = filter != nullptr;
        for (std::size_t k = i + 1; k < stages.size() && aroundFeatures; ++k) {
            ProcessStereoImagePair* stage = stages[k].get();
            if (stage == lighting || stage == filter || stage == visibility) continue;
            if (auto* l = dynamic_cast<LocateFeaturesStage*>(stage); l != nullptr && locate == nullptr && !l->readsImage()) {
                locate = l;
                continue;
            }
            aroundFeatures = (locate != nullptr && dynamic_cast<TriangulateStage*>(stage) != nullptr) ||
                             dynamic_cast<ErodeRestoreStage*>(stage) != nullptr || dynamic_cast<MatchStage*>(stage) != nullptr;
        }
        if (aroundFeatures && locate != nullptr) {
            demosaic->allowImagesAroundFeatures();
            locate->fillImagesWith(demosaic);
        }
        // The masks go from the pass to an erode_restore and a locate_features
        // right after it (only fused stages between, which leave them alone)
        // with where their on pixels lie.
        if (filter != nullptr) {
            const auto next = [&](std::size_t k) {
                while (k < stages.size() && (stages[k].get() == lighting || stages[k].get() == filter ||
                                             stages[k].get() == visibility))
                    ++k;
                return k;
            };
            std::size_t k = next(i + 1);
            ErodeRestoreStage* erode = nullptr;
            if (is(k, static_cast<ErodeRestoreStage*>(nullptr))) {
                erode = static_cast<ErodeRestoreStage*>(stages[k].get());
                erode->takeMasksFrom(demosaic);
                k = next(k + 1);
            }
            if (is(k, static_cast<LocateFeaturesStage*>(nullptr)))
                static_cast<LocateFeaturesStage*>(stages[k].get())->takeMasksFrom(demosaic, erode);
        }
        return;  // the first demosaic only
    }
}

namespace {

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
