// tautui: the text console of thesis Figure 4-6 — TAUNet's heartbeat, state
// and iterations, and a menu of the TAU requests. Interactive on a terminal
// (single keys, redrawn on a timer); one command per line when standard input
// is not a terminal. User guide: docs/tools/tautui.md

#include "Console.h"
#include "Terminal.h"

#include <avatar/common/Error.h>
#include <avatar/common/Logging.h>
#include <avatar/tau/Authentication.h>
#include <avatar/tau/TauUnit.h>

#include <boost/program_options.hpp>

#include <algorithm>
#include <cctype>
#include <csignal>
#include <iostream>
#include <string>
#include <vector>

#include <unistd.h>

namespace po = boost::program_options;
using namespace avatar;

namespace {

volatile std::sig_atomic_t stopRequested = 0;
void onSignal(int) { stopRequested = 1; }

void installSignalHandlers() {
    struct sigaction sa {};
    sa.sa_handler = onSignal;
    sigemptyset(&sa.sa_mask);
    sa.sa_flags = 0;  // no SA_RESTART: poll() returns so the loop can end
    sigaction(SIGINT, &sa, nullptr);
    sigaction(SIGTERM, &sa, nullptr);
    sigaction(SIGHUP, &sa, nullptr);
}

struct MenuEntry {
    char key;
    const char* text;
};
const MenuEntry kMenu[] = {
    {'q', "Quit"},
    {'s', "Send event: START SEARCHING"},
    {'t', "Send event: STOP SEARCHING"},
    {'n', "Send event: TAKE SNAPSHOT"},
    {'d', "Get Target Data"},
    {'c', "Send new config"},
    {'g', "Get current config"},
    {'i', "Get original images"},
    {'f', "Get filtered images"},
    {'m', "Get marked images"},
};

std::vector<std::string> screen(const tau::TauUnit& unit, const tui::Console& console,
                                const std::vector<std::string>& message) {
    std::vector<std::string> lines;
    std::string title = "tautui: TAUNet at " + unit.endpoint();
    if (const auto hello = unit.server()) title += " (" + hello->serverName + ", backend " + hello->backend + ")";
    lines.push_back(title);
    lines.emplace_back();
    for (const std::string& l : console.statusLines()) lines.push_back(l);
    lines.emplace_back();
    lines.emplace_back("Menu");
    for (const MenuEntry& e : kMenu) lines.push_back(std::string("[") + e.key + "] " + e.text);
    lines.emplace_back();
    const std::size_t shown = 30;
    for (std::size_t i = 0; i < message.size() && i < shown; ++i) lines.push_back(message[i]);
    if (message.size() > shown) lines.push_back("... " + std::to_string(message.size() - shown) + " more line(s)");
    return lines;
}

int interactive(tau::TauUnit& unit, tui::Console& console, std::chrono::milliseconds refresh) {
    tui::RawTerminal terminal;
    std::vector<std::string> message{"Press a key of the menu."};
    auto nextTick = std::chrono::steady_clock::now();
    while (!stopRequested) {
        const auto now = std::chrono::steady_clock::now();
        if (now >= nextTick) {
            console.tick();
            terminal.draw(screen(unit, console, message));
            nextTick = now + refresh;
            continue;
        }
        const auto key =
            terminal.readKey(std::chrono::ceil<std::chrono::milliseconds>(nextTick - std::chrono::steady_clock::now()));
        if (!key) continue;
        if (*key == 'q' || *key == 'Q') break;
        auto busy = [&](const std::string& what) {
            terminal.draw(screen(unit, console, {what + " ..."}));
        };
        tui::Result result;
        bool known = true;
        switch (*key) {
            case 's': busy("start searching"); result = console.startSearching(); break;
            case 't': busy("stop searching"); result = console.stopSearching(); break;
            case 'n': busy("snapshot"); result = console.snapshot(); break;
            case 'd': busy("target data"); result = console.targets(); break;
            case 'i': busy("original images"); result = console.images(tau::ImageKindCode::Original); break;
            case 'f': busy("filtered images"); result = console.images(tau::ImageKindCode::Filtered); break;
            case 'm': busy("marked images"); result = console.images(tau::ImageKindCode::Marked); break;
            case 'c': {
                terminal.draw(screen(unit, console, {}));
                const auto file = terminal.prompt("Configuration file to send: ");
                if (!file || file->empty()) {
                    result.lines.push_back("send-config: cancelled");
                    break;
                }
                busy("send-config " + *file);
                result = console.sendConfig(*file);
                break;
            }
            case 'g': {
                terminal.draw(screen(unit, console, {}));
                const std::string fallback = console.defaultConfigFile().string();
                const auto file = terminal.prompt("Write the configuration to [" + fallback + "]: ");
                if (!file) {
                    result.lines.push_back("get-config: cancelled");
                    break;
                }
                busy("get-config");
                result = console.getConfig(file->empty() ? fallback : *file);
                break;
            }
            default: known = false; break;
        }
        if (!known) {
            message = {std::string("no menu entry for key '") + (std::isprint(static_cast<unsigned char>(*key)) ? *key : '?') + "'"};
        } else {
            message = result.lines;
            if (!result.ok && !message.empty()) message.front() = "FAILED " + message.front();
        }
        console.refresh();
        terminal.draw(screen(unit, console, message));
    }
    return 0;
}

int script(tui::Console& console) {
    int failures = 0;
    std::string line;
    while (!stopRequested && std::getline(std::cin, line)) {
        const auto first = line.find_first_not_of(" \t\r");
        if (first == std::string::npos || line[first] == '#') continue;
        const auto last = line.find_last_not_of(" \t\r");
        const std::string command = line.substr(first, last - first + 1);
        if (command == "quit" || command == "exit") break;
        const tui::Result r = console.run(command);
        for (const std::string& l : r.lines) (r.ok ? std::cout : std::cerr) << (r.ok ? "" : "error: ") << l << "\n";
        std::cout.flush();
        if (!r.ok) ++failures;
    }
    return failures == 0 ? 0 : 1;
}

}  // namespace

