// tautui, the text console of thesis Figure 4-6, against the real taunet:
// interactively in a real terminal (tmux: send keys, capture the screen) and
// in script mode (commands on a pipe). Every wait is bounded.

#include "TauUnitTestProcess.h"

#include <gtest/gtest.h>

#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <functional>
#include <regex>
#include <sstream>
#include <string>

using avatar::tau::testing::CommandResult;
using avatar::tau::testing::runCommand;
using avatar::tau::testing::TauNetProcess;
using Clock = std::chrono::steady_clock;
using namespace std::chrono_literals;
namespace fs = std::filesystem;

namespace {

fs::path scratchDir(const std::string& name) {
    const fs::path dir = fs::temp_directory_path() / ("tautui-test-" + std::to_string(::getpid()) + "-" + name);
    fs::remove_all(dir);
    fs::create_directories(dir);
    return dir;
}

std::string readFile(const fs::path& p) {
    std::ifstream in(p, std::ios::binary);
    std::ostringstream s;
    s << in.rdbuf();
    return s.str();
}

bool isJpeg(const fs::path& p) {
    const std::string bytes = readFile(p);
    return bytes.size() > 1000 && static_cast<unsigned char>(bytes[0]) == 0xFF &&
           static_cast<unsigned char>(bytes[1]) == 0xD8;
}

/// One tmux server of our own (its own socket), one session running a command.
class TmuxSession {
public:
    TmuxSession(const std::string& command, int width, int height)
        : socket_("tautui-test-" + std::to_string(::getpid())) {
        ::setenv("TERM", "xterm", 0);
        const CommandResult r = tmux({"-f", "/dev/null", "new-session", "-d", "-s", "tui", "-x", std::to_string(width),
                                      "-y", std::to_string(height), command});
        if (r.status != 0) throw std::runtime_error("tmux new-session failed: " + r.err);
    }
    ~TmuxSession() { tmux({"kill-server"}); }

    CommandResult tmux(std::vector<std::string> args) const {
        std::vector<std::string> argv = {"tmux", "-L", socket_};
        argv.insert(argv.end(), args.begin(), args.end());
        return runCommand(argv, {}, 10s);
    }
    std::string screen() const { return tmux({"capture-pane", "-p", "-t", "tui"}).out; }
    void keys(const std::vector<std::string>& keys) const {
        std::vector<std::string> args = {"send-keys", "-t", "tui"};
        args.insert(args.end(), keys.begin(), keys.end());
        tmux(args);
    }
    bool alive() const { return tmux({"has-session", "-t", "tui"}).status == 0; }

    /// Waits until the screen satisfies @p ok; returns the last screen seen.
    std::string waitFor(const std::function<bool(const std::string&)>& ok, std::chrono::milliseconds limit,
                        bool* met) const {
        const auto deadline = Clock::now() + limit;
        std::string s;
        while (Clock::now() < deadline) {
            s = screen();
            if (ok(s)) {
                *met = true;
                return s;
            }
            std::this_thread::sleep_for(50ms);
        }
        *met = false;
        return s;
    }
    std::string waitForText(const std::string& text, std::chrono::milliseconds limit = 15s) const {
        bool met = false;
        const std::string s = waitFor([&](const std::string& x) { return x.find(text) != std::string::npos; }, limit, &met);
        EXPECT_TRUE(met) << "the screen never showed '" << text << "'; last screen:\n" << s;
        return s;
    }

private:
    std::string socket_;
};

std::uint64_t localHeartbeat(const std::string& screen) {
    std::smatch m;
    static const std::regex re(R"(Local\s+: heartbeat ([0-9]+))");
    return std::regex_search(screen, m, re) ? std::stoull(m[1].str()) : 0;
}

std::vector<std::string> tautui(std::uint16_t port, const fs::path& out) {
    return {TAUTUI_EXECUTABLE, "--port", std::to_string(port), "--out", out.string(), "--timeout-ms", "20000"};
}

}  // namespace

