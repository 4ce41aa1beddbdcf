#include <avatar/tau/TauNetServer.h>

#include "RequestHandler.h"

#include <avatar/common/Error.h>
#include <avatar/common/Logging.h>
#include <avatar/common/internal/Text.h>
#include <avatar/tau/Authentication.h>
#include <avatar/tau/Protocol.h>
#include <avatar/tau/VisionInterface.h>

#include <boost/asio/dispatch.hpp>
#include <boost/asio/generic/stream_protocol.hpp>
#include <boost/asio/io_context.hpp>
#include <boost/asio/ip/tcp.hpp>
#include <boost/asio/local/stream_protocol.hpp>
#include <boost/asio/post.hpp>
#include <boost/asio/steady_timer.hpp>
#include <boost/asio/strand.hpp>
#include <boost/asio/thread_pool.hpp>
#include <boost/asio/write.hpp>

#include <log4cpp/Category.hh>
#include <log4cpp/Priority.hh>

#include <array>
#include <atomic>
#include <cerrno>
#include <cstdio>
#include <cstring>
#include <condition_variable>
#include <deque>
#include <map>
#include <mutex>
#include <thread>
#include <type_traits>
#include <vector>

#include <sys/socket.h>
#include <sys/stat.h>
#include <sys/un.h>
#include <unistd.h>

namespace avatar::tau {

namespace asio = boost::asio;
using tcp = asio::ip::tcp;
using local = asio::local::stream_protocol;
/// A connection's socket, TCP or Unix-domain alike.
using stream = asio::generic::stream_protocol;
using boost::system::error_code;

namespace {

log4cpp::Category& log() { return logging::category("taunet"); }

/// Text from the wire made safe to log: control characters (a newline would
/// forge a log line) and backslashes are written as \xNN escapes.
std::string printable(const std::string& wire) {
    return text::escapeControl(wire, true);
}

/// Warnings about one client's mistakes: the first kWarningBurst are logged,
/// then at most one summary per kWarningSummaryPeriod (and one at the close),
/// so a client sending garbage cannot flood the log.
constexpr std::uint64_t kWarningBurst = 10;
constexpr std::chrono::seconds kWarningSummaryPeriod{10};

/// Loopback, including an IPv4 loopback address mapped into IPv6 (::ffff:127.0.0.1).
bool isLoopback(const asio::ip::address& a) {
    if (a.is_loopback()) return true;
    if (a.is_v6() && a.to_v6().is_v4_mapped())
        return asio::ip::make_address_v4(asio::ip::v4_mapped, a.to_v6()).is_loopback();
    return false;
}

std::string describe(const tcp::endpoint& e) {
    std::string a = e.address().to_string();
    if (e.address().is_v6()) a = "[" + a + "]";
    return a + ":" + std::to_string(e.port());
}

/// "unix, uid 1000, pid 4242": who is at the other end of a Unix-domain socket.
std::string describeLocalPeer(local::socket& socket) {
    ucred peer{};
    socklen_t size = sizeof peer;
    if (::getsockopt(socket.native_handle(), SOL_SOCKET, SO_PEERCRED, &peer, &size) != 0) return "unix";
    return "unix, uid " + std::to_string(peer.uid) + ", pid " + std::to_string(peer.pid);
}

constexpr std::size_t kReadChunk = 64 * 1024;
constexpr std::size_t kMaxWriteBatch = 64;  ///< frames per gathered write

}  // namespace

bool TauNetOptions::isValid(std::string* error) const {
    auto fail = [&](const std::string& why) {
        if (error) *error = why;
        return false;
    };
    if (listenAddress.empty() && unixSocketPath.empty())
        return fail("neither listenAddress nor unixSocketPath is set: nothing to listen on");
    if (!authKey.empty() && authKey.size() < kMinAuthKeySize)
        return fail("authKey has " + std::to_string(authKey.size()) + " bytes; at least " +
                    std::to_string(kMinAuthKeySize) + " are needed");
    if (unixSocketPath.size() >= sizeof(sockaddr_un::sun_path))
        return fail("unixSocketPath is " + std::to_string(unixSocketPath.size()) + " bytes; at most " +
                    std::to_string(sizeof(sockaddr_un::sun_path) - 1) + " fit");
    if (unixSocketMode > 0777) return fail("unixSocketMode must be a permission mode 0..0777");
    if (networkThreads < 1 || networkThreads > 64) return fail("networkThreads must be 1..64");
    if (workerThreads < 1 || workerThreads > 64) return fail("workerThreads must be 1..64");
    if (maxSendQueueBytes < 1024) return fail("maxSendQueueBytes must be at least 1024");
    if (maxTotalSendQueueBytes < 1024) return fail("maxTotalSendQueueBytes must be at least 1024");
    if (maxConnections < 1) return fail("maxConnections must be at least 1");
    if (idleTimeout.count() <= 0) return fail("idleTimeout must be positive");
    if (helloTimeout.count() <= 0) return fail("helloTimeout must be positive");
    if (sessionIdleTimeout.count() < 0) return fail("sessionIdleTimeout must not be negative (0: never)");
    if (evictAfter.count() < 0) return fail("evictAfter must not be negative");
    if (lingerTimeout.count() < 0) return fail("lingerTimeout must not be negative");
    if (serverName.empty()) return fail("serverName is empty");
    return true;
}

class Connection;

/// Everything of the server but its public face.
class ServerCore {
public:
    ServerCore(VisionInterface& vision, TauNetOptions options);

