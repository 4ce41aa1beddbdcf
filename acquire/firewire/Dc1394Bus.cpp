// The real FireWire bus: the only file that calls libdc1394 (v2). Everything
// above the FirewireBus seam is tested against a scripted bus; this file is
// compiled and linked in every build, and its no-hardware behaviour is tested.
#include "FirewireBus.h"

#include <avatar/common/Logging.h>

#include <dc1394/dc1394.h>
#include <log4cpp/Category.hh>
#include <poll.h>

#include <algorithm>
#include <map>
#include <mutex>
#include <thread>

namespace avatar {
namespace {

log4cpp::Category& logger() {
    static log4cpp::Category& category = logging::category("acquire");
    return category;
}

/// libdc1394 prints its errors and warnings to stderr by default; library code
/// must not print, so they go to the acquire log category instead.
void routeLibraryMessage(dc1394log_t type, const char* message, void* /*user*/) {
    const std::string text = std::string("libdc1394: ") + (message != nullptr ? message : "");
    if (type == DC1394_LOG_ERROR)
        logger().error(text);
    else if (type == DC1394_LOG_WARNING)
        logger().warn(text);
    else
        logger().debug(text);
}

void routeLibraryLog() {
    static std::once_flag once;
    std::call_once(once, [] {
        dc1394_log_register_handler(DC1394_LOG_ERROR, &routeLibraryMessage, nullptr);
        dc1394_log_register_handler(DC1394_LOG_WARNING, &routeLibraryMessage, nullptr);
    });
}

BusStatus fail(BusStatus::Code code, const char* call, dc1394error_t err) {
    return BusStatus::error(code, std::string(call) + ": " + dc1394_error_get_string(err) + " (" +
                                      std::to_string(static_cast<int>(err)) + ")");
}

const char* const kUnavailable =
    "libdc1394 could not be initialised (dc1394_new failed): no FireWire support on this machine "
    "(kernel module firewire-ohci/firewire-core, /dev/fw*)";

/// Format7 mode 0: the full-featured mode of the Scorpion (thesis 4.2.2).
constexpr dc1394video_mode_t kMode = DC1394_VIDEO_MODE_FORMAT7_0;
/// Two cameras share one bus: each takes half of the largest packet the camera
/// allows, so both isochronous streams fit (at the cost of frame rate).
constexpr std::uint32_t kCamerasPerBus = 2;

dc1394color_coding_t toDc1394(PixelCoding coding) {
    switch (coding) {
    case PixelCoding::Mono8: return DC1394_COLOR_CODING_MONO8;
    case PixelCoding::Mono16: return DC1394_COLOR_CODING_MONO16;
    case PixelCoding::Raw8: return DC1394_COLOR_CODING_RAW8;
    case PixelCoding::Raw16: return DC1394_COLOR_CODING_RAW16;
    case PixelCoding::Rgb8: return DC1394_COLOR_CODING_RGB8;
    case PixelCoding::Rgb16: return DC1394_COLOR_CODING_RGB16;
    }
    return DC1394_COLOR_CODING_RAW16;
}

dc1394feature_t toDc1394(FirewireFeature feature) {
    switch (feature) {
    case FirewireFeature::Exposure: return DC1394_FEATURE_EXPOSURE;
    case FirewireFeature::Shutter: return DC1394_FEATURE_SHUTTER;
    case FirewireFeature::Gain: return DC1394_FEATURE_GAIN;
    case FirewireFeature::Brightness: return DC1394_FEATURE_BRIGHTNESS;
    case FirewireFeature::Gamma: return DC1394_FEATURE_GAMMA;
    }
    return DC1394_FEATURE_GAIN;
}

using Context = std::shared_ptr<dc1394_t>;

struct CameraFree {
    void operator()(dc1394camera_t* camera) const { dc1394_camera_free(camera); }
};
using CameraPtr = std::unique_ptr<dc1394camera_t, CameraFree>;

struct ListFree {
    void operator()(dc1394camera_list_t* list) const { dc1394_camera_free_list(list); }
};
using ListPtr = std::unique_ptr<dc1394camera_list_t, ListFree>;

class Dc1394Camera final : public FirewireCamera {
public:
    // Members are destroyed in reverse order: the camera before the context it needs.
    Dc1394Camera(Context context, CameraPtr camera) : context_(std::move(context)), camera_(std::move(camera)) {}
    ~Dc1394Camera() override { stopCapture(); }

    FirewireGuid guid() const override { return camera_->guid; }

