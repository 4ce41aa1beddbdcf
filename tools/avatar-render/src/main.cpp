// avatar-render: renders synthetic stereo pairs with exact ground truth.
// User guide: docs/tools/avatar-render.md.

#include <avatar/acquire/SessionLog.h>
#include <avatar/common/Error.h>
#include <avatar/common/Logging.h>
#include <avatar/config/ConfigXml.h>
#include <avatar/render/Renderer.h>
#include <avatar/render/Scene.h>
#include <avatar/render/SceneSet.h>

#include <cstdio>
#include <cstdlib>
#include <iostream>
#include <optional>
#include <string>
#include <vector>

extern const char* const kScorpionSampleXml;  // ScorpionSample.cpp, generated

namespace {

using namespace avatar;
using namespace avatar::render;

const char* const kUsage = R"(usage:
  avatar-render (--config FILE | --scorpion) --scene FILE --out DIR [options]
  avatar-render (--config FILE | --scorpion) --scene-set N --out DIR [--min-targets N]
                [--max-targets N] [options]
  avatar-render (--config FILE | --scorpion) --checkerboards N --out DIR [--board 10x7]
                [--square-mm 30] [options]
  avatar-render --config FILE --scene FILE --session N --out DIR [options]

camera (one is required):
  --config FILE       AVATAR configuration: calibration, registration, image format
  --scorpion          the calibration of data/config/scorpion.xml (thesis Table 6-4, built in),
                      1280x960 16-bit BG
image format overrides:
  --width N --height N --bits N --pattern BG|GB|RG|GR --bgr --big-endian
rendering:
  --seed N            noise and scene-set seed (default 1)
  --supersampling N   N x N samples per edge pixel, 1..16 (default 4)
  --no-adaptive       supersample every pixel
  --no-noise          ignore the scene's read and shot noise
output:
  --out DIR           output directory (created)
  --session N         record N pairs of the scene (independent noise) as a session in the
                      raw log format (docs/formats.md): session.log, 16-bit PNG pairs and
                      <group>_<member>_truth.xml per pair; needs --config (it is recorded)
  --group N           acquisition group of the raw file names (default 1)
  --member N          member of the first pair (default 0; sets count up)
  --no-preview        no PNG previews
  --log-level LEVEL   debug, info, notice, warn (default), error
)";

[[noreturn]] void usageError(const std::string& message) {
    std::cerr << "avatar-render: " << message << "\n\n" << kUsage;
    std::exit(2);
}

long long toInteger(const std::string& option, const std::string& text, long long lo, long long hi) {
    char* end = nullptr;
    const long long v = std::strtoll(text.c_str(), &end, 10);
    if (text.empty() || *end != '\0' || v < lo || v > hi)
        usageError(option + ": expected an integer in [" + std::to_string(lo) + ", " + std::to_string(hi) +
                   "], got '" + text + "'");
    return v;
}

double toReal(const std::string& option, const std::string& text) {
    char* end = nullptr;
    const double v = std::strtod(text.c_str(), &end);
    if (text.empty() || *end != '\0' || !(v > 0.0)) usageError(option + ": expected a number > 0, got '" + text + "'");
    return v;
}

/// The calibration of data/config/scorpion.xml (thesis Table 6-4), built in;
/// without its example registration, as a bare stereo pair.
StereoSystemConfig scorpionCalibration() {
    StereoSystemConfig stereo = readConfigString(kScorpionSampleXml, "built-in data/config/scorpion.xml").stereo;
    stereo.baseTVision.reset();
    return stereo;
}

struct Arguments {
    std::optional<std::string> configFile;
    bool scorpion{false};
    std::optional<std::string> sceneFile;
    std::optional<int> sceneSet;
    std::optional<int> checkerboards;
    std::optional<int> session;
    std::string out;
    int minTargets{1}, maxTargets{8};
    int squaresX{10}, squaresY{7};
    double squareMm{30.0};
    std::optional<int> width, height, bits;
    std::optional<BayerPattern> pattern;
    bool bgr{false}, bigEndian{false};
    RenderOptions options;
    std::uint32_t group{1}, member{0};
    bool previews{true};
    logging::Priority logLevel{logging::Priority::Warn};
};

