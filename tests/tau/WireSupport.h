#pragma once
// Shared by the TAUNet tests: an in-process Daemon, frames built and parsed by
// hand from docs/protocol.md (independent of the codec), a raw TCP Client with
// deadlines, and the real taunet executable started and stopped.

#include "SphereScene.h"

#include <avatar/acquire/AcquireSIPSimulation.h>
#include <avatar/tau/Protocol.h>
#include <avatar/tau/TauNetServer.h>
#include <avatar/tau/VisionInterface.h>

#include <boost/asio/connect.hpp>
#include <boost/asio/io_context.hpp>
#include <boost/asio/ip/tcp.hpp>
#include <boost/asio/write.hpp>

#include <array>
#include <chrono>
#include <fcntl.h>
#include <filesystem>
#include <fstream>
#include <optional>
#include <poll.h>
#include <regex>
#include <signal.h>
#include <spawn.h>
#include <sstream>
#include <string>
#include <sys/wait.h>
#include <thread>
#include <unistd.h>
#include <vector>

extern char** environ;

namespace avatar::test::wire {

using namespace std::chrono_literals;
namespace asio = boost::asio;
using tcp = asio::ip::tcp;
using Bytes = std::vector<std::uint8_t>;


// The sphere scene of tests/support/SphereScene.h (640x480, one sphere).
using test::kSphereMm;

/// A VisionInterface and a TauNetServer on 127.0.0.1, ephemeral port.
struct Daemon {
    explicit Daemon(tau::TauNetOptions options = {}, std::unique_ptr<AcquireStereoImagePair> backend = test::sphereSimulation(),
                    const AvatarConfig& config = test::sphereSceneConfig(), std::filesystem::path configDirectory = {}) {
        VisionOptions vo;
        vo.configDirectory = std::move(configDirectory);
        vision = std::make_unique<VisionInterface>(std::move(backend), config, vo);
        options.port = 0;
        server = std::make_unique<tau::TauNetServer>(*vision, options);
    }
    ~Daemon() {
        server.reset();
        vision.reset();
    }
    std::uint16_t port() const { return server->port(); }

    std::unique_ptr<VisionInterface> vision;
    std::unique_ptr<tau::TauNetServer> server;
};

// ---- bytes by hand (independent of the codec) -----------------------------

inline void put16(Bytes& b, std::uint16_t v) {
    b.push_back(static_cast<std::uint8_t>(v >> 8));
    b.push_back(static_cast<std::uint8_t>(v));
}
inline void put32(Bytes& b, std::uint32_t v) {
    for (int s = 24; s >= 0; s -= 8) b.push_back(static_cast<std::uint8_t>(v >> s));
}
inline void putStr(Bytes& b, const std::string& s) {
    put32(b, static_cast<std::uint32_t>(s.size()));
    b.insert(b.end(), s.begin(), s.end());
}

inline Bytes frame(std::uint16_t type, std::uint32_t request, const Bytes& payload = {}, std::uint16_t reserved = 0) {
    Bytes b;
    put32(b, static_cast<std::uint32_t>(payload.size()));
    put16(b, type);
    put16(b, reserved);
    put32(b, request);
    b.insert(b.end(), payload.begin(), payload.end());
    return b;
}

inline Bytes helloPayload(std::uint16_t version = 2, const std::string& name = "wire-test") {
    Bytes p;
    put16(p, version);
    putStr(p, name);
    return p;
}

inline Bytes errorFrame(std::uint32_t request, std::uint16_t code, const std::string& message) {
    Bytes p;
    put16(p, code);
    putStr(p, message);
    return frame(0xFFFF, request, p);
}

/// Reads the fields of a payload in order.
class Fields {
public:
    explicit Fields(Bytes b) : b_(std::move(b)) {}
    std::uint8_t u8() { return need(1), b_[pos_++]; }
    std::uint16_t u16() {
        need(2);
        const auto v = static_cast<std::uint16_t>((b_[pos_] << 8) | b_[pos_ + 1]);
        pos_ += 2;
        return v;
    }
    std::uint32_t u32() {
        std::uint32_t v = 0;
        for (int i = 0; i < 4; ++i) v = (v << 8) | u8();
        return v;
    }
    std::uint64_t u64() {
        std::uint64_t v = 0;
        for (int i = 0; i < 8; ++i) v = (v << 8) | u8();
        return v;
    }
    std::string str() {
        const std::uint32_t n = u32();
        need(n);
        std::string s(b_.begin() + static_cast<std::ptrdiff_t>(pos_), b_.begin() + static_cast<std::ptrdiff_t>(pos_ + n));
        pos_ += n;
        return s;
    }
    bool done() const { return pos_ == b_.size(); }

private:
    void need(std::size_t n) const {
        if (pos_ + n > b_.size()) throw std::runtime_error("payload too short");
    }
    Bytes b_;
    std::size_t pos_{0};
};

struct RawFrame {
    std::uint16_t type{0};
    std::uint16_t reserved{0};
    std::uint32_t request{0};
    Bytes payload;
    Bytes bytes;  ///< the whole frame as received
};

/// A raw TCP client with deadlines: every operation runs the client's own
/// io_context for at most its timeout.
class Client {
public:
    enum class Result { Frame, Closed, Timeout };

