// taunet: the TAUNet daemon (thesis 4.3.2). Runs a VisionInterface over the
// chosen acquisition backend and serves it with the TAU protocol until SIGINT
// or SIGTERM. User guide: docs/tools/taunet.md

#include <avatar/acquire/AcquisitionBackends.h>
#include <avatar/common/Error.h>
#include <avatar/common/Logging.h>
#include <avatar/tau/Authentication.h>
#include <avatar/tau/TauNetServer.h>
#include <avatar/tau/VisionInterface.h>

#include <boost/asio/io_context.hpp>
#include <boost/asio/signal_set.hpp>
#include <boost/program_options.hpp>

#include <log4cpp/Category.hh>

#include <csignal>
#include <iostream>
#include <limits>
#include <memory>
#include <string>

namespace po = boost::program_options;
using namespace avatar;

namespace {

void printHelp(const po::options_description& options) {
    std::cout << "Usage: taunet --backend NAME [options]\n\n"
                 "Serves the AVATAR vision system over TCP with the TAU protocol (docs/protocol.md)\n"
                 "until SIGINT or SIGTERM. Listens on 127.0.0.1 unless --listen says otherwise;\n"
                 "any other address needs --auth-key. --unix-socket serves a Unix-domain socket too.\n\n"
              << options << "\nBackends:\n";
    for (const auto& b : backendTable())
        std::cout << "  " << b.name << std::string(b.name.size() < 12 ? 12 - b.name.size() : 1, ' ') << b.summary
                  << "\n";
    std::cout << "\nExample:\n  taunet --backend replay --session data/sessions/lab --port 0\n";
}

template <typename T>
T checkedRange(const po::variables_map& vm, const char* name, T low, T high) {
    const T v = vm[name].as<T>();
    if (v < low || v > high)
        throw InvalidArgument(std::string("--") + name + " " + std::to_string(v) + " outside " +
                              std::to_string(low) + ".." + std::to_string(high));
    return v;
}

}  // namespace

