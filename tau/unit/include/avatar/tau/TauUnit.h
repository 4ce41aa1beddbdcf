#pragma once
/// @file TauUnit.h
/// TAUUnit (thesis 4.3.3): the client of TAUNet that any executable (the
/// manipulator controller, the text console) links to command the vision
/// system and fetch its results over the TAU protocol (docs/protocol.md).
/// User guide: docs/tauunit.md.
///
/// Synchronous: every call sends one request and waits for its reply, at most
/// a bounded time. Not thread-safe: use one TauUnit from one thread (or guard it).
///
/// Error policy:
/// - the server answered ERROR: TauError (its code() and serverMessage());
///   a rejected configuration is the subclass ConfigRejectedError;
/// - the connection could not be made, broke, or the server sent bytes that do
///   not follow the protocol: ConnectionError;
/// - no reply within the limit: TimeoutError (a ConnectionError);
/// - the key does not fit (the server refused it, or the server could not
///   prove it has it), or the server needs a key and none is set:
///   AuthenticationError (never retried).
/// Every message names the endpoint (host:port or unix:PATH) and the request. "No data yet" is the server's
/// NOT_AVAILABLE, a TauError.

#include <avatar/common/Error.h>
#include <avatar/common/VisionTargets.h>
#include <avatar/tau/Protocol.h>

#include <opencv2/core/mat.hpp>

#include <chrono>
#include <cstddef>
#include <cstdint>
#include <deque>
#include <memory>
#include <optional>
#include <string>
#include <vector>

namespace avatar::tau {

/// What to do when the connection is lost or cannot be made during a request.
struct RetryPolicy {
    /// Further attempts after a connection failure: reconnect (with HELLO) and
    /// send the request again. 0: fail at once. SEND_CONFIG is never resent
    /// (whether the server applied it is unknown); timeouts are never retried.
    int attempts{0};
    /// Pause before each further attempt.
    std::chrono::milliseconds delay{250};
};

struct TauUnitOptions {
    std::string host{"127.0.0.1"};
    std::uint16_t port{0};
    /// A Unix-domain socket to connect to instead of host:port (TAUNet
    /// --unix-socket); empty: TCP.
    std::string unixSocket;
    /// The shared secret (readAuthKeyFile() of the daemon's key file). With a
    /// key the client proves it in every HELLO and checks the server's proof,
    /// so it also knows it talks to the daemon the key belongs to; a server
    /// without a key is then an AuthenticationError. Empty: no authentication
    /// (enough for a loopback daemon without a key, or a Unix-domain socket).
    std::string authKey;
    /// Sent in HELLO; TAUNet logs it.
    std::string clientName{"tauunit"};
    /// Limit for establishing the TCP connection and for the HELLO reply.
    std::chrono::milliseconds connectTimeout{2000};
    /// Limit for each request, from sending it to its whole reply.
    std::chrono::milliseconds requestTimeout{5000};
    /// TAKE_SNAPSHOT: how long the server may wait for the pair (sent in the
    /// request); the client waits this plus requestTimeout.
    std::chrono::milliseconds snapshotTimeout{10000};
    RetryPolicy retry;
    /// Action timings kept (oldest dropped first).
    std::size_t timingCapacity{1000};

