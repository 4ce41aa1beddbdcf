#include <avatar/tau/TauUnit.h>

#include "Socket.h"

#include <avatar/common/Logging.h>
#include <avatar/tau/Authentication.h>

#include <log4cpp/Category.hh>
#include <opencv2/imgcodecs.hpp>

#include <algorithm>
#include <array>
#include <functional>
#include <sstream>
#include <thread>
#include <utility>

namespace avatar::tau {

using detail::Clock;

namespace {

log4cpp::Category& log() { return avatar::logging::category("tauunit"); }

std::string formatMs(std::chrono::microseconds d) {
    std::ostringstream s;
    s.setf(std::ios::fixed);
    s.precision(1);
    s << static_cast<double>(d.count()) / 1000.0 << " ms";
    return s.str();
}

/// Why a request failed before it reached the server, or after.
struct Attempt {
    bool sent{false};
};

}  // namespace

// ---- options, errors, small records ------------------------------------

bool TauUnitOptions::isValid(std::string* error) const {
    auto fail = [&](const std::string& why) {
        if (error) *error = why;
        return false;
    };
    if (unixSocket.empty()) {
        if (host.empty()) return fail("host is empty");
        if (port == 0) return fail("port is 0");
    } else if (unixSocket.size() > 107) {
        return fail("unixSocket is longer than the 107 bytes a socket path may have");
    }
    if (!authKey.empty() && authKey.size() < kMinAuthKeySize)
        return fail("authKey has " + std::to_string(authKey.size()) + " bytes; at least " +
                    std::to_string(kMinAuthKeySize) + " are needed");
    if (connectTimeout.count() <= 0) return fail("connectTimeout must be positive");
    if (requestTimeout.count() <= 0) return fail("requestTimeout must be positive");
    if (snapshotTimeout.count() <= 0 || snapshotTimeout.count() > 0xFFFFFFFFLL)
        return fail("snapshotTimeout must be 1..4294967295 ms");
    if (retry.attempts < 0) return fail("retry.attempts must not be negative");
    if (retry.delay.count() < 0) return fail("retry.delay must not be negative");
    if (timingCapacity == 0) return fail("timingCapacity must be at least 1");
    return true;
}

TauError::TauError(ErrorCode code, std::string serverMessage, const std::string& what)
    : avatar::Error(what), code_(code), serverMessage_(std::move(serverMessage)) {}

ConnectionError::ConnectionError(std::string endpoint, std::string request, const std::string& what)
    : avatar::Error(what), endpoint_(std::move(endpoint)), request_(std::move(request)) {}

AuthenticationError::AuthenticationError(std::string endpoint, const std::string& what)
    : avatar::Error(what), endpoint_(std::move(endpoint)) {}

const TauImage* TauImages::side(Side s) const {
    for (const TauImage& i : images)
        if (i.side == s) return &i;
    return nullptr;
}

const char* toString(Outcome outcome) {
    switch (outcome) {
        case Outcome::Ok: return "ok";
        case Outcome::ServerError: return "server-error";
        case Outcome::Timeout: return "timeout";
        case Outcome::ConnectionFailed: return "connection-failed";
        case Outcome::AuthenticationFailed: return "authentication-failed";
    }
    return "?";
}

// ---- the connection and the request cycle --------------------------------

class TauUnit::Impl {
public:
    explicit Impl(TauUnitOptions o) : options(std::move(o)), decoder(kMaxReplyPayload) {}

    TauUnitOptions options;
    detail::Socket socket;
    FrameDecoder decoder;
    std::uint32_t nextId{1};
    std::optional<HelloReply> hello;
    TauIterations iterations;
    std::optional<VisionTargets> lastTargets;
    std::deque<ActionTiming> timings;

    std::string endpoint() const {
        if (!options.unixSocket.empty()) return "unix:" + options.unixSocket;
        const bool v6 = options.host.find(':') != std::string::npos;
        return (v6 ? "[" + options.host + "]" : options.host) + ":" + std::to_string(options.port);
    }

