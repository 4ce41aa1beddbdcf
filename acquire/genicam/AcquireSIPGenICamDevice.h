#pragma once
// Private to avatar::acquire: one GenICam camera opened through Aravis, with its
// stream and buffer pool, and the RAII/GError plumbing around GLib. Only
// AcquireSIPGenICam.cpp and AcquireSIPGenICamDevice.cpp include this header.
//
// Error policy: every failure is an AcquisitionError whose message starts with
// the camera's label ("left camera Aravis-Fake-GV01") and carries the GError
// text; out-of-range configuration values are InvalidArgument.

#include <avatar/acquire/AcquireSIPGenICam.h>
#include <avatar/config/CameraHardwareConfig.h>

#include <arv.h>
#include <opencv2/core/mat.hpp>

#include <atomic>
#include <chrono>
#include <cstdint>
#include <memory>
#include <optional>
#include <string>
#include <vector>

namespace avatar::genicam {

/// Unreferences a GObject (ArvCamera, ArvStream, ArvBuffer...).
struct GObjectUnref {
    void operator()(void* object) const {
        if (object != nullptr) g_object_unref(object);
    }
};
template <class T>
using GObjectPtr = std::unique_ptr<T, GObjectUnref>;

/// Receives a GError from one Aravis call and frees it.
class GErrorSlot {
public:
    GErrorSlot() = default;
    ~GErrorSlot() { clear(); }
    GErrorSlot(const GErrorSlot&) = delete;
    GErrorSlot& operator=(const GErrorSlot&) = delete;
    GError** out() {
        clear();
        return &error_;
    }
    explicit operator bool() const { return error_ != nullptr; }
    std::string message() const { return error_ != nullptr && error_->message != nullptr ? error_->message : ""; }
    void clear() {
        if (error_ != nullptr) g_error_free(error_);
        error_ = nullptr;
    }

private:
    GError* error_{nullptr};
};

/// One camera as a discovery pass reports it.
struct DeviceInfo {
    std::string id;          ///< Aravis device id: "<vendor>-<serial>" (GigE Vision)
    std::string physicalId;  ///< MAC address (GigE Vision)
    std::string address;     ///< IP address (GigE Vision)
    std::string serial;
    std::string protocol;    ///< "GigEVision", "USB3Vision"
    std::string vendor;      ///< as discovery reports it, e.g. "Aravis"
    std::string model;       ///< as discovery reports it, e.g. "Fake"
    /// "Aravis-Fake-GV01 (127.0.0.1, GigEVision)"
    std::string describe() const;
};

/// One discovery pass over every Aravis interface (about 1 s for GigE Vision).
std::vector<DeviceInfo> discoverDevices();
/// The device @p wanted names: its id, serial, MAC or IP address (ids first).
std::optional<DeviceInfo> findDevice(const std::vector<DeviceInfo>& devices, const std::string& wanted);
/// "A (..), B (..)" or "none".
std::string describeDevices(const std::vector<DeviceInfo>& devices);
/// Opens @p device for a moment and closes it again: "" when it could be
/// opened (and fills @p vendor and @p model from the camera itself), else
/// Aravis's reason.
std::string probeDevice(const DeviceInfo& device, std::string& vendor, std::string& model);

/// Region of interest and pixel format of one camera.
struct Geometry {
    int width{0};
    int height{0};
    int offsetX{0};
    int offsetY{0};
    std::string pixelFormat;  ///< GenICam name
    bool operator==(const Geometry& o) const {
        return width == o.width && height == o.height && offsetX == o.offsetX && offsetY == o.offsetY &&
               pixelFormat == o.pixelFormat;
    }
    bool operator!=(const Geometry& o) const { return !(*this == o); }
};

/// What the camera part of the configuration asks of a GenICam camera.
struct CameraRequest {
    CameraHardwareConfig hardware;
    std::optional<double> frameRateHz;
};

/// Logs a camera's missing feature once per camera and feature, and throws
/// when the feature is required.
class FeatureReporter {
public:
    explicit FeatureReporter(std::vector<std::string> required) : required_(std::move(required)) {}
    /// @p feature is the config name ("exposure"), @p what the GenICam side
    /// ("ExposureAuto").
    void missing(const std::string& cameraLabel, const std::string& deviceId, const std::string& feature,
                 const std::string& what);

private:
    std::vector<std::string> required_;
    std::vector<std::string> reported_;
};

/// A buffer popped from a stream; goes back into the stream's pool when
/// destroyed. The stream must outlive it.
class HeldBuffer {
public:
    HeldBuffer() = default;
    HeldBuffer(ArvStream* stream, ArvBuffer* buffer) : stream_(stream), buffer_(buffer) {}
    ~HeldBuffer() { release(); }
    HeldBuffer(HeldBuffer&& o) noexcept : stream_(o.stream_), buffer_(o.buffer_) { o.buffer_ = nullptr; }
    HeldBuffer& operator=(HeldBuffer&& o) noexcept {
        if (this != &o) {
            release();
            stream_ = o.stream_;
            buffer_ = o.buffer_;
            o.buffer_ = nullptr;
        }
        return *this;
    }
    HeldBuffer(const HeldBuffer&) = delete;
    HeldBuffer& operator=(const HeldBuffer&) = delete;