    /// True when the options are usable; otherwise false and *error (if given)
    /// says what is wrong.
    bool isValid(std::string* error = nullptr) const;
};

/// The server answered ERROR.
class TauError : public avatar::Error {
public:
    TauError(ErrorCode code, std::string serverMessage, const std::string& what);
    ErrorCode code() const { return code_; }
    /// The message as the server sent it (for CONFIG_REJECTED: "file:line: element path: problem").
    const std::string& serverMessage() const { return serverMessage_; }

private:
    ErrorCode code_;
    std::string serverMessage_;
};

/// SEND_CONFIG answered CONFIG_REJECTED; the previous configuration stays in force.
class ConfigRejectedError : public TauError {
public:
    using TauError::TauError;
};

/// No connection, a broken one, or a reply that does not follow the protocol.
class ConnectionError : public avatar::Error {
public:
    ConnectionError(std::string endpoint, std::string request, const std::string& what);
    /// "host:port".
    const std::string& endpoint() const { return endpoint_; }
    /// The request under way ("HELLO", "STATUS", ...).
    const std::string& request() const { return request_; }

private:
    std::string endpoint_;
    std::string request_;
};

/// No (whole) reply within the limit. The connection stays open; a late reply is discarded.
class TimeoutError : public ConnectionError {
public:
    using ConnectionError::ConnectionError;
};

/// The key and the server do not fit: it refused the client's proof, its own
/// proof is wrong (not the daemon the key belongs to), it has no key while the
/// client has one, or it requires one the client does not have. The
/// connection is closed; retrying cannot help.
class AuthenticationError : public avatar::Error {
public:
    AuthenticationError(std::string endpoint, const std::string& what);
    const std::string& endpoint() const { return endpoint_; }

private:
    std::string endpoint_;
};

/// Images as TAUNet sent them: the JPEG bytes and their decoding.
struct TauImage {
    Side side{Side::Left};
    std::vector<std::uint8_t> jpeg;  ///< as received; write it to disk as is
    cv::Mat image;                   ///< cv::imdecode of jpeg (8-bit, 1 or 3 channels)
};
struct TauImages {
    std::uint64_t iteration{0};
    ImageKindCode kind{ImageKindCode::Original};
    std::vector<TauImage> images;  ///< the sides asked for, left first
    /// The image of one side, or nullptr if it was not asked for.
    const TauImage* side(Side s) const;
};

/// The bookkeeping of thesis 4.3.3 / Figure 4-6: iterations as this client
/// last saw them. 0 means "never".
struct TauIterations {
    std::uint64_t vision{0};           ///< latest vision iteration known (from STATUS or a reply)
    std::uint32_t serverConfigVersion{0};   ///< configuration in force on the server, last known
    std::uint64_t serverConfigIteration{0}; ///< its first iteration, last known
    std::uint64_t targets{0};          ///< iteration of the target data last retrieved
    std::uint32_t configVersion{0};    ///< version of the configuration last retrieved or sent
    std::uint64_t config{0};           ///< its configIteration
    std::uint64_t leftImage{0};        ///< iteration of the left image last retrieved
    std::uint64_t rightImage{0};       ///< iteration of the right image last retrieved
};

/// How one request ended.
enum class Outcome { Ok, ServerError, Timeout, ConnectionFailed, AuthenticationFailed };
/// "ok", "server-error", "timeout", "connection-failed", "authentication-failed".
const char* toString(Outcome outcome);

/// One entry of the action log (thesis 4.3.3).
struct ActionTiming {
    std::string request;                          ///< "TAKE_SNAPSHOT", ...
    std::uint32_t requestId{0};                   ///< 0 when it was never sent
    std::chrono::system_clock::time_point start;  ///< wall clock when the call began
    std::chrono::microseconds duration{0};        ///< until the reply was decoded (or the failure)
    Outcome outcome{Outcome::Ok};
    std::string detail;                           ///< error code and message when not Ok
};

class TauUnit {
public:
    /// No I/O; throws avatar::InvalidArgument when !options.isValid().
    explicit TauUnit(TauUnitOptions options);
    ~TauUnit();
    TauUnit(const TauUnit&) = delete;
    TauUnit& operator=(const TauUnit&) = delete;
    TauUnit(TauUnit&&) noexcept;
    TauUnit& operator=(TauUnit&&) noexcept;

    /// Connects and exchanges HELLO (a no-op when connected). A request made
    /// while not connected connects first. Returns the server's HELLO reply.
    HelloReply connect();
    /// Closes the connection (if any) and connects again.
    HelloReply reconnect();
    void disconnect();
    bool connected() const;
    /// The server's HELLO reply of the current connection.
    std::optional<HelloReply> server() const;
    const TauUnitOptions& options() const;
    /// "host:port", or "unix:PATH".
    std::string endpoint() const;

    // ---- requests (docs/protocol.md) -------------------------------------
    void startSearching();
    void stopSearching();
    /// Acquires and analyses one pair (while searching: the next iteration).
    /// @p timeout overrides options().snapshotTimeout.
    VisionTargets takeSnapshot(std::optional<std::chrono::milliseconds> timeout = std::nullopt);
    /// The latest target data; TauError NOT_AVAILABLE before the first iteration.
    VisionTargets getTargetData();
    /// Sends a whole configuration document; ConfigRejectedError when invalid.
    ConfigApplied sendConfig(const std::string& xml);
    ConfigReply getConfig();
    /// JPEG images of the latest iteration; @p sides: kLeftImage | kRightImage.
    TauImages getImages(ImageKindCode kind, std::uint8_t sides = kLeftImage | kRightImage,
                        int jpegQuality = 90);
    StatusReply status();

    // ---- bookkeeping -------------------------------------------------------
    const TauIterations& iterations() const;
    /// The target data last retrieved (takeSnapshot or getTargetData).
    const std::optional<VisionTargets>& lastTargets() const;
    /// True when target data was retrieved, belongs to the latest iteration
    /// known and was computed with the configuration in force (iteration >=
    /// serverConfigIteration). Knowledge is as of the last reply: call status() first.
    bool isTargetDataFresh() const;
    /// True when the configuration last retrieved or sent is the one in force.
    bool isConfigFresh() const;
    /// True when the image of @p side last retrieved belongs to the latest iteration known.
    bool isImageFresh(Side side) const;

    /// The action log, oldest first (at most options().timingCapacity entries).
    const std::deque<ActionTiming>& timings() const;
    void clearTimings();

private:
    class Impl;
    std::unique_ptr<Impl> impl_;
};

}  // namespace avatar::tau
