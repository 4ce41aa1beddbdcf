// Replay: what reading a recorded session costs beside the analysis.
//
//   Replay/ReadPair/<raw|png>         SessionLogReader::loadPair of every record of
//                                     the session, one thread: CPU time per pair
//                                     (read, CRC-32, byte order or PNG decode).
//   Replay/ReadPairBaseline/raw       the same files read as the replay read them
//                                     before (an istreambuf_iterator into a vector,
//                                     Boost's byte-wise CRC-32, a copy into the
//                                     image), in the same process, for the ratio.
//   Replay/Analysis                   AnalyzeStereoImagePair::analyze on the
//                                     session's pairs held in memory: the rate a
//                                     replay could reach if reading cost nothing.
//   Replay/Search/<raw|png>           VisionInterface searching over RawDataAcquire
//                                     from the first record to the end of the
//                                     session, as `taunet --backend replay` does:
//                                     items_per_second is iterations per second
//                                     (wall; the read-ahead thread and the
//                                     analysis's two threads share the machine).
//
// The session: the bundled lab session's three pairs (data/sessions/lab, its
// recorded configuration) written 20 times over as raw files and as PNG files,
// 60 records each, into a temporary directory made once per process.
// Run with
//   bench_replay --benchmark_repetitions=5 --benchmark_report_aggregates_only=true

#include <avatar/acquire/RawDataAcquire.h>
#include <avatar/acquire/SessionLog.h>
#include <avatar/analyze/AnalyzeStereoImagePair.h>
#include <avatar/common/StereoImagePairFileIO.h>
#include <avatar/config/ConfigXml.h>
#include <avatar/tau/VisionInterface.h>

#include <benchmark/benchmark.h>
#include <boost/crc.hpp>

#include <chrono>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <stdexcept>
#include <string>
#include <thread>
#include <vector>

using namespace avatar;
namespace fs = std::filesystem;
using Clock = std::chrono::steady_clock;

namespace {

constexpr int kCopies = 20;

struct Sessions {
    fs::path root;
    fs::path raw, png;
    AvatarConfig config;
    std::vector<StereoImagePair> pairs;  ///< the lab session's, in memory

    Sessions() {
        char pattern[] = "/tmp/avatar-bench-replay-XXXXXX";
        if (::mkdtemp(pattern) == nullptr) throw std::runtime_error("mkdtemp failed");
        root = pattern;
        raw = root / "raw";
        png = root / "png";
        const RawDataAcquire lab(fs::path(AVATAR_DATA_DIR) / "sessions" / "lab");
        const RecordedConfig recorded = lab.initialConfig();
        config = recorded.config;
        for (const SessionRecord& r : lab.reader().records()) pairs.push_back(lab.reader().loadPair(r));
        write(raw, Compression::None);
        write(png, Compression::Png);
    }
    ~Sessions() {
        std::error_code ec;
        fs::remove_all(root, ec);
    }