    explicit Client(std::uint16_t port) : socket_(io_) {
        bool done = false;
        boost::system::error_code result;
        socket_.async_connect(tcp::endpoint(asio::ip::make_address("127.0.0.1"), port),
                              [&](const boost::system::error_code& ec) {
                                  result = ec;
                                  done = true;
                              });
        run(5s, done);
        if (!done || result) throw std::runtime_error("cannot connect to 127.0.0.1:" + std::to_string(port));
    }

    /// Writes all of @p bytes; false if the server closed the connection.
    bool send(const Bytes& bytes) {
        boost::system::error_code ec;
        asio::write(socket_, asio::buffer(bytes), ec);
        return !ec;
    }

    Result read(RawFrame& out, std::chrono::milliseconds timeout = 20s) {
        const auto deadline = std::chrono::steady_clock::now() + timeout;
        for (;;) {
            if (take(out)) return Result::Frame;
            if (closed_) return Result::Closed;
            const auto left = deadline - std::chrono::steady_clock::now();
            if (left <= 0s) return Result::Timeout;
            if (!receive(std::chrono::duration_cast<std::chrono::milliseconds>(left))) return Result::Timeout;
        }
    }

    /// The next frame; fails the test (by throwing) on close or timeout.
    RawFrame next(std::chrono::milliseconds timeout = 20s) {
        RawFrame f;
        const Result r = read(f, timeout);
        if (r == Result::Closed) throw std::runtime_error("connection closed while waiting for a frame");
        if (r == Result::Timeout) throw std::runtime_error("no frame within the timeout");
        return f;
    }

    RawFrame request(std::uint16_t type, std::uint32_t id, const Bytes& payload = {}) {
        if (!send(frame(type, id, payload))) throw std::runtime_error("send failed");
        return next();
    }

    void hello() {
        const RawFrame r = request(0x0001, 1, helloPayload());
        if (r.type != 0x8001) throw std::runtime_error("HELLO not answered with HELLO_REPLY");
    }

    /// True when the server closes the connection within @p timeout and sends
    /// no further frame; frames received meanwhile are counted in @p frames.
    bool closedWithin(std::chrono::milliseconds timeout, std::size_t* frames = nullptr) {
        const auto deadline = std::chrono::steady_clock::now() + timeout;
        std::size_t n = 0;
        for (;;) {
            RawFrame f;
            const auto left = std::chrono::duration_cast<std::chrono::milliseconds>(deadline - std::chrono::steady_clock::now());
            const Result r = read(f, std::max(left, 0ms));
            if (r == Result::Frame) {
                ++n;
                continue;
            }
            if (frames) *frames = n;
            return r == Result::Closed && (frames || n == 0);
        }
    }

