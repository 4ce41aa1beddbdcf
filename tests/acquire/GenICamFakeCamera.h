#pragma once
// Test support for the GenICam backend: a private loopback network for the
// test process and fake GigE Vision cameras (arv-fake-gv-camera-0.8) run as
// child processes on it.
//
// Each fake camera must own an IP address: it binds the GVCP port 3956 of the
// address it is given, and an address must belong to an interface. Linux has
// only 127.0.0.1 on lo out of the box, so the test process first moves into a
// network namespace of its own (unshare(CLONE_NEWNET), or with a user
// namespace when not root), brings its lo up and gives it 127.0.0.2 as well.
// Nothing outside the process changes; ctest may run the cases in parallel (each
// has its own namespace, so its own port 3956); and the cameras, children of
// the process, share its namespace. Only loopback addresses are ever used.

#include "TempDir.h"

#include <gtest/gtest.h>
#include <opencv2/core/mat.hpp>

#include <chrono>
#include <cstdio>
#include <fstream>
#include <sstream>
#include <stdexcept>
#include <string>
#include <thread>
#include <vector>

#include <arpa/inet.h>
#include <cerrno>
#include <csignal>
#include <cstring>
#include <fcntl.h>
#include <ifaddrs.h>
#include <net/if.h>
#include <netinet/in.h>
#include <sched.h>
#include <sys/ioctl.h>
#include <sys/prctl.h>
#include <sys/socket.h>
#include <sys/stat.h>
#include <sys/types.h>
#include <sys/wait.h>
#include <unistd.h>

