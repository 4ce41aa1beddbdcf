// TAUNet on loopback: what the daemon adds to the vision system.
//
//   TauNet/SnapshotOverhead   one client, TAKE_SNAPSHOT round trips against an
//                             idle vision loop. Time (manual) is the round trip
//                             minus the analysis ("total" of the returned
//                             timings): request framing, the worker pool, waking
//                             the vision thread, acquisition, encoding, the reply
//                             and the socket both ways. Counters give the medians
//                             of the round trip, the analysis and the overhead (ms).
//   TauNet/PollTargetData/50  50 clients, each on its own connection and thread,
//                             polling GET_TARGET_DATA back to back for a fixed
//                             number of requests while the vision loop searches
//                             continuously. Time (manual) is the wall time of one
//                             round of all requests; items_per_second is the total
//                             reply rate; counters give the median and 99th
//                             percentile latency of one request (ms).
//
// The backend hands over one pre-rendered 640x480 16-bit Bayer pair (the sphere
// scene of tests/tau/TauNetTest.cpp) so that acquisition costs only a copy.
// Run with
//   bench_taunet --benchmark_repetitions=5 --benchmark_report_aggregates_only=true
// and read the *_median rows.

#include "SphereScene.h"

#include <avatar/acquire/AcquireSIPSimulation.h>
#include <avatar/tau/Protocol.h>
#include <avatar/tau/TauNetServer.h>
#include <avatar/tau/VisionInterface.h>

#include <benchmark/benchmark.h>

#include <arpa/inet.h>
#include <netinet/in.h>
#include <netinet/tcp.h>
#include <sys/socket.h>
#include <sys/time.h>
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <cstring>
#include <memory>
#include <stdexcept>
#include <string>
#include <thread>
#include <vector>

using namespace avatar;
using Clock = std::chrono::steady_clock;

namespace {

AvatarConfig config() { return test::sphereSceneConfig(); }

/// Renders the sphere scene once; every grab hands over a copy of that pair.
class Prerendered final : public AcquireStereoImagePair {
public:
    Prerendered() {
        const auto simulation = test::sphereSimulation();
        simulation->applyConfig(config());
        pair_ = simulation->acquire().pair;
    }
    std::string name() const override { return "simulation"; }

protected:
    AcquiredPair grab() override {
        AcquiredPair a;
        a.pair = pair_.clone();
        return a;
    }

private:
    StereoImagePair pair_;
};

/// A blocking loopback client on a plain socket; every receive times out
/// after 30 s (so a broken server ends the benchmark instead of hanging it).
class Client {
public:
    explicit Client(std::uint16_t port) {
        fd_ = ::socket(AF_INET, SOCK_STREAM | SOCK_CLOEXEC, 0);
        if (fd_ < 0) throw std::runtime_error("socket");
        timeval tv{30, 0};
        ::setsockopt(fd_, SOL_SOCKET, SO_RCVTIMEO, &tv, sizeof tv);
        int one = 1;
        ::setsockopt(fd_, IPPROTO_TCP, TCP_NODELAY, &one, sizeof one);
        sockaddr_in a{};
        a.sin_family = AF_INET;
        a.sin_port = htons(port);
        a.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
        if (::connect(fd_, reinterpret_cast<sockaddr*>(&a), sizeof a) != 0) throw std::runtime_error("connect");
        const auto reply = request(tau::MessageType::Hello, tau::encode(tau::Hello{tau::kProtocolVersion, "bench"}));
        if (reply.header.type != tau::replyType(tau::MessageType::Hello)) throw std::runtime_error("HELLO refused");
    }
    ~Client() { ::close(fd_); }
    Client(const Client&) = delete;
    Client& operator=(const Client&) = delete;

