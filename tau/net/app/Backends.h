#pragma once
/// @file Backends.h
/// The acquisition backends the taunet daemon can run, chosen by name. Each
/// backend is one entry of the table in Backends.cpp; an entry whose code is
/// not part of this build stays in the table, marked unavailable, so asking
/// for it is a clear error rather than a silent fallback.

#include <avatar/acquire/AcquireStereoImagePair.h>
#include <avatar/config/AvatarConfig.h>

#include <cstdint>
#include <filesystem>
#include <memory>
#include <optional>
#include <string>
#include <vector>

namespace avatar::taunet {

/// What the command line says about the backend.
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
};

/// A backend ready to hand to VisionInterface, with the configuration to start with.
struct Backend {
    std::unique_ptr<AcquireStereoImagePair> acquisition;
    AvatarConfig config;
    std::filesystem::path configDirectory;  ///< where relative paths of the configuration resolve
    std::string configSource;               ///< for the log: the file, or "recorded in <session>"
};

struct BackendEntry {
    std::string name;
    std::string summary;    ///< one line for --help
    bool available{false};  ///< compiled into this build
    std::string missing;    ///< when not available: why
};

/// Every backend, available or not, in the order --help lists them.
std::vector<BackendEntry> backendTable();

/// Builds the backend @p request names. Throws avatar::InvalidArgument for an
/// unknown or unavailable backend or a missing/unsuitable option, and the
/// backend's own errors (IoError, FormatError, ConfigError, AcquisitionError).
Backend makeBackend(const BackendRequest& request);

}  // namespace avatar::taunet
