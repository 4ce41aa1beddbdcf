#pragma once
/// @file AcquireSIPSimulation.h
/// The simulation acquisition backend: a stereo camera pair looking at a
/// rendered scene. Every grab renders the scene anew with fresh sensor noise,
/// so the layers above (VisionInterface, TAUNet, the servo controller) run
/// end to end without hardware. The scene can be changed between grabs (a
/// moving target, the arm marker following the manipulator).
///
/// The simulated cameras have their own true calibration, which need not be
/// the one in the AVATAR configuration: that is how a calibration error is
/// simulated.

#include <avatar/acquire/AcquireStereoImagePair.h>
#include <avatar/render/Renderer.h>
#include <avatar/render/Scene.h>

#include <cstdint>
#include <functional>
#include <mutex>
#include <string>

namespace avatar {

class AcquireSIPSimulation final : public AcquireStereoImagePair {
public:
    /// @param trueStereo the calibration the images are rendered with
    /// @param options    image format, supersampling and noise; options.seed
    ///                   seeds the first grab, each later grab uses the next seed
    AcquireSIPSimulation(render::Scene scene, StereoSystemConfig trueStereo, render::RenderOptions options);

    std::string name() const override { return "simulation"; }

    /// Replaces the scene seen by later grabs. Thread-safe.
    void setScene(render::Scene scene);
    /// The ground truth of the last grab. Thread-safe.
    render::GroundTruth lastTruth() const;
    /// The camera ids the simulated pairs carry (default "sim-left",
    /// "sim-right"). The configuration's camera ids name hardware the
    /// simulation does not have, so they are not adopted: a recording made in
    /// simulation can never be mistaken for one made with the real cameras.
    void setCameraIds(std::string left, std::string right);

    /// The simulated cameras have no adjustable feature: the scene's
    /// <sensor> (exposure, noise, black level) sets their response, and the
    /// configuration's <features> are not used. Every feature is reported
    /// missing (present false, with that note), never an error. Thread-safe.
    std::array<CameraFeatureReadback, 2> readFeatures() const override;

protected:
    AcquiredPair grab() override;
    /// Adopts the image format of the configuration's camera (size, bit depth,
    /// mosaic or mono or colour, Bayer pattern); the true calibration does not change.
    void configure(const AvatarConfig& config) override;

private:
    mutable std::mutex mutex_;
    render::Scene scene_;
    StereoSystemConfig trueStereo_;
    render::RenderOptions options_;
    render::GroundTruth lastTruth_;
    std::string leftId_{"sim-left"};
    std::string rightId_{"sim-right"};
    std::uint64_t grabs_{0};
};

}  // namespace avatar