    explicit operator bool() const { return buffer_ != nullptr; }
    ArvBuffer* get() const { return buffer_; }
    /// Host reception time, microseconds since the Unix epoch.
    std::int64_t systemTimestampUs() const;
    void release();

private:
    ArvStream* stream_{nullptr};
    ArvBuffer* buffer_{nullptr};
};

/// Outcome of waiting for a frame.
struct PopResult {
    HeldBuffer buffer;             ///< a complete frame, or empty on timeout
    std::uint64_t incomplete{0};   ///< buffers with another status, skipped and returned
    std::string lastIncomplete;    ///< status of the last one, e.g. "missing packets"
};

/// "success", "missing packets", "timeout"...
std::string bufferStatusName(ArvBufferStatus status);

/// One opened camera: control channel, stream and buffer pool.
class Camera {
public:
    /// Opens @p device (exclusive control). Throws AcquisitionError naming
    /// @p side and the device with Aravis's reason.
    Camera(Side side, const DeviceInfo& device);
    ~Camera();
    Camera(const Camera&) = delete;
    Camera& operator=(const Camera&) = delete;

    /// "left camera Aravis-Fake-GV01"
    const std::string& label() const { return label_; }
    const DeviceInfo& device() const { return device_; }
    Side side() const { return side_; }
    /// The heartbeat failed (Aravis's "control-lost" signal).
    bool controlLost() const { return controlLost_.load(); }

    /// Works out the geometry for @p hardware and checks everything it asks
    /// against this camera without changing anything: size, pixel format,
    /// feature values. Throws AcquisitionError / InvalidArgument.
    Geometry plan(const CameraRequest& request) const;
    /// Writes @p geometry. Only while not streaming.
    void applyGeometry(const Geometry& geometry);
    /// Writes the feature set and frame rate; works while streaming.
    void applyFeatures(const CameraRequest& request, FeatureReporter& reporter);
    const std::optional<Geometry>& geometry() const { return geometry_; }

    /// Creates the stream with @p bufferCount buffers (socket buffer auto,
    /// packet resend on) and starts continuous acquisition.
    void start(int bufferCount);
    /// Stops acquisition and drops the stream (errors logged: the camera may be gone).
    void stop();
    /// The camera has vanished: send it nothing more on stop(). Releasing a
    /// vanished GigE Vision camera still costs Aravis 0.8 about 2.5 s per
    /// register write it makes while closing (5 tries of 500 ms, not adjustable).
    void abandon() { abandoned_ = true; }
    bool streaming() const { return stream_ != nullptr; }

    /// Returns every frame waiting in the stream to the pool (stale frames).
    /// Counts incomplete ones into @p incomplete.
    void flush(std::uint64_t& incomplete);
    /// Waits up to @p timeout for the next complete frame.
    PopResult pop(std::chrono::microseconds timeout);

    /// Copies a frame into an owning image of the planned geometry
    /// (RGB8 → BGR, byte swap when @p endianSwap). Throws AcquisitionError when
    /// the buffer does not have the geometry and format in force.
    cv::Mat copyImage(const HeldBuffer& buffer, bool endianSwap) const;

    GenICamReadback readBack() const;
    /// The feature set as this camera reports it (cameraId left empty).
    /// Reading the white balance selects BalanceRatioSelector Red, then Blue:
    /// the one register this writes, which selects what BalanceRatio shows.
    CameraFeatureReadback readFeatures() const;

private:
    ArvDevice* arvDevice() const;
    bool available(const char* feature) const;
    [[noreturn]] void fail(const std::string& what, const GErrorSlot& error) const;
    void check(const std::string& what, const GErrorSlot& error) const {
        if (error) fail(what, error);
    }
    void checkBounds(const char* feature, const std::string& configName, double value) const;
    /// Reads a float or integer feature as a number.
    double getNumber(const char* feature) const;
    void setNumber(const char* feature, double value);
    void setEnum(const char* feature, const char* value);
    void setAutoMode(const char* feature, bool automatic);

    Side side_;
    DeviceInfo device_;
    std::string label_;
    GObjectPtr<ArvCamera> camera_;
    GObjectPtr<ArvStream> stream_;
    unsigned long controlLostHandler_{0};
    std::atomic<bool> controlLost_{false};
    bool abandoned_{false};
    std::optional<Geometry> geometry_;
    ArvPixelFormat arvPixelFormat_{0};
};

}  // namespace avatar::genicam
