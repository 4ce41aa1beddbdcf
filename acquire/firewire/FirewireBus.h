#pragma once
/// @file FirewireBus.h
/// Internal to avatar::acquire (not installed; the tests reach it).
/// The seam between AvatarCameras and libdc1394 (thesis 4.2.2, 4.5.1).
///
/// Everything AvatarCameras needs from an IEEE 1394 bus is in the two small
/// interfaces below. The real implementation (makeDc1394Bus(), in
/// Dc1394Bus.cpp) is the only code that calls libdc1394; the tests drive
/// AvatarCameras through a scripted bus that implements the same interfaces.
///
/// Error policy of the seam: calls never throw for bus or camera trouble; they
/// return a BusStatus with a code and the library's own words, and AvatarCameras
/// turns them into AcquisitionError messages that name the camera. (They may
/// throw std::bad_alloc.)

#include <chrono>
#include <cstddef>
#include <cstdint>
#include <memory>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

namespace avatar {

/// IIDC globally unique id of a camera (64 bits).
using FirewireGuid = std::uint64_t;

/// "0x00b09d01004a2c1f": 0x and 16 lower-case hex digits (the spelling of
/// CameraHardwareConfig::leftCameraId / rightCameraId).
std::string formatGuid(FirewireGuid guid);
/// Parses "0x" followed by 1 to 16 hex digits (any case); nullopt otherwise.
std::optional<FirewireGuid> parseGuid(std::string_view text);

/// Outcome of one call across the seam.
class BusStatus {
public:
    enum class Code {
        Ok,
        Timeout,      ///< no frame within the time asked for
        NotFound,     ///< no such camera, or nothing on the bus to act through
        Unavailable,  ///< no FireWire support (library could not start, no kernel driver)
        Rejected,     ///< the camera refused a setting (mode, ROI, feature value)
        Failure       ///< anything else the library reported
    };
    BusStatus() = default;
    static BusStatus ok() { return {}; }
    static BusStatus error(Code code, std::string detail) { return BusStatus(code, std::move(detail)); }

    bool isOk() const { return code_ == Code::Ok; }
    Code code() const { return code_; }
    /// What went wrong, in the bus's words; empty when Ok.
    const std::string& detail() const { return detail_; }

private:
    BusStatus(Code code, std::string detail) : code_(code), detail_(std::move(detail)) {}
    Code code_{Code::Ok};
    std::string detail_;
};

/// "ok", "timeout", "not found", "unavailable", "rejected", "failure".
std::string_view toString(BusStatus::Code code);

/// IIDC colour codings AVATAR uses in Format7.
enum class PixelCoding { Mono8, Mono16, Raw8, Raw16, Rgb8, Rgb16 };
/// "MONO8", "MONO16", "RAW8", "RAW16", "RGB8", "RGB16" (the IIDC names).
std::string_view toString(PixelCoding coding);
/// Bytes per pixel of @p coding: 1, 2, 3 or 6.
int bytesPerPixel(PixelCoding coding);

/// A Format7 region of interest and its coding.
struct Format7Settings {
    int left{0};    ///< px from the sensor's left edge
    int top{0};     ///< px from the sensor's top edge
    int width{0};   ///< px
    int height{0};  ///< px
    PixelCoding coding{PixelCoding::Raw16};
    bool operator==(const Format7Settings& o) const {
        return left == o.left && top == o.top && width == o.width && height == o.height && coding == o.coding;
    }
    bool operator!=(const Format7Settings& o) const { return !(*this == o); }
};

/// The single-valued IIDC features of the AVATAR feature set (white balance,
/// which has two values, has its own call).
enum class FirewireFeature { Exposure, Shutter, Gain, Brightness, Gamma };
/// "exposure", "shutter", "gain", "brightness", "gamma".
std::string_view toString(FirewireFeature feature);

/// What a camera reports for one feature (FirewireCamera::getFeature(),
/// getWhiteBalance()).
struct FeatureState {
    /// Ok; NotFound when the camera does not have the feature; anything else
    /// when it could not be asked.
    BusStatus status;
    bool autoAvailable{false};  ///< the camera has an automatic mode for it
    bool automatic{false};      ///< it is in automatic mode now
    std::uint32_t value{0};     ///< the current value (white balance: blue/U)
    std::uint32_t redV{0};      ///< white balance only: red/V
};

/// One captured frame. The pixels live in a DMA buffer owned by the camera:
/// they stay valid until the frame is given back with FirewireCamera::enqueue(),
/// capture stops, or the camera is destroyed, whichever comes first.
struct FirewireFrame {
    std::uint8_t* data{nullptr};  ///< first pixel of the first row
    std::size_t bytes{0};         ///< usable bytes from data (at least stride * (height - 1) + row bytes)
    int width{0};                 ///< px
    int height{0};                ///< px
    std::size_t stride{0};        ///< bytes from one row to the next
    std::int64_t timestampUs{0};  ///< when the frame was captured, microseconds since the Unix epoch
    std::uint32_t bufferId{0};    ///< position in the camera's DMA ring; identifies the frame for enqueue()
};

/// A frame, or why there is none (Timeout when the camera sent nothing in time).
struct DequeueResult {
    BusStatus status;
    FirewireFrame frame;  ///< meaningful only when status.isOk()
};

/// One opened camera. Destroying it stops capture and releases the camera.
/// Not thread-safe: one thread drives a camera.
class FirewireCamera {
public:
    virtual ~FirewireCamera() = default;
    FirewireCamera(const FirewireCamera&) = delete;
    FirewireCamera& operator=(const FirewireCamera&) = delete;

