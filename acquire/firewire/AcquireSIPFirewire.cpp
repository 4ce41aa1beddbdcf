#include <avatar/acquire/AcquireSIPFirewire.h>

#include "AvatarCameras.h"
#include "FirewireBus.h"

#include <opencv2/core.hpp>

#include <algorithm>
#include <cctype>
#include <string>
#include <utility>
#include <vector>

#include <grp.h>
#include <pwd.h>
#include <sys/stat.h>
#include <unistd.h>

namespace avatar {

AcquireSIPFirewire::AcquireSIPFirewire(std::unique_ptr<FirewireBus> bus, FirewireOptions options,
                                       std::uint32_t groupSize, FirewireSleepFunction sleep)
    : AcquireStereoImagePair(groupSize),
      cameras_(std::make_unique<AvatarCameras>(std::move(bus), options, std::move(sleep))),
      zeroCopy_(options.zeroCopyViews) {}

AcquireSIPFirewire::~AcquireSIPFirewire() = default;

AcquisitionStatus AcquireSIPFirewire::status() const { return cameras_->status(); }

void AcquireSIPFirewire::configure(const AvatarConfig& config) { lastChange_ = cameras_->configure(config.camera); }

AcquiredPair AcquireSIPFirewire::grab() {
    const RawFramePair raw = cameras_->grabRawImagePair();
    const CameraHardwareConfig& camera = *cameras_->settings();

    PairLayout layout;
    layout.format = camera.channels == 3 ? PixelFormat::Bgr : camera.bayer ? PixelFormat::Bayer : PixelFormat::Mono;
    layout.bayerPattern = camera.bayerPattern;
    layout.bitDepth = camera.bitDepth;
    const int cvType = CV_MAKETYPE(camera.bitDepth <= 8 ? CV_8U : CV_16U, camera.channels);
    const cv::Size size(camera.width, camera.height);

    AcquisitionId id;
    id.left = {formatGuid(raw.leftGuid), raw.left.timestampUs};
    id.right = {formatGuid(raw.rightGuid), raw.right.timestampUs};

    AcquiredPair acquired;
    if (zeroCopy_ && camera.channels == 1 && raw.left.stride == raw.right.stride) {
        // Valid until the next grab gives the buffers back (see the header).
        acquired.pair = StereoImagePair::view(raw.left.data, raw.right.data, size, cvType, layout, raw.left.stride, id);
        return acquired;
    }
    const cv::Mat left(size, cvType, raw.left.data, raw.left.stride);
    const cv::Mat right(size, cvType, raw.right.data, raw.right.stride);
    cv::Mat leftCopy;
    cv::Mat rightCopy;
    if (camera.channels == 3) {
        // IIDC sends R, G, B; the pair holds B, G, R.
        leftCopy.create(size, cvType);
        rightCopy.create(size, cvType);
        const int fromTo[] = {0, 2, 1, 1, 2, 0};
        cv::mixChannels(&left, 1, &leftCopy, 1, fromTo, 3);
        cv::mixChannels(&right, 1, &rightCopy, 1, fromTo, 3);
    } else {
        leftCopy = left.clone();
        rightCopy = right.clone();
    }
    cameras_->releaseFrames();
    acquired.pair = StereoImagePair(std::move(leftCopy), std::move(rightCopy), layout, id);
    return acquired;
}

std::array<CameraFeatureReadback, 2> AcquireSIPFirewire::readFeatures() const { return cameras_->readFeatures(); }

namespace {

/// "crw-rw----" for @p mode.
std::string modeString(mode_t mode) {
    std::string m = S_ISCHR(mode) ? "c" : S_ISDIR(mode) ? "d" : S_ISREG(mode) ? "-" : "?";
    const char* letters = "rwxrwxrwx";
    for (int bit = 8; bit >= 0; --bit) m += (mode & (1u << bit)) != 0 ? letters[8 - bit] : '-';
    return m;
}

std::string userName(uid_t uid) {
    if (const passwd* p = ::getpwuid(uid)) return p->pw_name;
    return std::to_string(uid);
}

std::string groupName(gid_t gid) {
    if (const group* g = ::getgrgid(gid)) return g->gr_name;
    return std::to_string(gid);
}

/// The check of one device node: may this process read and write it?
BackendCheck checkNode(const std::filesystem::path& node) {
    BackendCheck c{node.string(), true, ""};
    struct stat st{};
    if (::stat(node.c_str(), &st) != 0) {
        c.ok = false;
        c.detail = "cannot be examined (it vanished?)";
        return c;
    }
    const std::string owner = modeString(st.st_mode) + " " + userName(st.st_uid) + ":" + groupName(st.st_gid);
    if (::access(node.c_str(), R_OK | W_OK) == 0) {
        c.detail = owner + ", readable and writable";
        return c;
    }
    c.ok = false;
    c.detail = owner + ": this user (" + userName(::geteuid()) +
               ") cannot read and write it, which libdc1394 needs: add the user to group '" + groupName(st.st_gid) +
               "' (usermod -aG " + groupName(st.st_gid) +
               " USER, then log in again) or install a udev rule that gives the group access";
    return c;
}

}  // namespace

BackendSurvey surveyFirewire(FirewireBus& bus, const std::filesystem::path& deviceDirectory) {
    BackendSurvey survey;
    survey.backend = "firewire";

    // The device nodes the kernel's firewire-core makes, one per node on the bus (the host adapter too).
    std::vector<std::filesystem::path> nodes;
    std::error_code ec;
    for (const auto& entry : std::filesystem::directory_iterator(deviceDirectory, ec)) {
        const std::string name = entry.path().filename().string();
        if (name.size() > 2 && name.compare(0, 2, "fw") == 0 &&
            std::all_of(name.begin() + 2, name.end(), [](unsigned char ch) { return std::isdigit(ch) != 0; }))
            nodes.push_back(entry.path());
    }
    std::sort(nodes.begin(), nodes.end());
    if (nodes.empty())
        survey.checks.push_back({(deviceDirectory / "fw*").string(), false,
                                 "no FireWire device nodes: there is no IEEE 1394 host adapter, or its kernel driver "
                                 "is not loaded (modprobe firewire-ohci; dmesg | grep -i firewire)"});
    for (const auto& node : nodes) survey.checks.push_back(checkNode(node));

    // What libdc1394 sees.
    const Enumeration e = bus.enumerate();
    BackendCheck library{bus.name(), e.status.isOk(), ""};
    if (!e.status.isOk()) {
        library.detail = std::string(toString(e.status.code())) + ": " + e.status.detail();
    } else {
        library.detail = "started; " + std::to_string(e.guids.size()) + " camera(s) on the bus";
    }
    survey.checks.push_back(library);
    if (e.status.isOk() && e.guids.empty())
        survey.checks.push_back({"cameras", false,
                                 "no camera on the bus: check the cable and the cameras' power; after plugging in, "
                                 "dmesg should show firewire_core creating a device fwN for each camera"});
    for (const FirewireGuid guid : e.guids) {
        CameraListing c;
        c.id = formatGuid(guid);
        c.model = bus.describe(guid);
        const OpenResult opened = bus.open(guid);
        c.reachable = opened.status.isOk() && opened.camera != nullptr;
        c.detail = "IIDC";
        if (!c.reachable) {
            c.detail += "; cannot be opened (" + std::string(toString(opened.status.code())) +
                        "): " + opened.status.detail();
            survey.checks.push_back({c.id, false, "on the bus but cannot be opened: " + opened.status.detail()});
        }
        survey.cameras.push_back(std::move(c));
    }
    return survey;
}

BackendSurvey surveyFirewire() {
    const std::unique_ptr<FirewireBus> bus = makeDc1394Bus();
    return surveyFirewire(*bus);
}

std::unique_ptr<AcquireSIPFirewire> makeFirewireAcquisition(FirewireOptions options, std::uint32_t groupSize) {
    return std::make_unique<AcquireSIPFirewire>(makeDc1394Bus(), options, groupSize);
}

}  // namespace avatar
