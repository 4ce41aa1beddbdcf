#include <avatar/tau/TauNetServer.h>

#include "RequestHandler.h"

#include <avatar/common/Error.h>
#include <avatar/common/Logging.h>
#include <avatar/common/internal/Text.h>
#include <avatar/tau/Protocol.h>
#include <avatar/tau/VisionInterface.h>

#include <boost/asio/dispatch.hpp>
#include <boost/asio/io_context.hpp>
#include <boost/asio/ip/tcp.hpp>
#include <boost/asio/post.hpp>
#include <boost/asio/steady_timer.hpp>
#include <boost/asio/strand.hpp>
#include <boost/asio/thread_pool.hpp>
#include <boost/asio/write.hpp>

#include <log4cpp/Category.hh>
#include <log4cpp/Priority.hh>

#include <array>
#include <atomic>
#include <condition_variable>
#include <deque>
#include <map>
#include <mutex>
#include <thread>
#include <vector>

namespace avatar::tau {

namespace asio = boost::asio;
using tcp = asio::ip::tcp;
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

constexpr std::size_t kReadChunk = 64 * 1024;
constexpr std::size_t kMaxWriteBatch = 64;  ///< frames per gathered write

}  // namespace

bool TauNetOptions::isValid(std::string* error) const {
    auto fail = [&](const std::string& why) {
        if (error) *error = why;
        return false;
    };
    if (listenAddress.empty()) return fail("listenAddress is empty");
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

    void accept();
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
    std::vector<std::thread> threads;

    mutable std::mutex mutex;  // guards the members below
    std::condition_variable stoppedCv;
    bool stopping{false};
    bool joined{false};
    std::uint64_t nextId{0};
    std::map<std::uint64_t, std::weak_ptr<Connection>> connections;

    std::atomic<std::uint64_t> accepted{0}, rejected{0}, requests{0}, protocolErrors{0}, slowClients{0},
        idleTimeouts{0}, helloTimeouts{0}, sessionTimeouts{0}, evicted{0};
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
    Connection(ServerCore& server, tcp::socket socket, std::uint64_t id)
        : server_(server),
          socket_(std::move(socket)),
          timer_(socket_.get_executor()),
          sessionTimer_(socket_.get_executor()),
          decoder_(kMaxRequestPayload),
          id_(id) {
        error_code ec;
        const auto peer = socket_.remote_endpoint(ec);
        name_ = "client " + std::to_string(id_) + " (" + (ec ? std::string("?") : describe(peer)) + ")";
    }

    tcp::socket::executor_type executor() { return socket_.get_executor(); }

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
        socket_.shutdown(tcp::socket::shutdown_both, ec);
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
            return;
        }
        if (!hello_)
            log().info("%s is '%s' (protocol version %u)", name_.c_str(), printable(m.clientName).c_str(),
                       static_cast<unsigned>(m.version));
        hello_ = true;
        helloSeen_ = true;
        version_ = m.version;
        reply(server_.handler.helloReply(id, version_));
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
        socket_.shutdown(tcp::socket::shutdown_send, ec);
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
        if (hello_ && server_.options.sessionIdleTimeout.count() > 0)
            armSessionTimer(server_.options.sessionIdleTimeout, SessionTimer::Idle);
    }

    void armSessionTimer(std::chrono::milliseconds after, SessionTimer purpose) {
        const std::uint64_t generation = ++sessionGeneration_;
        sessionTimer_.expires_after(after);
        sessionTimer_.async_wait([self = shared_from_this(), generation, purpose, after](const error_code& ec) {
            if (ec || generation != self->sessionGeneration_ || self->phase_ != Phase::Open) return;
            if (purpose == SessionTimer::Hello) {
                if (self->hello_) return;
                ++self->server_.helloTimeouts;
                log().warn("%s: no HELLO within %lld ms; closing", self->name_.c_str(),
                           static_cast<long long>(after.count()));
                return self->close("no HELLO in time");
            }
            if (self->busy_) return self->armSessionTimer(after, purpose);  // a request is being answered
            ++self->server_.sessionTimeouts;
            log().info("%s: no request for %lld ms; closing the idle session", self->name_.c_str(),
                       static_cast<long long>(after.count()));
            self->close("idle session");
        });
    }

    ServerCore& server_;
    tcp::socket socket_;
    asio::steady_timer timer_;
    asio::steady_timer sessionTimer_;
    FrameDecoder decoder_;
    std::uint64_t id_;
    std::string name_;
    std::array<std::uint8_t, kReadChunk> readBuffer_{};

    Phase phase_{Phase::Open};
    bool hello_{false};
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
      acceptRetry(acceptStrand) {
    const std::string where = options.listenAddress + ":" + std::to_string(options.port);
    try {
        tcp::resolver resolver(io);
        const auto results = resolver.resolve(options.listenAddress, std::to_string(options.port),
                                              tcp::resolver::numeric_service | tcp::resolver::passive);
        if (results.empty()) throw IoError("cannot listen on " + where + ": the address does not resolve");
        const tcp::endpoint wanted = results.begin()->endpoint();
        acceptor.open(wanted.protocol());
        acceptor.set_option(tcp::acceptor::reuse_address(true));
        acceptor.bind(wanted);
        acceptor.listen(asio::socket_base::max_listen_connections);
        endpoint = acceptor.local_endpoint();
    } catch (const boost::system::system_error& e) {
        throw IoError("cannot listen on " + where + ": " + e.code().message());
    }
    log().notice("listening on %s (backend %s)", describe(endpoint).c_str(), handler.backend().c_str());
    if (!isLoopback(endpoint.address()))
        log().warn("listening on %s: reachable from other machines; the TAU protocol has no authentication",
                   describe(endpoint).c_str());
    accept();
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

void ServerCore::accept() {
    acceptor.async_accept(asio::make_strand(io), [this](const error_code& ec, tcp::socket socket) {
        if (ec) {
            if (ec == asio::error::operation_aborted || !acceptor.is_open()) return;
            // Out of descriptors and the like: try again shortly, do not spin.
            log().error("accept failed: %s", ec.message().c_str());
            acceptRetry.expires_after(std::chrono::milliseconds(100));
            acceptRetry.async_wait([this](const error_code& e) {
                if (!e && acceptor.is_open()) accept();
            });
            return;
        }
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
            } else {
                error_code ignored;
                socket.set_option(tcp::no_delay(true), ignored);
                connection = std::make_shared<Connection>(*this, std::move(socket), ++nextId);
                connections.emplace(nextId, connection);
                ++accepted;
            }
        }
        if (connection) asio::dispatch(connection->executor(), [connection] { connection->start(); });
        accept();
    });
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
    log().notice("stopped");
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

std::string TauNetServer::address() const { return impl_->endpoint.address().to_string(); }
std::uint16_t TauNetServer::port() const { return impl_->endpoint.port(); }
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
    return s;
}

}  // namespace avatar::tau
