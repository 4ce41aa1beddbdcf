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

#include <avatar/acquire/AcquireStereoImagePair.h>
#include <avatar/acquire/AvatarCameras.h>
#include <avatar/acquire/FirewireBus.h>

#include <cstdint>
#include <memory>
#include <string>

namespace avatar {

class AcquireSIPFirewire : public AcquireStereoImagePair {
public:
    /// Takes over @p bus; touches no hardware until applyConfig(), which finds
    /// and starts the cameras. Throws InvalidArgument for bad options or group size.
    explicit AcquireSIPFirewire(std::unique_ptr<FirewireBus> bus, FirewireOptions options = {},
                                std::uint32_t groupSize = 99999, AvatarCameras::SleepFunction sleep = {});

    std::string name() const override { return "firewire"; }
    /// Thread-safe; see AvatarCameras::status().
    AcquisitionStatus status() const override { return cameras_.status(); }
    const AvatarCameras& cameras() const { return cameras_; }
    /// What the last successful applyConfig() changed on the cameras.
    CameraChange lastChange() const { return lastChange_; }

protected:
    /// One pair from AvatarCameras::grabRawImagePair(): camera ids are the
    /// GUIDs, timestamps the capture times. Throws AcquisitionError.
    AcquiredPair grab() override;
    /// Feature changes are written while capture runs; ROI, bit depth or
    /// channel changes restart capture; other GUIDs reopen the cameras. On
    /// failure throws and keeps the previous settings.
    void configure(const AvatarConfig& config) override;

private:
    AvatarCameras cameras_;
    bool zeroCopy_;
    CameraChange lastChange_{CameraChange::None};
};

/// The FireWire backend over the real bus (libdc1394).
std::unique_ptr<AcquireSIPFirewire> makeFirewireAcquisition(FirewireOptions options = {},
                                                            std::uint32_t groupSize = 99999);

}  // namespace avatar