    BusStatus setFormat7(const Format7Settings& s) override {
        if (capturing_) return BusStatus::error(BusStatus::Code::Rejected, "Format7 cannot change while capturing");
        dc1394error_t err = dc1394_video_set_iso_speed(camera_.get(), DC1394_ISO_SPEED_400);
        if (err != DC1394_SUCCESS) return fail(BusStatus::Code::Failure, "dc1394_video_set_iso_speed(400)", err);
        err = dc1394_video_set_mode(camera_.get(), kMode);
        if (err != DC1394_SUCCESS) return fail(BusStatus::Code::Rejected, "dc1394_video_set_mode(FORMAT7_0)", err);
        err = dc1394_format7_set_roi(camera_.get(), kMode, toDc1394(s.coding), DC1394_USE_MAX_AVAIL, s.left, s.top,
                                     s.width, s.height);
        if (err != DC1394_SUCCESS) return fail(BusStatus::Code::Rejected, "dc1394_format7_set_roi", err);
        std::uint32_t unit = 0;
        std::uint32_t max = 0;
        err = dc1394_format7_get_packet_parameters(camera_.get(), kMode, &unit, &max);
        if (err != DC1394_SUCCESS) return fail(BusStatus::Code::Failure, "dc1394_format7_get_packet_parameters", err);
        if (unit > 0 && max >= unit) {
            const std::uint32_t packet = std::max(unit, (max / kCamerasPerBus) / unit * unit);
            err = dc1394_format7_set_packet_size(camera_.get(), kMode, packet);
            if (err != DC1394_SUCCESS) return fail(BusStatus::Code::Rejected, "dc1394_format7_set_packet_size", err);
        }
        return BusStatus::ok();
    }

    BusStatus setFeature(FirewireFeature feature, std::uint32_t value, bool automatic) override {
        return setMode(toDc1394(feature), automatic, [&] {
            return dc1394_feature_set_value(camera_.get(), toDc1394(feature), value);
        });
    }

    BusStatus setWhiteBalance(std::uint32_t blueU, std::uint32_t redV, bool automatic) override {
        return setMode(DC1394_FEATURE_WHITE_BALANCE, automatic, [&] {
            return dc1394_feature_whitebalance_set_value(camera_.get(), blueU, redV);
        });
    }

    FeatureState getFeature(FirewireFeature feature) override { return readFeature(toDc1394(feature)); }

    FeatureState getWhiteBalance() override { return readFeature(DC1394_FEATURE_WHITE_BALANCE); }

    BusStatus startCapture(std::uint32_t dmaBuffers) override {
        if (capturing_) return BusStatus::error(BusStatus::Code::Rejected, "capture already running");
        dc1394error_t err = dc1394_capture_setup(camera_.get(), dmaBuffers, DC1394_CAPTURE_FLAGS_DEFAULT);
        if (err != DC1394_SUCCESS) return fail(BusStatus::Code::Failure, "dc1394_capture_setup", err);
        err = dc1394_video_set_transmission(camera_.get(), DC1394_ON);
        if (err != DC1394_SUCCESS) {
            dc1394_capture_stop(camera_.get());
            return fail(BusStatus::Code::Failure, "dc1394_video_set_transmission(on)", err);
        }
        capturing_ = true;
        return BusStatus::ok();
    }

    DequeueResult dequeue(std::chrono::milliseconds timeout) override {
        if (!capturing_) return {BusStatus::error(BusStatus::Code::Failure, "not capturing"), {}};
        const auto deadline = std::chrono::steady_clock::now() + timeout;
        const int fd = dc1394_capture_get_fileno(camera_.get());
        for (;;) {
            dc1394video_frame_t* frame = nullptr;
            const dc1394error_t err = dc1394_capture_dequeue(camera_.get(), DC1394_CAPTURE_POLICY_POLL, &frame);
            if (err != DC1394_SUCCESS) return {fail(BusStatus::Code::Failure, "dc1394_capture_dequeue", err), {}};
            if (frame != nullptr) {
                if (dc1394_capture_is_frame_corrupt(camera_.get(), frame) == DC1394_TRUE) {
                    logger().warn("libdc1394: corrupt frame from " + formatGuid(guid()) + " dropped");
                    dc1394_capture_enqueue(camera_.get(), frame);
                    continue;
                }
                outstanding_[frame->id] = frame;
                FirewireFrame out;
                out.data = frame->image;
                out.bytes = static_cast<std::size_t>(frame->total_bytes);
                out.width = static_cast<int>(frame->size[0]);
                out.height = static_cast<int>(frame->size[1]);
                out.stride = frame->stride != 0 ? frame->stride : frame->size[0] * frame->data_depth / 8;
                out.timestampUs = static_cast<std::int64_t>(frame->timestamp);
                out.bufferId = frame->id;
                return {BusStatus::ok(), out};
            }
            const auto left = std::chrono::duration_cast<std::chrono::milliseconds>(
                deadline - std::chrono::steady_clock::now());
            if (left.count() <= 0)
                return {BusStatus::error(BusStatus::Code::Timeout,
                                         "no frame within " + std::to_string(timeout.count()) + " ms"),
                        {}};
            const int waitMs = static_cast<int>(std::min<std::int64_t>(left.count(), 100));
            if (fd >= 0) {
                pollfd p{fd, POLLIN, 0};
                ::poll(&p, 1, waitMs);
            } else {
                std::this_thread::sleep_for(std::chrono::milliseconds(1));
            }
        }
    }