    [[noreturn]] void connectionFailed(const std::string& request, const std::string& why) {
        close();
        throw ConnectionError(endpoint(), request, "TAUNet " + endpoint() + ": " + request + ": " + why);
    }
    [[noreturn]] void authenticationFailed(const std::string& why) {
        close();
        throw AuthenticationError(endpoint(), "TAUNet " + endpoint() + ": HELLO: authentication: " + why);
    }
    [[noreturn]] void timedOut(const std::string& request, const std::string& why) {
        throw TimeoutError(endpoint(), request, "TAUNet " + endpoint() + ": " + request + ": " + why);
    }

    void close() {
        if (socket.isOpen()) log().debugStream() << "closing the connection to " << endpoint();
        socket.close();
        decoder = FrameDecoder(kMaxReplyPayload);
        hello.reset();
    }

    void record(ActionTiming entry) {
        auto& category = log();
        if (entry.outcome == Outcome::Ok)
            category.infoStream() << entry.request << " #" << entry.requestId << " ok in " << formatMs(entry.duration);
        else
            category.warnStream() << entry.request << " #" << entry.requestId << " " << toString(entry.outcome)
                                  << " after " << formatMs(entry.duration) << ": " << entry.detail;
        timings.push_back(std::move(entry));
        while (timings.size() > options.timingCapacity) timings.pop_front();
    }

    /// Sends one frame and returns the payload of its reply; ERROR replies are thrown as TauError.
    std::vector<std::uint8_t> exchange(MessageType type, const std::vector<std::uint8_t>& payload,
                                       Clock::time_point deadline, std::uint32_t& idOut, Attempt& attempt) {
        const std::string name = messageName(static_cast<std::uint16_t>(type));
        const std::uint32_t id = nextId++;
        if (nextId == 0) nextId = 1;
        idOut = id;
        const std::vector<std::uint8_t> frame = encodeFrame(static_cast<std::uint16_t>(type), id, payload);
        try {
            attempt.sent = true;
            socket.sendAll(frame.data(), frame.size(), deadline);
        } catch (const detail::SocketTimeout& e) {
            // A partly sent frame leaves the stream unusable.
            close();
            timedOut(name, e.what());
        } catch (const detail::SocketFailure& e) {
            connectionFailed(name, e.what());
        }
        std::array<std::uint8_t, 64 * 1024> buffer{};
        for (;;) {
            std::optional<Frame> reply;
            try {
                reply = decoder.next();
            } catch (const ProtocolError& e) {
                connectionFailed(name, std::string("reply does not follow the protocol: ") + e.what());
            }
            if (!reply) {
                try {
                    const std::size_t n = socket.receiveSome(buffer.data(), buffer.size(), deadline);
                    decoder.feed(buffer.data(), n);
                } catch (const detail::SocketTimeout& e) {
                    timedOut(name, e.what());
                } catch (const detail::SocketFailure& e) {
                    connectionFailed(name, e.what());
                }
                continue;
            }
            const FrameHeader& h = reply->header;
            const bool connectionLevelError = h.type == static_cast<std::uint16_t>(MessageType::Error) && h.request == 0;
            if (h.request != id && !connectionLevelError) {
                if (h.request < id) {
                    log().debugStream() << "discarding the late reply " << messageName(h.type) << " #" << h.request;
                    continue;
                }
                connectionFailed(name, "reply for request #" + std::to_string(h.request) + " while waiting for #" +
                                           std::to_string(id));
            }
            if (h.type == static_cast<std::uint16_t>(MessageType::Error)) {
                ErrorReply error;
                try {
                    error = decodeErrorReply(reply->payload);
                } catch (const ProtocolError& e) {
                    connectionFailed(name, std::string("reply does not follow the protocol: ") + e.what());
                }
                if (closesConnection(error.code)) close();
                const std::string what = "TAUNet " + endpoint() + ": " + name + " answered " +
                                         errorName(error.code) + ": " + error.message;
                if (error.code == ErrorCode::ConfigRejected) throw ConfigRejectedError(error.code, error.message, what);
                throw TauError(error.code, error.message, what);
            }
            if (h.type != replyType(type))
                connectionFailed(name, "reply of type " + messageName(h.type) + " to " + name);
            return std::move(reply->payload);
        }
    }

