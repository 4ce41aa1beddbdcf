#pragma once
/// @file ReplayAnalysis.h
/// A recorded session replayed through this build's analysis (thesis 4.3):
/// the loop behind avatar-replay (the reference-file regression check),
/// avatar-analyze and the replay regression test, written once. Each record's
/// pair is analysed with the configuration the recording had in force at that
/// iteration (the analysis is rebuilt where it changed), or with one fixed
/// configuration instead. VisionInterface follows recorded configurations the
/// same way (AcquiredPair::recordedConfig()) while it serves a replay.

#include <avatar/acquire/RawDataAcquire.h>
#include <avatar/analyze/AnalyzeStereoImagePair.h>
#include <avatar/common/VisionTargets.h>
#include <avatar/config/AvatarConfig.h>

#include <cstddef>
#include <cstdint>
#include <filesystem>
#include <memory>
#include <optional>
#include <string>

namespace avatar {

/// What became of one record.
struct ReplayStep {
    /// The pair as replayed; unset when the record is damaged.
    std::optional<AcquiredPair> acquired;
    /// Why the record could not be replayed (log line or image damage: the
    /// AcquisitionError's message, naming the file); empty otherwise.
    std::string damage;
    /// This build's analysis of the pair; unset when damaged or failed.
    std::optional<VisionTargets> result;
    /// Why a replayed pair has no result: its configuration cannot be used
    /// with this build, or the analysis failed. Empty otherwise.
    std::string failure;

    bool damaged() const { return !acquired.has_value(); }
    /// The iteration the recording gave the pair (0 when damaged).
    std::uint64_t iteration() const { return acquired ? acquired->recordedIteration.value_or(0) : 0; }
};

class ReplayAnalysis {
public:
    /// Opens @p session (RawDataAcquire: avatar::IoError or FormatError when
    /// the log is missing or has no valid header). With @p fixed every pair is
    /// analysed with it, its relative paths resolved against @p configDirectory,
    /// and an analysis that cannot be built from it throws here; otherwise the
    /// recorded configurations are used, relative paths resolved against the
    /// session directory.
    explicit ReplayAnalysis(const std::filesystem::path& session, std::optional<AvatarConfig> fixed = {},
                            std::filesystem::path configDirectory = {});
    ~ReplayAnalysis();
    ReplayAnalysis(const ReplayAnalysis&) = delete;
    ReplayAnalysis& operator=(const ReplayAnalysis&) = delete;

    /// True once every record has been replayed or reported.
    bool finished() const;
    /// Replays and analyses the next record. Never throws for a damaged record,
    /// an unusable configuration or a failed analysis: the step says which.
    ReplayStep next();

    /// Analyses the pair of @p step, the last step next() returned, once more
    /// with the same analysis (to time it: `avatar-analyze --repeat`). Throws
    /// avatar::InvalidState when that step has no result.
    VisionTargets analyzeAgain(const ReplayStep& step);

    /// One thread (false) or two (true) for every analysis from now on,
    /// whatever each configuration's analysis/threads says
    /// (AnalyzeStereoImagePair::setParallel).
    void setParallel(bool parallel);

    /// The replay backend: the reader, the last record (its files and configuration version), progress.
    const RawDataAcquire& replay() const { return replay_; }
    /// The analysis of the last step with a result (marked and filtered
    /// images); nullptr when no configuration could be used yet.
    const AnalyzeStereoImagePair* analyzer() const { return analyzer_.get(); }

private:
    RawDataAcquire replay_;
    bool fixed_;
    std::filesystem::path configDirectory_;
    std::unique_ptr<AnalyzeStereoImagePair> analyzer_;
    std::string configProblem_;  ///< why the recorded configuration in force cannot be used
    std::optional<bool> parallel_;  ///< unset: each configuration's analysis/threads
};

}  // namespace avatar
