#pragma once
/// @file RawDataAcquire.h
/// The replay backend (thesis 4.2.2 and 4.3): acquires the pairs of a recorded
/// session directory (docs/formats.md) in log order, so that a test can be
/// recreated from raw data and the system log; and the reference-file
/// regression check that compares a replayed result with the recorded one.
///
/// Each pair is handed over exactly as it was recorded: the samples of the
/// image files in host byte order (the file's byte order token is undone by
/// the reader, see docs/formats.md) and in the recorded layout (a Bayer mosaic
/// stays a mosaic). The endian swap of CameraHardwareConfig::endianSwap and the
/// demosaic are left to the analysis' `demosaic` stage, which reads both from
/// the recorded configuration. This is exact, not a simplification: a session
/// records the pair the acquisition handed to the analysis, so handing it over
/// unchanged makes the stage chain see what it saw live; converting here would
/// swap or demosaic a second time.
///
/// Every pair keeps its recorded numbers (group, member, camera ids and
/// timestamps) and carries the recorded iteration, the recorded result, and the
/// recorded configuration XML where the configuration changed (on the first
/// pair delivered, on every pair whose configuration version differs from the
/// last delivered pair's, and where a record applied its configuration again).
///
/// Damage: a damaged record (a log line the reader rejected, a configuration
/// the log does not hold, an image file that is missing, truncated or fails its
/// checksum) makes acquire() throw an AcquisitionError whose message is
/// `<session.log>:<line>: <what is wrong>` naming the file; status() is then
/// Recovering, and the next acquire() goes on with the next record. As soon as
/// the last record has been acquired (or reported) status() is Finished, and
/// acquire() throws an AcquisitionError saying so.
///
/// Read-ahead: while the caller works on a pair, the next intact record's
/// image files are read and checked on a thread of the backend's own, so a
/// replay costs the analysis only. What acquire() returns or throws is exactly
/// what reading the record at that moment would give.

#include <avatar/acquire/AcquireStereoImagePair.h>
#include <avatar/acquire/SessionLog.h>

#include <cstddef>
#include <cstdint>
#include <filesystem>
#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <vector>

namespace avatar {

/// A configuration a session was recorded with.
struct RecordedConfig {
    AvatarConfig config;
    std::uint32_t version{0};  ///< its version in the recording
    std::string source;        ///< "<session>/session.log (configuration N)"
};

class RawDataAcquire final : public AcquireStereoImagePair {
public:
    /// Reads `<sessionDirectory>/session.log`. Throws avatar::IoError or
    /// avatar::FormatError (SessionLogReader) when the log is missing or has no
    /// valid header; damage after the header is reported pair by pair.
    explicit RawDataAcquire(std::filesystem::path sessionDirectory);
    ~RawDataAcquire() override;

    std::string name() const override { return "replay"; }
    /// Ok, Recovering after a damaged record (message as the AcquisitionError),
    /// Finished after the last record. Thread-safe.
    AcquisitionStatus status() const override;

    /// The feature set the recording was made with (AcquireStereoImagePair::
    /// readFeatures()): the <features> of the configuration in force for the
    /// last pair delivered (before the first, the initial configuration),
    /// every feature present with its recorded value and mode, none
    /// adjustable (autoAvailable false: a recording cannot change). The
    /// camera ids are the recorded ones. Throws avatar::NotAvailable when the
    /// session does not hold that configuration.
    std::array<CameraFeatureReadback, 2> readFeatures() const override;

    const SessionLogReader& reader() const { return reader_; }
    /// The configuration the session starts with: that of its first intact
    /// record, validated. Throws avatar::NotAvailable when the session has no
    /// intact record or does not hold that record's configuration (the record
    /// that applied it is damaged), and ConfigError naming the log and the
    /// version when it does not validate.
    RecordedConfig initialConfig() const;
    /// The record of the pair acquire() returned last (its configuration
    /// version, file names and checksums); empty before the first pair.
    const std::optional<SessionRecord>& lastRecord() const { return lastRecord_; }
    /// Log lines after the header (records, intact or not).
    std::size_t entryCount() const { return reader_.entries().size(); }
    /// Lines consumed so far (delivered + damaged).
    std::size_t position() const { return position_; }
    std::size_t deliveredCount() const;
    std::size_t damagedCount() const;

protected:
    /// Delivers the next intact record's pair or throws for a damaged one.
    AcquiredPair grab() override;
    /// Nothing to apply: recorded images do not change with camera settings.
    /// The pairs keep their recorded numbers whatever is applied.
    void configure(const AvatarConfig& /*config*/) override {}

private:
    AcquiredPair next();
    /// The pair of entry @p index: the read-ahead's when it read that entry, else read now.
    StereoImagePair loadEntry(std::size_t index, const SessionRecord& record);
    /// Starts reading entry position_ ahead when it is an intact record.
    void readAhead();
    std::string configSource(std::uint32_t version) const;
    std::size_t firstIntactLine() const;
    void updateEndState();

    SessionLogReader reader_;
    std::size_t position_{0};
    std::optional<SessionRecord> lastRecord_;
    std::optional<std::uint32_t> deliveredVersion_;  ///< config version of the last delivered pair

    mutable std::mutex mutex_;
    AcquisitionStatus status_;
    std::size_t delivered_{0};
    std::size_t damaged_{0};
    std::string lastError_;

    struct ReadAhead;
    std::unique_ptr<ReadAhead> readAhead_;  ///< after reader_: stopped before it goes
};

/// One way in which a replayed result differs from the recorded one.
struct ResultDifference {
    std::string field;     ///< e.g. "targets[1].positionVisionMm.z", "targets.size", "visibility"
    std::string recorded;  ///< the recorded value as text ("-" when absent)
    std::string replayed;  ///< the replayed value as text
};

/// The thesis' reference-file regression check: compares every field of two
/// results exactly, doubles bit for bit (so 0 and -0 differ; two NaNs are
/// equal), except the stage timings' milliseconds, which measure this run and
/// can never match. The stage names and their order are compared. Returns the
/// differences in field order; empty when the results are identical.
std::vector<ResultDifference> compareResults(const VisionTargets& recorded, const VisionTargets& replayed);

}  // namespace avatar