    HelloReply handshake() {
        const auto deadline = Clock::now() + options.connectTimeout;
        try {
            socket = options.unixSocket.empty() ? detail::Socket::connect(options.host, options.port, deadline)
                                                : detail::Socket::connectUnix(options.unixSocket, deadline);
        } catch (const detail::SocketTimeout& e) {
            close();
            timedOut("HELLO", std::string("cannot connect: ") + e.what());
        } catch (const detail::SocketFailure& e) {
            connectionFailed("HELLO", std::string("cannot connect: ") + e.what());
        }
        decoder = FrameDecoder(kMaxReplyPayload);
        Attempt attempt;
        std::uint32_t id = 0;
        std::vector<std::uint8_t> payload;
        try {
            payload = exchange(MessageType::Hello, encode(Hello{kProtocolVersion, options.clientName}), deadline, id,
                               attempt);
        } catch (const TimeoutError&) {
            close();  // a connection without a HELLO reply is of no use
            throw;
        }
        HelloReply reply;
        try {
            reply = decodeHelloReply(payload);
        } catch (const ProtocolError& e) {
            connectionFailed("HELLO", std::string("reply does not follow the protocol: ") + e.what());
        }
        if (reply.version != kProtocolVersion)
            connectionFailed("HELLO", "the server answered protocol version " + std::to_string(reply.version) +
                                          " to a version " + std::to_string(kProtocolVersion) + " HELLO");
        if (!options.authKey.empty()) {
            authenticate(reply.challenge, deadline);
        } else if (reply.authenticationRequired) {
            authenticationFailed("the server requires it and no key is set (TauUnitOptions::authKey)");
        }
        hello = reply;
        log().infoStream() << "connected to " << reply.serverName << " at " << endpoint() << " (protocol "
                           << reply.version << ", backend " << reply.backend
                           << (options.authKey.empty() ? "" : ", authenticated both ways") << ")";
        return reply;
    }

    /// AUTHENTICATE (docs/protocol.md, "Authentication"): proves the key on
    /// the server's @p challenge and checks the server's proof in return.
    void authenticate(const std::vector<std::uint8_t>& challenge, Clock::time_point deadline) {
        if (challenge.empty())
            authenticationFailed("the server has no key, so it cannot prove it is the daemon the key belongs to");
        const std::vector<std::uint8_t> nonce = randomBytes(kChallengeSize);
        Attempt attempt;
        std::uint32_t id = 0;
        std::vector<std::uint8_t> payload;
        try {
            payload = exchange(MessageType::Authenticate,
                               encode(Authenticate{nonce, clientProof(options.authKey, challenge, nonce)}), deadline,
                               id, attempt);
        } catch (const TimeoutError&) {
            close();
            throw;
        } catch (const TauError& e) {
            if (e.code() == ErrorCode::AuthenticationFailed)
                authenticationFailed("the server refused the key: " + e.serverMessage());
            close();
            throw;
        }
        AuthenticateReply reply;
        try {
            reply = decodeAuthenticateReply(payload);
        } catch (const ProtocolError& e) {
            connectionFailed("AUTHENTICATE", std::string("reply does not follow the protocol: ") + e.what());
        }
        if (!macsEqual(serverProof(options.authKey, challenge, nonce), reply.mac))
            authenticationFailed("the server's proof does not match the key: it is not the daemon the key belongs to");
    }