Arguments parse(int argc, char** argv) {
    Arguments a;
    std::vector<std::string> args(argv + 1, argv + argc);
    for (std::size_t i = 0; i < args.size(); ++i) {
        const std::string& o = args[i];
        auto value = [&]() -> const std::string& {
            if (i + 1 >= args.size()) usageError(o + " needs a value");
            return args[++i];
        };
        if (o == "--help" || o == "-h") {
            std::cout << kUsage;
            std::exit(0);
        } else if (o == "--config") a.configFile = value();
        else if (o == "--scorpion") a.scorpion = true;
        else if (o == "--scene") a.sceneFile = value();
        else if (o == "--scene-set") a.sceneSet = static_cast<int>(toInteger(o, value(), 1, 100000));
        else if (o == "--checkerboards") a.checkerboards = static_cast<int>(toInteger(o, value(), 1, 10000));
        else if (o == "--session") a.session = static_cast<int>(toInteger(o, value(), 1, 99999));
        else if (o == "--out") a.out = value();
        else if (o == "--min-targets") a.minTargets = static_cast<int>(toInteger(o, value(), 1, 32));
        else if (o == "--max-targets") a.maxTargets = static_cast<int>(toInteger(o, value(), 1, 32));
        else if (o == "--board") {
            const std::string& v = value();
            const auto x = v.find('x');
            if (x == std::string::npos) usageError("--board: expected <squaresX>x<squaresY>, got '" + v + "'");
            a.squaresX = static_cast<int>(toInteger(o, v.substr(0, x), 3, 100));
            a.squaresY = static_cast<int>(toInteger(o, v.substr(x + 1), 3, 100));
        } else if (o == "--square-mm") a.squareMm = toReal(o, value());
        else if (o == "--width") a.width = static_cast<int>(toInteger(o, value(), 2, 16384));
        else if (o == "--height") a.height = static_cast<int>(toInteger(o, value(), 2, 16384));
        else if (o == "--bits") a.bits = static_cast<int>(toInteger(o, value(), 1, 16));
        else if (o == "--pattern") a.pattern = parseBayerPattern(value());
        else if (o == "--bgr") a.bgr = true;
        else if (o == "--big-endian") a.bigEndian = true;
        else if (o == "--seed") a.options.seed = static_cast<std::uint64_t>(toInteger(o, value(), 0, 1LL << 62));
        else if (o == "--supersampling") a.options.supersampling = static_cast<int>(toInteger(o, value(), 1, 16));
        else if (o == "--no-adaptive") a.options.adaptive = false;
        else if (o == "--no-noise") a.options.noise = false;
        else if (o == "--group") a.group = static_cast<std::uint32_t>(toInteger(o, value(), 0, 99999));
        else if (o == "--member") a.member = static_cast<std::uint32_t>(toInteger(o, value(), 0, 99999));
        else if (o == "--no-preview") a.previews = false;
        else if (o == "--log-level") a.logLevel = logging::parsePriority(value());
        else usageError("unknown option '" + o + "'");
    }
    if (a.configFile.has_value() == a.scorpion) usageError("give exactly one of --config FILE and --scorpion");
    if ((a.sceneFile ? 1 : 0) + (a.sceneSet ? 1 : 0) + (a.checkerboards ? 1 : 0) != 1)
        usageError("give exactly one of --scene, --scene-set and --checkerboards");
    if (a.out.empty()) usageError("--out DIR is required");
    if (a.minTargets > a.maxTargets) usageError("--min-targets is larger than --max-targets");
    if (a.session && (!a.sceneFile || !a.configFile)) usageError("--session needs --scene FILE and --config FILE");
    return a;
}

void printSummary(const std::string& sceneFile, const RenderResult& r, const WrittenFiles& files) {
    const GroundTruth& t = r.truth;
    std::printf("%s: %s, %s (%.0f ms, %llu of %llu pixels supersampled)\n", t.sceneName.c_str(),
                files.leftRaw.filename().c_str(), files.groundTruth.filename().c_str(), t.stats.milliseconds,
                static_cast<unsigned long long>(t.stats.supersampledPixels),
                static_cast<unsigned long long>(t.stats.pixels));
    if (!sceneFile.empty()) std::printf("  scene file %s\n", sceneFile.c_str());
    for (const TargetTruth& target : t.targets) {
        auto view = [](const TargetView& v) {
            char buffer[96];
            if (v.silhouetteCentroidPx)
                std::snprintf(buffer, sizeof buffer, "%-7s (%8.2f, %8.2f) %8.0f px2",
                              std::string(toString(v.visibility)).c_str(), v.silhouetteCentroidPx->x,
                              v.silhouetteCentroidPx->y, v.areaPx);
            else
                std::snprintf(buffer, sizeof buffer, "%-7s", std::string(toString(v.visibility)).c_str());
            return std::string(buffer);
        };
        std::printf("  %-12s %-12s %7.1f %7.1f %7.1f mm  L %s  R %s\n", target.name.c_str(), target.type.c_str(),
                    target.centreLeftMm.x, target.centreLeftMm.y, target.centreLeftMm.z, view(target.left).c_str(),
                    view(target.right).c_str());
    }
}