    tau::Frame request(tau::MessageType type, const std::vector<std::uint8_t>& payload = {}) {
        const auto bytes = tau::encodeFrame(static_cast<std::uint16_t>(type), ++id_, payload);
        std::size_t sent = 0;
        while (sent < bytes.size()) {
            const ssize_t n = ::send(fd_, bytes.data() + sent, bytes.size() - sent, MSG_NOSIGNAL);
            if (n <= 0) throw std::runtime_error("send failed");
            sent += static_cast<std::size_t>(n);
        }
        for (;;) {
            if (auto frame = decoder_.next()) {
                if (frame->header.request != id_) throw std::runtime_error("reply out of order");
                return std::move(*frame);
            }
            std::uint8_t buf[65536];
            const ssize_t n = ::recv(fd_, buf, sizeof buf, 0);
            if (n <= 0) throw std::runtime_error("connection closed or timed out");
            decoder_.feed(buf, static_cast<std::size_t>(n));
        }
    }

private:
    int fd_{-1};
    std::uint32_t id_{0};
    tau::FrameDecoder decoder_{tau::kMaxReplyPayload};
};

struct Daemon {
    Daemon() {
        vision = std::make_unique<VisionInterface>(std::make_unique<Prerendered>(), config());
        tau::TauNetOptions options;
        options.port = 0;
        server = std::make_unique<tau::TauNetServer>(*vision, options);
    }
    std::unique_ptr<VisionInterface> vision;
    std::unique_ptr<tau::TauNetServer> server;
};

double median(std::vector<double> v) {
    if (v.empty()) return 0.0;
    std::sort(v.begin(), v.end());
    const std::size_t n = v.size();
    return n % 2 ? v[n / 2] : 0.5 * (v[n / 2 - 1] + v[n / 2]);
}

double percentile(std::vector<double> v, double p) {
    if (v.empty()) return 0.0;
    std::sort(v.begin(), v.end());
    return v[std::min(v.size() - 1, static_cast<std::size_t>(p * static_cast<double>(v.size())))];
}

double analysisTotalMs(const VisionTargets& t) {
    for (const StageTiming& s : t.timings)
        if (s.stage == "total") return s.milliseconds;
    return 0.0;
}

void SnapshotOverhead(benchmark::State& state) {
    Daemon d;
    Client c(d.server->port());
    const auto payload = tau::encode(tau::TakeSnapshot{30000});
    c.request(tau::MessageType::TakeSnapshot, payload);  // warm up: first analysis builds its buffers
    std::vector<double> rtt, analysis, overhead;
    for (auto _ : state) {
        const auto start = Clock::now();
        const tau::Frame reply = c.request(tau::MessageType::TakeSnapshot, payload);
        const double ms = std::chrono::duration<double, std::milli>(Clock::now() - start).count();
        if (reply.header.type != tau::replyType(tau::MessageType::TakeSnapshot)) {
            state.SkipWithError("snapshot refused");
            break;
        }
        const double a = analysisTotalMs(tau::decodeTargetData(reply.payload));
        rtt.push_back(ms);
        analysis.push_back(a);
        overhead.push_back(ms - a);
        state.SetIterationTime((ms - a) / 1000.0);
    }
    state.counters["rtt_ms"] = median(rtt);
    state.counters["analysis_ms"] = median(analysis);
    state.counters["overhead_ms"] = median(overhead);
    state.counters["overhead_p90_ms"] = percentile(overhead, 0.9);
}
BENCHMARK(SnapshotOverhead)->Name("TauNet/SnapshotOverhead")->UseManualTime()->Unit(benchmark::kMillisecond)
    ->MinTime(2.0);

void PollTargetData(benchmark::State& state) {
    const int clients = static_cast<int>(state.range(0));
    constexpr int kRequestsPerClient = 200;
    Daemon d;
    std::vector<std::unique_ptr<Client>> connections;
    for (int i = 0; i < clients; ++i) connections.push_back(std::make_unique<Client>(d.server->port()));
    connections[0]->request(tau::MessageType::StartSearching);
    const auto until = Clock::now() + std::chrono::seconds(30);
    while (d.vision->status().iteration < 2 && Clock::now() < until)
        std::this_thread::sleep_for(std::chrono::milliseconds(5));

    std::vector<double> latencies;
    std::uint64_t iterations = 0, firstIteration = 0, lastIteration = 0;
    for (auto _ : state) {
        std::vector<std::vector<double>> perClient(static_cast<std::size_t>(clients));
        std::vector<std::uint64_t> seen(static_cast<std::size_t>(clients), 0);
        std::vector<std::string> errors(static_cast<std::size_t>(clients));
        std::vector<std::thread> threads;
        const auto start = Clock::now();
        for (int i = 0; i < clients; ++i)
            threads.emplace_back([&, i] {
                try {
                    auto& lat = perClient[static_cast<std::size_t>(i)];
                    lat.reserve(kRequestsPerClient);
                    for (int r = 0; r < kRequestsPerClient; ++r) {
                        const auto t0 = Clock::now();
                        const tau::Frame f = connections[static_cast<std::size_t>(i)]->request(
                            tau::MessageType::GetTargetData);
                        lat.push_back(std::chrono::duration<double, std::milli>(Clock::now() - t0).count());
                        if (f.header.type != tau::replyType(tau::MessageType::GetTargetData))
                            throw std::runtime_error("refused");
                        const std::uint64_t it = tau::decodeTargetData(f.payload).iteration;
                        if (it < seen[static_cast<std::size_t>(i)]) throw std::runtime_error("iteration went back");
                        seen[static_cast<std::size_t>(i)] = it;
                    }
                } catch (const std::exception& e) {
                    errors[static_cast<std::size_t>(i)] = e.what();
                }
            });
        for (auto& t : threads) t.join();
        const double seconds = std::chrono::duration<double>(Clock::now() - start).count();
        state.SetIterationTime(seconds);
        for (const auto& e : errors)
            if (!e.empty()) state.SkipWithError(e.c_str());
        for (const auto& l : perClient) latencies.insert(latencies.end(), l.begin(), l.end());
        if (!firstIteration) firstIteration = *std::min_element(seen.begin(), seen.end());
        lastIteration = *std::max_element(seen.begin(), seen.end());
        ++iterations;
    }
    connections[0]->request(tau::MessageType::StopSearching);
    state.SetItemsProcessed(static_cast<std::int64_t>(iterations) * clients * kRequestsPerClient);
    state.counters["latency_ms"] = median(latencies);
    state.counters["latency_p99_ms"] = percentile(latencies, 0.99);
    state.counters["vision_iterations"] = static_cast<double>(lastIteration - firstIteration);
}
BENCHMARK(PollTargetData)->Name("TauNet/PollTargetData")->Arg(50)->UseManualTime()->Unit(benchmark::kMillisecond)
    ->MinTime(2.0);

}  // namespace

BENCHMARK_MAIN();