namespace avatar::test {

inline bool writeProcFile(const char* path, const std::string& text) {
    const int fd = ::open(path, O_WRONLY | O_CLOEXEC);
    if (fd < 0) return false;
    const bool ok = ::write(fd, text.data(), text.size()) == static_cast<ssize_t>(text.size());
    ::close(fd);
    return ok;
}

inline bool hostHasAddress(const char* address) {
    ifaddrs* list = nullptr;
    if (::getifaddrs(&list) != 0) return false;
    in_addr wanted{};
    ::inet_pton(AF_INET, address, &wanted);
    bool found = false;
    for (ifaddrs* a = list; a != nullptr && !found; a = a->ifa_next) {
        if (a->ifa_addr == nullptr || a->ifa_addr->sa_family != AF_INET) continue;
        const auto* sin = reinterpret_cast<const sockaddr_in*>(a->ifa_addr);
        found = sin->sin_addr.s_addr == wanted.s_addr;
    }
    ::freeifaddrs(list);
    return found;
}

/// Moves the process into a private network namespace whose lo is up with
/// 127.0.0.1 and 127.0.0.2. Must run while the process has one thread.
/// Returns "" on success, else why it could not (the caller skips).
inline std::string setUpPrivateLoopback() {
    std::string how = "network namespace";
    if (::unshare(CLONE_NEWNET) != 0) {
        const int plain = errno;
        const uid_t uid = ::getuid();
        const gid_t gid = ::getgid();
        if (::unshare(CLONE_NEWUSER | CLONE_NEWNET) != 0) {
            const int withUser = errno;
            if (hostHasAddress("127.0.0.2")) return "";  // the host's lo already has both addresses
            return std::string("cannot make a private network namespace (unshare: ") + std::strerror(plain) +
                   "; with a user namespace: " + std::strerror(withUser) +
                   ") and the host's lo has no 127.0.0.2";
        }
        writeProcFile("/proc/self/setgroups", "deny");
        if (!writeProcFile("/proc/self/uid_map", "0 " + std::to_string(uid) + " 1") ||
            !writeProcFile("/proc/self/gid_map", "0 " + std::to_string(gid) + " 1"))
            return "cannot map the user into its namespace";
        how = "user and network namespace";
    }
    const int fd = ::socket(AF_INET, SOCK_DGRAM | SOCK_CLOEXEC, 0);
    if (fd < 0) return std::string("socket: ") + std::strerror(errno);
    ifreq flags{};
    std::strncpy(flags.ifr_name, "lo", IFNAMSIZ - 1);
    std::string problem;
    if (::ioctl(fd, SIOCGIFFLAGS, &flags) != 0) {
        problem = std::string("SIOCGIFFLAGS lo: ") + std::strerror(errno);
    } else {
        flags.ifr_flags = static_cast<short>(flags.ifr_flags | IFF_UP | IFF_RUNNING);
        if (::ioctl(fd, SIOCSIFFLAGS, &flags) != 0) problem = std::string("bringing lo up: ") + std::strerror(errno);
    }
    if (problem.empty()) {
        ifreq alias{};
        std::strncpy(alias.ifr_name, "lo:1", IFNAMSIZ - 1);
        sockaddr_in sin{};
        sin.sin_family = AF_INET;
        ::inet_pton(AF_INET, "127.0.0.2", &sin.sin_addr);
        std::memcpy(&alias.ifr_addr, &sin, sizeof sin);
        if (::ioctl(fd, SIOCSIFADDR, &alias) != 0)
            problem = std::string("adding 127.0.0.2 to lo: ") + std::strerror(errno);
    }
    ::close(fd);
    if (!problem.empty()) return "in a private " + how + ": " + problem;
    return "";
}

/// Why this test program has no private loopback network ("" when it has
/// one); "not set up" until the environment of registerPrivateLoopback() ran.
inline std::string& privateLoopbackProblem() {
    static std::string problem = "not set up";
    return problem;
}

/// Registers a GoogleTest environment that moves the process into a private
/// loopback network (setUpPrivateLoopback) before any test, while it still has
/// one thread. Once per test program, at namespace scope:
///   [[maybe_unused]] const bool kLoopback = test::registerPrivateLoopback();
inline bool registerPrivateLoopback() {
    struct PrivateLoopback : ::testing::Environment {
        void SetUp() override { privateLoopbackProblem() = setUpPrivateLoopback(); }
    };
    ::testing::AddGlobalTestEnvironment(new PrivateLoopback);
    return true;
}

/// True when a UDP socket is bound to @p address:@p port in this namespace.
inline bool udpPortBound(const std::string& address, int port) {
    in_addr a{};
    ::inet_pton(AF_INET, address.c_str(), &a);
    char local[32];
    std::snprintf(local, sizeof local, "%08X:%04X", static_cast<unsigned>(a.s_addr), static_cast<unsigned>(port));
    std::ifstream udp("/proc/net/udp");
    std::string line;
    while (std::getline(udp, line))
        if (line.find(local) != std::string::npos) return true;
    return false;
}

/// One arv-fake-gv-camera-0.8 process serving @p serial on @p address (a
/// loopback address). Killed (SIGKILL) by stop(), by the destructor, and by
/// the kernel if the test process dies first (PR_SET_PDEATHSIG).
/// Samples of a Mono8 frame of the fake camera at unit scale that break its
/// test pattern, a ramp rising by one per pixel to the right and down (0 for
/// a frame delivered whole; GenICamTest.cpp).
inline int rampViolations(const cv::Mat& m) {
    int bad = 0;
    for (int y = 0; y + 1 < m.rows; ++y) {
        const auto* row = m.ptr<unsigned char>(y);
        const auto* below = m.ptr<unsigned char>(y + 1);
        for (int x = 0; x + 1 < m.cols; ++x) {
            if (row[x + 1] != (row[x] + 1) % 255) ++bad;
            if (below[x] != row[x + 1]) ++bad;
        }
    }
    return bad;
}

class FakeGvCamera {
public:
    FakeGvCamera(std::string address, std::string serial, std::string logPath)
        : address_(std::move(address)), serial_(std::move(serial)), logPath_(std::move(logPath)) {}
    ~FakeGvCamera() { stop(); }
    FakeGvCamera(const FakeGvCamera&) = delete;
    FakeGvCamera& operator=(const FakeGvCamera&) = delete;

