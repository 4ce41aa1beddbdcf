#pragma once
/// @file Socket.h
/// Internal to tauunit: a blocking-looking TCP stream over a non-blocking
/// socket, every operation bounded by a deadline (poll). Failures throw
/// SocketFailure or SocketTimeout with the system's reason; TauUnit turns them
/// into ConnectionError / TimeoutError naming the endpoint and request.

#include <chrono>
#include <cstddef>
#include <cstdint>
#include <stdexcept>
#include <string>

namespace avatar::tau::detail {

using Clock = std::chrono::steady_clock;

struct SocketFailure : std::runtime_error {
    using std::runtime_error::runtime_error;
};
struct SocketTimeout : std::runtime_error {
    using std::runtime_error::runtime_error;
};

class Socket {
public:
    Socket() = default;
    ~Socket();
    Socket(const Socket&) = delete;
    Socket& operator=(const Socket&) = delete;
    Socket(Socket&& o) noexcept;
    Socket& operator=(Socket&& o) noexcept;

    /// Resolves @p host and connects to the first address that accepts.
    static Socket connect(const std::string& host, std::uint16_t port, Clock::time_point deadline);
    /// Connects to the Unix-domain socket at @p path.
    static Socket connectUnix(const std::string& path, Clock::time_point deadline);

    bool isOpen() const { return fd_ >= 0; }
    void close();

    /// Sends all @p size bytes.
    void sendAll(const std::uint8_t* data, std::size_t size, Clock::time_point deadline);
    /// Receives what has arrived (at least one byte) into @p buffer; throws
    /// SocketFailure("connection closed by the server") at end of stream.
    std::size_t receiveSome(std::uint8_t* buffer, std::size_t capacity, Clock::time_point deadline);

private:
    explicit Socket(int fd) : fd_(fd) {}
    /// Waits until @p events (POLLIN/POLLOUT) are possible or the deadline passes.
    void waitFor(short events, Clock::time_point deadline, const char* what);
    int fd_{-1};
};

}  // namespace avatar::tau::detail