    BusStatus enqueue(const FirewireFrame& frame) override {
        const auto it = outstanding_.find(frame.bufferId);
        if (it == outstanding_.end())
            return BusStatus::error(BusStatus::Code::NotFound,
                                    "frame buffer " + std::to_string(frame.bufferId) + " is not dequeued");
        dc1394video_frame_t* native = it->second;
        outstanding_.erase(it);
        const dc1394error_t err = dc1394_capture_enqueue(camera_.get(), native);
        if (err != DC1394_SUCCESS) return fail(BusStatus::Code::Failure, "dc1394_capture_enqueue", err);
        return BusStatus::ok();
    }

    BusStatus stopCapture() override {
        if (!capturing_) return BusStatus::ok();
        capturing_ = false;
        outstanding_.clear();  // dc1394_capture_stop releases every buffer
        const dc1394error_t off = dc1394_video_set_transmission(camera_.get(), DC1394_OFF);
        const dc1394error_t stop = dc1394_capture_stop(camera_.get());
        if (off != DC1394_SUCCESS) return fail(BusStatus::Code::Failure, "dc1394_video_set_transmission(off)", off);
        if (stop != DC1394_SUCCESS) return fail(BusStatus::Code::Failure, "dc1394_capture_stop", stop);
        return BusStatus::ok();
    }

private:
    static std::string featureName(dc1394feature_t feature) {
        const char* name = dc1394_feature_get_string(feature);
        return name != nullptr ? name : "feature " + std::to_string(static_cast<int>(feature));
    }

    /// Ok when the camera has @p feature (and, when @p automatic, its automatic
    /// mode); NotFound when it does not.
    BusStatus supports(dc1394feature_t feature, bool automatic, bool* autoAvailable = nullptr) {
        dc1394bool_t present = DC1394_FALSE;
        dc1394error_t err = dc1394_feature_is_present(camera_.get(), feature, &present);
        if (err != DC1394_SUCCESS) return fail(BusStatus::Code::Failure, "dc1394_feature_is_present", err);
        if (present != DC1394_TRUE)
            return BusStatus::error(BusStatus::Code::NotFound, "the camera has no " + featureName(feature) + " feature");
        dc1394feature_modes_t modes{};
        err = dc1394_feature_get_modes(camera_.get(), feature, &modes);
        if (err != DC1394_SUCCESS) return fail(BusStatus::Code::Failure, "dc1394_feature_get_modes", err);
        bool hasAuto = false;
        for (std::uint32_t i = 0; i < modes.num && i < DC1394_FEATURE_MODE_NUM; ++i)
            hasAuto = hasAuto || modes.modes[i] == DC1394_FEATURE_MODE_AUTO;
        if (autoAvailable != nullptr) *autoAvailable = hasAuto;
        if (automatic && !hasAuto)
            return BusStatus::error(BusStatus::Code::NotFound,
                                    "the camera has no automatic mode for " + featureName(feature));
        return BusStatus::ok();
    }