    void close() {
        boost::system::error_code ec;
        socket_.close(ec);
    }
    tcp::socket& socket() { return socket_; }

private:
    void run(std::chrono::milliseconds timeout, const bool& done) {
        io_.restart();
        io_.run_for(timeout);
        if (!done) {
            boost::system::error_code ec;
            socket_.cancel(ec);
            io_.restart();
            io_.run();
        }
    }

    bool receive(std::chrono::milliseconds timeout) {
        bool done = false;
        boost::system::error_code result;
        std::size_t got = 0;
        socket_.async_read_some(asio::buffer(chunk_), [&](const boost::system::error_code& ec, std::size_t n) {
            result = ec;
            got = n;
            done = true;
        });
        run(timeout, done);
        if (!done || result == asio::error::operation_aborted) return false;
        if (result) {
            closed_ = true;  // EOF or reset
            return true;
        }
        buffer_.insert(buffer_.end(), chunk_.begin(), chunk_.begin() + static_cast<std::ptrdiff_t>(got));
        return true;
    }

    bool take(RawFrame& out) {
        if (buffer_.size() < 12) return false;
        Fields h(buffer_);
        const std::uint32_t length = h.u32();
        if (buffer_.size() < 12 + std::size_t{length}) return false;
        out.type = h.u16();
        out.reserved = h.u16();
        out.request = h.u32();
        out.payload.assign(buffer_.begin() + 12, buffer_.begin() + 12 + length);
        out.bytes.assign(buffer_.begin(), buffer_.begin() + 12 + length);
        buffer_.erase(buffer_.begin(), buffer_.begin() + 12 + length);
        return true;
    }

