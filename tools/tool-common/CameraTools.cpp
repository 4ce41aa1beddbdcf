#include "CameraTools.h"

#include <avatar/common/StereoImagePairFileIO.h>
#include <avatar/config/ConfigXml.h>

#include <cstdio>
#include <fstream>

namespace po = boost::program_options;

namespace avatar::tools {

namespace {

/// Writes each pair as left_NNNN.png / right_NNNN.png (lossless, samples as
/// given) and one line per pair into pairs.txt.
class PngFilesSink final : public SessionSink {
public:
    explicit PngFilesSink(std::filesystem::path directory) : directory_(std::move(directory)) {}

    PairFiles writePair(const StereoImagePair& pair) override {
        ++count_;
        PairFiles files;
        files.left.name = PairSaver::pngName(Side::Left, count_);
        files.right.name = PairSaver::pngName(Side::Right, count_);
        for (const auto& [side, name] : {std::pair{Side::Left, files.left.name}, {Side::Right, files.right.name}}) {
            const std::filesystem::path path = directory_ / name;
            if (std::filesystem::exists(path)) throw IoError("will not overwrite " + path.string());
            StereoImagePairFileIO::writeLossless(path, pair.image(side));
        }
        return files;
    }

    void append(const SessionRecord& record) override {
        const AcquisitionId& id = record.acquisition;
        std::ofstream out(directory_ / "pairs.txt", std::ios::app);
        out << record.files.left.name << " " << record.files.right.name << " group=" << id.group
            << " member=" << id.member << " leftCamera=" << id.left.cameraId
            << " leftTimeUs=" << id.left.timestampUs << " rightCamera=" << id.right.cameraId
            << " rightTimeUs=" << id.right.timestampUs << "\n";
        out.close();
        if (!out) throw IoError("cannot append to " + (directory_ / "pairs.txt").string());
    }

