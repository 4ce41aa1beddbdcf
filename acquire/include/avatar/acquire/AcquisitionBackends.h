#pragma once
/// @file AcquisitionBackends.h
/// The acquisition backends by name (thesis 4.2.2): what a program such as
/// the taunet daemon offers on its command line. Each backend is one class in
/// its own folder of acquire/ and one entry of the table in
/// AcquisitionBackends.cpp (explicit, no self-registration); a name that is
/// not in the table is an error, never a silent fallback to another backend.

#include <avatar/acquire/AcquireStereoImagePair.h>
#include <avatar/acquire/CameraReport.h>
#include <avatar/config/AvatarConfig.h>

#include <chrono>
#include <cstdint>
#include <filesystem>
#include <memory>
#include <optional>
#include <string>
#include <vector>

namespace avatar {

/// What a command line says about the backend.
struct BackendRequest {
    std::string name;                              ///< "replay", "files", "firewire", "genicam", "simulation"
    std::optional<std::filesystem::path> session;  ///< replay: session directory
    std::optional<std::filesystem::path> config;   ///< configuration file (replay: overrides the recorded one)
    std::optional<std::filesystem::path> scene;    ///< simulation: scene file (avatar-render format)
    std::optional<std::string> leftFiles;          ///< files: printf pattern of the left images
    std::optional<std::string> rightFiles;         ///< files: printf pattern of the right images
    std::uint64_t firstFile{0};                    ///< files: index of the first pair
    std::optional<std::uint64_t> fileCount;        ///< files: number of pairs (unset: until none exists)
    std::uint64_t seed{1};                         ///< simulation: noise seed of the first pair
    /// genicam: the frame rate to set on the cameras (GenICamOptions::frameRateHz).
    std::optional<double> frameRateHz;
    /// genicam: GenICamOptions::pairTolerance; firewire: FirewireOptions::timestampTolerance.
    /// Unset: the backend's default, except for genicam with frameRateHz
    /// set, where it is half the frame period (free-running cameras are not
    /// in phase, docs/acquisition.md).
    std::optional<std::chrono::microseconds> pairTolerance;
    /// genicam: GenICamOptions::frameTimeout; firewire: FirewireOptions::dequeueTimeout.
    /// Unset: the backend's default.
    std::optional<std::chrono::milliseconds> frameTimeout;
};

/// A backend ready to hand to VisionInterface, with the configuration to start with.
struct Backend {
    std::unique_ptr<AcquireStereoImagePair> acquisition;
    AvatarConfig config;
    std::filesystem::path configDirectory;  ///< where relative paths of the configuration resolve
    std::string configSource;               ///< for the log: the file, or the session log and version
};

/// One line of the table.
struct BackendEntry {
    std::string name;
    std::string summary;  ///< one line for --help
};

/// Every backend, in the order --help lists them.
std::vector<BackendEntry> backendTable();

/// What the backend @p request names can reach now, without starting it
/// (CameraReport.h): for avatar-camtest --list. firewire: the /dev/fw* nodes
/// and their permissions, libdc1394 and the cameras on the bus
/// (surveyFirewire()); genicam: Aravis, a discovery pass and every camera
/// found, opened for a moment (AcquireSIPGenICam::survey()); replay: the
/// session log, its image files and the recorded camera ids; files: the
/// patterns and the first pair; simulation: the scene and the two simulated
/// cameras. A problem the backend would have is a failed check naming it,
/// not an exception. Throws avatar::InvalidArgument for an unknown backend
/// or a missing option (as makeBackend()).
BackendSurvey surveyBackend(const BackendRequest& request);

/// Builds the backend @p request names. Throws avatar::InvalidArgument for an
/// unknown backend or a missing/unsuitable option, avatar::NotAvailable for a
/// session that does not hold the configuration to start with, and the
/// backend's own errors (IoError, FormatError, ConfigError, AcquisitionError).
Backend makeBackend(const BackendRequest& request);

}  // namespace avatar