    /// Accepts on @p acceptor until it closes; @p authenticate: its
    /// connections must AUTHENTICATE (TCP with a key).
    template <typename Acceptor>
    void accept(Acceptor& acceptor, asio::steady_timer& retry, bool authenticate);
    /// Makes a Connection of an accepted socket unless the limit refuses it.
    void admit(stream::socket socket, std::string peer, bool authenticate);
    void openUnixSocket();
    /// Removes the socket file if it is still the one this server made.
    void removeSocketFile();
    void stop();
    void wait();
    void remove(std::uint64_t id);
    /// At the connection limit: the connection to close for a new one, or null (mutex held).
    std::shared_ptr<Connection> evictionCandidate();
    /// The connection with the most replies waiting, or null (takes the mutex).
    std::shared_ptr<Connection> worstOffender();
    std::atomic<std::size_t> totalQueued{0};  ///< replies waiting, all connections

    VisionInterface& vision;
    const TauNetOptions options;
    const detail::RequestHandler handler;

    // Declared in destruction order: the worker pool goes before the
    // io_context whose sockets its tasks may still hold.
    asio::io_context io;
    asio::thread_pool workers;
    asio::strand<asio::io_context::executor_type> acceptStrand;
    tcp::acceptor acceptor;
    asio::steady_timer acceptRetry;
    tcp::endpoint endpoint;
    bool listensTcp{false};
    local::acceptor localAcceptor;
    asio::steady_timer localAcceptRetry;
    /// The socket file made, to remove at the end only if it is still ours.
    dev_t socketDevice{0};
    ino_t socketInode{0};
    /// The socket file's change time when it was made: an inode number is
    /// reused as soon as a file is removed, so device and inode alone would
    /// take another server's socket, made after ours was removed, for ours.
    timespec socketChanged{};
    std::vector<std::thread> threads;

    mutable std::mutex mutex;  // guards the members below
    std::condition_variable stoppedCv;
    bool stopping{false};
    bool joined{false};
    std::uint64_t nextId{0};
    std::map<std::uint64_t, std::weak_ptr<Connection>> connections;

    std::atomic<std::uint64_t> accepted{0}, rejected{0}, requests{0}, protocolErrors{0}, slowClients{0},
        idleTimeouts{0}, helloTimeouts{0}, sessionTimeouts{0}, evicted{0}, authFailures{0};
};

/// One client. Every member is touched only on the connection's strand
/// (the socket's executor), except `server_`, which is shared and thread-safe.
///
/// Requests are handled strictly one after the other, as the protocol says
/// ("frames are processed in order"): a blocking request runs on the worker
/// pool and, until its reply is queued, the connection neither reads nor
/// handles its next frame. So a pipelined TAKE_SNAPSHOT, GET_IMAGES sees the
/// snapshot's images, replies go out in request order by construction, and
/// TCP flow control holds back a client that pipelines faster than it is
/// served. Other connections are not affected.
class Connection : public std::enable_shared_from_this<Connection> {
public:
    /// @p authenticate: no request but HELLO and AUTHENTICATE until the client proved the key.
    Connection(ServerCore& server, stream::socket socket, std::uint64_t id, const std::string& peer,
               bool authenticate)
        : server_(server),
          socket_(std::move(socket)),
          timer_(socket_.get_executor()),
          sessionTimer_(socket_.get_executor()),
          decoder_(kMaxRequestPayload),
          id_(id),
          name_("client " + std::to_string(id) + " (" + peer + ")"),
          authRequired_(authenticate) {}

    stream::socket::executor_type executor() { return socket_.get_executor(); }

    void start() {
        if (phase_ == Phase::Closed) return;
        log().info("%s connected", name_.c_str());
        touch();
        armSessionTimer(server_.options.helloTimeout, SessionTimer::Hello);
        read();
    }

    /// For the eviction choice (read from the accept handler, hence atomic).
    bool saidHello() const { return helloSeen_; }
    bool quiet() const { return quiet_; }
    std::size_t queued() const { return queuedShared_; }
    std::int64_t lastActivityNs() const { return lastActivityNs_; }

    /// Closes at once; replies not yet written are dropped.
    void close(const std::string& why) {
        if (phase_ == Phase::Closed) return;
        phase_ = Phase::Closed;
        error_code ec;
        socket_.shutdown(asio::socket_base::shutdown_both, ec);
        socket_.close(ec);
        timer_.cancel();
        sessionTimer_.cancel();
        server_.totalQueued -= queuedBytes_;  // dropped with the connection
        queuedBytes_ = 0;
        queuedShared_ = 0;
        sendQueue_.clear();
        server_.remove(id_);
        summariseWarnings();
        log().info("%s disconnected: %s", name_.c_str(), why.c_str());
    }

private:
    enum class Phase {
        Open,      ///< reading and answering
        Closing,   ///< a closing ERROR is queued; no more requests
        Draining,  ///< the closing ERROR is written: reading and discarding until EOF or linger timeout
        Closed
    };