    /// Runs HELLO as a logged action.
    HelloReply connectLogged() {
        ActionTiming entry{"HELLO", 0, std::chrono::system_clock::now(), {}, Outcome::Ok, {}};
        const auto t0 = Clock::now();
        auto finish = [&](Outcome o, const std::string& detail) {
            entry.duration = std::chrono::duration_cast<std::chrono::microseconds>(Clock::now() - t0);
            entry.outcome = o;
            entry.detail = detail;
            entry.requestId = nextId > 1 ? nextId - 1 : 0;
            record(entry);
        };
        try {
            HelloReply r = handshake();
            finish(Outcome::Ok, {});
            return r;
        } catch (const TimeoutError& e) {
            finish(Outcome::Timeout, e.what());
            throw;
        } catch (const ConnectionError& e) {
            finish(Outcome::ConnectionFailed, e.what());
            throw;
        } catch (const TauError& e) {
            finish(Outcome::ServerError, std::string(errorName(e.code())) + ": " + e.serverMessage());
            throw;
        } catch (const AuthenticationError& e) {
            finish(Outcome::AuthenticationFailed, e.what());
            throw;
        }
    }

    /// One request as a logged action, with the retry policy. @p onReply
    /// decodes the payload (ProtocolError there is a bad reply) and updates
    /// the bookkeeping.
    void request(MessageType type, const std::vector<std::uint8_t>& payload, std::chrono::milliseconds timeout,
                 bool resendable, const std::function<void(const std::vector<std::uint8_t>&)>& onReply) {
        const std::string name = messageName(static_cast<std::uint16_t>(type));
        ActionTiming entry{name, 0, std::chrono::system_clock::now(), {}, Outcome::Ok, {}};
        const auto t0 = Clock::now();
        auto finish = [&](Outcome o, const std::string& detail) {
            entry.duration = std::chrono::duration_cast<std::chrono::microseconds>(Clock::now() - t0);
            entry.outcome = o;
            entry.detail = detail;
            record(entry);
        };
        for (int retry = 0;; ++retry) {
            Attempt attempt;
            try {
                if (!socket.isOpen()) {
                    try {
                        connectLogged();
                    } catch (const TimeoutError& e) {
                        // Say which request could not be made.
                        throw TimeoutError(e.endpoint(), name, std::string(e.what()) + " (before " + name + ")");
                    } catch (const ConnectionError& e) {
                        throw ConnectionError(e.endpoint(), name, std::string(e.what()) + " (before " + name + ")");
                    } catch (const TauError& e) {
                        throw TauError(e.code(), e.serverMessage(), std::string(e.what()) + " (before " + name + ")");
                    } catch (const AuthenticationError& e) {
                        throw AuthenticationError(e.endpoint(), std::string(e.what()) + " (before " + name + ")");
                    }
                }
                const auto reply = exchange(type, payload, Clock::now() + timeout, entry.requestId, attempt);
                try {
                    onReply(reply);
                } catch (const ProtocolError& e) {
                    connectionFailed(name, std::string("reply does not follow the protocol: ") + e.what());
                }
                finish(Outcome::Ok, {});
                return;
            } catch (const TimeoutError& e) {
                finish(Outcome::Timeout, e.what());
                throw;
            } catch (const ConnectionError& e) {
                const bool mayResend = resendable || !attempt.sent;
                if (retry >= options.retry.attempts || !mayResend) {
                    finish(Outcome::ConnectionFailed, e.what());
                    throw;
                }
                log().warnStream() << e.what() << "; reconnecting (attempt " << retry + 1 << " of "
                                   << options.retry.attempts << ")";
                close();
                std::this_thread::sleep_for(options.retry.delay);
            } catch (const TauError& e) {
                finish(Outcome::ServerError, std::string(errorName(e.code())) + ": " + e.serverMessage());
                throw;
            } catch (const AuthenticationError& e) {
                finish(Outcome::AuthenticationFailed, e.what());
                throw;
            }
        }
    }

    void noteVision(std::uint64_t iteration) { iterations.vision = std::max(iterations.vision, iteration); }