    std::string describe() const override { return directory_.string(); }

private:
    std::filesystem::path directory_;
    std::size_t count_{0};
};

template <typename T>
T inRange(const po::variables_map& vm, const char* name, T low, T high) {
    const T v = vm[name].as<T>();
    if (!(v >= low && v <= high))
        throw UsageError(std::string("--") + name + " " + std::to_string(v) + " is outside " + std::to_string(low) +
                         ".." + std::to_string(high));
    return v;
}

}  // namespace

void addBackendOptions(po::options_description& options) {
    // clang-format off
    options.add_options()
        ("backend,b", po::value<std::string>(), "acquisition backend: replay, files, firewire, genicam, simulation")
        ("config,c", po::value<std::string>(), "configuration file (docs/config.md): the camera ids, image format and "
                                               "features; replay: instead of the recorded one")
        ("session,s", po::value<std::string>(), "replay: the session directory (docs/formats.md)")
        ("scene", po::value<std::string>(), "simulation: the scene file (e.g. data/scenes/lab.xml)")
        ("seed", po::value<std::uint64_t>()->default_value(1), "simulation: noise seed of the first pair")
        ("left-files", po::value<std::string>(), "files: printf pattern of the left images, e.g. left_%04d.jpg")
        ("right-files", po::value<std::string>(), "files: printf pattern of the right images")
        ("first", po::value<std::uint64_t>()->default_value(0), "files: index of the first pair")
        ("count", po::value<std::uint64_t>(), "files: number of pairs (default: until no file exists)")
        ("frame-rate", po::value<double>(), "genicam: frame rate to set on the cameras, Hz")
        ("pair-tolerance-ms", po::value<double>(),
            "genicam, firewire: largest left/right capture-time difference in a pair "
            "(genicam with --frame-rate: half the frame period)")
        ("timeout-ms", po::value<unsigned>(), "genicam, firewire: longest wait for a camera's frame, per pair");
    // clang-format on
}

BackendRequest backendRequest(const po::variables_map& vm) {
    if (!vm.count("backend")) throw UsageError("--backend is required");
    BackendRequest r;
    r.name = vm["backend"].as<std::string>();
    std::string names;
    bool known = false;
    for (const BackendEntry& e : backendTable()) {
        known = known || e.name == r.name;
        names += (names.empty() ? "" : ", ") + e.name;
    }
    if (!known) throw UsageError("unknown backend '" + r.name + "' (one of: " + names + ")");
    if (vm.count("session")) r.session = vm["session"].as<std::string>();
    if (vm.count("config")) r.config = vm["config"].as<std::string>();
    if (vm.count("scene")) r.scene = vm["scene"].as<std::string>();
    if (vm.count("left-files")) r.leftFiles = vm["left-files"].as<std::string>();
    if (vm.count("right-files")) r.rightFiles = vm["right-files"].as<std::string>();
    r.firstFile = vm["first"].as<std::uint64_t>();
    if (vm.count("count")) r.fileCount = vm["count"].as<std::uint64_t>();
    r.seed = vm["seed"].as<std::uint64_t>();
    if (vm.count("frame-rate")) r.frameRateHz = inRange(vm, "frame-rate", 0.01, 10000.0);
    if (vm.count("pair-tolerance-ms"))
        r.pairTolerance = std::chrono::microseconds(
            static_cast<std::int64_t>(1000.0 * inRange(vm, "pair-tolerance-ms", 0.0, 60000.0)));
    if (vm.count("timeout-ms")) r.frameTimeout = std::chrono::milliseconds(inRange(vm, "timeout-ms", 1u, 3600000u));
    return r;
}

void requireBackendOptions(const BackendRequest& r, bool toAcquire) {
    const std::string& b = r.name;
    if (b == "replay" && !r.session) throw UsageError("the replay backend needs --session DIR");
    if (b == "files" && (!r.leftFiles || !r.rightFiles))
        throw UsageError("the files backend needs --left-files PATTERN and --right-files PATTERN");
    if (b == "simulation" && !r.scene) throw UsageError("the simulation backend needs --scene FILE");
    const bool needsConfig = b == "files" || (toAcquire && (b == "simulation" || b == "firewire" || b == "genicam"));
    if (needsConfig && !r.config)
        throw UsageError("the " + b + " backend needs --config FILE" +
                         (b == "firewire" || b == "genicam" ? " (it names the cameras)" : ""));
}

std::string backendHelp() {
    std::string out = "Backends:\n";
    for (const BackendEntry& b : backendTable())
        out += "  " + b.name + std::string(b.name.size() < 12 ? 12 - b.name.size() : 1, ' ') + b.summary + "\n";
    return out;
}

// ---------------------------------------------------------------- saving

SaveFormat parseSaveFormat(const std::string& text) {
    if (text == "session") return SaveFormat::Session;
    if (text == "session-png") return SaveFormat::SessionPng;
    if (text == "png") return SaveFormat::Png;
    throw UsageError("--format must be session, session-png or png, got '" + text + "'");
}

const char* toString(SaveFormat format) {
    switch (format) {
        case SaveFormat::Session: return "session";
        case SaveFormat::SessionPng: return "session-png";
        case SaveFormat::Png: return "png";
    }
    return "?";
}

std::string PairSaver::pngName(Side side, std::size_t index) {
    char name[32];
    std::snprintf(name, sizeof name, "%s_%04zu.png", side == Side::Left ? "left" : "right", index);
    return name;
}

PairSaver::PairSaver(const std::filesystem::path& directory, SaveFormat format, const AvatarConfig& config,
                     std::size_t queueCapacity)
    : directory_(directory), format_(format), configXml_(writeConfigString(config)) {
    std::unique_ptr<SessionSink> sink;
    if (format == SaveFormat::Png) {
        std::error_code ec;
        std::filesystem::create_directories(directory, ec);
        if (ec) throw IoError("cannot create " + directory.string() + ": " + ec.message());
        const std::filesystem::path first = directory / pngName(Side::Left, 1);
        if (std::filesystem::exists(first))
            throw IoError(directory.string() + " already holds saved pairs (" + first.filename().string() +
                          "): give a new directory");
        sink = std::make_unique<PngFilesSink>(directory);
    } else {
        sink = std::make_unique<SessionLogSink>(
            directory, format == SaveFormat::SessionPng ? Compression::Png : Compression::None);
    }
    SessionRecorderOptions options;
    options.queueCapacity = queueCapacity;
    recorder_ = std::make_unique<SessionRecorder>(std::move(sink), options);
}

PairSaver::~PairSaver() = default;

bool PairSaver::save(const StereoImagePair& pair) {
    ++iteration_;
    std::optional<std::string> xml;
    if (iteration_ == 1) xml = configXml_;
    return recorder_->record(pair, iteration_, 1, xml, std::nullopt);
}

void PairSaver::flush() { recorder_->flush(); }

SessionRecorderStatus PairSaver::status() const { return recorder_->status(); }

}  // namespace avatar::tools