    void write(const fs::path& dir, Compression compression) const {
        SessionLogWriter writer(dir);
        const std::string xml = writeConfigString(config);
        std::uint64_t iteration = 0;
        for (int copy = 0; copy < kCopies; ++copy)
            for (const StereoImagePair& p : pairs) {
                AcquisitionId id = p.id();
                id.group = 1;
                id.member = static_cast<std::uint32_t>(iteration);
                SessionRecord r;
                r.iteration = ++iteration;
                r.acquisition = id;
                r.files = writer.writePair(StereoImagePair(p.left(), p.right(), p.layout(), id), compression);
                r.configVersion = 1;
                if (iteration == 1) r.configXml = xml;
                writer.append(r);
            }
    }
};

const Sessions& sessions() {
    static const Sessions s;
    return s;
}

void ReadPair(benchmark::State& state, bool raw) {
    const SessionLogReader reader(raw ? sessions().raw : sessions().png);
    const std::vector<SessionRecord> records = reader.records();
    std::size_t i = 0;
    for (auto _ : state) {
        StereoImagePair p = reader.loadPair(records[i++ % records.size()]);
        benchmark::DoNotOptimize(p.left().data);
    }
    state.SetItemsProcessed(state.iterations());
}

/// The read of the replay before it was changed: the file through an
/// istreambuf_iterator, Boost's byte-wise CRC-32, then a copy into the image.
cv::Mat readBaseline(const fs::path& path, std::uint32_t expectedCrc) {
    const RawImageGeometry g = RawImageName::parse(path.filename().string()).geometry;
    std::ifstream in(path, std::ios::binary);
    const std::vector<unsigned char> bytes((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
    boost::crc_32_type crc;
    crc.process_bytes(bytes.data(), bytes.size());
    if (crc.checksum() != expectedCrc) throw std::runtime_error("checksum mismatch in " + path.string());
    cv::Mat image(g.height, g.width, g.cvType());
    std::copy(bytes.begin(), bytes.end(), image.data);
    return image;
}

void ReadPairBaseline(benchmark::State& state) {
    const SessionLogReader reader(sessions().raw);
    const std::vector<SessionRecord> records = reader.records();
    std::size_t i = 0;
    for (auto _ : state) {
        const SessionRecord& r = records[i++ % records.size()];
        cv::Mat left = readBaseline(sessions().raw / r.files.left.name, r.files.left.crc32);
        cv::Mat right = readBaseline(sessions().raw / r.files.right.name, r.files.right.crc32);
        benchmark::DoNotOptimize(left.data);
        benchmark::DoNotOptimize(right.data);
    }
    state.SetItemsProcessed(state.iterations());
}

void Analysis(benchmark::State& state) {
    AnalyzeStereoImagePair analyzer(sessions().config);
    std::size_t i = 0;
    for (auto _ : state) {
        VisionTargets t = analyzer.analyze(sessions().pairs[i % sessions().pairs.size()], i + 1);
        ++i;
        benchmark::DoNotOptimize(t.targets.data());
    }
    state.SetItemsProcessed(state.iterations());
}

void Search(benchmark::State& state, bool raw) {
    const fs::path dir = raw ? sessions().raw : sessions().png;
    std::int64_t iterations = 0;
    for (auto _ : state) {
        auto backend = std::make_unique<RawDataAcquire>(dir);
        const std::size_t records = backend->entryCount();
        VisionInterface vision(std::move(backend), sessions().config);
        const auto t0 = Clock::now();
        vision.startSearching();
        VisionStatus s = vision.status();
        while (s.acquisition.state != AcquisitionStatus::State::Finished || s.state == VisionState::Searching) {
            std::this_thread::sleep_for(std::chrono::microseconds(200));
            s = vision.status();
        }
        const double seconds = std::chrono::duration<double>(Clock::now() - t0).count();
        if (s.iteration != records) state.SkipWithError("the replay did not analyse every record");
        state.SetIterationTime(seconds);
        iterations += static_cast<std::int64_t>(records);
    }
    state.SetItemsProcessed(iterations);
}

}  // namespace

BENCHMARK_CAPTURE(ReadPair, raw, true)->Name("Replay/ReadPair/raw")->Unit(benchmark::kMillisecond);
BENCHMARK_CAPTURE(ReadPair, png, false)->Name("Replay/ReadPair/png")->Unit(benchmark::kMillisecond);
BENCHMARK(ReadPairBaseline)->Name("Replay/ReadPairBaseline/raw")->Unit(benchmark::kMillisecond);
BENCHMARK(Analysis)->Name("Replay/Analysis")->Unit(benchmark::kMillisecond);
BENCHMARK_CAPTURE(Search, raw, true)->Name("Replay/Search/raw")->UseManualTime()->Unit(benchmark::kMillisecond);
BENCHMARK_CAPTURE(Search, png, false)->Name("Replay/Search/png")->UseManualTime()->Unit(benchmark::kMillisecond);

BENCHMARK_MAIN();