    /// "Aravis-Fake-" + serial: the device id Aravis gives it.
    std::string deviceId() const { return "Aravis-Fake-" + serial_; }
    const std::string& address() const { return address_; }
    bool running() const { return pid_ > 0; }

    /// Starts the process (with extra arguments, e.g. {"-r", "50"} to lose
    /// packets) and waits until it answers on its GVCP port.
    void start(const std::string& extra1 = {}, const std::string& extra2 = {}) {
        if (pid_ > 0) return;
        std::string binary = AVATAR_ARV_FAKE_GV_CAMERA;
        std::string a1 = "-i", a3 = "-s";
        std::vector<char*> argv{binary.data(), a1.data(), address_.data(), a3.data(), serial_.data()};
        std::string e1 = extra1, e2 = extra2;
        if (!e1.empty()) argv.push_back(e1.data());
        if (!e2.empty()) argv.push_back(e2.data());
        argv.push_back(nullptr);
        const pid_t parent = ::getpid();
        const pid_t pid = ::fork();
        if (pid < 0) throw std::runtime_error(std::string("fork: ") + std::strerror(errno));
        if (pid == 0) {  // child: async-signal-safe calls only
            ::prctl(PR_SET_PDEATHSIG, SIGKILL);
            if (::getppid() != parent) ::_exit(127);
            const int log = ::open(logPath_.c_str(), O_WRONLY | O_CREAT | O_APPEND, 0644);
            if (log >= 0) {
                ::dup2(log, 1);
                ::dup2(log, 2);
            }
            ::execv(argv[0], argv.data());
            ::_exit(127);
        }
        pid_ = pid;
        const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(10);
        while (!udpPortBound(address_, 3956)) {
            int status = 0;
            if (::waitpid(pid_, &status, WNOHANG) == pid_) {
                pid_ = -1;
                throw std::runtime_error("fake camera " + serial_ + " on " + address_ + " exited: " + log());
            }
            if (std::chrono::steady_clock::now() > deadline) {
                stop();
                throw std::runtime_error("fake camera " + serial_ + " on " + address_ +
                                         " did not bind its GVCP port within 10 s: " + log());
            }
            std::this_thread::sleep_for(std::chrono::milliseconds(20));
        }
    }

    /// Kills the process at once, as a power loss or crash would.
    void stop() {
        if (pid_ <= 0) return;
        ::kill(pid_, SIGKILL);
        int status = 0;
        ::waitpid(pid_, &status, 0);
        pid_ = -1;
    }

    std::string log() const {
        std::ifstream in(logPath_);
        std::stringstream ss;
        ss << in.rdbuf();
        return ss.str();
    }

private:
    std::string address_;
    std::string serial_;
    std::string logPath_;
    pid_t pid_{-1};
};

/// A test with two fake cameras, GV01 on 127.0.0.1 and GV02 on 127.0.0.2, in
/// the private loopback network (skipped, saying why, where there is none);
/// their logs go into dir_.
class FakeCameraPairTest : public ::testing::Test {
protected:
    explicit FakeCameraPairTest(const std::string& prefix) : dir_(prefix) {}
    void SetUp() override {
        if (const std::string& problem = privateLoopbackProblem(); !problem.empty())
            GTEST_SKIP() << "no private loopback network: " << problem;
        left_.start();
        right_.start();
    }
    void TearDown() override {
        left_.stop();
        right_.stop();
    }

    TempDir dir_;
    FakeGvCamera left_{"127.0.0.1", "GV01", (dir_.path() / "GV01.log").string()};
    FakeGvCamera right_{"127.0.0.2", "GV02", (dir_.path() / "GV02.log").string()};
};

}  // namespace avatar::test
