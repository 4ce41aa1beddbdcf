#pragma once
/// @file SessionRecorder.h
/// Records every acquired pair and its analysis result into a session
/// (docs/formats.md) off the acquisition path (thesis 4.2.2, 4.3): record()
/// only queues the pair; a thread of the recorder's own writes the queue into a
/// SessionSink, normally a SessionLogWriter.
///
/// Nothing is lost silently. record() never blocks: when the queue is full the
/// pair is not recorded, the unrecorded count grows and the recorder logs a
/// warning (category avatar.acquire) naming the iteration. A pair the sink
/// cannot write (disk full, an inconsistent record) is counted too, with the
/// error naming the file in status().lastError, and recording goes on with
/// later pairs where the sink still can. A dropped or failed pair that applied
/// a new configuration does not lose that configuration: the next recorded
/// pair of the same version carries its XML instead. When the session log
/// itself cannot be written (disk full), SessionLogSink goes on in a new
/// session directory as soon as there is room again (docs/formats.md).

#include <avatar/acquire/SessionLog.h>
#include <avatar/common/StereoImagePair.h>
#include <avatar/common/VisionTargets.h>

#include <condition_variable>
#include <cstddef>
#include <cstdint>
#include <deque>
#include <filesystem>
#include <map>
#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <thread>
#include <vector>

namespace avatar {

/// Where a SessionRecorder writes; called from the recorder's thread only.
/// Both functions throw avatar::Error naming the file on failure.
class SessionSink {
public:
    virtual ~SessionSink() = default;
    /// Writes both images of @p pair and returns their names and checksums.
    virtual PairFiles writePair(const StereoImagePair& pair) = 0;
    /// Appends @p record (its files as writePair() returned them).
    virtual void append(const SessionRecord& record) = 0;
    /// For messages: the session directory, e.g. "/data/dive-042".
    virtual std::string describe() const = 0;
    /// True when the next append() starts a session, so its record must carry
    /// the configuration in force. The default: only before the first record.
    virtual bool atSessionStart() const { return false; }
};

/// The real sink: a SessionLogWriter on a new session directory. When the log
/// line of a pair cannot be written (disk full), that session takes nothing
/// more, and the next pair starts a new session beside it, `<dir>.part2`
/// (then `.part3`, ...: the first name that does not exist), retried with
/// every pair until there is room; its first record carries the configuration.
class SessionLogSink final : public SessionSink {
public:
    /// Creates the session (SessionLogWriter's constructor and its errors).
    explicit SessionLogSink(std::filesystem::path sessionDirectory, Compression compression = Compression::None,
                            ByteOrder rawByteOrder = hostByteOrder());
    PairFiles writePair(const StereoImagePair& pair) override;
    void append(const SessionRecord& record) override;
    /// The session being written.
    std::string describe() const override;
    bool atSessionStart() const override;
    const SessionLogWriter& writer() const { return *writer_; }
    /// Every session directory started, the first one first.
    const std::vector<std::filesystem::path>& sessions() const { return sessions_; }

private:
    /// Starts the next session after a failed log (throws avatar::IoError when there is no room yet).
    void continueInNewSession();

    std::filesystem::path base_;
    std::unique_ptr<SessionLogWriter> writer_;
    std::vector<std::filesystem::path> sessions_;
    Compression compression_;
    ByteOrder byteOrder_;
};

struct SessionRecorderOptions {
    /// Pairs that may wait for the sink; at 2 x 2.4 MB a 1280x960 16-bit pair,
    /// 8 pairs hold about 40 MB. 1 .. 1024.
    std::size_t queueCapacity{8};

    /// Throws avatar::InvalidArgument naming the field.
    void validate() const;
};

struct SessionRecorderStatus {
    std::size_t backlog{0};     ///< pairs queued, not yet written
    std::size_t recorded{0};    ///< pairs written and appended to the log
    std::size_t dropped{0};     ///< not recorded: the queue was full
    std::size_t failed{0};      ///< not recorded: the sink failed (see lastError)
    std::string lastError;      ///< the last reason a pair was not recorded, naming the file or iteration
    std::size_t unrecorded() const { return dropped + failed; }
};

class SessionRecorder {
public:
    /// Starts the recorder's thread. Throws avatar::InvalidArgument for invalid
    /// options or a null sink.
    explicit SessionRecorder(std::unique_ptr<SessionSink> sink, SessionRecorderOptions options = {});
    /// Writes what is still queued, then stops the thread.
    ~SessionRecorder();
    SessionRecorder(const SessionRecorder&) = delete;
    SessionRecorder& operator=(const SessionRecorder&) = delete;

    /// Queues one iteration and returns at once: true when queued, false when
    /// the queue was full (counted in dropped, logged). @p configXml is the
    /// configuration applied at this iteration (set when it changed, and on the
    /// first iteration); @p result, when set, must belong to this iteration and
    /// pair. A pair that views external memory (a camera buffer) is copied; an
    /// owning pair's pixels are shared, so the caller must not modify them
    /// afterwards (analysis stages never do).
    bool record(const StereoImagePair& pair, std::uint64_t iteration, std::uint32_t configVersion,
                std::optional<std::string> configXml, std::optional<VisionTargets> result);

    /// Blocks until every queued pair has been written or failed.
    void flush();

    SessionRecorderStatus status() const;
    const SessionRecorderOptions& options() const { return options_; }

private:
    struct Item {
        StereoImagePair pair;
        std::uint64_t iteration{0};
        std::uint32_t configVersion{0};
        bool xmlApplied{false};  ///< record() got configXml for this iteration
        std::shared_ptr<const std::string> versionXml;  ///< the latest XML known for configVersion
        std::optional<VisionTargets> result;
    };

    void run();
    void write(Item& item);
    void fail(const std::string& message);

    std::unique_ptr<SessionSink> sink_;
    SessionRecorderOptions options_;

    mutable std::mutex mutex_;
    std::condition_variable wake_;   ///< an item was queued, or stop
    std::condition_variable idle_;   ///< the queue emptied and nothing is being written
    std::deque<Item> queue_;
    bool writing_{false};
    bool stop_{false};
    bool losing_{false};  ///< the last pair was not recorded (its loss was logged)
    SessionRecorderStatus status_;
    std::map<std::uint32_t, std::shared_ptr<const std::string>> xmlByVersion_;  ///< record()'s side

    // The thread's side only.
    std::optional<std::uint32_t> appendedVersion_;

    std::thread thread_;
};

}  // namespace avatar
