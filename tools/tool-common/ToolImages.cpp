#include "ToolImages.h"

#include <avatar/acquire/SessionLog.h>
#include <avatar/analyze/LightingCorrection.h>
#include <avatar/common/Error.h>
#include <avatar/common/ImageUtils.h>
#include <avatar/common/StereoImagePairFileIO.h>

#include <opencv2/core.hpp>

#include <algorithm>
#include <cctype>
#include <cmath>
#include <sstream>
#include <vector>

namespace po = boost::program_options;

namespace avatar::tools {
namespace {

std::string lower(std::string s) {
    for (char& c : s) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
    return s;
}

}  // namespace

WorkingImage loadImage(const std::filesystem::path& path, const ImagePurpose& purpose,
                       std::optional<BayerPattern> bayer, std::optional<int> bitDepth) {
    const std::string ext = lower(path.extension().string());
    WorkingImage w;
    std::ostringstream what;
    if (ext == ".raw") {
        const RawImageName name = RawImageName::parse(path.filename().string());
        const cv::Mat raw = StereoImagePairFileIO::readRaw(path);
        w.bitDepth = bitDepth.value_or(name.geometry.bitDepth);
        if (name.geometry.format == PixelFormat::Bayer) {
            w.bgr = demosaic(raw, name.geometry.bayerPattern);
            what << "raw " << name.geometry.bitDepth << "-bit Bayer " << toString(name.geometry.bayerPattern);
        } else if (raw.channels() == 3) {
            w.bgr = raw;
            what << "raw " << name.geometry.bitDepth << "-bit BGR";
        } else {
            throw FormatError("image " + path.string() + ": a monochrome raw image has no " + purpose.noColour);
        }
    } else if (ext == ".png" || ext == ".tif" || ext == ".tiff") {
        const cv::Mat img = StereoImagePairFileIO::readLossless(path);
        if (img.depth() != CV_8U && img.depth() != CV_16U)
            throw FormatError("image " + path.string() + ": samples must be 8- or 16-bit" +
                              (purpose.sampleTypeInMessage ? ", got " + cv::typeToString(img.type()) : ""));
        const int bits = img.depth() == CV_8U ? 8 : 16;
        // A PNG named like a raw file (a session's lossless archive,
        // docs/formats.md) says its layout and bit depth itself.
        std::optional<RawImageGeometry> named;
        if (purpose.layoutFromPngName && ext == ".png") {
            try {
                named = RawImageName::parse(path.filename().string()).geometry;
            } catch (const FormatError&) {
            }
        }
        w.bitDepth = bitDepth.value_or(named ? named->bitDepth : bits);
        if (img.channels() == 1 && !bayer && named && named->format == PixelFormat::Bayer) bayer = named->bayerPattern;
        if (img.channels() == 1) {
            if (!bayer)
                throw FormatError("image " + path.string() +
                                  " has one channel: give its Bayer pattern (--bayer BG|GB|RG|GR) to demosaic it");
            w.bgr = demosaic(img, *bayer);
            what << bits << "-bit Bayer " << toString(*bayer);
        } else if (img.channels() == 3) {
            w.bgr = img;
            what << bits << "-bit BGR";
        } else {
            throw FormatError("image " + path.string() + " has " + std::to_string(img.channels()) +
                              " channels; 3 (or a 1-channel Bayer mosaic) are needed");
        }
    } else {
        w.bgr = StereoImagePairFileIO::readDisplay(path);
        w.bitDepth = 8;
        what << "8-bit BGR";
    }
    const int maxBits = w.bgr.depth() == CV_8U ? 8 : 16;
    if (w.bitDepth < 1 || w.bitDepth > maxBits)
        throw InvalidArgument("bit depth " + std::to_string(w.bitDepth) + " does not fit the " +
                              std::to_string(maxBits) + "-bit samples of " + path.string());
    double largest = 0.0;
    cv::minMaxLoc(w.bgr.reshape(1), nullptr, &largest);
    if (largest > std::ldexp(1.0, w.bitDepth) - 1.0)
        throw InvalidArgument("image " + path.string() + " holds samples up to " + std::to_string(cvRound(largest)) +
                              ", beyond " + std::to_string(w.bitDepth) + " significant bits (--bit-depth)");
    what << " " << w.bgr.cols << "x" << w.bgr.rows << " (" << path.filename().string() << ")";
    w.description = what.str();
    return w;
}

WorkingImage loadSessionImage(const std::filesystem::path& session, std::uint64_t iteration, Side side,
                              const ImagePurpose& purpose) {
    const SessionLogReader reader(session);
    const std::vector<SessionRecord> records = reader.records();
    if (records.empty()) throw FormatError("session " + session.string() + " holds no readable record");
    const SessionRecord* chosen = &records.front();
    if (iteration != 0) {
        chosen = nullptr;
        for (const SessionRecord& r : records)
            if (r.iteration == iteration) chosen = &r;
        if (!chosen)
            throw InvalidArgument("session " + session.string() + " has no record of iteration " +
                                  std::to_string(iteration));
    }
    const StereoImagePair pair = reader.loadPair(*chosen);
    const cv::Mat& img = pair.image(side);
    WorkingImage w;
    w.bitDepth = pair.layout().bitDepth;
    w.bgr = pair.layout().format == PixelFormat::Bayer ? demosaic(img, pair.layout().bayerPattern) : img;
    if (w.bgr.channels() != 3)
        throw FormatError("session " + session.string() + ": the images are monochrome; " + purpose.needsColour);
    w.description = "session " + session.filename().string() + " iteration " + std::to_string(chosen->iteration) +
                    (side == Side::Left ? " left" : " right") + " " + std::to_string(w.bgr.cols) + "x" +
                    std::to_string(w.bgr.rows) + ", " + std::to_string(w.bitDepth) + "-bit";
    return w;
}

bool correctLighting(WorkingImage& image, const AvatarConfig& config, const std::filesystem::path& configDir) {
    const auto& stages = config.analysis.stages;
    if (std::find(stages.begin(), stages.end(), "lighting") == stages.end()) return false;
    LightingCorrector corrector(config.lighting, configDir);
    if (!corrector.enabled()) return false;
    corrector.prepare(image.bgr.size());
    image.bgr = image.bgr.clone();
    corrector.apply(image.bgr, image.bitDepth);
    image.description += ", lighting-corrected";
    return true;
}

void addImageOptions(po::options_description& options, const std::string& imageHelp) {
    // clang-format off
    options.add_options()
        ("image", po::value<std::string>(), imageHelp.c_str())
        ("session", po::value<std::string>(), "instead of --image: a recorded session directory")
        ("iteration", po::value<std::uint64_t>()->default_value(0), "with --session: the record's iteration (0: the first)")
        ("side", po::value<std::string>()->default_value("left"), "with --session: left or right")
        ("bayer", po::value<std::string>(), "a 1-channel PNG/TIFF is a Bayer mosaic of this pattern (BG, GB, RG, GR)")
        ("bit-depth", po::value<int>(), "significant bits of 16-bit samples (default: the raw name's, else 16)");
    // clang-format on
}

WorkingImage imageFromOptions(const po::variables_map& vm, const ImagePurpose& purpose) {
    if (vm.count("session")) {
        const std::string side = vm["side"].as<std::string>();
        if (side != "left" && side != "right") throw InvalidArgument("--side must be left or right, got '" + side + "'");
        return loadSessionImage(vm["session"].as<std::string>(), vm["iteration"].as<std::uint64_t>(),
                                side == "left" ? Side::Left : Side::Right, purpose);
    }
    std::optional<BayerPattern> bayer;
    if (vm.count("bayer")) bayer = parseBayerPattern(vm["bayer"].as<std::string>());
    std::optional<int> bits;
    if (vm.count("bit-depth")) bits = vm["bit-depth"].as<int>();
    return loadImage(vm["image"].as<std::string>(), purpose, bayer, bits);
}

}  // namespace avatar::tools
