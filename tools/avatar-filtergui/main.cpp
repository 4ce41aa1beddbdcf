// avatar-filtergui: tune a target type's colour filter and minimum area on
// one image, with a slider per range, the live filtered view and the located
// features (thesis 4.5.1). Runs headless too (render to a file, save without
// a key press). User guide: docs/tools/avatar-filtergui.md

#include "FilterGui.h"
#include "ToolDisplay.h"
#include "ToolImages.h"
#include "ToolMain.h"

#include <avatar/common/Error.h>
#include <avatar/common/StereoImagePairFileIO.h>
#include <avatar/config/ConfigXml.h>

#include <boost/program_options.hpp>
#include <log4cpp/Category.hh>
#include <opencv2/highgui.hpp>

#include <chrono>
#include <cstdlib>
#include <iostream>
#include <memory>
#include <optional>
#include <string>
#include <vector>

namespace po = boost::program_options;
namespace fs = std::filesystem;
using namespace avatar;

namespace {

/// Throws avatar::InvalidState unless the X display of $DISPLAY can be
/// reached. HighGUI's Qt backend aborts the process when it cannot connect,
/// so a local display (":N") is tried first (ToolDisplay.h); any other form
/// (a remote or forwarded one) and a non-X11 Qt platform (QT_QPA_PLATFORM)
/// are left to Qt.
void requireDisplay() {
    const char* platform = std::getenv("QT_QPA_PLATFORM");
    if (platform && *platform && std::string(platform).rfind("xcb", 0) != 0) return;  // not X11: Qt's own business
    const char* env = std::getenv("DISPLAY");
    const std::string display = env ? env : "";
    if (display.empty())
        throw InvalidState("no display: DISPLAY is not set (use --headless --render OUT.png to work without a window)");
    if (const std::optional<std::string> socketPath = tools::unreachableLocalDisplay(display))
        throw InvalidState("cannot reach the display DISPLAY=" + display + " (no X server at " + *socketPath +
                           "; use --headless --render OUT.png to work without a window)");
}

/// The window's state; HighGUI's callbacks reach it through their userdata.
class Tuner {
public:
    Tuner(const tools::WorkingImage& image, const AvatarConfig& config, TargetType type, double scale,
          fs::path source, fs::path destination)
        : image_(image), config_(config), initial_(type), type_(std::move(type)), scale_(scale),
          source_(std::move(source)), destination_(std::move(destination)),
          sliders_(filtergui::slidersFor(type_)), positions_(sliders_.size(), -1) {
        keys_ = "s: save to " + destination_.string() + "   r: reset   q/Esc: quit";
        message_ = keys_;
    }

    /// Opens the window with its sliders and runs until q, Esc, the window
    /// is closed or @p exitAfterMs has passed since the first draw.
    void run(std::optional<int> exitAfterMs) {
        requireDisplay();
        window_ = "avatar-filtergui: " + type_.name;
        cv::namedWindow(window_, cv::WINDOW_AUTOSIZE | cv::WINDOW_GUI_NORMAL);
        bindings_.reserve(sliders_.size());
        for (std::size_t i = 0; i < sliders_.size(); ++i) bindings_.push_back({this, i});
        for (std::size_t i = 0; i < sliders_.size(); ++i) {
            cv::createTrackbar(sliders_[i].label, window_, nullptr, sliders_[i].count, &Tuner::onTrackbar, &bindings_[i]);
        }
        syncAll();
        using Clock = std::chrono::steady_clock;
        std::optional<Clock::time_point> firstDraw;
        for (;;) {
            if (dirty_) redraw();
            const int key = cv::waitKey(30);
            if (!firstDraw) {
                firstDraw = Clock::now();
                std::cout << "avatar-filtergui: window shown" << std::endl;
            }
            if (exitAfterMs && Clock::now() - *firstDraw >= std::chrono::milliseconds(*exitAfterMs)) break;
            if (key >= 0) {
                const int k = key & 0xFF;
                if (k == 'q' || k == 27) break;
                if (k == 's') save();
                if (k == 'r') reset();
            }
            syncPartners();
            if (cv::getWindowProperty(window_, cv::WND_PROP_VISIBLE) == 0.0) break;  // closed by the user
        }
        cv::destroyWindow(window_);
    }

