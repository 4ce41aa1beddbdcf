#pragma once
// Internal to avatar::analyze: image buffers reused across frames of the same
// geometry. A fresh 7 MB image per frame costs its page faults again every
// frame (docs/benchmarks.md); a buffer from here is handed out again only
// once nothing but the pool refers to it, so a frame a client still holds is
// never written into (AnalyzeStereoImagePair::lastFrame()).

#include <opencv2/core/mat.hpp>

#include <cstddef>
#include <vector>

namespace avatar::detail {

class BufferPool {
public:
    /// Keeps at most @p maxKept buffers; beyond that, a buffer asked for while
    /// all are in use is a fresh one that is not kept.
    explicit BufferPool(std::size_t maxKept = 4) : maxKept_(maxKept) {}

    /// A continuous buffer of @p size and @p type that nothing else refers
    /// to: a kept one that is free again, else a new one (kept when there is room).
    cv::Mat get(cv::Size size, int type) {
        for (const cv::Mat& m : kept_)
            if (m.size() == size && m.type() == type && m.u != nullptr && m.u->refcount == 1) return m;
        cv::Mat fresh(size, type);
        if (kept_.size() < maxKept_) {
            kept_.push_back(fresh);
        } else {
            // Drop a kept buffer of another geometry that is free, if any, to make room.
            for (cv::Mat& m : kept_)
                if ((m.size() != size || m.type() != type) && m.u != nullptr && m.u->refcount == 1) {
                    m = fresh;
                    break;
                }
        }
        return fresh;
    }

private:
    std::size_t maxKept_;
    std::vector<cv::Mat> kept_;
};

}  // namespace avatar::detail
