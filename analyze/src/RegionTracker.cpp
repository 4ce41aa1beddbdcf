#include "RegionTracker.h"

#include <avatar/common/Logging.h>

#include <log4cpp/Category.hh>

#include <algorithm>

namespace avatar::detail {
namespace {

constexpr std::uint32_t kPartial = kTargetCut | kTargetOccludedLeft | kTargetOccludedRight | kTargetMerged |
                                   kTargetAmbiguous | kTargetLeftOnly | kTargetRightOnly;

bool isFollowed(const VisionTarget& t) { return (t.flags & kTargetStereo) && (t.flags & kTargetWhole); }

/// The boxes of the features of @p work (any type) whose box holds @p centroid:
/// the target's silhouette, with every fragment of another filter on it.
cv::Rect targetBox(const ImageWork& work, const cv::Point2d& centroid) {
    cv::Rect box;
    const cv::Point p(static_cast<int>(centroid.x), static_cast<int>(centroid.y));
    for (const auto& features : work.features)
        for (const Feature& f : features)
            if (f.box.contains(p)) box = box.empty() ? f.box : (box | f.box);
    return box;
}

}  // namespace

std::vector<cv::Rect> regionsAround(const std::vector<cv::Rect>& boxes, int margin, cv::Size size) {
    const cv::Rect image(cv::Point(), size);
    std::vector<cv::Rect> out;
    for (const cv::Rect& b : boxes) {
        const cv::Rect r = cv::Rect(b.x - margin, b.y - margin, b.width + 2 * margin, b.height + 2 * margin) & image;
        if (!r.empty()) out.push_back(r);
    }
    // Merge until no two are closer than one clear pixel.
    for (bool merged = true; merged;) {
        merged = false;
        for (std::size_t i = 0; i < out.size() && !merged; ++i)
            for (std::size_t j = i + 1; j < out.size(); ++j) {
                const cv::Rect grown(out[i].x - 1, out[i].y - 1, out[i].width + 2, out[i].height + 2);
                if ((grown & out[j]).empty()) continue;
                out[i] |= out[j];
                out.erase(out.begin() + static_cast<std::ptrdiff_t>(j));
                merged = true;
                break;
            }
    }
    std::sort(out.begin(), out.end(),
              [](const cv::Rect& a, const cv::Rect& b) { return a.y != b.y ? a.y < b.y : a.x < b.x; });
    return out;
}

void RegionTracker::begin(AnalysisFrame& frame) const {
    if (!config_.enabled || next_[0].empty() || next_[1].empty()) {
        frame.coarse = coarse_;
        return;
    }
    frame.regions = next_;
    for (std::size_t i = 0; i < 2; ++i) frame.images[i].visibility = visibility_[i];
}

void RegionTracker::end(const AnalysisFrame& frame) {
    if (!config_.enabled) return;
    log4cpp::Category& log = logging::category("analyze");
    const bool tracking = frame.tracking() && !frame.coarse;  // a coarse frame's regions are its own
    std::size_t whole = 0;
    bool partial = false;
    for (const VisionTarget& t : frame.result.targets) {
        whole += isFollowed(t) ? 1 : 0;
        partial = partial || (t.flags & kPartial) != 0;
    }
    if (!tracking) {
        sinceFull_ = 1;
        for (std::size_t i = 0; i < 2; ++i) visibility_[i] = frame.images[i].visibility;
    } else {
        ++sinceFull_;
        if (whole < followed_ || partial) {
            if (log.isInfoEnabled())
                log.infoStream() << "tracking: iteration " << frame.result.iteration << " found " << whole << " of "
                                 << followed_ << " whole targets" << (partial ? ", some partial" : "")
                                 << "; searching the whole image next";
            next_ = {};
            return;
        }
    }
    if (whole == 0 || sinceFull_ >= config_.fullFrameEvery) {
        next_ = {};
        return;
    }
    std::array<std::vector<cv::Rect>, 2> boxes;
    for (const VisionTarget& t : frame.result.targets) {
        if (!isFollowed(t) || !t.centroidLeftPx || !t.centroidRightPx) continue;
        const cv::Rect left = targetBox(frame.images[0], *t.centroidLeftPx);
        const cv::Rect right = targetBox(frame.images[1], *t.centroidRightPx);
        if (left.empty() || right.empty()) {  // no feature under the centroid: search the whole image
            next_ = {};
            return;
        }
        boxes[0].push_back(left);
        boxes[1].push_back(right);
    }
    const cv::Size size = frame.original.size();
    for (std::size_t i = 0; i < 2; ++i) next_[i] = regionsAround(boxes[i], config_.marginPx, size);
    followed_ = whole;
}

}  // namespace avatar::detail
