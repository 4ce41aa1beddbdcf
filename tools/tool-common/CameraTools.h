#pragma once
/// @file CameraTools.h
/// What the camera utilities (avatar-camtest, avatar-featureset,
/// avatar-calib-capture; thesis 4.2.4, 4.5.1) share beyond what every tool
/// shares (ToolMain.h, ToolProgress.h): the backend options of the command
/// line (the backend table of AcquisitionBackends.h, as taunet offers it) and
/// saving pairs (a session directory the replay backend and avatar-calibrate
/// read, or numbered PNG files). Usage errors are ToolMain.h's UsageError.

#include "ToolMain.h"

#include <avatar/acquire/AcquisitionBackends.h>
#include <avatar/acquire/SessionRecorder.h>
#include <avatar/common/StereoImagePair.h>

#include <boost/program_options.hpp>

#include <cstddef>
#include <cstdint>
#include <filesystem>
#include <memory>
#include <string>
#include <vector>

namespace avatar::tools {

/// Adds the options that choose and set up the backend (--backend, --config,
/// --session, --scene, --seed, --left-files, --right-files, --first,
/// --count, --frame-rate, --pair-tolerance-ms, --timeout-ms) to @p options.
void addBackendOptions(boost::program_options::options_description& options);

/// The request those options describe. Throws UsageError when --backend is
/// missing or names no backend of the table (listing them), or a number is
/// out of range.
BackendRequest backendRequest(const boost::program_options::variables_map& vm);

/// Throws UsageError naming the option when @p request lacks one its backend
/// needs: replay --session; files --left-files, --right-files and --config;
/// simulation --scene and, with @p toAcquire, --config; firewire and genicam
/// --config with @p toAcquire (listing their cameras needs none).
void requireBackendOptions(const BackendRequest& request, bool toAcquire);

/// The backends, one per line, for --help.
std::string backendHelp();

/// How pairs are saved.
enum class SaveFormat {
    Session,     ///< a session directory with raw image files (docs/formats.md)
    SessionPng,  ///< a session directory with 16-bit PNG image files
    Png,         ///< numbered PNG files left_NNNN.png, right_NNNN.png and pairs.txt
};
/// "session", "session-png", "png"; throws UsageError otherwise.
SaveFormat parseSaveFormat(const std::string& text);
const char* toString(SaveFormat format);

/// Saves pairs on a thread of its own (SessionRecorder), so saving does not
/// slow the acquisition: into a session directory that the replay backend
/// (--backend replay --session DIR) and avatar-calibrate --session read, with
/// @p config as the recorded configuration, or into numbered PNG files with
/// a pairs.txt that lists each pair's acquisition (group, member, camera ids,
/// timestamps). PNG files hold the samples they are given, losslessly.
class PairSaver {
public:
    /// Creates @p directory. Throws avatar::IoError when it already holds a
    /// session (session.log) or the first PNG pair, or cannot be created.
    PairSaver(const std::filesystem::path& directory, SaveFormat format, const AvatarConfig& config,
              std::size_t queueCapacity = 16);
    ~PairSaver();
    PairSaver(const PairSaver&) = delete;
    PairSaver& operator=(const PairSaver&) = delete;

    /// Queues @p pair; false when it was not queued (the queue was full:
    /// counted in status().dropped).
    bool save(const StereoImagePair& pair);
    /// Waits until every queued pair is written.
    void flush();
    SessionRecorderStatus status() const;
    const std::filesystem::path& directory() const { return directory_; }
    SaveFormat format() const { return format_; }
    /// The name of saved pair @p index (1-based) in the PNG format: "left_0001.png".
    static std::string pngName(Side side, std::size_t index);

private:
    std::filesystem::path directory_;
    SaveFormat format_;
    std::string configXml_;
    std::uint64_t iteration_{0};
    std::unique_ptr<SessionRecorder> recorder_;
};

}  // namespace avatar::tools
