#pragma once
/// @file AcquireSIPGenICam.h
/// Acquisition from two GenICam cameras (GigE Vision or USB3 Vision) through
/// the Aravis library: the modern counterpart of AcquireSIPFirewire (thesis
/// 4.2.2), with the same behaviour. See docs/acquisition.md, "GenICam (Aravis)".
///
/// Cameras are named by Aravis device id ("<vendor>-<serial>", e.g.
/// "Aravis-Fake-GV01"); a configured id may also be the camera's serial number,
/// its MAC address or its IP address. Both cameras stream continuously into a
/// pool of buffers; grab() pairs the newest left and right frames whose host
/// timestamps lie within GenICamOptions::pairTolerance and copies them into an
/// owning StereoImagePair (the buffers go straight back to the stream, which
/// refills them, so a view would not stay valid).
///
/// Error policy: as AcquireStereoImagePair. A camera that stops delivering
/// makes grab() throw an AcquisitionError naming it and turns status() to
/// Recovering; every later grab() makes one reconnection attempt (discover,
/// open, configure, start) for each lost camera, and after
/// GenICamOptions::reconnectAttempts failed attempts status() is Failed and
/// grab() throws at once until applyConfig() opens the cameras again.
///
/// No Aravis or GLib type appears here: users of avatar::acquire need neither
/// header. Not thread-safe: one thread acquires and configures.

#include <avatar/acquire/AcquireStereoImagePair.h>

#include <chrono>
#include <cstdint>
#include <memory>
#include <optional>
#include <string>
#include <vector>

namespace avatar {

/// How AcquireSIPGenICam finds, streams from and recovers the cameras.
struct GenICamOptions {
    /// Longest wait for the next frame of one camera before it counts as lost.
    std::chrono::milliseconds frameTimeout{2000};
    /// Largest difference between the left and right host timestamps of a pair.
    std::chrono::microseconds pairTolerance{10000};
    /// Longest time grab() spends dropping frames to find a matching pair.
    std::chrono::milliseconds pairTimeout{3000};
    /// Buffers in each camera's stream pool (2..64).
    int bufferCount{8};
    /// Device discovery passes before a camera is declared missing (1..20),
    /// with discoverySettle between them (a camera that was just plugged in or
    /// restarted may not answer the first one).
    int discoveryAttempts{3};
    std::chrono::milliseconds discoverySettle{500};
    /// Failed reconnection attempts after which status() is Failed (1..1000).
    int reconnectAttempts{5};
    /// Frame rate to set on the cameras (AcquisitionFrameRate), if given and
    /// the cameras have the feature; otherwise they keep their own.
    std::optional<double> frameRateHz;
    /// Config feature names ("exposure", "gain", "whiteBalance", "brightness",
    /// "gamma") whose absence on a camera is an error; other missing features
    /// are logged once and skipped.
    std::vector<std::string> requiredFeatures;

    /// Empty when the options are usable, else what is wrong with which field.
    std::string validate() const;
};

/// Counters since construction, for diagnostics and the daemon's STATUS.
struct GenICamStatistics {
    std::uint64_t pairs{0};              ///< pairs returned by grab()
    std::uint64_t incompleteFrames[2]{}; ///< left, right: buffers with a status other than success, skipped
    std::uint64_t unmatchedFrames[2]{};  ///< left, right: frames dropped because the other side had none close enough
    std::uint64_t cameraLosses{0};       ///< times a camera stopped delivering
    std::uint64_t reconnections{0};      ///< successful reconnections
};

/// What one camera reports it is doing now (read from the device).
struct GenICamReadback {
    std::string deviceId;     ///< Aravis device id, e.g. "Aravis-Fake-GV01"
    std::string address;      ///< e.g. "127.0.0.1" (empty for USB3 Vision)
    int width{0};
    int height{0};
    int offsetX{0};
    int offsetY{0};
    std::string pixelFormat;  ///< GenICam name, e.g. "Mono8", "BayerRG16"
    std::optional<double> exposureUs;
    std::optional<bool> exposureAuto;
    std::optional<double> gain;
    std::optional<bool> gainAuto;
    std::optional<double> frameRateHz;
};

/// The GenICam pixel formats that carry the camera part of a configuration,
/// in order of preference: "Mono<b>" or "Bayer<pattern><b>" for b = 8, 10, 12,
/// 14, 16 (unpacked, one sample per 8- or 16-bit container), "BGR8"/"RGB8" for
/// 3 channels. Throws avatar::InvalidArgument when no GenICam format carries
/// that bit depth and layout. Pure: needs no camera.
std::vector<std::string> genicamPixelFormatCandidates(const CameraHardwareConfig& camera);

class AcquireSIPGenICam : public AcquireStereoImagePair {
public:
    /// Opens and configures both cameras (see configure()) and starts them
    /// streaming. Throws avatar::InvalidArgument for unusable options or
    /// configuration, AcquisitionError when a camera is missing, cannot be
    /// opened or refuses a setting.
    explicit AcquireSIPGenICam(const AvatarConfig& config, GenICamOptions options = {},
                               std::uint32_t groupSize = 99999);
    ~AcquireSIPGenICam() override;

    std::string name() const override { return "genicam"; }
    AcquisitionStatus status() const override;

    GenICamStatistics statistics() const;
    /// Reads back what the camera on @p side is set to. Throws AcquisitionError
    /// when that camera is not open or does not answer.
    GenICamReadback readBack(Side side) const;

    /// The feature set of both cameras (AcquireStereoImagePair::readFeatures()):
    /// exposure is ExposureTime / ExposureAuto, gain Gain / GainAuto,
    /// whiteBalance BalanceRatio (Blue, Red) / BalanceWhiteAuto, brightness
    /// BlackLevel / BlackLevelAuto, gamma Gamma (never automatic); shutter is
    /// an IIDC feature and always reported missing. The camera ids are the
    /// configured ones. Throws AcquisitionError when a camera is not open
    /// (lost) or does not answer.
    std::array<CameraFeatureReadback, 2> readFeatures() const override;

    /// "id (address, protocol)" of every camera Aravis finds now (one
    /// discovery pass, about a second for GigE Vision).
    static std::vector<std::string> listDevices();

    /// What Aravis reaches now, for avatar-camtest (surveyBackend()): the
    /// Aravis version and interfaces, one discovery pass (a check that fails
    /// when it finds no camera), and every camera found with its vendor and
    /// model, opened for a moment to see that it answers (a camera another
    /// program controls, or one on another subnet, is listed as not
    /// reachable with Aravis's reason). Do not call while this process has
    /// the cameras open for acquisition.
    static BackendSurvey survey();

protected:
    AcquiredPair grab() override;
    /// Applies @p config: cameras by id (re-opened when an id changed),
    /// geometry and pixel format (the streams restart), features (applied to
    /// the running streams). On failure the cameras keep their previous
    /// settings. On a Failed backend it re-opens everything.
    void configure(const AvatarConfig& config) override;

private:
    struct Impl;
    std::unique_ptr<Impl> impl_;
};

}  // namespace avatar
