#pragma once
// Child processes for the TAUUnit and TAUTUI tests: the real taunet daemon on
// an ephemeral loopback port, and commands (tmux, tautui) run to completion.
// Every wait is bounded; a child that outlives its test is killed.

#include <gtest/gtest.h>

#include <chrono>
#include <csignal>
#include <cstdint>
#include <cstring>
#include <optional>
#include <regex>
#include <string>
#include <thread>
#include <vector>

#include <fcntl.h>
#include <poll.h>
#include <sys/wait.h>
#include <unistd.h>

namespace avatar::tau::testing {

using Clock = std::chrono::steady_clock;
using namespace std::chrono_literals;

/// Output and exit status of a command run to completion.
struct CommandResult {
    int status{-1};  ///< exit status; -1 when killed or not started
    std::string out;
    std::string err;
    bool timedOut{false};
};

namespace detail {

inline pid_t spawn(const std::vector<std::string>& argv, int stdinFd, int stdoutFd, int stderrFd) {
    std::vector<char*> args;
    for (const std::string& a : argv) args.push_back(const_cast<char*>(a.c_str()));
    args.push_back(nullptr);
    const pid_t pid = ::fork();
    if (pid == 0) {
        if (stdinFd >= 0) ::dup2(stdinFd, STDIN_FILENO);
        if (stdoutFd >= 0) ::dup2(stdoutFd, STDOUT_FILENO);
        if (stderrFd >= 0) ::dup2(stderrFd, STDERR_FILENO);
        ::setpgid(0, 0);
        ::execvp(args[0], args.data());
        ::_exit(127);
    }
    return pid;
}

/// Waits for @p pid at most @p limit; kills it (and its group) after that.
inline int reap(pid_t pid, std::chrono::milliseconds limit, bool* timedOut = nullptr) {
    const auto deadline = Clock::now() + limit;
    int status = 0;
    for (;;) {
        const pid_t r = ::waitpid(pid, &status, WNOHANG);
        if (r == pid) return WIFEXITED(status) ? WEXITSTATUS(status) : -1;
        if (r < 0) return -1;
        if (Clock::now() >= deadline) {
            if (timedOut) *timedOut = true;
            ::kill(-pid, SIGKILL);
            ::kill(pid, SIGKILL);
            ::waitpid(pid, &status, 0);
            return -1;
        }
        std::this_thread::sleep_for(5ms);
    }
}

}  // namespace detail

/// Runs @p argv with @p input on its standard input (a pipe, so not a
/// terminal); kills it after @p limit.
inline CommandResult runCommand(const std::vector<std::string>& argv, const std::string& input = {},
                                std::chrono::milliseconds limit = 30s) {
    int in[2], out[2], err[2];
    if (::pipe2(in, O_CLOEXEC) != 0 || ::pipe2(out, O_CLOEXEC) != 0 || ::pipe2(err, O_CLOEXEC) != 0) return {};
    const pid_t pid = detail::spawn(argv, in[0], out[1], err[1]);
    ::close(in[0]);
    ::close(out[1]);
    ::close(err[1]);
    CommandResult result;
    const auto deadline = Clock::now() + limit;
    std::size_t written = 0;
    int inFd = in[1];
    if (input.empty()) {
        ::close(inFd);
        inFd = -1;
    } else {
        ::fcntl(inFd, F_SETFL, O_NONBLOCK);
    }
    bool outOpen = true, errOpen = true;
    while ((outOpen || errOpen) && Clock::now() < deadline) {
        pollfd p[3] = {{out[0], POLLIN, 0}, {err[0], POLLIN, 0}, {inFd, POLLOUT, 0}};
        ::poll(p, inFd >= 0 ? 3 : 2, 50);
        char buffer[4096];
        for (int i = 0; i < 2; ++i) {
            bool& open = i == 0 ? outOpen : errOpen;
            if (!open || !(p[i].revents & (POLLIN | POLLHUP))) continue;
            const ssize_t n = ::read(p[i].fd, buffer, sizeof buffer);
            if (n > 0)
                (i == 0 ? result.out : result.err).append(buffer, static_cast<std::size_t>(n));
            else
                open = false;
        }
        if (inFd >= 0 && (p[2].revents & (POLLOUT | POLLERR | POLLHUP))) {
            const ssize_t n = ::write(inFd, input.data() + written, input.size() - written);
            if (n > 0) written += static_cast<std::size_t>(n);
            if (n < 0 || written == input.size()) {
                ::close(inFd);
                inFd = -1;
            }
        }
    }
    if (inFd >= 0) ::close(inFd);
    ::close(out[0]);
    ::close(err[0]);
    result.timedOut = outOpen || errOpen;
    const auto left = std::chrono::duration_cast<std::chrono::milliseconds>(deadline - Clock::now());
    result.status = detail::reap(pid, std::max(left, std::chrono::milliseconds(100)), &result.timedOut);
    return result;
}

/// The real taunet on 127.0.0.1 with the replay backend on the bundled lab
/// session. Started in the constructor (port 0: an ephemeral one, or a given
/// one to restart on the same port); stopped by stop() or the destructor.
class TauNetProcess {
public:
    explicit TauNetProcess(std::uint16_t port = 0, std::vector<std::string> extra = {}) {
        int out[2];
        if (::pipe2(out, O_CLOEXEC) != 0) throw std::runtime_error("pipe failed");
        std::vector<std::string> argv = {TAUNET_EXECUTABLE, "--backend", "replay", "--session",
                                         std::string(AVATAR_DATA_DIR) + "/sessions/lab", "--port",
                                         std::to_string(port), "--log", "warn"};
        argv.insert(argv.end(), extra.begin(), extra.end());
        pid_ = detail::spawn(argv, -1, out[1], -1);
        ::close(out[1]);
        outFd_ = out[0];
        // "listening on 127.0.0.1:NNNNN" within 20 s.
        const std::regex listening(R"(listening on 127\.0\.0\.1:([0-9]+))");
        const auto deadline = Clock::now() + 20s;
        while (Clock::now() < deadline) {
            std::smatch m;
            if (std::regex_search(output_, m, listening)) {
                port_ = static_cast<std::uint16_t>(std::stoi(m[1].str()));
                return;
            }
            pollfd p{outFd_, POLLIN, 0};
            if (::poll(&p, 1, 100) > 0) {
                char buffer[1024];
                const ssize_t n = ::read(outFd_, buffer, sizeof buffer);
                if (n <= 0) break;
                output_.append(buffer, static_cast<std::size_t>(n));
            }
        }
        stop();
        throw std::runtime_error("taunet did not say where it listens; it printed: " + output_);
    }
    ~TauNetProcess() { stop(); }
    TauNetProcess(const TauNetProcess&) = delete;
    TauNetProcess& operator=(const TauNetProcess&) = delete;

    std::uint16_t port() const { return port_; }
    bool running() const { return pid_ > 0; }

    /// SIGTERM, then SIGKILL after 10 s.
    void stop() {
        if (pid_ > 0) {
            ::kill(pid_, SIGTERM);
            detail::reap(pid_, 10s);
            pid_ = -1;
        }
        if (outFd_ >= 0) {
            ::close(outFd_);
            outFd_ = -1;
        }
    }

private:
    pid_t pid_{-1};
    int outFd_{-1};
    std::uint16_t port_{0};
    std::string output_;
};

}  // namespace avatar::tau::testing