    FeatureState readFeature(dc1394feature_t feature) {
        FeatureState state;
        state.status = supports(feature, false, &state.autoAvailable);
        if (!state.status.isOk()) return state;
        dc1394feature_mode_t mode = DC1394_FEATURE_MODE_MANUAL;
        dc1394error_t err = dc1394_feature_get_mode(camera_.get(), feature, &mode);
        if (err != DC1394_SUCCESS) {
            state.status = fail(BusStatus::Code::Failure, "dc1394_feature_get_mode", err);
            return state;
        }
        state.automatic = mode == DC1394_FEATURE_MODE_AUTO;
        if (feature == DC1394_FEATURE_WHITE_BALANCE)
            err = dc1394_feature_whitebalance_get_value(camera_.get(), &state.value, &state.redV);
        else
            err = dc1394_feature_get_value(camera_.get(), feature, &state.value);
        if (err != DC1394_SUCCESS) state.status = fail(BusStatus::Code::Failure, "dc1394_feature_get_value", err);
        return state;
    }

    template <typename SetValue>
    BusStatus setMode(dc1394feature_t feature, bool automatic, SetValue setValue) {
        if (const BusStatus s = supports(feature, automatic); !s.isOk()) return s;
        dc1394error_t err = dc1394_feature_set_mode(camera_.get(), feature,
                                                    automatic ? DC1394_FEATURE_MODE_AUTO : DC1394_FEATURE_MODE_MANUAL);
        if (err != DC1394_SUCCESS) return fail(BusStatus::Code::Rejected, "dc1394_feature_set_mode", err);
        if (automatic) return BusStatus::ok();
        err = setValue();
        if (err != DC1394_SUCCESS) return fail(BusStatus::Code::Rejected, "dc1394_feature_set_value", err);
        return BusStatus::ok();
    }

    Context context_;
    CameraPtr camera_;
    bool capturing_{false};
    std::map<std::uint32_t, dc1394video_frame_t*> outstanding_;  ///< dequeued frames by ring position
};

class Dc1394Bus final : public FirewireBus {
public:
    Dc1394Bus() {
        routeLibraryLog();
        if (dc1394_t* d = dc1394_new())
            context_ = Context(d, &dc1394_free);
        else
            logger().warn(kUnavailable);
    }

    std::string name() const override { return "libdc1394"; }

    Enumeration enumerate() override {
        if (!context_) return {BusStatus::error(BusStatus::Code::Unavailable, kUnavailable), {}};
        dc1394camera_list_t* raw = nullptr;
        const dc1394error_t err = dc1394_camera_enumerate(context_.get(), &raw);
        const ListPtr list(raw);
        if (err != DC1394_SUCCESS) return {fail(BusStatus::Code::Failure, "dc1394_camera_enumerate", err), {}};
        Enumeration result;
        if (list)
            for (std::uint32_t i = 0; i < list->num; ++i) result.guids.push_back(list->ids[i].guid);
        return result;
    }

    std::string describe(FirewireGuid guid) override {
        if (!context_) return {};
        const CameraPtr camera(dc1394_camera_new(context_.get(), guid));
        if (!camera) return {};
        const std::string vendor = camera->vendor != nullptr ? camera->vendor : "";
        const std::string model = camera->model != nullptr ? camera->model : "";
        return vendor.empty() ? model : model.empty() ? vendor : vendor + " " + model;
    }

    OpenResult open(FirewireGuid guid) override {
        if (!context_) return {BusStatus::error(BusStatus::Code::Unavailable, kUnavailable), nullptr};
        CameraPtr camera(dc1394_camera_new(context_.get(), guid));
        if (!camera)
            return {BusStatus::error(BusStatus::Code::NotFound,
                                     "dc1394_camera_new: no camera " + formatGuid(guid) + " on the bus"),
                    nullptr};
        return {BusStatus::ok(), std::make_unique<Dc1394Camera>(context_, std::move(camera))};
    }

    BusStatus resetBus() override {
        if (!context_) return BusStatus::error(BusStatus::Code::Unavailable, kUnavailable);
        // libdc1394 resets the bus through a camera: use the first one that answers.
        const Enumeration e = enumerate();
        if (!e.status.isOk()) return e.status;
        for (const FirewireGuid guid : e.guids) {
            const CameraPtr camera(dc1394_camera_new(context_.get(), guid));
            if (!camera) continue;
            const dc1394error_t err = dc1394_reset_bus(camera.get());
            if (err != DC1394_SUCCESS) return fail(BusStatus::Code::Failure, "dc1394_reset_bus", err);
            return BusStatus::ok();
        }
        return BusStatus::error(BusStatus::Code::NotFound,
                                "no camera on the bus to reset it through (libdc1394 resets via a camera)");
    }

private:
    Context context_;
};

}  // namespace

std::unique_ptr<FirewireBus> makeDc1394Bus() { return std::make_unique<Dc1394Bus>(); }

}  // namespace avatar