    // ---- the warning budget ------------------------------------------------

    /// True when a warning about this client may be logged now; otherwise it
    /// is counted, and summarised at most every kWarningSummaryPeriod.
    bool mayWarn() {
        if (++warnings_ <= kWarningBurst) return true;
        ++suppressed_;
        if (std::chrono::steady_clock::now() - lastSummary_ >= kWarningSummaryPeriod) summariseWarnings();
        return false;
    }

    void summariseWarnings() {
        if (suppressed_ == 0) return;
        log().warn("%s: %llu more warnings about this client suppressed (%llu in all)", name_.c_str(),
                   static_cast<unsigned long long>(suppressed_), static_cast<unsigned long long>(warnings_));
        suppressed_ = 0;
        lastSummary_ = std::chrono::steady_clock::now();
    }

    // ---- reading -----------------------------------------------------------

    void read() {
        if (reading_ || busy_) return;
        if (phase_ != Phase::Open && phase_ != Phase::Draining) return;
        if (phase_ == Phase::Open && peerEof_) return;
        reading_ = true;
        socket_.async_read_some(asio::buffer(readBuffer_),
                                [self = shared_from_this()](const error_code& ec, std::size_t n) {
                                    self->onRead(ec, n);
                                });
    }

    void onRead(const error_code& ec, std::size_t n) {
        reading_ = false;
        if (phase_ == Phase::Closed) return;
        if (ec) {
            if (phase_ == Phase::Draining) return close("closed after a protocol error");
            if (ec != asio::error::eof) return close("read failed: " + ec.message());
            if (decoder_.buffered() > 0)
                log().warn("%s closed its side in the middle of a frame (%zu bytes of it received)", name_.c_str(),
                           decoder_.buffered());
            peerEof_ = true;
            cancelTimer();
            finishIfDone();
            return;
        }
        if (phase_ == Phase::Draining) return read();  // discard
        if (phase_ != Phase::Open) return;
        decoder_.feed(readBuffer_.data(), n);
        resume();
    }

    /// Handles the frames received so far, then reads on (unless a blocking
    /// request is in progress or the connection is closing).
    void resume() {
        process();
        if (phase_ == Phase::Open) {
            // The deadline runs from the frame's first byte: bytes trickling in do not extend it.
            if (decoder_.buffered() > 0 && !busy_) {
                if (!frameTimerArmed_ || frameTimerFrame_ != framesTaken_) {
                    armTimer(server_.options.idleTimeout, TimerPurpose::Idle);
                    frameTimerArmed_ = true;
                    frameTimerFrame_ = framesTaken_;
                }
            } else {
                cancelTimer();
            }
        }
        quiet_ = decoder_.buffered() == 0 && !busy_;
        read();
    }

    /// Takes whole frames out of the decoder while no request is in progress.
    void process() {
        try {
            while (phase_ == Phase::Open && !busy_) {
                std::optional<Frame> frame = decoder_.next();
                if (!frame) break;
                dispatch(std::move(*frame));
            }
        } catch (const ProtocolError& e) {
            // The header itself is bad: its request id cannot be trusted.
            closingError(0, e.code(), detail::messageOf(e));
        }
    }

    void dispatch(Frame frame) {
        ++server_.requests;
        ++framesTaken_;
        touch();
        const std::uint16_t type = frame.header.type;
        const std::uint32_t id = frame.header.request;
        if (!hello_ && type != static_cast<std::uint16_t>(MessageType::Hello))
            return closingError(id, ErrorCode::HelloRequired,
                                "the first message must be HELLO, not " + messageName(type));
        if (type == static_cast<std::uint16_t>(MessageType::Hello)) return hello(frame);
        if (type == static_cast<std::uint16_t>(MessageType::Authenticate) && version_ >= kAuthenticatingVersion)
            return authenticate(frame);
        if (authRequired_ && !authenticated_)
            return closingError(id, ErrorCode::AuthenticationRequired,
                                messageName(type) + " before AUTHENTICATE: this connection must prove the key first");
        if (!detail::RequestHandler::known(type)) {
            ++server_.protocolErrors;
            if (mayWarn())
                log().warn("%s sent unknown message type %s (request %u)", name_.c_str(), messageName(type).c_str(),
                           id);
            reply(detail::errorAnswer(id, {ErrorCode::UnknownMessage, "unknown message type " + messageName(type)}).frame);
            return;
        }
        log().debug("%s: %s (request %u, %zu payload bytes)", name_.c_str(), messageName(type).c_str(), id,
                    frame.payload.size());
        if (!detail::RequestHandler::blocks(type)) {
            detail::Answer answer = server_.handler.handle(frame, version_);
            logError(frame, answer);
            reply(std::move(answer.frame));
            return;
        }

        // Blocking: answered on the worker pool; the reply comes back to this strand.
        busy_ = true;
        quiet_ = false;
        cancelTimer();
        auto request = std::make_shared<Frame>(std::move(frame));
        asio::post(server_.workers, [self = shared_from_this(), request] {
            auto answer = std::make_shared<detail::Answer>(self->server_.handler.handle(*request, self->version_));
            asio::post(self->executor(), [self, request, answer] {
                self->busy_ = false;
                if (self->phase_ == Phase::Closed) return;
                self->logError(*request, *answer);
                self->reply(std::move(answer->frame));
                self->resume();
            });
        });
    }

