#pragma once
/// @file SessionLog.h
/// The session log (thesis 4.2.2 and 4.3, docs/formats.md): what TAUNet records
/// in live operation and replay reads back. A session is one directory holding
/// `session.log` and the image files of every acquired pair; the log has one
/// line per iteration with the pair's identity, its files and their checksums,
/// the configuration in force (in full where it changed) and the analysis result.
///
/// Error policy: writing and opening throw avatar::Error (IoError, FormatError,
/// InvalidArgument) naming the file. Damage inside a log that opened is not
/// thrown but reported per line in SessionLogEntry, so a caller can report
/// each damaged record and go on with the rest.

#include <avatar/common/ImageFormat.h>
#include <avatar/common/StereoImagePair.h>
#include <avatar/common/VisionTargets.h>

#include <cstddef>
#include <cstdint>
#include <filesystem>
#include <optional>
#include <string>
#include <vector>

namespace avatar {

/// The name of the log file inside a session directory.
inline constexpr const char* kSessionLogFileName = "session.log";
/// The first word of a session log's header line.
inline constexpr const char* kSessionLogFormatName = "AVATAR-SESSION-LOG";
/// The format version this code writes.
inline constexpr int kSessionLogVersion = 2;
/// The oldest version it reads. Version 1 records targets without their shape
/// model, covariances and ray residuals, made by an analysis that did not
/// judge completeness (its targets never carry kTargetWhole).
inline constexpr int kOldestSessionLogVersion = 1;

/// How an image file stores its samples.
enum class Compression {
    None,  ///< `.raw`: headerless samples in the byte order of the name
    Png    ///< `.png`: lossless PNG, 8- or 16-bit, samples unscaled
};

/// A recorded image file: its name (no directory) and the CRC-32 of its bytes
/// (boost::crc_32_type, see docs/formats.md).
struct ImageFileRef {
    std::string name;
    std::uint32_t crc32{0};

    bool operator==(const ImageFileRef& o) const { return name == o.name && crc32 == o.crc32; }
    bool operator!=(const ImageFileRef& o) const { return !(*this == o); }
};

/// The files of one acquired pair.
struct PairFiles {
    ImageFileRef left;
    ImageFileRef right;
};

/// One iteration of a session.
struct SessionRecord {
    std::uint64_t iteration{0};  ///< vision iteration counter; increases from record to record
    AcquisitionId acquisition;   ///< group, member, camera ids and timestamps of the pair
    PairFiles files;             ///< names (of this session directory) and CRC-32s
    std::uint32_t configVersion{0};  ///< the configuration in force
    /// The XML text applied at this iteration: set when this record is the first
    /// one or its configVersion differs from the previous record's.
    std::optional<std::string> configXml;
    /// The analysis result; its iteration and acquisition equal the record's.
    std::optional<VisionTargets> result;
};

/// One line of a session log after the header: either an intact record or a
/// description of the damage.
struct SessionLogEntry {
    std::size_t line{0};                  ///< 1-based line number in session.log
    std::optional<SessionRecord> record;  ///< set when the line is intact
    /// Set when it is not: "<path of session.log>:<line>: <what is wrong>".
    std::string error;

    bool ok() const { return record.has_value(); }
};

/// Records a session: creates the directory and its session.log, writes the
/// image files of each pair and appends one line per iteration. Each line is
/// written with one write() and synced before append() returns, so a crash
/// loses at most the line being written. Not thread-safe.
class SessionLogWriter {
public:
    /// Creates @p sessionDirectory (and parents) if needed and a new
    /// session.log in it with the header line. Throws avatar::IoError if a
    /// session.log already exists there (a session is never appended to or
    /// overwritten) or cannot be created.
    explicit SessionLogWriter(std::filesystem::path sessionDirectory);
    ~SessionLogWriter();
    SessionLogWriter(const SessionLogWriter&) = delete;
    SessionLogWriter& operator=(const SessionLogWriter&) = delete;

    /// Writes both images of @p pair into the session directory, named from the
    /// pair's AcquisitionId (group, member) and layout, 16-bit `.raw` samples in
    /// @p rawByteOrder. Returns the names and checksums to put in the record.
    /// Throws avatar::InvalidArgument for an empty pair or a group/member above
    /// 99999, avatar::IoError if a file exists already or cannot be written.
    PairFiles writePair(const StereoImagePair& pair, Compression compression = Compression::None,
                        ByteOrder rawByteOrder = hostByteOrder());

    /// Appends one record and syncs it to disk. Throws avatar::InvalidArgument
    /// naming the field when the record is inconsistent: iteration not above the
    /// previous one, a file name that does not parse or does not match the side,
    /// group and member, a missing configXml where the version changes (or on
    /// the first record), a result whose iteration or acquisition differ from
    /// the record's; the writer stays usable. Throws avatar::IoError if the
    /// line cannot be written or synced; the log may then end in a partial line
    /// and every later append() throws avatar::IoError too (start a new session).
    void append(const SessionRecord& record);

    const std::filesystem::path& directory() const { return directory_; }
    /// Number of records appended so far.
    std::size_t recordCount() const { return count_; }
    /// True once writing or syncing the log failed: nothing more can be
    /// appended to this session (its log may end in a partial line).
    bool failed() const { return failed_; }

private:
    std::filesystem::path directory_;
    std::filesystem::path logPath_;
    int fd_{-1};
    std::size_t count_{0};
    std::uint64_t lastIteration_{0};
    std::uint32_t lastConfigVersion_{0};
    bool failed_{false};  ///< a write or sync of the log failed
};

/// Reads a session directory. The whole log is parsed on construction; every
/// line after the header becomes a SessionLogEntry. Image files are verified
/// only when loadPair() is called.
class SessionLogReader {
public:
    /// Reads `<sessionDirectory>/session.log`. Throws avatar::IoError if it is
    /// missing or unreadable and avatar::FormatError if its header is not a
    /// session log header of a supported version; damage after the header is
    /// reported in entries(), never thrown.
    explicit SessionLogReader(std::filesystem::path sessionDirectory);

    const std::filesystem::path& directory() const { return directory_; }
    const std::filesystem::path& logPath() const { return logPath_; }
    /// The version in the header (kOldestSessionLogVersion..kSessionLogVersion).
    int version() const { return version_; }

    /// Every line after the header, in file order.
    const std::vector<SessionLogEntry>& entries() const { return entries_; }
    /// The intact records, in file order.
    std::vector<SessionRecord> records() const;
    /// The damaged lines' messages, in file order (empty when the log is intact).
    std::vector<std::string> errors() const;

    /// The XML that an intact record applied for @p configVersion; empty if no
    /// intact record applied it (for instance because that record is damaged).
    std::optional<std::string> configXml(std::uint32_t configVersion) const;

    /// Loads the pair of @p record from the session directory after checking
    /// each file: that it exists, that its name parses, that its size (`.raw`)
    /// or decoded geometry (`.png`) is what its name says and that its CRC-32 is
    /// the recorded one. The layout comes from the names, which must agree; the
    /// pair carries record.acquisition. Throws avatar::IoError (missing or
    /// unreadable file) or avatar::FormatError, naming the file.
    StereoImagePair loadPair(const SessionRecord& record) const;

private:
    std::filesystem::path directory_;
    std::filesystem::path logPath_;
    int version_{0};
    std::vector<SessionLogEntry> entries_;
};

}  // namespace avatar