    /// Saves the current type; the outcome goes to the status line and stdout.
    void save() {
        try {
            const bool replaced = filtergui::saveType(type_, source_, destination_);
            message_ = "saved '" + type_.name + "' to " + destination_.string() + (replaced ? "" : " (added)") +
                       "   " + keys_;
            std::cout << (replaced ? "replaced" : "added") << " target type '" << type_.name << "' in "
                      << destination_.string() << "\n";
        } catch (const Error& e) {
            message_ = std::string("save failed: ") + e.what();
            std::cerr << "avatar-filtergui: " << e.what() << "\n";
        }
        dirty_ = true;
    }

private:
    struct Binding {
        Tuner* tuner;
        std::size_t index;
    };

    static void onTrackbar(int position, void* userdata) {
        const Binding& b = *static_cast<const Binding*>(userdata);
        b.tuner->moved(b.index, position);
    }

    void moved(std::size_t i, int position) {
        if (position == positions_[i]) return;  // set by syncAll / syncPartner, or unchanged
        positions_[i] = position;
        filtergui::applySlider(type_, sliders_[i], position, image_.bitDepth);
        moved_.push_back(i);
        dirty_ = true;
    }

    /// The other end of a moved slider's range follows when it was pushed.
    void syncPartners() {
        const std::vector<std::size_t> moved = std::move(moved_);
        moved_.clear();
        for (const std::size_t i : moved)
            for (std::size_t j = 0; j < sliders_.size(); ++j)
                if (j != i && sliders_[j].quantity == sliders_[i].quantity) setPosition(j);
    }

    void syncAll() {
        for (std::size_t j = 0; j < sliders_.size(); ++j) setPosition(j);
    }

    void setPosition(std::size_t j) {
        const int p = filtergui::sliderPosition(sliders_[j], type_, image_.bitDepth);
        if (p == positions_[j]) return;
        positions_[j] = p;
        cv::setTrackbarPos(sliders_[j].label, window_, p);
    }

    void reset() {
        type_ = initial_;
        syncAll();
        message_ = "reset to the starting ranges   " + keys_;
        dirty_ = true;
    }

    void redraw() {
        dirty_ = false;
        try {
            const filtergui::Analysis a = filtergui::analyse(image_, type_, config_.analysis);
            cv::imshow(window_, filtergui::renderView(image_, type_, a, scale_, message_));
        } catch (const Error& e) {
            std::cerr << "avatar-filtergui: " << e.what() << "\n";
        }
    }

    const tools::WorkingImage& image_;
    const AvatarConfig& config_;
    const TargetType initial_;
    TargetType type_;
    double scale_;
    fs::path source_, destination_;
    std::vector<filtergui::Slider> sliders_;
    std::vector<int> positions_;
    std::vector<Binding> bindings_;
    std::string window_, keys_, message_;
    std::vector<std::size_t> moved_;  ///< sliders moved since the last sync
    bool dirty_{true};
};

/// The slider scales, for --help.
constexpr const char* kSliderScales =
    "Slider scales: ratios 0, 0.01..100 on a log scale (100 steps a decade), open; brightness in\n"
    "1/1000 of 3 x full scale; hue in degrees; saturation and value in 0.01; area 0, 1..1e6 px\n"
    "on a log scale. The status line below the view gives the exact values.\n";

const TargetType& findType(const AvatarConfig& config, const std::string& name, const std::string& file) {
    std::string names;
    for (const TargetType& t : config.targets.targets) {
        if (t.name == name) return t;
        names += (names.empty() ? "" : ", ") + t.name;
    }
    throw InvalidArgument("configuration " + file + " has no target type '" + name + "' (it has " + names + ")");
}

}  // namespace

