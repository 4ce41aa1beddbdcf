// avatar-info: loads an AVATAR configuration and a stereo pair and prints what
// they contain. A quick check that a config is valid and a pair is readable.
// User guide: docs/tools/avatar-info.md

#include <avatar/common/Error.h>
#include <avatar/common/ImageUtils.h>
#include <avatar/common/Logging.h>
#include <avatar/common/StereoImagePairFileIO.h>
#include <avatar/config/ConfigXml.h>

#include <boost/program_options.hpp>
#include <opencv2/core.hpp>

#include <cstdio>
#include <iostream>
#include <string>

namespace po = boost::program_options;
using namespace avatar;

namespace {

std::string rangeText(const Range& r) {
    char buf[96];
    std::snprintf(buf, sizeof buf, "%g..%g", r.min, r.max);
    return buf;
}

std::string veilText(const Veil& v) {
    char buf[96];
    std::snprintf(buf, sizeof buf, "R:G:B %g:%g:%g up to %g of G", v.colourRgb[0], v.colourRgb[1], v.colourRgb[2],
                  v.maxShare);
    return buf;
}

std::string waterText(const Water& w) {
    char buf[96];
    std::snprintf(buf, sizeof buf, "k R:G:B %g:%g:%g /m up to %g m", w.attenuationPerM[0], w.attenuationPerM[1],
                  w.attenuationPerM[2], w.maxPathM);
    return buf;
}

void printConfig(const AvatarConfig& c, std::ostream& out) {
    const auto& cam = c.camera;
    out << "camera:   " << cam.width << "x" << cam.height << ", " << cam.bitDepth << "-bit, "
        << cam.channels << " channel(s)";
    if (cam.bayer) out << ", Bayer " << toString(cam.bayerPattern);
    out << (cam.endianSwap ? ", endian swap" : "") << "; left id '" << cam.leftCameraId
        << "', right id '" << cam.rightCameraId << "'\n";
    const auto& s = c.stereo;
    char line[256];
    std::snprintf(line, sizeof line,
                  "stereo:   left fc %.2f/%.2f cc %.2f/%.2f; right fc %.2f/%.2f cc %.2f/%.2f\n"
                  "          om %.4f %.4f %.4f rad, T %.2f %.2f %.2f mm\n",
                  s.left.fc[0], s.left.fc[1], s.left.cc[0], s.left.cc[1], s.right.fc[0],
                  s.right.fc[1], s.right.cc[0], s.right.cc[1], s.om[0], s.om[1], s.om[2],
                  s.translationMm[0], s.translationMm[1], s.translationMm[2]);
    out << line;
    out << "          registration base_T_vision: " << (s.baseTVision ? "set" : "not set") << "\n";
    const char* methods[] = {"shape", "epipolar box", "epipolar line"};
    std::snprintf(line, sizeof line, "match:    %s, box dx %g..%g dy %g..%g px\n",
                  methods[static_cast<int>(c.match.method)], c.match.boxDxMin, c.match.boxDxMax,
                  c.match.boxDyMin, c.match.boxDyMax);
    out << line;
    out << "lighting: frame average " << (c.lighting.frameAverageEnabled ? "on" : "off")
        << ", strobe pattern " << (c.lighting.patternEnabled ? "on" : "off") << "\n";
    out << "targets:  " << c.targets.targets.size() << "\n";
    for (const auto& t : c.targets.targets) {
        out << "  - " << t.name << ": "
            << (t.filter == ColorFilterMethod::RgbRatio
                    ? "R/G " + rangeText(t.redGreen) + ", R/B " + rangeText(t.redBlue) + ", B/G " +
                          rangeText(t.blueGreen)
                    : std::string("hsv"))
            << (t.veil ? ", veil " + veilText(*t.veil) : std::string())
            << (t.water ? ", water " + waterText(*t.water) : std::string())
            << ", area " << rangeText(t.area) << " px" << (t.erodeRestore ? ", erode+restore" : "")
            << "\n";
    }
}

void printImage(const char* side, const cv::Mat& bgr) {
    cv::Scalar mean = cv::mean(bgr);
    std::vector<cv::Mat> channels;
    cv::split(bgr, channels);
    double lo[3] = {0, 0, 0}, hi[3] = {0, 0, 0};
    for (int i = 0; i < 3 && i < static_cast<int>(channels.size()); ++i)
        cv::minMaxLoc(channels[static_cast<std::size_t>(i)], &lo[i], &hi[i]);
    std::printf("  %-5s  mean R/G/B %8.1f %8.1f %8.1f   min %6.0f %6.0f %6.0f   max %6.0f %6.0f %6.0f\n",
                side, mean[2], mean[1], mean[0], lo[2], lo[1], lo[0], hi[2], hi[1], hi[0]);
}

}  // namespace