TEST(TauTuiTest, InteractiveConsoleInATerminal) {
    if (runCommand({"tmux", "-V"}).status != 0) GTEST_FAIL() << "tmux is not installed (tools/scripts/bootstrap.sh)";
    TauNetProcess server;
    const fs::path out = scratchDir("interactive");
    std::string command;
    for (const std::string& a : tautui(server.port(), out)) command += a + " ";
    command += "--refresh-ms 100";
    TmuxSession tmux(command, 140, 50);

    // The screen of Figure 4-6: heartbeats, state, iterations, the menu.
    std::string s = tmux.waitForText("state 0:Idle");
    for (const char* line : {"TAUNET Iteration     : 0", "Config Iteration     : -", "Target Iteration      : -",
                             "Left Image Iteration : -", "Right Image Iteration : -", "[q] Quit",
                             "[s] Send event: START SEARCHING", "[t] Send event: STOP SEARCHING",
                             "[n] Send event: TAKE SNAPSHOT", "[d] Get Target Data", "[c] Send new config",
                             "[g] Get current config", "[i] Get original images", "[f] Get filtered images",
                             "[m] Get marked images", "backend replay"})
        EXPECT_NE(s.find(line), std::string::npos) << line << " missing from:\n" << s;

    // Redrawn on a timer: the local heartbeat advances by itself.
    const std::uint64_t first = localHeartbeat(s);
    bool met = false;
    s = tmux.waitFor([&](const std::string& x) { return localHeartbeat(x) >= first + 3; }, 5s, &met);
    EXPECT_TRUE(met) << s;

    // [n] snapshot: its targets are shown, and the iterations it retrieved.
    tmux.keys({"n"});
    s = tmux.waitForText("snapshot: iteration 1 (group 1 member 0), 2 target(s)");
    EXPECT_NE(s.find("sample [stereo"), std::string::npos) << s;
    EXPECT_NE(s.find("arm_marker [stereo"), std::string::npos) << s;
    s = tmux.waitForText("TAUNET Iteration     : 1");
    EXPECT_NE(s.find("Target Iteration      : 1"), std::string::npos) << s;

    // [m] marked images: written into --out, named with the iteration.
    tmux.keys({"m"});
    s = tmux.waitForText("images marked: iteration 1:");
    s = tmux.waitForText("Left Image Iteration : 1 ");
    EXPECT_NE(s.find("Right Image Iteration : 1"), std::string::npos) << s;
    EXPECT_TRUE(isJpeg(out / "marked_000001_left.jpg"));
    EXPECT_TRUE(isJpeg(out / "marked_000001_right.jpg"));

    // [g] get current config: prompts for a file.
    tmux.keys({"g"});
    tmux.waitForText("Write the configuration to [");
    tmux.keys({(out / "current.xml").string(), "Enter"});
    s = tmux.waitForText("get-config: version 1 from iteration");
    EXPECT_NE(readFile(out / "current.xml").find("<avatar"), std::string::npos);
    s = tmux.waitForText("Config Iteration     : ");

    // [s] start searching: the state changes and the console's target data
    // goes stale; [t] stops.
    tmux.keys({"s"});
    s = tmux.waitForText("start: searching");
    bool searched = false;
    s = tmux.waitFor([](const std::string& x) { return x.find("(stale)") != std::string::npos; }, 15s, &searched);
    EXPECT_TRUE(searched) << s;
    tmux.keys({"t"});
    tmux.waitForText("stop: idle");

    // [q] quits and restores the terminal.
    tmux.keys({"q"});
    const auto deadline = Clock::now() + 5s;
    while (tmux.alive() && Clock::now() < deadline) std::this_thread::sleep_for(50ms);
    EXPECT_FALSE(tmux.alive());
    fs::remove_all(out);
}

TEST(TauTuiTest, ScriptModeOneCommandPerLine) {
    TauNetProcess server;
    const fs::path out = scratchDir("script");
    const std::string config = (out / "config.xml").string();
    const CommandResult r = runCommand(tautui(server.port(), out),
                                       "status\n"
                                       "# comments and empty lines are ignored\n\n"
                                       "snapshot\n"
                                       "targets\n"
                                       "images marked\n"
                                       "images original\n"
                                       "get-config " + config + "\n"
                                       "send-config " + config + "\n"
                                       "iterations\n"
                                       "quit\n"
                                       "status\n",  // after quit: not run
                                       60s);
    EXPECT_FALSE(r.timedOut);
    EXPECT_EQ(r.status, 0) << r.out << r.err;
    const std::string& o = r.out;
    EXPECT_NE(o.find("connected: "), std::string::npos) << o;
    EXPECT_NE(o.find("status: heartbeat "), std::string::npos) << o;
    EXPECT_NE(o.find("state 0:Idle, iteration 0"), std::string::npos) << o;
    EXPECT_NE(o.find("snapshot: iteration 1 (group 1 member 0), 2 target(s), visibility good"), std::string::npos) << o;
    EXPECT_NE(o.find("targets: iteration 1 (group 1 member 0), 2 target(s)"), std::string::npos) << o;
    // A target line: type, flags, vision and base positions, both centroids.
    const std::regex target(R"(  sample \[stereo[^\]]*\] vision \(6[0-9]\.[0-9], 8[0-9]\.[0-9], 7[0-9]{2}\.[0-9]\) mm )"
                            R"(base \(-?[0-9.]+, -?[0-9.]+, -?[0-9.]+\) mm L \([0-9.]+, [0-9.]+\) R \([0-9.]+, [0-9.]+\))");
    EXPECT_TRUE(std::regex_search(o, target)) << o;
    EXPECT_NE(o.find("images marked: iteration 1: left 1280x960 " + (out / "marked_000001_left.jpg").string() +
                     " right 1280x960 " + (out / "marked_000001_right.jpg").string()),
              std::string::npos)
        << o;
    EXPECT_TRUE(isJpeg(out / "marked_000001_left.jpg"));
    EXPECT_TRUE(isJpeg(out / "original_000001_right.jpg"));
    EXPECT_NE(o.find("get-config: version 1 from iteration"), std::string::npos) << o;
    EXPECT_NE(o.find("send-config: " + config + " applied as version 2 from iteration"), std::string::npos) << o;
    EXPECT_NE(o.find("iterations: vision 1, config "), std::string::npos) << o;
    // "status" after "quit" did not run: exactly one status line.
    EXPECT_EQ(o.find("status: heartbeat"), o.rfind("status: heartbeat")) << o;
    fs::remove_all(out);
}