int main(int argc, char** argv) {
    po::options_description options(
        "avatar-filtergui: tune a target type's colour filter and minimum area on one image\n"
        "Usage: avatar-filtergui --image IMG --config CONFIG.xml --target NAME [--set rg.min=1.2 ...]\n"
        "       avatar-filtergui ... --headless --render VIEW.png [--save] [--save-to OUT.xml]\n"
        "Window keys: s save the type into the configuration, r reset, q or Esc quit.\n\nOptions");
    // clang-format off
    options.add_options()
        ("help,h", "show this help");
    tools::addImageOptions(options, "the image: raw (docs/formats.md), 8/16-bit PNG or TIFF, or any 8-bit image file");
    options.add_options()
        ("config", po::value<std::string>(), "the configuration: its lighting correction, analysis options and the target type")
        ("target", po::value<std::string>(), "the target type to tune (its ranges are the starting point)")
        ("set", po::value<std::vector<std::string>>()->composing(),
         "change a range at the start, e.g. rg.min=1.2, area.min=50, hue.max=20, brightness=off (repeatable)")
        ("save-to", po::value<std::string>(), "save into this configuration (if it exists; else a copy of --config) instead of --config")
        ("save", "save the type (after --set) at once, without a key press")
        ("render", po::value<std::string>(), "write the view (after --set) to this PNG or TIFF file")
        ("headless", "no window: only --render and --save")
        ("scale", po::value<double>(), "view scale (default: the image fits 1024x768)")
        ("exit-after-ms", po::value<int>(), "quit this many ms after the window's first draw (0: right after it)")
        ("log", po::value<std::string>()->default_value("warn"), "log priority");
    // clang-format on
    return tools::runTool("avatar-filtergui", tools::HelpHint::Short, [&] {
        const po::variables_map vm = tools::parseCommandLine(argc, argv, options);
        if (vm.count("help"))
            return tools::printHelp(options, std::string(kSliderScales) + "\n" + tools::kInputExitStatus);
        if (vm.count("image") + vm.count("session") != 1)
            throw tools::UsageError("give exactly one of --image and --session");
        if (!vm.count("config")) throw tools::UsageError("--config is required");
        if (!vm.count("target")) throw tools::UsageError("--target is required");
        if (vm.count("headless") && !vm.count("render") && !vm.count("save"))
            throw tools::UsageError("nothing to do without a window: give --render or --save with --headless");
        if (vm.count("headless") && vm.count("exit-after-ms"))
            throw tools::UsageError("--exit-after-ms needs the window (drop --headless)");
        if (vm.count("scale") && !(vm["scale"].as<double>() > 0.0 && vm["scale"].as<double>() <= 4.0))
            throw tools::UsageError("--scale must be above 0 and at most 4");
        if (vm.count("exit-after-ms") && vm["exit-after-ms"].as<int>() < 0)
            throw tools::UsageError("--exit-after-ms must be >= 0");
        if (vm.count("render")) {
            const std::string ext = fs::path(vm["render"].as<std::string>()).extension().string();
            if (ext != ".png" && ext != ".tif" && ext != ".tiff")
                throw tools::UsageError("--render writes the view losslessly: give a .png, .tif or .tiff file");
        }

        tools::configureLogging(vm);
        const fs::path configFile = vm["config"].as<std::string>();
        const AvatarConfig config = readConfigFile(configFile);
        TargetType type = findType(config, vm["target"].as<std::string>(), configFile.string());

        if (vm.count("session")) {  // here a --side other than left or right is a usage error
            const std::string side = vm["side"].as<std::string>();
            if (side != "left" && side != "right")
                throw tools::UsageError("--side must be left or right, got '" + side + "'");
        }
        tools::WorkingImage image = tools::imageFromOptions(vm, tools::kForColourFilter);
        tools::correctLighting(image, config, configFile.parent_path());

        if (vm.count("set")) {
            try {
                for (const std::string& a : vm["set"].as<std::vector<std::string>>())
                    filtergui::applyAssignment(type, a, image.bitDepth);
                validateTargetType(type);
            } catch (const ConfigError& e) {
                throw tools::UsageError(std::string("the ranges after --set are not valid: ") + e.what());
            } catch (const Error& e) {
                throw tools::UsageError(e.what());
            }
        }
        const double scale = vm.count("scale") ? vm["scale"].as<double>() : filtergui::defaultScale(image.bgr.size());
        const fs::path destination = vm.count("save-to") ? fs::path(vm["save-to"].as<std::string>()) : configFile;

        if (vm.count("render")) {
            const filtergui::Analysis a = filtergui::analyse(image, type, config.analysis);
            const fs::path out = vm["render"].as<std::string>();
            StereoImagePairFileIO::writeLossless(out, filtergui::renderView(image, type, a, scale, ""));
            std::cout << filtergui::countsText(type, a) << "\n" << filtergui::rangesText(type) << "\n";
            for (const Feature& f : a.features)
                std::cout << "feature at (" << f.weightedCentroid.x << ", " << f.weightedCentroid.y << "), box "
                          << f.box.x << " " << f.box.y << " " << f.box.width << "x" << f.box.height << ", area "
                          << f.area << "\n";
        }
        if (vm.count("save")) {
            const bool replaced = filtergui::saveType(type, configFile, destination);
            std::cout << (replaced ? "replaced" : "added") << " target type '" << type.name << "' in "
                      << destination.string() << "\n";
        }
        if (!vm.count("headless")) {
            Tuner tuner(image, config, type, scale, configFile, destination);
            std::optional<int> exitAfter;
            if (vm.count("exit-after-ms")) exitAfter = vm["exit-after-ms"].as<int>();
            tuner.run(exitAfter);
        }
        return 0;
    });
}
