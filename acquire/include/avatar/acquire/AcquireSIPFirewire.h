#pragma once
/// @file AcquireSIPFirewire.h
/// The live FireWire backend (thesis 4.2.2): stereo pairs from two IIDC
/// cameras through AvatarCameras, with camera settings adjustable while running.
///
/// Pixel lifetime. By default every pair is an owning copy of the two DMA
/// buffers, and the buffers go back to the cameras at once. Callers of
/// AcquireStereoImagePair keep pairs (analysis, the session log, the daemon's
/// latest images for other threads) without knowing where they came from, so a
/// view could dangle; the copy (2 x 2.4 MB at 1280x960x16 bit, about 1 ms) is
/// under 2 % of the 52 ms frame period at 19 frames/s, and returning the
/// buffers at once keeps the whole DMA ring for the cameras.
///
/// With FirewireOptions::zeroCopyViews the pair of a 1-channel format is
/// instead a view (StereoImagePair::ownsPixels() false) over the DMA buffers,
/// valid only until the next acquire(), applyConfig() or the destruction of
/// this object; clone() it to keep it. 3-channel frames (RGB from the camera)
/// are always converted to BGR copies, as are pairs whose two row strides differ.
///
/// The bus is reached through a small seam (FirewireBus, AvatarCameras: the
/// internal headers of acquire/firewire/), so the tests drive the whole
/// backend through a scripted bus.

#include <avatar/acquire/AcquireStereoImagePair.h>

#include <array>
#include <chrono>
#include <cstdint>
#include <filesystem>
#include <functional>
#include <memory>
#include <string>
#include <string_view>

namespace avatar {

class AvatarCameras;
class FirewireBus;

/// Tuning of the FireWire backend. Defaults suit two Point Grey Scorpion
/// cameras at up to 19 frames/s on one bus.
struct FirewireOptions {
    /// Pause after a failed enumeration or a bus reset for the bus to settle.
    std::chrono::milliseconds settleDelay{500};
    /// Plain re-enumerations (after a settle delay) before the first bus reset:
    /// enough for a bus that is still settling after a hot-plug.
    int settleRetries{2};
    /// Bus resets (each followed by a settle delay and an enumeration) before
    /// reporting that the cameras are not there.
    int maxBusResets{3};
    /// How long to wait for each camera's frame before calling it lost.
    std::chrono::milliseconds dequeueTimeout{1000};
    /// Largest difference of the two capture timestamps in one pair: about half
    /// a frame period (19 frames/s: 52.6 ms period).
    std::chrono::microseconds timestampTolerance{25000};
    /// Frames dropped while trying to bring the two cameras into step before a
    /// grab gives up (with an AcquisitionError, never a mismatched pair).
    int maxResyncDrops{8};
    /// DMA ring buffers per camera (libdc1394 needs at least 1).
    std::uint32_t dmaBuffers{4};
    /// Consecutive failed recovery attempts after a lost camera before the
    /// status turns Failed.
    int maxRecoveryAttempts{3};
    /// AcquireSIPFirewire only: hand out pairs that are views over the DMA
    /// buffers instead of copies (see AcquireSIPFirewire.h for the lifetime).
    bool zeroCopyViews{false};

    /// Empty when every option is usable; otherwise one "name: problem" per
    /// bad option, separated by "; ".
    std::string validate() const;
};

/// What AvatarCameras::configure() had to do.
enum class CameraChange {
    None,      ///< nothing the cameras care about changed
    Features,  ///< feature set written, capture kept running
    Capture,   ///< capture stopped, Format7 (ROI/coding) set, capture restarted
    Cameras,   ///< cameras (re)opened: first start, or other GUIDs
};
/// "none", "features", "capture", "cameras".
std::string_view toString(CameraChange change);

/// Waits for the bus to settle; the default sleeps the calling thread.
using FirewireSleepFunction = std::function<void(std::chrono::milliseconds)>;

class AcquireSIPFirewire : public AcquireStereoImagePair {
public:
    /// Takes over @p bus (internal/FirewireBus.h; makeFirewireAcquisition()
    /// gives the real one); touches no hardware until applyConfig(), which
    /// finds and starts the cameras. Throws InvalidArgument for bad options or
    /// group size.
    explicit AcquireSIPFirewire(std::unique_ptr<FirewireBus> bus, FirewireOptions options = {},
                                std::uint32_t groupSize = 99999, FirewireSleepFunction sleep = {});
    ~AcquireSIPFirewire() override;

    std::string name() const override { return "firewire"; }
    /// Thread-safe; see AvatarCameras::status().
    AcquisitionStatus status() const override;
    /// The cameras (enumeration, recovery counters); see acquire/firewire/AvatarCameras.h.
    const AvatarCameras& cameras() const { return *cameras_; }
    /// What the last successful applyConfig() changed on the cameras.
    CameraChange lastChange() const { return lastChange_; }

    /// The IIDC feature set of both cameras as they report it
    /// (AcquireStereoImagePair::readFeatures()); a feature the camera lacks,
    /// which applyConfig() skipped with a warning, is present = false. The
    /// camera ids are the GUIDs. Throws AcquisitionError before applyConfig()
    /// or when a camera cannot be asked.
    std::array<CameraFeatureReadback, 2> readFeatures() const override;

protected:
    /// One pair from AvatarCameras::grabRawImagePair(): camera ids are the
    /// GUIDs, timestamps the capture times. Throws AcquisitionError.
    AcquiredPair grab() override;
    /// Feature changes are written while capture runs; ROI, bit depth or
    /// channel changes restart capture; other GUIDs reopen the cameras. On
    /// failure throws and keeps the previous settings.
    void configure(const AvatarConfig& config) override;

private:
    std::unique_ptr<AvatarCameras> cameras_;
    bool zeroCopy_;
    CameraChange lastChange_{CameraChange::None};
};

/// The FireWire backend over the real bus (libdc1394).
std::unique_ptr<AcquireSIPFirewire> makeFirewireAcquisition(FirewireOptions options = {},
                                                            std::uint32_t groupSize = 99999);

/// What @p bus reaches now, for avatar-camtest (surveyBackend()): the device
/// nodes `<deviceDirectory>/fw*` and whether this process may read and write
/// each (libdc1394 needs both; a failed check names the node, its mode, owner
/// and group and what to do), whether libdc1394 starts (the kernel driver),
/// and every camera on the bus with its vendor and model, opened for a moment.
/// Opens no camera for capture.
BackendSurvey surveyFirewire(FirewireBus& bus, const std::filesystem::path& deviceDirectory = "/dev");
/// The same over the real bus (libdc1394) and /dev.
BackendSurvey surveyFirewire();

}  // namespace avatar