int main(int argc, char** argv) {
    po::options_description options(
        "tautui: the text console of TAUNet (thesis Figure 4-6)\n"
        "On a terminal: a single-key menu, redrawn every --refresh-ms.\n"
        "Otherwise: one command per line on standard input");
    options.add_options()
        ("help,h", "show this help and the script commands")
        ("host", po::value<std::string>()->default_value("127.0.0.1"), "TAUNet's host")
        ("port,p", po::value<unsigned>()->default_value(7010), "TAUNet's port")
        ("unix-socket", po::value<std::string>(), "connect to TAUNet's Unix-domain socket instead of --host/--port")
        ("auth-key", po::value<std::string>(), "file with TAUNet's authentication key (chmod 600); both sides prove it")
        ("out,o", po::value<std::string>()->default_value("tautui-out"), "directory for images and configurations")
        ("refresh-ms", po::value<int>()->default_value(500), "screen refresh period (interactive), 50..60000 ms")
        ("timeout-ms", po::value<int>()->default_value(5000), "limit for each request, ms")
        ("snapshot-timeout-ms", po::value<int>()->default_value(10000), "how long a snapshot may take, ms")
        ("retries", po::value<int>()->default_value(0), "reconnect and resend this many times when the connection fails")
        ("log", po::value<std::string>()->default_value("error"), "log priority: debug, info, notice, warn, error");
    po::variables_map vm;
    try {
        po::store(po::parse_command_line(argc, argv, options), vm);
        po::notify(vm);
    } catch (const po::error& e) {
        std::cerr << "tautui: " << e.what() << "\n" << options;
        return 2;
    }
    if (vm.count("help")) {
        std::cout << options << "\nScript commands:\n";
        for (const std::string& h : tui::Console::commandHelp()) std::cout << "  " << h << "\n";
        return 0;
    }
    const unsigned port = vm["port"].as<unsigned>();
    const int refreshMs = vm["refresh-ms"].as<int>();
    if (port == 0 || port > 65535) {
        std::cerr << "tautui: --port must be 1..65535\n";
        return 2;
    }
    if (refreshMs < 50 || refreshMs > 60000) {
        std::cerr << "tautui: --refresh-ms must be 50..60000\n";
        return 2;
    }
    try {
        logging::configure(logging::parsePriority(vm["log"].as<std::string>()));
        tau::TauUnitOptions o;
        o.host = vm["host"].as<std::string>();
        o.port = static_cast<std::uint16_t>(port);
        o.clientName = "tautui";
        if (vm.count("unix-socket")) o.unixSocket = vm["unix-socket"].as<std::string>();
        if (vm.count("auth-key")) o.authKey = tau::readAuthKeyFile(vm["auth-key"].as<std::string>());
        o.requestTimeout = std::chrono::milliseconds(vm["timeout-ms"].as<int>());
        o.connectTimeout = std::min(o.requestTimeout, std::chrono::milliseconds(2000));
        o.snapshotTimeout = std::chrono::milliseconds(vm["snapshot-timeout-ms"].as<int>());
        o.retry.attempts = vm["retries"].as<int>();
        std::string why;
        if (!o.isValid(&why)) {
            std::cerr << "tautui: " << why << "\n";
            return 2;
        }
        tau::TauUnit unit(o);
        tui::Console console(unit, vm["out"].as<std::string>());
        installSignalHandlers();
        if (::isatty(STDIN_FILENO)) return interactive(unit, console, std::chrono::milliseconds(refreshMs));
        try {
            const tau::HelloReply hello = unit.connect();
            std::cout << "connected: " << hello.serverName << " at " << unit.endpoint() << ", backend "
                      << hello.backend << "\n";
        } catch (const avatar::Error& e) {
            std::cerr << "error: " << e.what() << "\n";
            return 1;
        }
        return script(console);
    } catch (const avatar::Error& e) {
        std::cerr << "tautui: " << e.what() << "\n";
        return 1;
    }
}