    virtual FirewireGuid guid() const = 0;
    /// Selects Format7 mode 0 with @p settings. Only while not capturing.
    virtual BusStatus setFormat7(const Format7Settings& settings) = 0;
    /// Sets @p feature to manual @p value, or lets the camera adjust it
    /// (@p automatic; the value is then not written). NotFound when the
    /// camera does not have the feature, or (@p automatic) has no automatic
    /// mode for it: AvatarCameras then skips it and reports it (a camera that
    /// lacks a feature is not an error).
    virtual BusStatus setFeature(FirewireFeature feature, std::uint32_t value, bool automatic) = 0;
    /// White balance: blue/U and red/V components, or automatic. NotFound as setFeature().
    virtual BusStatus setWhiteBalance(std::uint32_t blueU, std::uint32_t redV, bool automatic) = 0;
    /// What the camera reports for @p feature now (its value as the camera
    /// adjusted it, in automatic mode).
    virtual FeatureState getFeature(FirewireFeature feature) = 0;
    /// What the camera reports for its white balance now.
    virtual FeatureState getWhiteBalance() = 0;
    /// Allocates @p dmaBuffers DMA buffers and starts isochronous transmission.
    virtual BusStatus startCapture(std::uint32_t dmaBuffers) = 0;
    /// The oldest captured frame not yet dequeued, waiting up to @p timeout.
    virtual DequeueResult dequeue(std::chrono::milliseconds timeout) = 0;
    /// Gives a dequeued frame's buffer back to the DMA ring.
    virtual BusStatus enqueue(const FirewireFrame& frame) = 0;
    /// Stops transmission and frees the DMA buffers; Ok when not capturing.
    virtual BusStatus stopCapture() = 0;

protected:
    FirewireCamera() = default;
};

/// Result of FirewireBus::enumerate().
struct Enumeration {
    BusStatus status;
    std::vector<FirewireGuid> guids;  ///< in bus order; the same GUID twice means a misrecognised camera
};

/// Result of FirewireBus::open().
struct OpenResult {
    BusStatus status;
    std::unique_ptr<FirewireCamera> camera;  ///< set when status.isOk(); the caller owns it
};

/// An IEEE 1394 bus (all host adapters). Not thread-safe.
class FirewireBus {
public:
    virtual ~FirewireBus() = default;
    FirewireBus(const FirewireBus&) = delete;
    FirewireBus& operator=(const FirewireBus&) = delete;

    /// "libdc1394" for the real bus.
    virtual std::string name() const = 0;
    /// The GUIDs of the cameras on the bus now.
    virtual Enumeration enumerate() = 0;
    /// "<vendor> <model>" as the camera with @p guid reports them; empty when
    /// it cannot be asked (not on the bus, no FireWire support).
    virtual std::string describe(FirewireGuid guid) = 0;
    /// Opens the camera with @p guid. A camera may outlive the bus object.
    virtual OpenResult open(FirewireGuid guid) = 0;
    /// Resets the bus: every node re-enumerates and isochronous channels and
    /// bandwidth are freed. Call with no camera capturing. NotFound when there
    /// is no camera to reset the bus through (libdc1394 resets through a camera).
    virtual BusStatus resetBus() = 0;

protected:
    FirewireBus() = default;
};

/// The real bus over libdc1394 (v2). Never throws for a missing bus: without
/// FireWire support every call returns a BusStatus saying so.
std::unique_ptr<FirewireBus> makeDc1394Bus();

}  // namespace avatar