    asio::io_context io_;
    tcp::socket socket_;
    std::array<std::uint8_t, 65536> chunk_{};
    Bytes buffer_;
    bool closed_{false};
};

template <typename Predicate>
inline bool eventually(Predicate p, std::chrono::milliseconds limit = 30s) {
    const auto end = std::chrono::steady_clock::now() + limit;
    while (std::chrono::steady_clock::now() < end) {
        if (p()) return true;
        std::this_thread::sleep_for(10ms);
    }
    return p();
}

inline std::uint16_t errorCode(const RawFrame& f) {
    Fields r(f.payload);
    return r.u16();
}
inline std::string errorMessage(const RawFrame& f) {
    Fields r(f.payload);
    r.u16();
    return r.str();
}

/// The message the codec gives a framing error, as the server sends it
/// (without the "CODE: " prefix of ProtocolError::what()).
inline std::string framingMessage(const Bytes& bytes) {
    tau::FrameDecoder decoder(tau::kMaxRequestPayload);
    decoder.feed(bytes.data(), bytes.size());
    try {
        decoder.next();
    } catch (const tau::ProtocolError& e) {
        std::string m = e.what();
        const std::string prefix = std::string(tau::errorName(e.code())) + ": ";
        if (m.compare(0, prefix.size(), prefix) == 0) m.erase(0, prefix.size());
        return m;
    }
    return "(no error)";
}

constexpr std::uint16_t kHello = 0x0001, kStart = 0x0002, kStop = 0x0003, kSnapshot = 0x0004, kTargets = 0x0005,
                        kSendConfig = 0x0006, kGetConfig = 0x0007, kImages = 0x0008, kStatus = 0x0009;

inline Bytes u32Payload(std::uint32_t v) {
    Bytes p;
    put32(p, v);
    return p;
}
inline Bytes strPayload(const std::string& s) {
    Bytes p;
    putStr(p, s);
    return p;
}
inline Bytes imagesPayload(std::uint8_t kind, std::uint8_t sides, std::uint8_t quality) { return {kind, sides, quality}; }


// ---- the executable ---------------------------------------------------------------


struct Child {
    pid_t pid{-1};
    int out{-1};
};

inline Child spawnTaunet(const std::vector<std::string>& args, const std::string& stderrPath) {
    int pipeFds[2];
    if (::pipe(pipeFds) != 0) throw std::runtime_error("pipe");
    posix_spawn_file_actions_t actions;
    posix_spawn_file_actions_init(&actions);
    posix_spawn_file_actions_adddup2(&actions, pipeFds[1], STDOUT_FILENO);
    posix_spawn_file_actions_addclose(&actions, pipeFds[0]);
    posix_spawn_file_actions_addopen(&actions, STDERR_FILENO, stderrPath.c_str(), O_WRONLY | O_CREAT | O_TRUNC,
                                     0644);
    std::vector<std::string> all = {TAUNET_EXECUTABLE};
    all.insert(all.end(), args.begin(), args.end());
    std::vector<char*> argv;
    for (auto& a : all) argv.push_back(a.data());
    argv.push_back(nullptr);
    Child c;
    const int rc = posix_spawn(&c.pid, TAUNET_EXECUTABLE, &actions, nullptr, argv.data(), environ);
    posix_spawn_file_actions_destroy(&actions);
    ::close(pipeFds[1]);
    if (rc != 0) throw std::runtime_error("posix_spawn failed");
    c.out = pipeFds[0];
    return c;
}

/// Reads the child's stdout until @p pattern matches or the time is up.
inline std::optional<std::smatch> readUntil(int fd, const std::regex& pattern, std::string& text,
                                     std::chrono::milliseconds limit) {
    const auto end = std::chrono::steady_clock::now() + limit;
    while (std::chrono::steady_clock::now() < end) {
        std::smatch m;
        if (std::regex_search(text, m, pattern)) return m;
        pollfd p{fd, POLLIN, 0};
        if (::poll(&p, 1, 100) > 0) {
            char buf[512];
            const ssize_t n = ::read(fd, buf, sizeof buf);
            if (n <= 0) break;
            text.append(buf, static_cast<std::size_t>(n));
        }
    }
    std::smatch m;
    if (std::regex_search(text, m, pattern)) return m;
    return std::nullopt;
}

/// waitpid with a deadline; kills the child if it does not exit in time.
inline std::optional<int> waitExit(pid_t pid, std::chrono::milliseconds limit) {
    const auto end = std::chrono::steady_clock::now() + limit;
    int status = 0;
    while (std::chrono::steady_clock::now() < end) {
        if (::waitpid(pid, &status, WNOHANG) == pid) return status;
        std::this_thread::sleep_for(20ms);
    }
    ::kill(pid, SIGKILL);
    ::waitpid(pid, &status, 0);
    return std::nullopt;
}

inline std::string slurp(const std::string& path) {
    std::ifstream in(path);
    std::stringstream s;
    s << in.rdbuf();
    return s.str();
}

/// taunet replaying the lab session on a free loopback port, logging at info
/// into @p errPath; its port, or std::nullopt (it is stopped) when it did not start.
inline std::optional<std::uint16_t> startLabDaemon(Child& child, const std::string& errPath) {
    child = spawnTaunet({"--backend", "replay", "--session", std::string(AVATAR_DATA_DIR) + "/sessions/lab", "--port",
                         "0", "--log", "info"},
                        errPath);
    std::string out;
    const auto m = readUntil(child.out, std::regex(R"(listening on 127\.0\.0\.1:([0-9]+)\n)"), out, 30s);
    if (!m) {
        waitExit(child.pid, 0ms);
        return std::nullopt;
    }
    return static_cast<std::uint16_t>(std::stoi((*m)[1].str()));
}

/// SIGTERM and the exit; true when it exited in time.
inline bool stopDaemon(Child& child) {
    ::kill(child.pid, SIGTERM);
    const bool exited = waitExit(child.pid, 15s).has_value();
    ::close(child.out);
    return exited;
}


}  // namespace avatar::test::wire
