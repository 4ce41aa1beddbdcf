#pragma once
/// @file AvatarCameras.h
/// Internal to avatar::acquire (not installed; the tests reach it).
/// AvatarCameras: the stereo pair of IIDC cameras on a FireWire bus, made fit
/// for unattended operation (thesis 4.2.2, 4.5.1). It finds the left and right
/// camera by GUID, survives a bus that has not settled after a hot-plug or boot
/// (waits, re-enumerates, resets the bus a bounded number of times), captures
/// Format7 at the configured ROI and bit depth, applies the feature set, and
/// delivers only pairs whose two frames belong together. A camera that stops
/// delivering is named in an AcquisitionError and recovered (stop, bus reset,
/// re-open, restart) a bounded number of times before the status turns Failed.
///
/// All hardware access goes through the FirewireBus seam (FirewireBus.h).
/// Not thread-safe, except status(), which another thread may call.

#include "FirewireBus.h"

#include <avatar/acquire/AcquireSIPFirewire.h>
#include <avatar/acquire/AcquireStereoImagePair.h>
#include <avatar/config/CameraHardwareConfig.h>

#include <array>
#include <chrono>
#include <cstdint>
#include <functional>
#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

namespace avatar {

/// Counters for logs and the daemon's report.
struct FirewireDiagnostics {
    std::uint64_t enumerations{0};
    std::uint64_t busResets{0};
    std::uint64_t pairsGrabbed{0};
    std::uint64_t framesDroppedForSync{0};
    std::uint64_t cameraFailures{0};  ///< timeouts and capture errors
    std::uint64_t recoveries{0};      ///< successful recoveries
};

/// Both frames of one grab, borrowed from the cameras' DMA rings. Valid until
/// the next grabRawImagePair(), releaseFrames(), configure(), stop() or the
/// destruction of the AvatarCameras, whichever comes first.
struct RawFramePair {
    FirewireFrame left;
    FirewireFrame right;
    FirewireGuid leftGuid{0};
    FirewireGuid rightGuid{0};
};

class AvatarCameras {
public:
    /// Waits for the bus; the default sleeps the calling thread.
    using SleepFunction = FirewireSleepFunction;

    /// Takes over @p bus. Touches no hardware until configure(). Throws
    /// avatar::InvalidArgument with FirewireOptions::validate()'s message for
    /// bad options, or when @p bus is null.
    explicit AvatarCameras(std::unique_ptr<FirewireBus> bus, FirewireOptions options = {},
                           SleepFunction sleep = {});
    ~AvatarCameras();
    AvatarCameras(const AvatarCameras&) = delete;
    AvatarCameras& operator=(const AvatarCameras&) = delete;

    /// Throws avatar::InvalidArgument unless @p camera is usable over FireWire:
    /// both camera ids set, valid GUIDs and different; channels 1 (mono or
    /// Bayer) or 3; feature values integers in 0..4095 (IIDC).
    static void check(const CameraHardwareConfig& camera);
    /// The Format7 settings for @p camera: ROI at (0,0), coding RAW for Bayer,
    /// MONO for mono, RGB for 3 channels; 8-bit when bitDepth <= 8, else 16-bit.
    static Format7Settings format7For(const CameraHardwareConfig& camera);

    /// Brings the cameras to @p camera, doing as little as needed (see
    /// CameraChange): the first call finds, opens and starts both cameras.
    /// On failure throws (InvalidArgument for an unusable configuration, before
    /// touching anything; AcquisitionError naming the camera otherwise) and
    /// restores the previous settings; if even that fails, the next grab
    /// recovers. Frames of the previous grab are released.
    CameraChange configure(const CameraHardwareConfig& camera);

    /// Stops capture and releases both cameras; configure() starts them again.
    void stop();
    bool running() const { return active_.has_value(); }
    /// The settings in force; nullopt when not running.
    const std::optional<CameraHardwareConfig>& settings() const { return active_; }

    /// Dequeues one frame from each camera and returns them when their
    /// timestamps are within the tolerance; otherwise drops the older frame and
    /// dequeues again (bounded by maxResyncDrops). Releases the previous grab's
    /// frames first, and first recovers a lost camera if the last grab lost one.
    /// Throws AcquisitionError naming the camera (left/right and GUID) when a
    /// camera sends nothing or fails, when the frames cannot be brought into
    /// step, when a recovery attempt fails, when not running, or after status()
    /// turned Failed.
    RawFramePair grabRawImagePair();
    /// Gives the frames of the last grab back to the DMA rings (no-op if none).
    void releaseFrames();

    /// The feature set as each camera reports it (FirewireCamera::getFeature()):
    /// a feature the camera lacks is present = false with the bus's words in
    /// the note. Throws AcquisitionError naming the camera when not running
    /// or when a camera cannot be asked.
    std::array<CameraFeatureReadback, 2> readFeatures() const;

    /// Thread-safe. Ok; Recovering (a camera was lost or frames were out of
    /// step; message names it); Failed (not started, cameras not found, or
    /// recovery given up; message says why).
    AcquisitionStatus status() const;
    FirewireDiagnostics diagnostics() const { return diagnostics_; }
    const FirewireOptions& options() const { return options_; }
    /// "left camera 0x00b09d01004a2c1f"
    static std::string describe(Side side, FirewireGuid guid);

private:
    struct Camera {
        Side side{Side::Left};
        FirewireGuid guid{0};
        std::unique_ptr<FirewireCamera> handle;
        bool capturing{false};
        std::optional<FirewireFrame> held;  ///< dequeued, not yet given back
    };

    void findCameras(FirewireGuid left, FirewireGuid right, int settleRetries, int busResets);
    void openCameras(FirewireGuid left, FirewireGuid right);
    void startCapture(const CameraHardwareConfig& camera);
    void stopCapture();
    void applyFeatures(const CameraFeatureSet& features);
    void applyFeatures(Camera& camera, const CameraFeatureSet& features);
    /// A feature @p camera lacks (the bus said NotFound): logged once per
    /// camera and feature, skipped.
    void noteMissing(const Camera& camera, std::string_view feature, bool automatic, const std::string& detail);
    void bringUp(const CameraHardwareConfig& camera, int busResets);
    void closeCameras();
    void restore(const CameraHardwareConfig& previous, CameraChange change, const std::string& cause);
    void recover();
    FirewireFrame dequeue(Camera& camera);
    [[noreturn]] void cameraLost(Camera& camera, const std::string& what);
    void giveBack(Camera& camera);
    void setStatus(AcquisitionStatus::State state, std::string message);

    std::unique_ptr<FirewireBus> bus_;
    FirewireOptions options_;
    SleepFunction sleep_;
    std::optional<CameraHardwareConfig> active_;
    Camera left_;
    Camera right_;
    bool needsRecovery_{false};
    int failedRecoveries_{0};
    std::string lostReason_;  ///< why the last camera was lost
    std::vector<std::string> reportedMissing_;  ///< "<guid>/<feature>/<auto>" already logged
    FirewireDiagnostics diagnostics_;
    mutable std::mutex statusMutex_;
    AcquisitionStatus status_;
};

}  // namespace avatar