    void hello(const Frame& frame) {
        const std::uint32_t id = frame.header.request;
        // The version comes first and is checked first: a client of another
        // version may well have a different HELLO payload.
        if (const auto version = helloVersion(frame.payload); version && !protocolVersionSupported(*version))
            return closingError(id, ErrorCode::VersionUnsupported,
                                "protocol version " + std::to_string(*version) +
                                    " is not supported; this server speaks versions " +
                                    std::to_string(kOldestProtocolVersion) + " to " +
                                    std::to_string(kProtocolVersion));
        if (const auto version = helloVersion(frame.payload);
            version && authRequired_ && *version < kAuthenticatingVersion)
            return closingError(id, ErrorCode::VersionUnsupported,
                                "protocol version " + std::to_string(*version) +
                                    " has no authentication, which this server requires on TCP connections; "
                                    "speak version " + std::to_string(kAuthenticatingVersion) + " and AUTHENTICATE");
        Hello m;
        try {
            m = decodeHello(frame.payload);
        } catch (const ProtocolError& e) {
            ++server_.protocolErrors;
            if (mayWarn()) log().warn("%s: HELLO (request %u): %s", name_.c_str(), id, printable(e.what()).c_str());
            reply(detail::errorAnswer(id, {e.code(), detail::messageOf(e)}).frame);
            // docs/protocol.md: the session is not open after a HELLO that does
            // not decode, even if one was: the next frame must be HELLO again.
            if (hello_) armSessionTimer(server_.options.helloTimeout, SessionTimer::Hello);
            hello_ = false;
            helloSeen_ = false;
            authenticated_ = false;
            challenge_.clear();
            return;
        }
        if (!hello_)
            log().info("%s is '%s' (protocol version %u)", name_.c_str(), printable(m.clientName).c_str(),
                       static_cast<unsigned>(m.version));
        hello_ = true;
        version_ = m.version;
        challenge_.clear();
        if (version_ >= kAuthenticatingVersion && !server_.options.authKey.empty()) challenge_ = randomBytes(kChallengeSize);
        reply(server_.handler.helloReply(id, version_, authRequired_ && !authenticated_, challenge_));
        if (open()) {
            helloSeen_ = true;
            touch();  // the idle limit runs from here
        }
    }

    /// The session may make requests: HELLO done, and AUTHENTICATE where required.
    bool open() const { return hello_ && (!authRequired_ || authenticated_); }

    void authenticate(const Frame& frame) {
        const std::uint32_t id = frame.header.request;
        auto refuse = [&](const std::string& why) {
            if (mayWarn()) log().warn("%s: AUTHENTICATE (request %u): %s", name_.c_str(), id, why.c_str());
            reply(detail::errorAnswer(id, {ErrorCode::InvalidState, why}).frame);
        };
        if (server_.options.authKey.empty()) return refuse("this server has no authentication key");
        if (challenge_.empty()) return refuse("no challenge outstanding: send HELLO first (each challenge is used once)");
        Authenticate m;
        try {
            m = decodeAuthenticate(frame.payload);
        } catch (const ProtocolError& e) {
            ++server_.protocolErrors;
            if (mayWarn()) log().warn("%s: AUTHENTICATE (request %u): %s", name_.c_str(), id, printable(e.what()).c_str());
            reply(detail::errorAnswer(id, {e.code(), detail::messageOf(e)}).frame);
            return;
        }
        const std::vector<std::uint8_t> challenge = std::move(challenge_);
        challenge_.clear();
        if (!macsEqual(clientProof(server_.options.authKey, challenge, m.nonce), m.mac)) {
            ++server_.authFailures;
            authenticated_ = false;
            return closingError(id, ErrorCode::AuthenticationFailed, "the proof does not match this server's key");
        }
        if (!authenticated_) log().info("%s authenticated", name_.c_str());
        authenticated_ = true;
        reply(encodeFrame(replyType(MessageType::Authenticate), id,
                          encode(AuthenticateReply{serverProof(server_.options.authKey, challenge, m.nonce)})));
        if (open()) {
            helloSeen_ = true;
            touch();
        }
    }

    /// Logs an ERROR answer (and counts BAD_PAYLOAD as a protocol error).
    void logError(const Frame& request, const detail::Answer& answer) {
        if (!answer.error) return;
        const ErrorReply& e = *answer.error;
        // The client's mistakes are warnings; refusing a valid request is information.
        const bool clientFault = e.code == ErrorCode::BadPayload;
        if (clientFault) ++server_.protocolErrors;
        if (clientFault && !mayWarn()) return;
        log().log(clientFault ? log4cpp::Priority::WARN : log4cpp::Priority::INFO, "%s: %s (request %u) answered %s: %s",
                  name_.c_str(), messageName(request.header.type).c_str(), request.header.request, errorName(e.code),
                  printable(e.message).c_str());
    }