// Records @p count renders of one scene as a session: what TAUNet would have
// recorded watching a still scene, with the ground truth beside each pair.
void recordSession(const Arguments& a, const AvatarConfig& config, const Scene& scene, int count) {
    SessionLogWriter writer(a.out);
    const std::string configXml = writeConfigString(config);
    // Deterministic timestamps: 2 Hz from a fixed start, the right camera 40 us later.
    const std::int64_t startUs = 1'790'000'000'000'000LL;
    for (int i = 0; i < count; ++i) {
        const std::uint32_t member = a.member + static_cast<std::uint32_t>(i);
        RenderOptions options = a.options;
        options.seed = a.options.seed * 1000003ULL + member;
        RenderResult result = avatar::render::render(scene, config.stereo, options);
        AcquisitionId id;
        id.group = a.group;
        id.member = member;
        id.left = {config.camera.leftCameraId, startUs + 500'000LL * i};
        id.right = {config.camera.rightCameraId, startUs + 500'000LL * i + 40};
        result.pair.setId(id);
        SessionRecord record;
        record.iteration = static_cast<std::uint64_t>(i) + 1;
        record.acquisition = id;
        record.files = writer.writePair(result.pair, Compression::Png);
        record.configVersion = 1;
        if (i == 0) record.configXml = configXml;
        writer.append(record);
        char truthName[64];
        std::snprintf(truthName, sizeof truthName, "%05u_%05u_truth.xml", a.group, member);
        writeGroundTruthFile(result.truth, std::filesystem::path(a.out) / truthName);
        std::printf("iteration %d: %s %s, %s (%.0f ms)\n", i + 1, record.files.left.name.c_str(),
                    record.files.right.name.c_str(), truthName, result.truth.stats.milliseconds);
    }
}

int run(int argc, char** argv) {
    Arguments a = parse(argc, argv);
    logging::configure(a.logLevel);

    StereoSystemConfig stereo;
    SensorFormat& sensor = a.options.sensor;
    std::optional<AvatarConfig> loaded;
    if (a.configFile) {
        loaded = readConfigFile(*a.configFile);
        const AvatarConfig& config = *loaded;
        stereo = config.stereo;
        sensor = sensorFormatFrom(config.camera);
    } else {
        stereo = scorpionCalibration();
        sensor = SensorFormat{};  // 1280x960, 16-bit, Bayer BG, little-endian
    }
    if (a.width) sensor.width = *a.width;
    if (a.height) sensor.height = *a.height;
    if (a.bits) sensor.bitDepth = *a.bits;
    if (a.pattern) sensor.bayerPattern = *a.pattern;
    if (a.bgr) sensor.format = PixelFormat::Bgr;
    if (a.bigEndian) sensor.fileByteOrder = ByteOrder::Big;
    a.options.validate();

    if (a.session) {
        if (a.width || a.height || a.bits || a.pattern || a.bgr || a.bigEndian)
            usageError("--session records the image format of --config; format overrides do not apply");
        recordSession(a, *loaded, readSceneFile(*a.sceneFile), *a.session);
        return 0;
    }

    std::vector<std::pair<Scene, std::string>> scenes;  // scene and the file it came from / goes to
    if (a.sceneFile) {
        scenes.emplace_back(readSceneFile(*a.sceneFile), *a.sceneFile);
    } else {
        std::filesystem::create_directories(a.out);
        std::vector<Scene> generated;
        if (a.sceneSet) {
            SceneSetSpec spec;
            spec.count = *a.sceneSet;
            spec.seed = a.options.seed;
            spec.minTargets = a.minTargets;
            spec.maxTargets = a.maxTargets;
            generated = makeSceneSet(spec, stereo, sensor);
        } else {
            CheckerboardSpec spec;
            spec.views = *a.checkerboards;
            spec.seed = a.options.seed;
            spec.squaresX = a.squaresX;
            spec.squaresY = a.squaresY;
            spec.squareMm = a.squareMm;
            generated = makeCheckerboardViews(spec, stereo, sensor);
        }
        for (Scene& s : generated) {
            const std::filesystem::path file = std::filesystem::path(a.out) / (s.name + ".xml");
            writeSceneFile(s, file);
            scenes.emplace_back(std::move(s), file.string());
        }
    }
    std::uint32_t member = a.member;
    for (const auto& [scene, file] : scenes) {
        RenderOptions options = a.options;
        if (!a.sceneFile) options.seed = a.options.seed * 1000003ULL + member;  // distinct noise per pair
        const RenderResult result = avatar::render::render(scene, stereo, options);
        const WrittenFiles files = writeRender(result, sensor, a.out, a.group, member, a.previews);
        printSummary(file, result, files);
        ++member;
    }
    return 0;
}

}  // namespace

int main(int argc, char** argv) {
    try {
        return run(argc, argv);
    } catch (const avatar::Error& e) {
        std::cerr << "avatar-render: " << e.what() << "\n";
        return 1;
    } catch (const std::exception& e) {
        std::cerr << "avatar-render: unexpected error: " << e.what() << "\n";
        return 1;
    }
}