int main(int argc, char** argv) {
    po::options_description options("avatar-info: print an AVATAR configuration and a stereo pair");
    options.add_options()
        ("help,h", "show this help")
        ("config,c", po::value<std::string>(), "AVATAR XML configuration file")
        ("left,l", po::value<std::string>(), "left image: raw file named as in docs/formats.md, or a .png/.tif")
        ("right,r", po::value<std::string>(), "right image, same kind as --left")
        ("log", po::value<std::string>()->default_value("warn"), "log priority: debug, info, notice, warn, error");
    po::variables_map vm;
    try {
        po::store(po::parse_command_line(argc, argv, options), vm);
        po::notify(vm);
    } catch (const po::error& e) {
        std::cerr << "avatar-info: " << e.what() << "\n" << options;
        return 2;
    }
    if (vm.count("help") || (!vm.count("config") && !vm.count("left"))) {
        std::cout << options;
        return vm.count("help") ? 0 : 2;
    }
    if (vm.count("left") != vm.count("right")) {
        std::cerr << "avatar-info: --left and --right go together\n";
        return 2;
    }
    try {
        logging::configure(logging::parsePriority(vm["log"].as<std::string>()));
        std::optional<AvatarConfig> config;
        if (vm.count("config")) {
            config = readConfigFile(vm["config"].as<std::string>());
            std::cout << "config " << vm["config"].as<std::string>() << "\n";
            printConfig(*config, std::cout);
        }
        if (vm.count("left")) {
            const std::filesystem::path left = vm["left"].as<std::string>();
            const std::filesystem::path right = vm["right"].as<std::string>();
            StereoImagePair pair;
            std::optional<RawImageName> ln, rn;
            try {
                ln = RawImageName::parse(left.filename().string());
                rn = RawImageName::parse(right.filename().string());
            } catch (const FormatError&) {
                if (left.extension() == ".raw") throw;  // a raw file is unreadable without its name
                ln.reset();
            }
            if (ln && rn) {
                // Files named as in docs/formats.md: the name gives the geometry.
                PairLayout layout{ln->geometry.format, ln->geometry.bayerPattern, ln->geometry.bitDepth};
                auto read = [](const std::filesystem::path& p) {
                    return p.extension() == ".raw" ? StereoImagePairFileIO::readRaw(p)
                                                   : StereoImagePairFileIO::readLossless(p);
                };
                pair = StereoImagePair(read(left), read(right), layout, {ln->group, ln->member, {}, {}});
                if (rn->group != ln->group || rn->member != ln->member)
                    std::cerr << "avatar-info: warning: left is group/member " << ln->group << "/"
                              << ln->member << ", right is " << rn->group << "/" << rn->member << "\n";
            } else {
                if (!config) {
                    std::cerr << "avatar-info: a .png/.tif pair needs --config to say what the pixels are\n";
                    return 2;
                }
                const auto& cam = config->camera;
                PairLayout layout{cam.channels == 3 ? PixelFormat::Bgr
                                                    : (cam.bayer ? PixelFormat::Bayer : PixelFormat::Mono),
                                  cam.bayerPattern, cam.bitDepth};
                pair = StereoImagePairFileIO::readLossless(left, right, layout);
            }
            std::cout << "pair     " << pair.describe() << "\n";
            StereoImagePair rgb = pair.layout().format == PixelFormat::Bayer ? demosaic(pair) : pair;
            printImage("left", rgb.left());
            printImage("right", rgb.right());
        }
    } catch (const Error& e) {
        std::cerr << "avatar-info: " << e.what() << "\n";
        return 1;
    }
    return 0;
}