    /// Queues an ERROR after which the connection closes (docs/protocol.md).
    void closingError(std::uint32_t request, ErrorCode code, const std::string& message) {
        ++server_.protocolErrors;
        log().warn("%s: %s: %s; closing", name_.c_str(), errorName(code), printable(message).c_str());
        if (!reply(detail::errorAnswer(request, {code, message}).frame)) return;
        phase_ = Phase::Closing;
        closeAfterWrite_ = true;
        cancelTimer();
    }

    // ---- writing -----------------------------------------------------------

    /// Queues one reply for sending; false when that disconnected a client
    /// whose send queue is over its limit.
    bool reply(std::vector<std::uint8_t> frame) {
        if (phase_ == Phase::Closed) return false;
        const std::size_t limit = server_.options.maxSendQueueBytes;
        if (queuedBytes_ > 0 && queuedBytes_ + frame.size() > limit) {
            ++server_.slowClients;
            log().warn("%s does not read its replies: %zu bytes queued, %zu more would exceed the limit of %zu",
                       name_.c_str(), queuedBytes_, frame.size(), limit);
            close("send queue over its limit (the client does not read)");
            return false;
        }
        if (server_.totalQueued + frame.size() > server_.options.maxTotalSendQueueBytes) {
            // Over the budget of all clients: the one with the most waiting goes.
            std::shared_ptr<Connection> worst = server_.worstOffender();
            if (!worst || worst.get() == this) {
                if (queuedBytes_ > 0) {
                    ++server_.slowClients;
                    log().warn("%s has the most replies waiting (%zu bytes) when all clients' %zu bytes would exceed "
                               "the budget of %zu; closing", name_.c_str(), queuedBytes_,
                               static_cast<std::size_t>(server_.totalQueued),
                               server_.options.maxTotalSendQueueBytes);
                    close("the send budget of all clients is exhausted and this client has the most waiting");
                    return false;
                }
            } else {
                ++server_.slowClients;
                asio::post(worst->executor(), [worst] {
                    worst->close("the send budget of all clients is exhausted and this client has the most waiting");
                });
            }
        }
        queuedBytes_ += frame.size();
        queuedShared_ = queuedBytes_;
        server_.totalQueued += frame.size();
        sendQueue_.push_back(std::move(frame));
        write();
        return true;
    }

    void write() {
        if (writing_ || sendQueue_.empty() || phase_ == Phase::Closed) return;
        std::vector<asio::const_buffer> buffers;
        const std::size_t count = std::min(sendQueue_.size(), kMaxWriteBatch);
        buffers.reserve(count);
        for (std::size_t i = 0; i < count; ++i) buffers.push_back(asio::buffer(sendQueue_[i]));
        writing_ = true;
        asio::async_write(socket_, buffers,
                          [self = shared_from_this(), count](const error_code& ec, std::size_t n) {
                              self->onWrite(ec, n, count);
                          });
    }

    void onWrite(const error_code& ec, std::size_t n, std::size_t count) {
        writing_ = false;
        if (phase_ == Phase::Closed) return;
        if (ec) return close("write failed: " + ec.message());
        for (std::size_t i = 0; i < count; ++i) sendQueue_.pop_front();
        queuedBytes_ -= n;
        queuedShared_ = queuedBytes_;
        server_.totalQueued -= n;
        if (closeAfterWrite_ && sendQueue_.empty()) return drain();
        write();
        finishIfDone();
    }

    /// After a closing ERROR: half-close and read until the client closes, so
    /// it receives the ERROR rather than a reset.
    void drain() {
        phase_ = Phase::Draining;
        error_code ec;
        socket_.shutdown(asio::socket_base::shutdown_send, ec);
        if (ec) return close("closed after a protocol error");
        armTimer(server_.options.lingerTimeout, TimerPurpose::Linger);
        read();
    }

    /// Closes once a client that closed its side has all its replies.
    void finishIfDone() {
        if (phase_ == Phase::Open && peerEof_ && !busy_ && sendQueue_.empty() && !writing_)
            close("the client closed the connection");
    }

    // ---- timers ------------------------------------------------------------

    enum class TimerPurpose { Idle, Linger };

    void armTimer(std::chrono::milliseconds after, TimerPurpose purpose) {
        const std::uint64_t generation = ++timerGeneration_;
        timer_.expires_after(after);
        timer_.async_wait([self = shared_from_this(), generation, purpose, after](const error_code& ec) {
            if (ec || generation != self->timerGeneration_ || self->phase_ == Phase::Closed) return;
            if (purpose == TimerPurpose::Linger) return self->close("closed after a protocol error");
            ++self->server_.idleTimeouts;
            log().warn("%s: partial frame (%zu bytes) not completed within %lld ms; closing", self->name_.c_str(),
                       self->decoder_.buffered(), static_cast<long long>(after.count()));
            self->close("idle timeout in the middle of a frame");
        });
    }

    void cancelTimer() {
        ++timerGeneration_;
        frameTimerArmed_ = false;
        timer_.cancel();
    }

    // The session's own timer: HELLO until it is received, then idleness.
    enum class SessionTimer { Hello, Idle };

