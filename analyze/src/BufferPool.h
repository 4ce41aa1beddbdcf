#pragma once
// Internal to avatar::analyze: image buffers reused across frames of the same
// geometry. A fresh 7 MB image per frame costs its page faults again every
// frame (docs/benchmarks.md); a buffer from here is handed out again only
// once nothing but the pool refers to it, so a frame a client still holds is
// never written into (AnalyzeStereoImagePair::lastFrame()).
//
// A tracking frame writes only its search regions: getZeroedOutside() hands
// out a buffer that is 0 everywhere else, clearing only what the buffer's
// last user may have written (the pool remembers it), not the whole image.
// A user that writes a whole buffer may say where it left non-zero values
// (wrote()); the next user then learns where the rest is 0 already (a
// filter's mask is 0 in most rows: the front end writes those again only
// when they change, instead of streaming 1.2 MB of zeros per mask and frame).

#include <opencv2/core/mat.hpp>

#include <cstddef>
#include <cstring>
#include <vector>

namespace avatar::detail {

class BufferPool {
public:
    /// Keeps at most @p maxKept buffers; beyond that, a buffer asked for while
    /// all are in use is a fresh one that is not kept.
    explicit BufferPool(std::size_t maxKept = 4) : maxKept_(maxKept) {}

    /// A continuous buffer of @p size and @p type that nothing else refers
    /// to: a kept one that is free again, else a new one (kept when there is
    /// room). Its content is undefined; the caller writes all of it.
    cv::Mat get(cv::Size size, int type) { return take(size, type, {cv::Rect(cv::Point(), size)}, false); }

    /// The same, and in @p dirty where the buffer may hold non-zero values:
    /// where its last user left them (wrote(), getZeroedOutside()), the whole
    /// image for a new buffer. Outside @p dirty it is 0.
    cv::Mat get(cv::Size size, int type, std::vector<cv::Rect>& dirty) {
        return take(size, type, {cv::Rect(cv::Point(), size)}, false, &dirty);
    }

    /// The user of @p buffer (handed out by this pool) left non-zero values
    /// only inside @p rects. Ignored for a buffer the pool does not keep.
    void wrote(const cv::Mat& buffer, std::vector<cv::Rect> rects) {
        for (Kept& k : kept_)
            if (k.buffer.data == buffer.data && k.buffer.size() == buffer.size() && k.buffer.type() == buffer.type())
                k.written = std::move(rects);
    }

    /// The same, 0 outside @p regions (rectangles inside the image); the
    /// caller writes inside them only. Inside them the content is undefined.
    cv::Mat getZeroedOutside(cv::Size size, int type, const std::vector<cv::Rect>& regions) {
        return take(size, type, regions, true);
    }

private:
    struct Kept {
        cv::Mat buffer;
        std::vector<cv::Rect> written;  ///< where its last user may have left non-zero values
    };

    cv::Mat take(cv::Size size, int type, const std::vector<cv::Rect>& willWrite, bool zeroOutside,
                 std::vector<cv::Rect>* dirty = nullptr) {
        for (Kept& k : kept_)
            if (k.buffer.size() == size && k.buffer.type() == type && k.buffer.u != nullptr &&
                k.buffer.u->refcount == 1) {
                if (zeroOutside)
                    for (const cv::Rect& r : uncovered(k.written, willWrite)) clear(k.buffer, r);
                if (dirty != nullptr) *dirty = std::move(k.written);
                k.written = willWrite;
                return k.buffer;
            }
        if (dirty != nullptr) *dirty = {cv::Rect(cv::Point(), size)};
        cv::Mat fresh(size, type);
        if (zeroOutside) fresh.setTo(0);
        Kept entry{fresh, willWrite};
        if (kept_.size() < maxKept_) {
            kept_.push_back(std::move(entry));
        } else {
            // Drop a kept buffer of another geometry that is free, if any, to make room.
            for (Kept& k : kept_)
                if ((k.buffer.size() != size || k.buffer.type() != type) && k.buffer.u != nullptr &&
                    k.buffer.u->refcount == 1) {
                    k = std::move(entry);
                    break;
                }
        }
        return fresh;
    }

    /// The parts of @p rects outside every rectangle of @p cover (each cut
    /// into at most four bands per covering rectangle): what is written again
    /// need not be cleared first.
    static std::vector<cv::Rect> uncovered(std::vector<cv::Rect> rects, const std::vector<cv::Rect>& cover) {
        for (const cv::Rect& c : cover) {
            std::vector<cv::Rect> left;
            for (const cv::Rect& r : rects) {
                const cv::Rect i = r & c;
                if (i.empty()) {
                    left.push_back(r);
                    continue;
                }
                const cv::Rect bands[4] = {{r.x, r.y, r.width, i.y - r.y},                               // above
                                           {r.x, i.y + i.height, r.width, r.y + r.height - i.y - i.height},  // below
                                           {r.x, i.y, i.x - r.x, i.height},                              // left
                                           {i.x + i.width, i.y, r.x + r.width - i.x - i.width, i.height}};  // right
                for (const cv::Rect& b : bands)
                    if (b.width > 0 && b.height > 0) left.push_back(b);
            }
            rects = std::move(left);
        }
        return rects;
    }

    /// Zeroes @p r of @p m, a row at a time (cheaper than setTo on a view).
    static void clear(cv::Mat& m, const cv::Rect& r) {
        const std::size_t pixel = m.elemSize(), bytes = static_cast<std::size_t>(r.width) * pixel;
        for (int y = r.y; y < r.y + r.height; ++y) std::memset(m.ptr(y) + r.x * pixel, 0, bytes);
    }

    std::size_t maxKept_;
    std::vector<Kept> kept_;
};

}  // namespace avatar::detail