int main(int argc, char** argv) {
    po::options_description options("Options");
    // clang-format off
    options.add_options()
        ("help,h", "show this help")
        ("backend,b", po::value<std::string>(), "acquisition backend: replay, files, firewire, genicam, simulation")
        ("session,s", po::value<std::string>(), "replay: the session directory (docs/formats.md)")
        ("config,c", po::value<std::string>(), "configuration file (docs/config.md); replay: instead of the recorded one")
        ("scene", po::value<std::string>(), "simulation: the scene file (e.g. data/scenes/lab.xml)")
        ("seed", po::value<std::uint64_t>()->default_value(1), "simulation: noise seed of the first pair")
        ("left-files", po::value<std::string>(), "files: printf pattern of the left images, e.g. left_%04d.jpg")
        ("right-files", po::value<std::string>(), "files: printf pattern of the right images")
        ("first", po::value<std::uint64_t>()->default_value(0), "files: index of the first pair")
        ("count", po::value<std::uint64_t>(), "files: number of pairs (default: until no file exists)")
        ("listen", po::value<std::string>()->default_value("127.0.0.1"),
            "TCP address to listen on ('none': no TCP); anything but loopback needs --auth-key")
        ("port,p", po::value<unsigned>()->default_value(7010), "TCP port; 0 picks a free one (printed on stdout)")
        ("auth-key", po::value<std::string>(),
            "file with the shared secret (chmod 600, at least 16 bytes, e.g. openssl rand -hex 32); "
            "every TCP client must then prove it (protocol version 3)")
        ("unix-socket", po::value<std::string>(), "also listen on this Unix-domain socket; its permissions decide who may connect")
        ("unix-socket-mode", po::value<std::string>()->default_value("0600"), "permissions of the socket file, octal")
        ("record", po::value<std::string>(), "record every pair and its result into this new session directory")
        ("record-png", "record: archive pairs as 16-bit PNG instead of raw files")
        ("period", po::value<unsigned>()->default_value(0), "pause between iterations while searching, ms")
        ("workers", po::value<unsigned>()->default_value(4), "threads for snapshots, configurations and images")
        ("max-clients", po::value<unsigned>()->default_value(256), "simultaneous connections")
        ("send-queue-mb", po::value<unsigned>()->default_value(256),
            "replies waiting for one client before it is disconnected, MiB")
        ("send-budget-mb", po::value<unsigned>()->default_value(512),
            "replies that may wait for all clients together, MiB; beyond it the client with the most waiting is disconnected")
        ("idle-timeout", po::value<unsigned>()->default_value(30), "close a connection whose frame is not complete this many s after its first byte")
        ("hello-timeout", po::value<unsigned>()->default_value(10), "close a connection that has not said HELLO after this many s")
        ("session-timeout", po::value<unsigned>()->default_value(3600), "close a session without a request for this many s (0: never)")
        ("log", po::value<std::string>()->default_value("notice"), "log priority: debug, info, notice, warn, error")
        ("log-config", po::value<std::string>(), "log4cpp property file (instead of --log)");
    // clang-format on
    po::variables_map vm;
    try {
        po::store(po::parse_command_line(argc, argv, options), vm);
        po::notify(vm);
    } catch (const po::error& e) {
        std::cerr << "taunet: " << e.what() << " (see taunet --help)\n";
        return 2;
    }
    if (vm.count("help")) {
        printHelp(options);
        return 0;
    }
    if (!vm.count("backend")) {
        std::cerr << "taunet: --backend is required (see taunet --help)\n";
        return 2;
    }

    try {
        if (vm.count("log-config")) logging::configureFromFile(vm["log-config"].as<std::string>());
        else logging::configure(logging::parsePriority(vm["log"].as<std::string>()));
        log4cpp::Category& log = logging::category("taunet");

        // Signals first, so a SIGTERM that arrives while the backend starts
        // shuts down cleanly as well.
        boost::asio::io_context signalIo;
        boost::asio::signal_set signals(signalIo, SIGINT, SIGTERM);

        BackendRequest request;
        request.name = vm["backend"].as<std::string>();
        if (vm.count("session")) request.session = vm["session"].as<std::string>();
        if (vm.count("config")) request.config = vm["config"].as<std::string>();
        if (vm.count("scene")) request.scene = vm["scene"].as<std::string>();
        if (vm.count("left-files")) request.leftFiles = vm["left-files"].as<std::string>();
        if (vm.count("right-files")) request.rightFiles = vm["right-files"].as<std::string>();
        request.firstFile = vm["first"].as<std::uint64_t>();
        if (vm.count("count")) request.fileCount = vm["count"].as<std::uint64_t>();
        request.seed = vm["seed"].as<std::uint64_t>();

        tau::TauNetOptions serverOptions;
        serverOptions.listenAddress = vm["listen"].as<std::string>();
        if (serverOptions.listenAddress == "none") serverOptions.listenAddress.clear();
        if (vm.count("auth-key")) serverOptions.authKey = tau::readAuthKeyFile(vm["auth-key"].as<std::string>());
        if (vm.count("unix-socket")) serverOptions.unixSocketPath = vm["unix-socket"].as<std::string>();
        {
            const std::string mode = vm["unix-socket-mode"].as<std::string>();
            std::size_t used = 0;
            unsigned long value = 0;
            try {
                value = std::stoul(mode, &used, 8);
            } catch (const std::exception&) {
                used = 0;
            }
            if (used != mode.size() || mode.empty() || value > 0777)
                throw InvalidArgument("--unix-socket-mode '" + mode + "' is not an octal permission mode 0..0777");
            serverOptions.unixSocketMode = static_cast<unsigned>(value);
        }
        serverOptions.port = static_cast<std::uint16_t>(checkedRange<unsigned>(vm, "port", 0, 65535));
        serverOptions.workerThreads = checkedRange<unsigned>(vm, "workers", 1, 64);
        serverOptions.maxConnections = checkedRange<unsigned>(vm, "max-clients", 1, 100000);
        serverOptions.maxSendQueueBytes = std::size_t{checkedRange<unsigned>(vm, "send-queue-mb", 1, 4096)} << 20;
        serverOptions.maxTotalSendQueueBytes = std::size_t{checkedRange<unsigned>(vm, "send-budget-mb", 1, 65536)} << 20;
        serverOptions.idleTimeout = std::chrono::seconds(checkedRange<unsigned>(vm, "idle-timeout", 1, 86400));
        serverOptions.helloTimeout = std::chrono::seconds(checkedRange<unsigned>(vm, "hello-timeout", 1, 3600));
        serverOptions.sessionIdleTimeout =
            std::chrono::seconds(checkedRange<unsigned>(vm, "session-timeout", 0, 7 * 86400));
        std::string why;
        if (!serverOptions.isValid(&why)) throw InvalidArgument(why);

        Backend backend = makeBackend(request);
        log.notice("backend %s, configuration from %s", request.name.c_str(), backend.configSource.c_str());
        VisionOptions visionOptions;
        visionOptions.configDirectory = backend.configDirectory;
        visionOptions.searchPeriod = std::chrono::milliseconds(vm["period"].as<unsigned>());
        if (vm.count("record")) {
            visionOptions.recordDirectory = vm["record"].as<std::string>();
            visionOptions.recordPng = vm.count("record-png") > 0;
            log.notice("recording into %s", visionOptions.recordDirectory->string().c_str());
        } else if (vm.count("record-png")) {
            throw InvalidArgument("--record-png needs --record DIR");
        }
        auto vision = std::make_unique<VisionInterface>(std::move(backend.acquisition), backend.config, visionOptions);

        tau::TauNetServer server(*vision, serverOptions);
        int caught = 0;
        signals.async_wait([&](const boost::system::error_code& ec, int signal) {
            if (ec) return;
            caught = signal;
            server.stop();
        });
        if (const std::string address = server.address(); !address.empty()) {
            const bool v6 = address.find(':') != std::string::npos;
            std::cout << "listening on " << (v6 ? "[" + address + "]" : address) << ":" << server.port()
                      << std::endl;
        }
        if (!server.unixSocketPath().empty()) std::cout << "listening on unix:" << server.unixSocketPath() << std::endl;
        signalIo.run();  // until SIGINT or SIGTERM
        log.notice("%s received: shutting down", caught == SIGINT ? "SIGINT" : "SIGTERM");
        server.wait();
        vision->stopSearching();
        vision.reset();  // finishes the current iteration and stops the vision thread
        log.notice("vision stopped; bye");
        return 0;
    } catch (const Error& e) {
        std::cerr << "taunet: " << e.what() << "\n";
        return 1;
    } catch (const std::exception& e) {
        std::cerr << "taunet: unexpected error: " << e.what() << "\n";
        return 1;
    }
}