    /// A request arrived (or the connection opened): the session is not idle.
    void touch() {
        lastActivityNs_ = std::chrono::duration_cast<std::chrono::nanoseconds>(
                              std::chrono::steady_clock::now().time_since_epoch())
                              .count();
        if (open() && server_.options.sessionIdleTimeout.count() > 0)
            armSessionTimer(server_.options.sessionIdleTimeout, SessionTimer::Idle);
    }

    void armSessionTimer(std::chrono::milliseconds after, SessionTimer purpose) {
        const std::uint64_t generation = ++sessionGeneration_;
        sessionTimer_.expires_after(after);
        sessionTimer_.async_wait([self = shared_from_this(), generation, purpose, after](const error_code& ec) {
            if (ec || generation != self->sessionGeneration_ || self->phase_ != Phase::Open) return;
            if (purpose == SessionTimer::Hello) {
                if (self->open()) return;
                ++self->server_.helloTimeouts;
                const char* what = self->hello_ ? "AUTHENTICATE" : "HELLO";
                log().warn("%s: no %s within %lld ms; closing", self->name_.c_str(), what,
                           static_cast<long long>(after.count()));
                return self->close(std::string("no ") + what + " in time");
            }
            if (self->busy_) return self->armSessionTimer(after, purpose);  // a request is being answered
            ++self->server_.sessionTimeouts;
            log().info("%s: no request for %lld ms; closing the idle session", self->name_.c_str(),
                       static_cast<long long>(after.count()));
            self->close("idle session");
        });
    }

    ServerCore& server_;
    stream::socket socket_;
    asio::steady_timer timer_;
    asio::steady_timer sessionTimer_;
    FrameDecoder decoder_;
    std::uint64_t id_;
    std::string name_;
    std::array<std::uint8_t, kReadChunk> readBuffer_{};

