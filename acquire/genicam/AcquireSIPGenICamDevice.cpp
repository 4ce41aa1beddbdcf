#include "AcquireSIPGenICamDevice.h"

#include <avatar/common/Logging.h>

#include <log4cpp/Category.hh>
#include <opencv2/core.hpp>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <initializer_list>
#include <sstream>

namespace avatar::genicam {

namespace {

log4cpp::Category& logger() { return logging::category("acquire"); }

std::string text(const char* s) { return s != nullptr ? std::string(s) : std::string(); }

std::string number(double v) {
    std::ostringstream os;
    os << v;
    return os.str();
}

std::string join(const std::vector<std::string>& items, const std::string& sep) {
    std::string out;
    for (const auto& item : items) {
        if (!out.empty()) out += sep;
        out += item;
    }
    return out;
}

std::string sideName(Side side) { return side == Side::Left ? "left" : "right"; }

// The Aravis "control-lost" signal: the device's heartbeat went unanswered.
// Called from Aravis's heartbeat thread.
void onControlLost(ArvDevice* /*device*/, gpointer flag) {
    static_cast<std::atomic<bool>*>(flag)->store(true);
}

}  // namespace

// ---------------------------------------------------------------- discovery

std::string DeviceInfo::describe() const {
    std::string where = address.empty() ? protocol : address + ", " + protocol;
    return id + " (" + where + ")";
}

std::vector<DeviceInfo> discoverDevices() {
    arv_update_device_list();
    std::vector<DeviceInfo> devices;
    const unsigned n = arv_get_n_devices();
    for (unsigned i = 0; i < n; ++i) {
        DeviceInfo d;
        d.id = text(arv_get_device_id(i));
        d.physicalId = text(arv_get_device_physical_id(i));
        d.address = text(arv_get_device_address(i));
        d.serial = text(arv_get_device_serial_nbr(i));
        d.protocol = text(arv_get_device_protocol(i));
        d.vendor = text(arv_get_device_vendor(i));
        d.model = text(arv_get_device_model(i));
        if (!d.id.empty()) devices.push_back(std::move(d));
    }
    return devices;
}

std::optional<DeviceInfo> findDevice(const std::vector<DeviceInfo>& devices, const std::string& wanted) {
    if (wanted.empty()) return std::nullopt;
    // Ids first: a serial number of one camera could look like another's id.
    for (const auto& d : devices)
        if (d.id == wanted) return d;
    for (const auto& d : devices)
        if (d.serial == wanted || (!d.physicalId.empty() && d.physicalId == wanted) ||
            (!d.address.empty() && d.address == wanted))
            return d;
    return std::nullopt;
}

std::string describeDevices(const std::vector<DeviceInfo>& devices) {
    if (devices.empty()) return "none";
    std::vector<std::string> parts;
    for (const auto& d : devices) parts.push_back(d.describe());
    return join(parts, ", ");
}

std::string probeDevice(const DeviceInfo& device, std::string& vendor, std::string& model) {
    GErrorSlot error;
    GObjectPtr<ArvCamera> camera(arv_camera_new(device.id.c_str(), error.out()));
    if (error || !camera) return error ? error.message() : std::string("Aravis gave no reason");
    GErrorSlot nameError;
    const std::string v = text(arv_camera_get_vendor_name(camera.get(), nameError.out()));
    if (!nameError && !v.empty()) vendor = v;
    nameError.clear();
    const std::string m = text(arv_camera_get_model_name(camera.get(), nameError.out()));
    if (!nameError && !m.empty()) model = m;
    return "";
}

// ---------------------------------------------------------------- features

void FeatureReporter::missing(const std::string& cameraLabel, const std::string& deviceId,
                              const std::string& feature, const std::string& what) {
    const std::string message = cameraLabel + " has no " + what + " (config feature <" + feature + ">)";
    if (std::find(required_.begin(), required_.end(), feature) != required_.end())
        throw AcquisitionError(message + ", which GenICamOptions::requiredFeatures requires");
    const std::string key = deviceId + "/" + feature + "/" + what;
    if (std::find(reported_.begin(), reported_.end(), key) != reported_.end()) return;
    reported_.push_back(key);
    logger().warn("%s; skipped", message.c_str());
}

// ---------------------------------------------------------------- buffers

std::int64_t HeldBuffer::systemTimestampUs() const {
    return buffer_ != nullptr ? static_cast<std::int64_t>(arv_buffer_get_system_timestamp(buffer_) / 1000u) : 0;
}

void HeldBuffer::release() {
    if (buffer_ != nullptr) {
        arv_stream_push_buffer(stream_, buffer_);  // back into the pool, the stream owns it again
        g_object_unref(stream_);
    }
    buffer_ = nullptr;
    stream_ = nullptr;
}

std::string bufferStatusName(ArvBufferStatus status) {
    switch (status) {
        case ARV_BUFFER_STATUS_SUCCESS: return "success";
        case ARV_BUFFER_STATUS_CLEARED: return "cleared";
        case ARV_BUFFER_STATUS_TIMEOUT: return "timeout";
        case ARV_BUFFER_STATUS_MISSING_PACKETS: return "missing packets";
        case ARV_BUFFER_STATUS_WRONG_PACKET_ID: return "wrong packet id";
        case ARV_BUFFER_STATUS_SIZE_MISMATCH: return "size mismatch";
        case ARV_BUFFER_STATUS_FILLING: return "filling";
        case ARV_BUFFER_STATUS_ABORTED: return "aborted";
        case ARV_BUFFER_STATUS_UNKNOWN: break;
    }
    return "unknown (" + std::to_string(static_cast<int>(status)) + ")";
}

// ---------------------------------------------------------------- camera

Camera::Camera(Side side, const DeviceInfo& device)
    : side_(side), device_(device), label_(sideName(side) + " camera " + device.id) {
    GErrorSlot error;
    camera_.reset(arv_camera_new(device.id.c_str(), error.out()));
    if (error || !camera_)
        throw AcquisitionError(label_ + ": cannot open " + device.describe() + ": " +
                               (error ? error.message() : std::string("no reason given")));
    controlLostHandler_ =
        g_signal_connect(arvDevice(), "control-lost", G_CALLBACK(onControlLost), &controlLost_);
    logger().info("%s: opened %s", label_.c_str(), device.describe().c_str());
}

Camera::~Camera() {
    stop();
    if (controlLostHandler_ != 0) g_signal_handler_disconnect(arvDevice(), controlLostHandler_);
    camera_.reset();
}

ArvDevice* Camera::arvDevice() const { return arv_camera_get_device(camera_.get()); }

void Camera::fail(const std::string& what, const GErrorSlot& error) const {
    throw AcquisitionError(label_ + ": " + what + ": " + error.message());
}

bool Camera::available(const char* feature) const {
    GErrorSlot error;
    const bool yes = arv_camera_is_feature_available(camera_.get(), feature, error.out()) != FALSE;
    return yes && !error;
}

void Camera::checkBounds(const char* feature, const std::string& configName, double value) const {
    GErrorSlot error;
    double lo = 0.0;
    double hi = 0.0;
    ArvGcNode* node = arv_device_get_feature(arvDevice(), feature);
    if (node != nullptr && ARV_IS_GC_INTEGER(node)) {
        gint64 ilo = 0;
        gint64 ihi = 0;
        arv_camera_get_integer_bounds(camera_.get(), feature, &ilo, &ihi, error.out());
        lo = static_cast<double>(ilo);
        hi = static_cast<double>(ihi);
    } else {
        arv_camera_get_float_bounds(camera_.get(), feature, &lo, &hi, error.out());
    }
    check(std::string("cannot read the range of ") + feature, error);
    if (!(value >= lo && value <= hi))
        throw InvalidArgument(label_ + ": " + configName + " " + number(value) + " is outside the camera's range " +
                              number(lo) + ".." + number(hi) + " (" + feature + ")");
}

double Camera::getNumber(const char* feature) const {
    GErrorSlot error;
    double value = 0.0;
    ArvGcNode* node = arv_device_get_feature(arvDevice(), feature);
    if (node != nullptr && ARV_IS_GC_INTEGER(node))
        value = static_cast<double>(arv_camera_get_integer(camera_.get(), feature, error.out()));
    else
        value = arv_camera_get_float(camera_.get(), feature, error.out());
    check(std::string("cannot read ") + feature, error);
    return value;
}

void Camera::setNumber(const char* feature, double value) {
    GErrorSlot error;
    ArvGcNode* node = arv_device_get_feature(arvDevice(), feature);
    if (node != nullptr && ARV_IS_GC_INTEGER(node))
        arv_camera_set_integer(camera_.get(), feature, static_cast<gint64>(std::llround(value)), error.out());
    else
        arv_camera_set_float(camera_.get(), feature, value, error.out());
    check(std::string("cannot set ") + feature + " to " + number(value), error);
}

void Camera::setEnum(const char* feature, const char* value) {
    GErrorSlot error;
    arv_camera_set_string(camera_.get(), feature, value, error.out());
    check(std::string("cannot set ") + feature + " to " + value, error);
}

void Camera::setAutoMode(const char* feature, bool automatic) { setEnum(feature, automatic ? "Continuous" : "Off"); }

Geometry Camera::plan(const CameraRequest& request) const {
    const CameraHardwareConfig& hw = request.hardware;
    ArvCamera* cam = camera_.get();
    GErrorSlot error;
    Geometry g;

    // Pixel format: the first candidate the camera offers.
    const std::vector<std::string> candidates = genicamPixelFormatCandidates(hw);
    guint n = 0;
    const char** formats = arv_camera_dup_available_pixel_formats_as_strings(cam, &n, error.out());
    check("cannot list pixel formats", error);
    std::vector<std::string> offered;
    for (guint i = 0; i < n; ++i) offered.push_back(text(formats[i]));
    g_free(static_cast<gpointer>(formats));
    for (const auto& c : candidates) {
        if (std::find(offered.begin(), offered.end(), c) != offered.end()) {
            g.pixelFormat = c;
            break;
        }
    }
    if (g.pixelFormat.empty()) {
        std::string layout = hw.channels == 3 ? "colour" : hw.bayer ? "Bayer " + std::string(toString(hw.bayerPattern)) : "mono";
        throw AcquisitionError(label_ + " cannot deliver " + std::to_string(hw.bitDepth) + "-bit " + layout +
                               " images: it offers no " + join(candidates, " or ") + " (it offers " +
                               (offered.empty() ? std::string("nothing") : join(offered, ", ")) + ")");
    }

    // Size, centred on the sensor.
    gint wmin = 0;
    gint wmax = 0;
    gint hmin = 0;
    gint hmax = 0;
    arv_camera_get_width_bounds(cam, &wmin, &wmax, error.out());
    check("cannot read the width range", error);
    arv_camera_get_height_bounds(cam, &hmin, &hmax, error.out());
    check("cannot read the height range", error);
    const gint winc = std::max(1, arv_camera_get_width_increment(cam, nullptr));
    const gint hinc = std::max(1, arv_camera_get_height_increment(cam, nullptr));
    gint sensorW = wmax;
    gint sensorH = hmax;
    if (available("SensorWidth")) sensorW = static_cast<gint>(arv_camera_get_integer(cam, "SensorWidth", nullptr));
    if (available("SensorHeight")) sensorH = static_cast<gint>(arv_camera_get_integer(cam, "SensorHeight", nullptr));
    sensorW = std::max(sensorW, wmax);
    sensorH = std::max(sensorH, hmax);
    auto checkSize = [&](const char* what, int v, gint lo, gint hi, gint inc) {
        if (v < lo || v > hi || (v - lo) % inc != 0)
            throw AcquisitionError(label_ + " cannot deliver " + what + " " + std::to_string(v) + " px: it allows " +
                                   std::to_string(lo) + ".." + std::to_string(hi) +
                                   (inc > 1 ? " in steps of " + std::to_string(inc) : std::string()));
    };
    checkSize("width", hw.width, wmin, sensorW, winc);
    checkSize("height", hw.height, hmin, sensorH, hinc);
    g.width = hw.width;
    g.height = hw.height;
    GErrorSlot offsetError;
    if (arv_camera_is_region_offset_available(cam, offsetError.out()) != FALSE && !offsetError) {
        const gint xinc = std::max(1, arv_camera_get_x_offset_increment(cam, nullptr));
        const gint yinc = std::max(1, arv_camera_get_y_offset_increment(cam, nullptr));
        g.offsetX = (sensorW - g.width) / 2 / xinc * xinc;
        g.offsetY = (sensorH - g.height) / 2 / yinc * yinc;
    }

    // Feature values the camera has must lie in its ranges.
    const CameraFeatureSet& f = hw.features;
    if (!f.exposure.automatic && arv_camera_is_exposure_time_available(cam, nullptr) != FALSE) {
        double lo = 0.0;
        double hi = 0.0;
        arv_camera_get_exposure_time_bounds(cam, &lo, &hi, error.out());
        check("cannot read the exposure time range", error);
        if (!(f.exposure.value >= lo && f.exposure.value <= hi))
            throw InvalidArgument(label_ + ": exposure " + number(f.exposure.value) +
                                  " us is outside the camera's range " + number(lo) + ".." + number(hi) + " us");
    }
    if (!f.gain.automatic && arv_camera_is_gain_available(cam, nullptr) != FALSE) {
        double lo = 0.0;
        double hi = 0.0;
        arv_camera_get_gain_bounds(cam, &lo, &hi, error.out());
        check("cannot read the gain range", error);
        if (!(f.gain.value >= lo && f.gain.value <= hi))
            throw InvalidArgument(label_ + ": gain " + number(f.gain.value) + " is outside the camera's range " +
                                  number(lo) + ".." + number(hi));
    }
    if (!f.brightness.automatic && available("BlackLevel")) checkBounds("BlackLevel", "brightness", f.brightness.value);
    if (!f.gamma.automatic && available("Gamma")) checkBounds("Gamma", "gamma", f.gamma.value);
    if (request.frameRateHz && available("AcquisitionFrameRate"))
        checkBounds("AcquisitionFrameRate", "frame rate", *request.frameRateHz);
    return g;
}

void Camera::applyGeometry(const Geometry& g) {
    ArvCamera* cam = camera_.get();
    GErrorSlot error;
    geometry_.reset();  // unknown until every write succeeded
    const bool offsets = available("OffsetX") && available("OffsetY");
    if (offsets) {  // the largest width/height may depend on the offsets
        arv_camera_set_integer(cam, "OffsetX", 0, error.out());
        check("cannot set OffsetX", error);
        arv_camera_set_integer(cam, "OffsetY", 0, error.out());
        check("cannot set OffsetY", error);
    }
    arv_camera_set_pixel_format_from_string(cam, g.pixelFormat.c_str(), error.out());
    check("cannot set PixelFormat to " + g.pixelFormat, error);
    arv_camera_set_integer(cam, "Width", g.width, error.out());
    check("cannot set Width to " + std::to_string(g.width), error);
    arv_camera_set_integer(cam, "Height", g.height, error.out());
    check("cannot set Height to " + std::to_string(g.height), error);
    if (offsets) {
        arv_camera_set_integer(cam, "OffsetX", g.offsetX, error.out());
        check("cannot set OffsetX to " + std::to_string(g.offsetX), error);
        arv_camera_set_integer(cam, "OffsetY", g.offsetY, error.out());
        check("cannot set OffsetY to " + std::to_string(g.offsetY), error);
    }
    arvPixelFormat_ = arv_camera_get_pixel_format(cam, error.out());
    check("cannot read back PixelFormat", error);
    arv_camera_set_acquisition_mode(cam, ARV_ACQUISITION_MODE_CONTINUOUS, error.out());
    check("cannot set AcquisitionMode to Continuous", error);
    if (available("TriggerMode")) {  // free-running: a camera left in trigger mode would send nothing
        arv_camera_clear_triggers(cam, error.out());
        check("cannot switch triggers off", error);
    }
    geometry_ = g;
    logger().info("%s: %dx%d at (%d,%d), %s", label_.c_str(), g.width, g.height, g.offsetX, g.offsetY,
                  g.pixelFormat.c_str());
}

void Camera::applyFeatures(const CameraRequest& request, FeatureReporter& reporter) {
    ArvCamera* cam = camera_.get();
    const CameraHardwareConfig& hw = request.hardware;
    const CameraFeatureSet& f = hw.features;
    const std::string& id = device_.id;
    GErrorSlot error;

    // exposure -> ExposureTime (us), ExposureAuto
    const bool exposureAuto = arv_camera_is_exposure_auto_available(cam, nullptr) != FALSE;
    if (f.exposure.automatic) {
        if (exposureAuto) {
            arv_camera_set_exposure_time_auto(cam, ARV_AUTO_CONTINUOUS, error.out());
            check("cannot set ExposureAuto to Continuous", error);
        } else {
            reporter.missing(label_, id, "exposure", "ExposureAuto");
        }
    } else {
        if (exposureAuto) {
            arv_camera_set_exposure_time_auto(cam, ARV_AUTO_OFF, error.out());
            check("cannot set ExposureAuto to Off", error);
        }
        if (arv_camera_is_exposure_time_available(cam, nullptr) != FALSE) {
            arv_camera_set_exposure_time(cam, f.exposure.value, error.out());
            check("cannot set the exposure time to " + number(f.exposure.value) + " us", error);
        } else {
            reporter.missing(label_, id, "exposure", "ExposureTime");
        }
    }

    // gain -> Gain (or GainRaw), GainAuto
    const bool gainAuto = arv_camera_is_gain_auto_available(cam, nullptr) != FALSE;
    if (f.gain.automatic) {
        if (gainAuto) {
            arv_camera_set_gain_auto(cam, ARV_AUTO_CONTINUOUS, error.out());
            check("cannot set GainAuto to Continuous", error);
        } else {
            reporter.missing(label_, id, "gain", "GainAuto");
        }
    } else {
        if (gainAuto) {
            arv_camera_set_gain_auto(cam, ARV_AUTO_OFF, error.out());
            check("cannot set GainAuto to Off", error);
        }
        if (arv_camera_is_gain_available(cam, nullptr) != FALSE) {
            arv_camera_set_gain(cam, f.gain.value, error.out());
            check("cannot set the gain to " + number(f.gain.value), error);
        } else {
            reporter.missing(label_, id, "gain", "Gain");
        }
    }

    // whiteBalance -> BalanceWhiteAuto, BalanceRatio[Red|Blue]; colour images only
    if (hw.bayer || hw.channels == 3) {
        const WhiteBalance& wb = f.whiteBalance;
        const bool wbAuto = available("BalanceWhiteAuto");
        if (wb.automatic) {
            if (wbAuto)
                setAutoMode("BalanceWhiteAuto", true);
            else
                reporter.missing(label_, id, "whiteBalance", "BalanceWhiteAuto");
        } else {
            if (wbAuto) setAutoMode("BalanceWhiteAuto", false);
            if (available("BalanceRatioSelector") && available("BalanceRatio")) {
                setEnum("BalanceRatioSelector", "Red");
                setNumber("BalanceRatio", wb.redV);
                setEnum("BalanceRatioSelector", "Blue");
                setNumber("BalanceRatio", wb.blueU);
            } else {
                reporter.missing(label_, id, "whiteBalance", "BalanceRatio");
            }
        }
    }

    // brightness -> BlackLevel, BlackLevelAuto
    if (f.brightness.automatic) {
        if (available("BlackLevelAuto"))
            setAutoMode("BlackLevelAuto", true);
        else
            reporter.missing(label_, id, "brightness", "BlackLevelAuto");
    } else {
        if (available("BlackLevelAuto")) setAutoMode("BlackLevelAuto", false);
        if (available("BlackLevel"))
            setNumber("BlackLevel", f.brightness.value);
        else
            reporter.missing(label_, id, "brightness", "BlackLevel");
    }

    // gamma -> Gamma (GammaEnable on); GenICam has no automatic gamma
    if (f.gamma.automatic) {
        reporter.missing(label_, id, "gamma", "automatic gamma");
    } else if (available("Gamma")) {
        if (available("GammaEnable")) {
            arv_camera_set_boolean(cam, "GammaEnable", TRUE, error.out());
            check("cannot set GammaEnable", error);
        }
        setNumber("Gamma", f.gamma.value);
    } else {
        reporter.missing(label_, id, "gamma", "Gamma");
    }

    if (request.frameRateHz) {
        if (arv_camera_is_frame_rate_available(cam, nullptr) != FALSE) {
            arv_camera_set_frame_rate(cam, *request.frameRateHz, error.out());
            check("cannot set the frame rate to " + number(*request.frameRateHz) + " Hz", error);
        } else {
            reporter.missing(label_, id, "frameRate", "AcquisitionFrameRate");
        }
    }
}

void Camera::start(int bufferCount) {
    if (stream_) return;
    ArvCamera* cam = camera_.get();
    GErrorSlot error;
    const guint payload = arv_camera_get_payload(cam, error.out());
    check("cannot read the payload size", error);
    GObjectPtr<ArvStream> stream(arv_camera_create_stream(cam, nullptr, nullptr, error.out()));
    if (error || !stream) fail("cannot create the stream", error);
    if (ARV_IS_GV_STREAM(stream.get())) {
        // Without a socket buffer sized to the payload and packet resend,
        // frames arrive incomplete as soon as the host is busy (even on loopback).
        g_object_set(stream.get(), "socket-buffer", ARV_GV_STREAM_SOCKET_BUFFER_AUTO, "packet-resend",
                     ARV_GV_STREAM_PACKET_RESEND_ALWAYS, nullptr);
    }
    for (int i = 0; i < bufferCount; ++i) arv_stream_push_buffer(stream.get(), arv_buffer_new_allocate(payload));
    stream_ = std::move(stream);
    arv_camera_start_acquisition(cam, error.out());
    if (error) {
        stream_.reset();
        fail("cannot start acquisition", error);
    }
    logger().info("%s: streaming, %d buffers of %u bytes", label_.c_str(), bufferCount, payload);
}

void Camera::stop() {
    if (!stream_) return;
    GErrorSlot error;
    if (!abandoned_) arv_camera_stop_acquisition(camera_.get(), error.out());
    if (error) logger().warn("%s: stopping acquisition: %s", label_.c_str(), error.message().c_str());
    stream_.reset();  // stops the receiving thread and frees the pool
}

void Camera::flush(std::uint64_t& incomplete) {
    if (!stream_) return;
    while (ArvBuffer* b = arv_stream_try_pop_buffer(stream_.get())) {
        if (arv_buffer_get_status(b) != ARV_BUFFER_STATUS_SUCCESS) ++incomplete;
        arv_stream_push_buffer(stream_.get(), b);
    }
}

PopResult Camera::pop(std::chrono::microseconds timeout) {
    PopResult result;
    if (!stream_) return result;
    const auto deadline = std::chrono::steady_clock::now() + timeout;
    for (;;) {
        const auto left =
            std::chrono::duration_cast<std::chrono::microseconds>(deadline - std::chrono::steady_clock::now());
        if (left.count() <= 0) return result;
        ArvBuffer* b = arv_stream_timeout_pop_buffer(stream_.get(), static_cast<guint64>(left.count()));
        if (b == nullptr) return result;
        const ArvBufferStatus status = arv_buffer_get_status(b);
        if (status == ARV_BUFFER_STATUS_SUCCESS) {
            g_object_ref(stream_.get());  // HeldBuffer keeps the stream alive
            result.buffer = HeldBuffer(stream_.get(), b);
            return result;
        }
        ++result.incomplete;
        result.lastIncomplete = bufferStatusName(status);
        arv_stream_push_buffer(stream_.get(), b);
    }
}

cv::Mat Camera::copyImage(const HeldBuffer& held, bool endianSwap) const {
    ArvBuffer* b = held.get();
    if (b == nullptr || !geometry_) throw AcquisitionError(label_ + ": no frame to copy");
    const ArvBufferPayloadType type = arv_buffer_get_payload_type(b);
    if (type != ARV_BUFFER_PAYLOAD_TYPE_IMAGE && type != ARV_BUFFER_PAYLOAD_TYPE_EXTENDED_CHUNK_DATA)
        throw AcquisitionError(label_ + ": frame carries no image (payload type " +
                               std::to_string(static_cast<int>(type)) + ")");
    const int w = arv_buffer_get_image_width(b);
    const int h = arv_buffer_get_image_height(b);
    const ArvPixelFormat pf = arv_buffer_get_image_pixel_format(b);
    if (w != geometry_->width || h != geometry_->height || pf != arvPixelFormat_)
        throw AcquisitionError(label_ + ": frame is " + std::to_string(w) + "x" + std::to_string(h) +
                               " in pixel format 0x" + [&] {
                                   std::ostringstream os;
                                   os << std::hex << pf;
                                   return os.str();
                               }() + ", but the camera is set to " + std::to_string(geometry_->width) + "x" +
                               std::to_string(geometry_->height) + " " + geometry_->pixelFormat);
    const int bytesPerPixel = static_cast<int>(ARV_PIXEL_FORMAT_BIT_PER_PIXEL(pf)) / 8;
    int cvType = 0;
    switch (bytesPerPixel) {
        case 1: cvType = CV_8UC1; break;
        case 2: cvType = CV_16UC1; break;
        case 3: cvType = CV_8UC3; break;
        default:
            throw AcquisitionError(label_ + ": pixel format " + geometry_->pixelFormat + " has " +
                                   std::to_string(bytesPerPixel) + " bytes per pixel, which AVATAR does not handle");
    }
    size_t size = 0;
    const void* data = arv_buffer_get_image_data(b, &size);
    gint padX = 0;
    gint padY = 0;
    arv_buffer_get_image_padding(b, &padX, &padY);
    const size_t row = static_cast<size_t>(w) * static_cast<size_t>(bytesPerPixel);
    const size_t step = row + static_cast<size_t>(std::max(0, padX));
    if (data == nullptr || size < step * static_cast<size_t>(h - 1) + row)
        throw AcquisitionError(label_ + ": frame holds " + std::to_string(size) + " bytes, " + std::to_string(w) +
                               "x" + std::to_string(h) + " " + geometry_->pixelFormat + " needs " +
                               std::to_string(step * static_cast<size_t>(h - 1) + row));
    // The pool buffer goes back to the stream after this, so copy.
    const cv::Mat view(h, w, cvType, const_cast<void*>(data), step);
    cv::Mat image;
    if (geometry_->pixelFormat.rfind("RGB", 0) == 0) {
        image.create(h, w, CV_8UC3);
        const int fromTo[] = {0, 2, 1, 1, 2, 0};
        cv::mixChannels(&view, 1, &image, 1, fromTo, 3);
    } else {
        image = view.clone();
    }
    if (endianSwap && image.depth() == CV_16U) {
        for (int y = 0; y < image.rows; ++y) {
            auto* p = image.ptr<std::uint16_t>(y);
            for (int x = 0; x < image.cols * image.channels(); ++x)
                p[x] = static_cast<std::uint16_t>((p[x] >> 8) | (p[x] << 8));
        }
    }
    return image;
}

GenICamReadback Camera::readBack() const {
    ArvCamera* cam = camera_.get();
    GErrorSlot error;
    GenICamReadback r;
    r.deviceId = device_.id;
    r.address = device_.address;
    arv_camera_get_region(cam, &r.offsetX, &r.offsetY, &r.width, &r.height, error.out());
    check("cannot read the region", error);
    r.pixelFormat = text(arv_camera_get_pixel_format_as_string(cam, error.out()));
    check("cannot read PixelFormat", error);
    if (arv_camera_is_exposure_time_available(cam, nullptr) != FALSE) {
        r.exposureUs = arv_camera_get_exposure_time(cam, error.out());
        check("cannot read the exposure time", error);
    }
    if (arv_camera_is_exposure_auto_available(cam, nullptr) != FALSE) {
        r.exposureAuto = arv_camera_get_exposure_time_auto(cam, error.out()) != ARV_AUTO_OFF;
        check("cannot read ExposureAuto", error);
    }
    if (arv_camera_is_gain_available(cam, nullptr) != FALSE) {
        r.gain = arv_camera_get_gain(cam, error.out());
        check("cannot read the gain", error);
    }
    if (arv_camera_is_gain_auto_available(cam, nullptr) != FALSE) {
        r.gainAuto = arv_camera_get_gain_auto(cam, error.out()) != ARV_AUTO_OFF;
        check("cannot read GainAuto", error);
    }
    if (arv_camera_is_frame_rate_available(cam, nullptr) != FALSE) {
        r.frameRateHz = arv_camera_get_frame_rate(cam, error.out());
        check("cannot read the frame rate", error);
    }
    return r;
}

CameraFeatureReadback Camera::readFeatures() const {
    ArvCamera* cam = camera_.get();
    GErrorSlot error;
    CameraFeatureReadback r;
    r.side = side_;
    const auto notes = [](std::initializer_list<std::string> parts) {
        std::string out;
        for (const auto& p : parts)
            if (!p.empty()) out += (out.empty() ? "" : "; ") + p;
        return out;
    };
    const auto isAuto = [&](const char* feature) {
        const std::string mode = text(arv_camera_get_string(cam, feature, error.out()));
        check(std::string("cannot read ") + feature, error);
        return mode != "Off";
    };

    // exposure -> ExposureTime (or ExposureTimeAbs), ExposureAuto
    FeatureReading exposure;
    exposure.name = "exposure";
    exposure.present = arv_camera_is_exposure_time_available(cam, nullptr) != FALSE;
    exposure.autoAvailable = arv_camera_is_exposure_auto_available(cam, nullptr) != FALSE;
    if (exposure.present) {
        exposure.value = arv_camera_get_exposure_time(cam, error.out());
        check("cannot read the exposure time", error);
    }
    if (exposure.autoAvailable) {
        exposure.automatic = arv_camera_get_exposure_time_auto(cam, error.out()) != ARV_AUTO_OFF;
        check("cannot read ExposureAuto", error);
    }
    exposure.note = notes({exposure.present ? "" : "no ExposureTime", exposure.autoAvailable ? "" : "no ExposureAuto"});

    // shutter: an IIDC register with no GenICam counterpart
    FeatureReading shutter;
    shutter.name = "shutter";
    shutter.note = "an IIDC feature: on GenICam <exposure> is the integration time";

    // gain -> Gain (or GainRaw), GainAuto
    FeatureReading gain;
    gain.name = "gain";
    gain.present = arv_camera_is_gain_available(cam, nullptr) != FALSE;
    gain.autoAvailable = arv_camera_is_gain_auto_available(cam, nullptr) != FALSE;
    if (gain.present) {
        gain.value = arv_camera_get_gain(cam, error.out());
        check("cannot read the gain", error);
    }
    if (gain.autoAvailable) {
        gain.automatic = arv_camera_get_gain_auto(cam, error.out()) != ARV_AUTO_OFF;
        check("cannot read GainAuto", error);
    }
    gain.note = notes({gain.present ? "" : "no Gain", gain.autoAvailable ? "" : "no GainAuto"});

    // whiteBalance -> BalanceRatioSelector Red/Blue + BalanceRatio, BalanceWhiteAuto
    FeatureReading wb;
    wb.name = "whiteBalance";
    wb.present = available("BalanceRatioSelector") && available("BalanceRatio");
    wb.autoAvailable = available("BalanceWhiteAuto");
    if (wb.present) {
        arv_camera_set_string(cam, "BalanceRatioSelector", "Red", error.out());
        check("cannot set BalanceRatioSelector to Red", error);
        wb.redV = getNumber("BalanceRatio");
        arv_camera_set_string(cam, "BalanceRatioSelector", "Blue", error.out());
        check("cannot set BalanceRatioSelector to Blue", error);
        wb.value = getNumber("BalanceRatio");
    }
    if (wb.autoAvailable) wb.automatic = isAuto("BalanceWhiteAuto");
    wb.note = notes({wb.present ? "" : "no BalanceRatio", wb.autoAvailable ? "" : "no BalanceWhiteAuto"});

    // brightness -> BlackLevel, BlackLevelAuto
    FeatureReading brightness;
    brightness.name = "brightness";
    brightness.present = available("BlackLevel");
    brightness.autoAvailable = available("BlackLevelAuto");
    if (brightness.present) brightness.value = getNumber("BlackLevel");
    if (brightness.autoAvailable) brightness.automatic = isAuto("BlackLevelAuto");
    brightness.note =
        notes({brightness.present ? "" : "no BlackLevel", brightness.autoAvailable ? "" : "no BlackLevelAuto"});

    // gamma -> Gamma; never automatic
    FeatureReading gamma;
    gamma.name = "gamma";
    gamma.present = available("Gamma");
    if (gamma.present) gamma.value = getNumber("Gamma");
    gamma.note = notes({gamma.present ? "" : "no Gamma", "GenICam has no automatic gamma"});

    r.features = {exposure, shutter, gain, wb, brightness, gamma};
    return r;
}

}  // namespace avatar::genicam
