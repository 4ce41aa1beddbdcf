#pragma once
/// @file VisionInterface.h
/// VisionInterface (thesis 4.3.1): the one public face of AVATAR for the layers
/// above (TAUNet, the servo controller). It owns an acquisition backend, the
/// analysis and the latest results and images, and runs acquisition and
/// analysis on its own thread, so callers never slow the vision loop and the
/// loop never waits for a caller.
///
/// Every change to the backend or the analysis (searching, snapshots, new
/// configurations) is carried out by the vision thread between iterations;
/// the public functions are thread-safe and may be called from any thread.

#include <avatar/acquire/AcquireStereoImagePair.h>
#include <avatar/common/StereoImagePair.h>
#include <avatar/common/VisionTargets.h>
#include <avatar/config/AvatarConfig.h>

#include <chrono>
#include <cstdint>
#include <filesystem>
#include <memory>
#include <optional>
#include <string>

namespace avatar {

/// What the vision loop is doing.
enum class VisionState {
    Idle,       ///< waiting for a command
    Searching,  ///< acquiring and analysing continuously
    Snapshot,   ///< acquiring and analysing one pair
    Error       ///< the backend failed; VisionStatus::error says why
};

/// "idle", "searching", "snapshot" or "error".
const char* toString(VisionState state);

/// The bookkeeping of thesis Figure 4-6 and the health of the system.
struct VisionStatus {
    VisionState state{VisionState::Idle};
    std::string error;                   ///< why the state is Error (or the last error)
    std::uint64_t heartbeat{0};          ///< increments 20 times a second while the vision thread runs (its own timer, not the iterations)
    std::uint64_t iteration{0};          ///< the last vision iteration analysed (0: none yet)
    std::uint64_t configIteration{0};    ///< iteration at which the configuration in force was applied
    std::uint32_t configVersion{1};      ///< increments with every configuration applied
    std::uint64_t targetsIteration{0};   ///< iteration of the latest target data
    std::uint64_t imagesIteration{0};    ///< iteration of the latest images
    AcquisitionStatus acquisition;       ///< the backend's own health
    Visibility visibility{Visibility::Unknown};
    std::string visibilityReason;
    std::uint64_t recordBacklog{0};      ///< pairs waiting to be written
    std::uint64_t recorded{0};           ///< pairs written to the session log
    std::uint64_t unrecorded{0};         ///< pairs that could not be recorded (queue full or disk error)
    std::string recordError;             ///< why the last pair was not recorded, if any
};

/// Which images a client asks for.
enum class ImageKind { Original, Filtered, Marked };

/// A pair of images and the iteration they belong to.
struct VisionImages {
    std::uint64_t iteration{0};
    StereoImagePair pair;
};

struct VisionOptions {
    /// Record every acquired pair and its result into this new session
    /// directory (docs/formats.md); unset: no recording.
    std::optional<std::filesystem::path> recordDirectory;
    /// Pairs that may wait for the disk; when full, pairs are not recorded and
    /// are counted (VisionStatus::unrecorded), never silently lost.
    std::size_t recordQueue{8};
    bool recordPng{false};  ///< archive pairs as 16-bit PNG instead of raw
    /// Where relative paths of the configuration are resolved (lighting template).
    std::filesystem::path configDirectory;
    /// Pause between iterations while searching (0: as fast as the backend delivers).
    std::chrono::milliseconds searchPeriod{0};
};

class VisionInterface {
public:
    /// Takes ownership of @p backend, applies @p config to it, builds the
    /// analysis and opens the recording. Throws (ConfigError, InvalidArgument,
    /// AcquisitionError, IoError) when any cannot be set up. Starts the vision
    /// thread, idle.
    VisionInterface(std::unique_ptr<AcquireStereoImagePair> backend, const AvatarConfig& config,
                    VisionOptions options = {});
    /// Stops the vision thread, finishing the current iteration, then writes
    /// what the recorder still holds.
    ~VisionInterface();
    VisionInterface(const VisionInterface&) = delete;
    VisionInterface& operator=(const VisionInterface&) = delete;

    /// Starts continuous acquisition and analysis. Throws avatar::InvalidState
    /// when the backend has failed or finished (the status says which).
    void startSearching();
    /// Stops after the current iteration; a no-op when not searching.
    void stopSearching();

    /// Acquires and analyses one pair and returns its targets. While searching,
    /// returns the result of the next iteration instead. Throws AcquisitionError
    /// (naming the camera or file) when no pair could be had, avatar::TimedOut
    /// after @p timeout, and avatar::InvalidState when the interface stops first.
    VisionTargets snapshot(std::chrono::milliseconds timeout = std::chrono::seconds(10));

    /// The latest targets; std::nullopt before the first iteration.
    std::optional<VisionTargets> latestTargets() const;

    /// The latest images of a kind (original: as acquired; filtered; marked);
    /// an empty pair before the first iteration. Computed from a copy of the
    /// last frame, without blocking the vision loop.
    VisionImages images(ImageKind kind) const;

    /// Validates a whole XML document and applies it atomically between two
    /// iterations: the analysis is rebuilt and the backend reconfigured, which
    /// starts a new acquisition group. On any error nothing changes and the old
    /// configuration stays in force: ConfigError when the document is invalid
    /// (with line and element) or cannot be applied (an analysis that cannot be
    /// built, a camera configuration the backend cannot use: the element of the
    /// part that refused it), AcquisitionError when the backend fails, and
    /// avatar::TimedOut after @p timeout. Returns the new configuration version.
    std::uint32_t applyConfig(const std::string& xml,
                              std::chrono::milliseconds timeout = std::chrono::seconds(10));

    /// The configuration in force, as XML, and as a value.
    std::string configXml() const;
    AvatarConfig config() const;

    VisionStatus status() const;

    /// The name of the backend ("replay", "firewire", ...).
    std::string backendName() const;

private:
    class Loop;
    std::unique_ptr<Loop> loop_;
};

}  // namespace avatar