    Phase phase_{Phase::Open};
    bool hello_{false};
    const bool authRequired_;
    bool authenticated_{false};
    std::vector<std::uint8_t> challenge_;  ///< of the last HELLO_REPLY, until an AUTHENTICATE uses it
    std::uint64_t warnings_{0};    ///< about this client's mistakes, logged or not
    std::uint64_t suppressed_{0};  ///< not logged since the last summary
    std::chrono::steady_clock::time_point lastSummary_{std::chrono::steady_clock::now()};
    std::uint16_t version_{kProtocolVersion};  ///< the session's, from its HELLO
    bool reading_{false};
    bool writing_{false};
    bool busy_{false};  ///< a blocking request is on the worker pool
    bool peerEof_{false};
    bool closeAfterWrite_{false};
    std::uint64_t timerGeneration_{0};
    std::uint64_t sessionGeneration_{0};
    bool frameTimerArmed_{false};
    std::uint64_t framesTaken_{0};      ///< frames taken out of the decoder so far
    std::uint64_t frameTimerFrame_{0};  ///< framesTaken_ when the frame timer was armed
    std::atomic<bool> helloSeen_{false};
    std::atomic<bool> quiet_{true};     ///< no partial frame, no request in progress
    std::atomic<std::int64_t> lastActivityNs_{0};
    std::deque<std::vector<std::uint8_t>> sendQueue_;
    std::size_t queuedBytes_{0};
    std::atomic<std::size_t> queuedShared_{0};  ///< queuedBytes_ for worstOffender()
};

// ---- the server -----------------------------------------------------------

class TauNetServer::Impl : public ServerCore {
public:
    using ServerCore::ServerCore;
};

ServerCore::ServerCore(VisionInterface& v, TauNetOptions o)
    : vision(v),
      options(std::move(o)),
      handler(v, options.serverName),
      workers(options.workerThreads),
      acceptStrand(asio::make_strand(io)),
      acceptor(acceptStrand),
      acceptRetry(acceptStrand),
      localAcceptor(acceptStrand),
      localAcceptRetry(acceptStrand) {
    const bool keyed = !options.authKey.empty();
    if (!options.listenAddress.empty()) {
        const std::string where = options.listenAddress + ":" + std::to_string(options.port);
        tcp::endpoint wanted;
        try {
            tcp::resolver resolver(io);
            const auto results = resolver.resolve(options.listenAddress, std::to_string(options.port),
                                                  tcp::resolver::numeric_service | tcp::resolver::passive);
            if (results.empty()) throw IoError("cannot listen on " + where + ": the address does not resolve");
            wanted = results.begin()->endpoint();
        } catch (const boost::system::system_error& e) {
            throw IoError("cannot listen on " + where + ": " + e.code().message());
        }
        // Beyond loopback anyone on the network could command the arm's eyes.
        if (!isLoopback(wanted.address()) && !keyed)
            throw InvalidArgument("listening on " + where +
                                  " reaches other machines, which needs an authentication key "
                                  "(TauNetOptions::authKey, taunet --auth-key FILE)");
        try {
            acceptor.open(wanted.protocol());
            acceptor.set_option(tcp::acceptor::reuse_address(true));
            acceptor.bind(wanted);
            acceptor.listen(asio::socket_base::max_listen_connections);
            endpoint = acceptor.local_endpoint();
        } catch (const boost::system::system_error& e) {
            throw IoError("cannot listen on " + where + ": " + e.code().message());
        }
        listensTcp = true;
        log().notice("listening on %s (backend %s; %s)", describe(endpoint).c_str(), handler.backend().c_str(),
                     keyed ? "clients must authenticate" : "no authentication: loopback only");
    }
    if (!options.unixSocketPath.empty()) {
        openUnixSocket();
        char mode[8];
        std::snprintf(mode, sizeof mode, "%04o", options.unixSocketMode);
        log().notice("listening on unix:%s (mode %s; backend %s)", options.unixSocketPath.c_str(), mode,
                     handler.backend().c_str());
    }
    if (listensTcp) accept(acceptor, acceptRetry, keyed);
    if (localAcceptor.is_open()) accept(localAcceptor, localAcceptRetry, false);
    for (std::size_t i = 0; i < options.networkThreads; ++i)
        threads.emplace_back([this] {
            for (;;) {
                try {
                    io.run();
                    return;
                } catch (const std::exception& e) {
                    log().error("network thread: unexpected exception: %s", e.what());
                }
            }
        });
}

void ServerCore::openUnixSocket() {
    const std::string& path = options.unixSocketPath;
    const std::string where = "cannot listen on unix:" + path + ": ";
    struct stat st {};
    if (::lstat(path.c_str(), &st) == 0) {
        if (!S_ISSOCK(st.st_mode)) throw IoError(where + "a file that is not a socket is in the way");
        // A socket file: in use by a live server, or left behind by a dead one.
        local::socket probe(io);
        error_code ec;
        probe.connect(local::endpoint(path), ec);
        if (!ec) throw IoError(where + "another server is listening on it");
        if (::unlink(path.c_str()) != 0) throw IoError(where + "cannot remove the stale socket: " + std::strerror(errno));
        log().notice("removed the stale socket file %s", path.c_str());
    }
    try {
        localAcceptor.open(local());
        localAcceptor.bind(local::endpoint(path));
        // The permissions are set before listen(): until then no client can connect.
        if (::chmod(path.c_str(), static_cast<mode_t>(options.unixSocketMode)) != 0 ||
            ::lstat(path.c_str(), &st) != 0) {
            const std::string why = std::strerror(errno);
            ::unlink(path.c_str());
            throw IoError(where + "cannot set its permissions: " + why);
        }
        socketDevice = st.st_dev;
        socketInode = st.st_ino;
        socketChanged = st.st_ctim;
        localAcceptor.listen(asio::socket_base::max_listen_connections);
    } catch (const boost::system::system_error& e) {
        throw IoError(where + e.code().message());
    }
}

template <typename Acceptor>
void ServerCore::accept(Acceptor& a, asio::steady_timer& retry, bool authenticate) {
    a.async_accept(asio::make_strand(io), [this, &a, &retry, authenticate](const error_code& ec,
                                                                           typename Acceptor::protocol_type::socket socket) {
        if (ec) {
            if (ec == asio::error::operation_aborted || !a.is_open()) return;
            // Out of descriptors and the like: try again shortly, do not spin.
            log().error("accept failed: %s", ec.message().c_str());
            retry.expires_after(std::chrono::milliseconds(100));
            retry.async_wait([this, &a, &retry, authenticate](const error_code& e) {
                if (!e && a.is_open()) accept(a, retry, authenticate);
            });
            return;
        }
        std::string peer;
        if constexpr (std::is_same_v<typename Acceptor::protocol_type, tcp>) {
            error_code ignored;
            socket.set_option(tcp::no_delay(true), ignored);
            const auto remote = socket.remote_endpoint(ignored);
            peer = ignored ? std::string("?") : describe(remote);
        } else {
            peer = describeLocalPeer(socket);
        }
        admit(stream::socket(std::move(socket)), std::move(peer), authenticate);
        accept(a, retry, authenticate);
    });
}

void ServerCore::admit(stream::socket socket, std::string peer, bool authenticate) {
    std::shared_ptr<Connection> connection;
    {
        std::lock_guard<std::mutex> lock(mutex);
        if (stopping) return;  // the socket closes as it goes out of scope
        std::shared_ptr<Connection> evict;
        if (connections.size() >= options.maxConnections) evict = evictionCandidate();
        if (evict) {
            ++evicted;
            log().warn("%zu clients (the limit): a connection %s makes room for a new one", connections.size(),
                       evict->saidHello() ? "idle the longest" : "that has not said HELLO");
            asio::post(evict->executor(), [evict] { evict->close("evicted to make room (the connection limit)"); });
            connections.erase(std::find_if(connections.begin(), connections.end(), [&](const auto& entry) {
                                  return entry.second.lock() == evict;
                              }));
        }
        if (connections.size() >= options.maxConnections) {
            ++rejected;
            log().warn("connection refused: already %zu clients (the limit), none silent or idle to evict",
                       connections.size());
            return;
        }
        connection = std::make_shared<Connection>(*this, std::move(socket), ++nextId, peer, authenticate);
        connections.emplace(nextId, connection);
        ++accepted;
    }
    asio::dispatch(connection->executor(), [connection] { connection->start(); });
}

std::shared_ptr<Connection> ServerCore::evictionCandidate() {
    const std::int64_t now =
        std::chrono::duration_cast<std::chrono::nanoseconds>(std::chrono::steady_clock::now().time_since_epoch())
            .count();
    const std::int64_t minIdle = std::chrono::duration_cast<std::chrono::nanoseconds>(options.evictAfter).count();
    std::shared_ptr<Connection> silent, idlest;
    std::int64_t silentSince = now, idlestSince = now;
    for (const auto& [id, weak] : connections) {
        const std::shared_ptr<Connection> c = weak.lock();
        if (!c) continue;
        const std::int64_t since = c->lastActivityNs();
        if (!c->saidHello()) {
            if (now - since >= minIdle && since <= silentSince) {
                silent = c;
                silentSince = since;
            }
        } else if (c->quiet() && now - since >= minIdle && since <= idlestSince) {
            idlest = c;
            idlestSince = since;
        }
    }
    return silent ? silent : idlest;
}

std::shared_ptr<Connection> ServerCore::worstOffender() {
    std::lock_guard<std::mutex> lock(mutex);
    std::shared_ptr<Connection> worst;
    std::size_t most = 0;
    for (const auto& [id, weak] : connections) {
        const std::shared_ptr<Connection> c = weak.lock();
        if (c && c->queued() > most) {
            most = c->queued();
            worst = c;
        }
    }
    return worst;
}

void ServerCore::remove(std::uint64_t id) {
    std::lock_guard<std::mutex> lock(mutex);
    connections.erase(id);
}

void ServerCore::stop() {
    std::vector<std::shared_ptr<Connection>> open;
    {
        std::lock_guard<std::mutex> lock(mutex);
        if (stopping) return;
        stopping = true;
        for (auto& [id, weak] : connections)
            if (auto c = weak.lock()) open.push_back(std::move(c));
    }
    log().notice("stopping: closing %zu connection(s)", open.size());
    asio::post(acceptStrand, [this] {
        error_code ec;
        acceptor.close(ec);
        acceptRetry.cancel();
        localAcceptor.close(ec);
        localAcceptRetry.cancel();
    });
    for (auto& c : open) asio::post(c->executor(), [c] { c->close("the server is stopping"); });
    stoppedCv.notify_all();
}

void ServerCore::wait() {
    {
        std::unique_lock<std::mutex> lock(mutex);
        stoppedCv.wait(lock, [this] { return stopping; });
        if (joined) return;
        joined = true;
        // The connections close on their strands; give them a moment.
        const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(2);
        while (!connections.empty() && std::chrono::steady_clock::now() < deadline) {
            lock.unlock();
            std::this_thread::sleep_for(std::chrono::milliseconds(5));
            lock.lock();
        }
    }
    workers.join();  // blocking requests still running finish (bounded by their timeouts)
    io.stop();
    for (auto& t : threads) t.join();
    threads.clear();
    removeSocketFile();
    log().notice("stopped");
}

void ServerCore::removeSocketFile() {
    if (socketInode == 0) return;
    struct stat st {};
    if (::lstat(options.unixSocketPath.c_str(), &st) == 0 && st.st_dev == socketDevice && st.st_ino == socketInode &&
        st.st_ctim.tv_sec == socketChanged.tv_sec && st.st_ctim.tv_nsec == socketChanged.tv_nsec)
        ::unlink(options.unixSocketPath.c_str());
    socketInode = 0;
}

TauNetServer::TauNetServer(VisionInterface& vision, TauNetOptions options) {
    std::string why;
    if (!options.isValid(&why)) throw InvalidArgument("TAUNet options: " + why);
    impl_ = std::make_unique<Impl>(vision, std::move(options));
}

TauNetServer::~TauNetServer() {
    stop();
    wait();
}

std::string TauNetServer::address() const {
    return impl_->listensTcp ? impl_->endpoint.address().to_string() : std::string();
}
std::uint16_t TauNetServer::port() const { return impl_->listensTcp ? impl_->endpoint.port() : 0; }
std::string TauNetServer::unixSocketPath() const { return impl_->options.unixSocketPath; }
void TauNetServer::stop() { impl_->stop(); }
void TauNetServer::wait() { impl_->wait(); }

bool TauNetServer::stopped() const {
    std::lock_guard<std::mutex> lock(impl_->mutex);
    return impl_->stopping;
}

TauNetStats TauNetServer::stats() const {
    TauNetStats s;
    {
        std::lock_guard<std::mutex> lock(impl_->mutex);
        s.connections = impl_->connections.size();
    }
    s.accepted = impl_->accepted;
    s.rejected = impl_->rejected;
    s.requests = impl_->requests;
    s.protocolErrors = impl_->protocolErrors;
    s.slowClients = impl_->slowClients;
    s.idleTimeouts = impl_->idleTimeouts;
    s.helloTimeouts = impl_->helloTimeouts;
    s.sessionTimeouts = impl_->sessionTimeouts;
    s.evicted = impl_->evicted;
    s.authFailures = impl_->authFailures;
    return s;
}

}  // namespace avatar::tau