    void noteTargets(VisionTargets t) {
        iterations.targets = t.iteration;
        noteVision(t.iteration);
        lastTargets = std::move(t);
    }
};

TauUnit::TauUnit(TauUnitOptions options) {
    std::string why;
    if (!options.isValid(&why)) throw InvalidArgument("TauUnit options: " + why);
    impl_ = std::make_unique<Impl>(std::move(options));
}

TauUnit::~TauUnit() = default;
TauUnit::TauUnit(TauUnit&&) noexcept = default;
TauUnit& TauUnit::operator=(TauUnit&&) noexcept = default;

HelloReply TauUnit::connect() {
    if (impl_->socket.isOpen() && impl_->hello) return *impl_->hello;
    return impl_->connectLogged();
}

HelloReply TauUnit::reconnect() {
    impl_->close();
    return impl_->connectLogged();
}

void TauUnit::disconnect() { impl_->close(); }
bool TauUnit::connected() const { return impl_->socket.isOpen(); }
std::optional<HelloReply> TauUnit::server() const { return impl_->hello; }
const TauUnitOptions& TauUnit::options() const { return impl_->options; }
std::string TauUnit::endpoint() const { return impl_->endpoint(); }

void TauUnit::startSearching() {
    impl_->request(MessageType::StartSearching, {}, impl_->options.requestTimeout, true,
                   [](const std::vector<std::uint8_t>& p) { decodeEmpty(MessageType::StartSearching, p); });
}

void TauUnit::stopSearching() {
    impl_->request(MessageType::StopSearching, {}, impl_->options.requestTimeout, true,
                   [](const std::vector<std::uint8_t>& p) { decodeEmpty(MessageType::StopSearching, p); });
}

VisionTargets TauUnit::takeSnapshot(std::optional<std::chrono::milliseconds> timeout) {
    const std::chrono::milliseconds serverTimeout = timeout.value_or(impl_->options.snapshotTimeout);
    if (serverTimeout.count() <= 0 || serverTimeout.count() > 0xFFFFFFFFLL)
        throw InvalidArgument("takeSnapshot: timeout must be 1..4294967295 ms, not " +
                              std::to_string(serverTimeout.count()));
    VisionTargets out;
    impl_->request(MessageType::TakeSnapshot, encode(TakeSnapshot{static_cast<std::uint32_t>(serverTimeout.count())}),
                   serverTimeout + impl_->options.requestTimeout, true,
                   [&](const std::vector<std::uint8_t>& p) { out = decodeTargetData(p); });
    impl_->noteTargets(out);
    return out;
}

VisionTargets TauUnit::getTargetData() {
    VisionTargets out;
    impl_->request(MessageType::GetTargetData, {}, impl_->options.requestTimeout, true,
                   [&](const std::vector<std::uint8_t>& p) { out = decodeTargetData(p); });
    impl_->noteTargets(out);
    return out;
}

ConfigApplied TauUnit::sendConfig(const std::string& xml) {
    if (xml.size() + 4 > kMaxRequestPayload)
        throw InvalidArgument("sendConfig: the document has " + std::to_string(xml.size()) +
                              " bytes, more than a request may carry (" + std::to_string(kMaxRequestPayload - 4) + ")");
    ConfigApplied out;
    impl_->request(MessageType::SendConfig, encode(SendConfig{xml}), impl_->options.requestTimeout, false,
                   [&](const std::vector<std::uint8_t>& p) { out = decodeConfigApplied(p); });
    auto& it = impl_->iterations;
    it.configVersion = it.serverConfigVersion = out.configVersion;
    it.config = it.serverConfigIteration = out.configIteration;
    return out;
}

ConfigReply TauUnit::getConfig() {
    ConfigReply out;
    impl_->request(MessageType::GetConfig, {}, impl_->options.requestTimeout, true,
                   [&](const std::vector<std::uint8_t>& p) { out = decodeConfigReply(p); });
    auto& it = impl_->iterations;
    it.configVersion = it.serverConfigVersion = out.configVersion;
    it.config = it.serverConfigIteration = out.configIteration;
    return out;
}

TauImages TauUnit::getImages(ImageKindCode kind, std::uint8_t sides, int jpegQuality) {
    if (sides == 0 || (sides & ~(kLeftImage | kRightImage)) != 0)
        throw InvalidArgument("getImages: sides must be kLeftImage, kRightImage or both, not " +
                              std::to_string(static_cast<unsigned>(sides)));
    if (jpegQuality < 1 || jpegQuality > 100)
        throw InvalidArgument("getImages: JPEG quality must be 1..100, not " + std::to_string(jpegQuality));
    TauImages out;
    impl_->request(
        MessageType::GetImages, encode(GetImages{kind, sides, static_cast<std::uint8_t>(jpegQuality)}),
        impl_->options.requestTimeout, true, [&](const std::vector<std::uint8_t>& p) {
            ImagesReply reply = decodeImagesReply(p);
            TauImages images;
            images.iteration = reply.iteration;
            images.kind = reply.kind;
            for (EncodedImage& e : reply.images) {
                const char* sideName = e.side == 0 ? "left" : "right";
                TauImage image;
                image.side = e.side == 0 ? Side::Left : Side::Right;
                image.image = cv::imdecode(e.jpeg, cv::IMREAD_UNCHANGED);
                if (image.image.empty())
                    throw ProtocolError(ErrorCode::BadPayload,
                                        std::string("GET_IMAGES: the ") + sideName + " JPEG does not decode");
                if (static_cast<std::uint32_t>(image.image.cols) != e.width ||
                    static_cast<std::uint32_t>(image.image.rows) != e.height)
                    throw ProtocolError(ErrorCode::BadPayload,
                                        std::string("GET_IMAGES: the ") + sideName + " JPEG is " +
                                            std::to_string(image.image.cols) + "x" + std::to_string(image.image.rows) +
                                            ", the reply says " + std::to_string(e.width) + "x" +
                                            std::to_string(e.height));
                image.jpeg = std::move(e.jpeg);
                images.images.push_back(std::move(image));
            }
            if (images.kind != kind)
                throw ProtocolError(ErrorCode::BadPayload, "GET_IMAGES: reply of another kind of images");
            for (Side s : {Side::Left, Side::Right}) {
                const bool asked = (sides & (s == Side::Left ? kLeftImage : kRightImage)) != 0;
                if (asked != (images.side(s) != nullptr))
                    throw ProtocolError(ErrorCode::BadPayload, "GET_IMAGES: the reply's sides differ from the request");
            }
            std::stable_sort(images.images.begin(), images.images.end(),
                             [](const TauImage& a, const TauImage& b) { return a.side < b.side; });
            out = std::move(images);
        });
    auto& it = impl_->iterations;
    impl_->noteVision(out.iteration);
    if (out.side(Side::Left)) it.leftImage = out.iteration;
    if (out.side(Side::Right)) it.rightImage = out.iteration;
    return out;
}

StatusReply TauUnit::status() {
    StatusReply out;
    impl_->request(MessageType::Status, {}, impl_->options.requestTimeout, true,
                   [&](const std::vector<std::uint8_t>& p) { out = decodeStatusReply(p); });
    auto& it = impl_->iterations;
    it.vision = out.iteration;  // authoritative, also after the server restarted
    it.serverConfigVersion = out.configVersion;
    it.serverConfigIteration = out.configIteration;
    return out;
}

const TauIterations& TauUnit::iterations() const { return impl_->iterations; }
const std::optional<VisionTargets>& TauUnit::lastTargets() const { return impl_->lastTargets; }

bool TauUnit::isTargetDataFresh() const {
    const TauIterations& it = impl_->iterations;
    return impl_->lastTargets && it.targets > 0 && it.targets >= it.vision && it.targets >= it.serverConfigIteration;
}

bool TauUnit::isConfigFresh() const {
    const TauIterations& it = impl_->iterations;
    return it.configVersion != 0 && it.configVersion == it.serverConfigVersion;
}

bool TauUnit::isImageFresh(Side side) const {
    const TauIterations& it = impl_->iterations;
    const std::uint64_t image = side == Side::Left ? it.leftImage : it.rightImage;
    return image > 0 && image >= it.vision;
}

const std::deque<ActionTiming>& TauUnit::timings() const { return impl_->timings; }
void TauUnit::clearTimings() { impl_->timings.clear(); }

}  // namespace avatar::tau