TEST(TauTuiTest, ScriptModeFailsOnErrorsButRunsTheRest) {
    TauNetProcess server;
    const fs::path out = scratchDir("errors");
    {
        std::ofstream bad(out / "bad.xml");
        bad << "<avatar version=\"1\"><camera><width>banana</width></camera></avatar>\n";
    }
    const CommandResult r = runCommand(tautui(server.port(), out),
                                       "targets\n"                       // NOT_AVAILABLE before the first iteration
                                       "send-config " + (out / "bad.xml").string() + "\n"
                                       "send-config " + (out / "missing.xml").string() + "\n"
                                       "images sideways\n"
                                       "dance\n"
                                       "get-config " + (out / "after.xml").string() + "\n",
                                       30s);
    EXPECT_EQ(r.status, 1) << r.out << r.err;
    EXPECT_NE(r.err.find("error: targets: TAUNet answered NOT_AVAILABLE"), std::string::npos) << r.err;
    EXPECT_NE(r.err.find("error: send-config: configuration rejected, the previous one stays in force"),
              std::string::npos)
        << r.err;
    EXPECT_NE(r.err.find("cannot read " + (out / "missing.xml").string()), std::string::npos) << r.err;
    EXPECT_NE(r.err.find("images: unknown kind 'sideways'"), std::string::npos) << r.err;
    EXPECT_NE(r.err.find("unknown command or wrong arguments: 'dance'"), std::string::npos) << r.err;
    // The command after the errors ran: the configuration in force is still version 1.
    EXPECT_NE(r.out.find("get-config: version 1 from iteration"), std::string::npos) << r.out;
    fs::remove_all(out);
}

TEST(TauTuiTest, ScriptModeWithoutServerFails) {
    const fs::path out = scratchDir("noserver");
    // Find a port nobody listens on: start and stop a server.
    std::uint16_t port = 0;
    {
        TauNetProcess server;
        port = server.port();
    }
    const CommandResult r = runCommand(tautui(port, out), "status\n", 20s);
    EXPECT_EQ(r.status, 1);
    EXPECT_NE(r.err.find("127.0.0.1:" + std::to_string(port)), std::string::npos) << r.err;
    EXPECT_NE(r.err.find("refused"), std::string::npos) << r.err;
    fs::remove_all(out);
}

// docs/tools/tautui.md: --auth-key proves the daemon's key over TCP,
// --unix-socket connects through the socket file instead of host:port.
TEST(TauTuiTest, ScriptModeWithAKeyAndOverAUnixSocket) {
    const fs::path out = scratchDir("auth");
    const std::string key = (out / "key").string();
    const std::string sock = (out / "taunet.sock").string();
    std::ofstream(key) << "0123456789abcdef0123456789abcdef\n";
    fs::permissions(key, fs::perms::owner_read | fs::perms::owner_write);
    TauNetProcess server(0, {"--auth-key", key, "--unix-socket", sock});
    std::vector<std::string> keyed = tautui(server.port(), out);
    keyed.insert(keyed.end(), {"--auth-key", key});
    const CommandResult proved = runCommand(keyed, "status\n", 20s);
    EXPECT_EQ(proved.status, 0) << proved.out << proved.err;
    EXPECT_NE(proved.out.find("connected: TAUNet at 127.0.0.1:" + std::to_string(server.port())), std::string::npos)
        << proved.out;
    EXPECT_NE(proved.out.find("status: heartbeat "), std::string::npos) << proved.out;
    const CommandResult refused = runCommand(tautui(server.port(), out), "status\n", 20s);
    EXPECT_EQ(refused.status, 1);
    EXPECT_NE(refused.err.find("HELLO: authentication: the server requires it and no key is set"), std::string::npos)
        << refused.err;
    const CommandResult local = runCommand({TAUTUI_EXECUTABLE, "--unix-socket", sock, "--out", out.string()},
                                           "status\n", 20s);
    EXPECT_EQ(local.status, 0) << local.out << local.err;
    EXPECT_NE(local.out.find("connected: TAUNet at unix:" + sock), std::string::npos) << local.out;
    server.stop();
    fs::remove_all(out);
}
