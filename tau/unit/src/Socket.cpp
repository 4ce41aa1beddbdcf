#include "Socket.h"

#include <cerrno>
#include <cstring>
#include <utility>

#include <fcntl.h>
#include <netdb.h>
#include <netinet/in.h>
#include <netinet/tcp.h>
#include <poll.h>
#include <sys/socket.h>
#include <sys/un.h>
#include <unistd.h>

namespace avatar::tau::detail {

namespace {

std::string systemError(const char* what, int err) { return std::string(what) + ": " + std::strerror(err); }

int remainingMs(Clock::time_point deadline) {
    const auto left = std::chrono::ceil<std::chrono::milliseconds>(deadline - Clock::now()).count();
    if (left <= 0) return 0;
    return left > 1'000'000'000 ? 1'000'000'000 : static_cast<int>(left);
}

}  // namespace

Socket::~Socket() { close(); }

Socket::Socket(Socket&& o) noexcept : fd_(std::exchange(o.fd_, -1)) {}

Socket& Socket::operator=(Socket&& o) noexcept {
    if (this != &o) {
        close();
        fd_ = std::exchange(o.fd_, -1);
    }
    return *this;
}

void Socket::close() {
    if (fd_ >= 0) {
        ::close(fd_);
        fd_ = -1;
    }
}

void Socket::waitFor(short events, Clock::time_point deadline, const char* what) {
    for (;;) {
        pollfd p{fd_, events, 0};
        const int ms = remainingMs(deadline);
        const int n = ::poll(&p, 1, ms);
        if (n > 0) return;  // ready, or an error/hang-up the next call reports
        if (n == 0) throw SocketTimeout(std::string("no ") + what + " within the time limit");
        if (errno != EINTR) throw SocketFailure(systemError("poll", errno));
    }
}

Socket Socket::connect(const std::string& host, std::uint16_t port, Clock::time_point deadline) {
    addrinfo hints{};
    hints.ai_family = AF_UNSPEC;
    hints.ai_socktype = SOCK_STREAM;
    hints.ai_flags = AI_NUMERICSERV;
    addrinfo* list = nullptr;
    const std::string service = std::to_string(port);
    if (const int rc = ::getaddrinfo(host.c_str(), service.c_str(), &hints, &list); rc != 0)
        throw SocketFailure(std::string("cannot resolve host: ") + ::gai_strerror(rc));
    std::string lastError = "no address";
    bool timedOut = false;
    for (addrinfo* a = list; a; a = a->ai_next) {
        Socket s(::socket(a->ai_family, a->ai_socktype | SOCK_NONBLOCK | SOCK_CLOEXEC, a->ai_protocol));
        if (!s.isOpen()) {
            lastError = systemError("socket", errno);
            continue;
        }
        if (::connect(s.fd_, a->ai_addr, a->ai_addrlen) != 0) {
            if (errno != EINPROGRESS) {
                lastError = systemError("connect", errno);
                continue;
            }
            try {
                s.waitFor(POLLOUT, deadline, "connection");
            } catch (const SocketTimeout& e) {
                lastError = e.what();
                timedOut = true;
                continue;
            }
            int err = 0;
            socklen_t len = sizeof err;
            if (::getsockopt(s.fd_, SOL_SOCKET, SO_ERROR, &err, &len) != 0) err = errno;
            if (err != 0) {
                lastError = systemError("connect", err);
                continue;
            }
        }
        int one = 1;
        ::setsockopt(s.fd_, IPPROTO_TCP, TCP_NODELAY, &one, sizeof one);
        ::freeaddrinfo(list);
        return s;
    }
    ::freeaddrinfo(list);
    if (timedOut) throw SocketTimeout(lastError);
    throw SocketFailure(lastError);
}

Socket Socket::connectUnix(const std::string& path, Clock::time_point deadline) {
    sockaddr_un address{};
    address.sun_family = AF_UNIX;
    if (path.empty() || path.size() >= sizeof address.sun_path)
        throw SocketFailure("a Unix-domain socket path must have 1 to " + std::to_string(sizeof address.sun_path - 1) +
                            " bytes");
    std::memcpy(address.sun_path, path.data(), path.size());
    Socket s(::socket(AF_UNIX, SOCK_STREAM | SOCK_NONBLOCK | SOCK_CLOEXEC, 0));
    if (!s.isOpen()) throw SocketFailure(systemError("socket", errno));
    for (;;) {
        if (::connect(s.fd_, reinterpret_cast<const sockaddr*>(&address), sizeof address) == 0) return s;
        if (errno == EINTR) continue;
        if (errno != EAGAIN && errno != EINPROGRESS) throw SocketFailure(systemError("connect", errno));
        // The server's backlog is full: wait for room, then look at the outcome.
        s.waitFor(POLLOUT, deadline, "connection");
        int err = 0;
        socklen_t len = sizeof err;
        if (::getsockopt(s.fd_, SOL_SOCKET, SO_ERROR, &err, &len) != 0) err = errno;
        if (err == 0) return s;
        if (err != EAGAIN) throw SocketFailure(systemError("connect", err));
    }
}

void Socket::sendAll(const std::uint8_t* data, std::size_t size, Clock::time_point deadline) {
    if (!isOpen()) throw SocketFailure("not connected");
    while (size > 0) {
        const ssize_t n = ::send(fd_, data, size, MSG_NOSIGNAL);
        if (n > 0) {
            data += n;
            size -= static_cast<std::size_t>(n);
            continue;
        }
        if (n < 0 && errno == EINTR) continue;
        if (n < 0 && (errno == EAGAIN || errno == EWOULDBLOCK)) {
            waitFor(POLLOUT, deadline, "room to send the request");
            continue;
        }
        throw SocketFailure(systemError("send", errno));
    }
}

std::size_t Socket::receiveSome(std::uint8_t* buffer, std::size_t capacity, Clock::time_point deadline) {
    if (!isOpen()) throw SocketFailure("not connected");
    for (;;) {
        const ssize_t n = ::recv(fd_, buffer, capacity, 0);
        if (n > 0) return static_cast<std::size_t>(n);
        if (n == 0) throw SocketFailure("connection closed by the server");
        if (errno == EINTR) continue;
        if (errno == EAGAIN || errno == EWOULDBLOCK) {
            waitFor(POLLIN, deadline, "reply");
            continue;
        }
        throw SocketFailure(systemError("recv", errno));
    }
}

}  // namespace avatar::tau::detail
