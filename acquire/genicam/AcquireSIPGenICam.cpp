#include <avatar/acquire/AcquireSIPGenICam.h>

#include "AcquireSIPGenICamDevice.h"

#include <avatar/common/Logging.h>

#include <log4cpp/Category.hh>

#include <algorithm>
#include <array>
#include <cstdlib>
#include <mutex>
#include <thread>

namespace avatar {

using genicam::Camera;
using genicam::CameraRequest;
using genicam::DeviceInfo;
using genicam::Geometry;
using genicam::HeldBuffer;
using genicam::PopResult;

namespace {

log4cpp::Category& logger() { return logging::category("acquire"); }

constexpr std::array<Side, 2> kSides{Side::Left, Side::Right};

int index(Side side) { return side == Side::Left ? 0 : 1; }
const char* sideName(Side side) { return side == Side::Left ? "left" : "right"; }

const std::string& configuredId(const CameraHardwareConfig& hw, Side side) {
    return side == Side::Left ? hw.leftCameraId : hw.rightCameraId;
}

std::string ms(std::chrono::microseconds us) {
    const long long tenths = static_cast<long long>(us.count()) / 100;
    return std::to_string(tenths / 10) + "." + std::to_string(std::llabs(tenths % 10)) + " ms";
}

const std::vector<std::string>& knownFeatures() {
    static const std::vector<std::string> names{"exposure", "gain", "whiteBalance", "brightness", "gamma", "frameRate"};
    return names;
}

/// InvalidArgument unless the camera part of @p hw is usable by this backend.
void checkHardware(const CameraHardwareConfig& hw) {
    for (Side side : kSides) {
        if (configuredId(hw, side).empty())
            throw InvalidArgument(std::string("camera/") + sideName(side) +
                                  "CameraId is empty: the GenICam backend needs an Aravis device id, serial number, "
                                  "MAC or IP address");
    }
    if (hw.leftCameraId == hw.rightCameraId)
        throw InvalidArgument("camera/leftCameraId and camera/rightCameraId are both \"" + hw.leftCameraId +
                              "\": the left and right camera must be different cameras");
    genicamPixelFormatCandidates(hw);  // throws for a layout no GenICam format carries
}

}  // namespace

// ---------------------------------------------------------------- options, formats

std::string GenICamOptions::validate() const {
    std::vector<std::string> problems;
    if (frameTimeout.count() <= 0) problems.push_back("frameTimeout: must be positive");
    if (pairTolerance.count() < 0) problems.push_back("pairTolerance: must not be negative");
    if (pairTimeout.count() <= 0) problems.push_back("pairTimeout: must be positive");
    if (bufferCount < 2 || bufferCount > 64)
        problems.push_back("bufferCount: " + std::to_string(bufferCount) + " outside 2..64");
    if (discoveryAttempts < 1 || discoveryAttempts > 20)
        problems.push_back("discoveryAttempts: " + std::to_string(discoveryAttempts) + " outside 1..20");
    if (discoverySettle.count() < 0) problems.push_back("discoverySettle: must not be negative");
    if (reconnectAttempts < 1 || reconnectAttempts > 1000)
        problems.push_back("reconnectAttempts: " + std::to_string(reconnectAttempts) + " outside 1..1000");
    if (frameRateHz && !(*frameRateHz > 0.0)) problems.push_back("frameRateHz: must be positive");
    for (const auto& f : requiredFeatures) {
        if (std::find(knownFeatures().begin(), knownFeatures().end(), f) == knownFeatures().end())
            problems.push_back("requiredFeatures: \"" + f +
                               "\" is not one of exposure, gain, whiteBalance, brightness, gamma, frameRate");
    }
    std::string out;
    for (const auto& p : problems) out += (out.empty() ? "" : "; ") + p;
    return out;
}

std::vector<std::string> genicamPixelFormatCandidates(const CameraHardwareConfig& camera) {
    const std::string depth = std::to_string(camera.bitDepth);
    if (camera.channels == 3) {
        if (camera.bitDepth != 8)
            throw InvalidArgument("camera/bitDepth " + depth +
                                  ": colour (3-channel) GenICam images are taken as BGR8/RGB8, so bitDepth must be 8");
        return {"BGR8", "RGB8", "BGR8Packed", "RGB8Packed"};
    }
    if (camera.channels != 1)
        throw InvalidArgument("camera/channels " + std::to_string(camera.channels) + ": must be 1 or 3");
    static const int depths[] = {8, 10, 12, 14, 16};
    if (std::find(std::begin(depths), std::end(depths), camera.bitDepth) == std::end(depths))
        throw InvalidArgument("camera/bitDepth " + depth +
                              ": GenICam's unpacked pixel formats carry 8, 10, 12, 14 or 16 bits per sample");
    if (camera.bayer) return {"Bayer" + std::string(toString(camera.bayerPattern)) + depth};
    return {"Mono" + depth};
}

// ---------------------------------------------------------------- implementation

struct AcquireSIPGenICam::Impl {
    explicit Impl(GenICamOptions o) : options(std::move(o)), reporter(options.requiredFeatures) {}

    GenICamOptions options;
    genicam::FeatureReporter reporter;
    std::optional<CameraRequest> request;  // the settings in force
    std::array<std::unique_ptr<Camera>, 2> cameras;
    std::array<bool, 2> lost{false, false};
    int failedAttempts{0};
    GenICamStatistics stats;
    bool shutterNoted{false};

    mutable std::mutex statusMutex;  // status() may be asked from another thread
    AcquisitionStatus current;

    void setStatus(AcquisitionStatus::State state, std::string message) {
        std::lock_guard<std::mutex> lock(statusMutex);
        current.state = state;
        current.message = std::move(message);
    }
    AcquisitionStatus::State state() const {
        std::lock_guard<std::mutex> lock(statusMutex);
        return current.state;
    }

    CameraRequest makeRequest(const CameraHardwareConfig& hw) const { return CameraRequest{hw, options.frameRateHz}; }

    /// Discovery passes until every id in @p wanted is found or the attempts
    /// run out; returns the last pass.
    std::vector<DeviceInfo> discover(const std::vector<std::string>& wanted, int attempts) const {
        std::vector<DeviceInfo> devices;
        for (int attempt = 1; attempt <= attempts; ++attempt) {
            devices = genicam::discoverDevices();
            const bool all = std::all_of(wanted.begin(), wanted.end(),
                                         [&](const std::string& id) { return genicam::findDevice(devices, id).has_value(); });
            if (all) break;
            logger().info("GenICam discovery %d of %d found %s", attempt, attempts,
                          genicam::describeDevices(devices).c_str());
            if (attempt < attempts) std::this_thread::sleep_for(options.discoverySettle);
        }
        return devices;
    }

    /// Opens, configures and starts one camera.
    std::unique_ptr<Camera> openOne(Side side, const DeviceInfo& device, const CameraRequest& r) {
        auto camera = std::make_unique<Camera>(side, device);
        const Geometry g = camera->plan(r);
        camera->applyGeometry(g);
        camera->applyFeatures(r, reporter);
        camera->start(options.bufferCount);
        return camera;
    }

    void noteShutter(const CameraHardwareConfig& hw) {
        if (shutterNoted) return;
        shutterNoted = true;
        logger().info("GenICam: <shutter> (%g) is an IIDC register with no GenICam counterpart and is not used; "
                      "<exposure> sets ExposureTime in microseconds",
                      hw.features.shutter.value);
    }

    /// Closes whatever is open and opens both cameras for @p r.
    void openAll(const CameraRequest& r) {
        const CameraHardwareConfig& hw = r.hardware;
        for (auto& c : cameras) c.reset();
        const std::vector<DeviceInfo> devices =
            discover({hw.leftCameraId, hw.rightCameraId}, options.discoveryAttempts);
        std::array<DeviceInfo, 2> found;
        std::string missing;
        for (Side side : kSides) {
            auto d = genicam::findDevice(devices, configuredId(hw, side));
            if (d)
                found[static_cast<size_t>(index(side))] = *d;
            else
                missing += std::string(missing.empty() ? "" : "; ") + sideName(side) + " camera \"" +
                           configuredId(hw, side) + "\" not found";
        }
        if (!missing.empty())
            throw AcquisitionError(missing + " after " + std::to_string(options.discoveryAttempts) +
                                   " discovery passes; cameras found: " + genicam::describeDevices(devices));
        if (found[0].id == found[1].id)
            throw InvalidArgument("camera/leftCameraId \"" + hw.leftCameraId + "\" and camera/rightCameraId \"" +
                                  hw.rightCameraId + "\" name the same camera " + found[0].describe());
        std::array<std::unique_ptr<Camera>, 2> opened;
        for (Side side : kSides) {
            const size_t i = static_cast<size_t>(index(side));
            opened[i] = std::make_unique<Camera>(side, found[i]);
        }
        // Check both before changing either.
        std::array<Geometry, 2> plans{opened[0]->plan(r), opened[1]->plan(r)};
        for (size_t i = 0; i < 2; ++i) {
            opened[i]->applyGeometry(plans[i]);
            opened[i]->applyFeatures(r, reporter);
        }
        for (auto& c : opened) c->start(options.bufferCount);
        cameras = std::move(opened);
        lost = {false, false};
        failedAttempts = 0;
        request = r;
        noteShutter(hw);
        setStatus(AcquisitionStatus::State::Ok, "");
    }

    bool healthy() const {
        return cameras[0] && cameras[1] && !lost[0] && !lost[1] && state() == AcquisitionStatus::State::Ok;
    }

    void configure(const CameraHardwareConfig& hw) {
        checkHardware(hw);
        const CameraRequest r = makeRequest(hw);
        if (!request) {
            openAll(r);  // first start: failures go to the caller (the constructor)
            return;
        }
        if (!healthy()) {
            // Re-opening after a loss or Failed: everything anew.
            try {
                openAll(r);
            } catch (const std::exception& e) {
                lost = {true, true};  // openAll closed them; grab() keeps trying with the old settings
                const bool failed = state() == AcquisitionStatus::State::Failed;
                const std::string message = std::string("re-opening the cameras failed: ") + e.what();
                logger().error("GenICam: %s", message.c_str());
                setStatus(failed ? AcquisitionStatus::State::Failed : AcquisitionStatus::State::Recovering,
                          message);
                throw;
            }
            return;
        }
        const bool sameCameras =
            hw.leftCameraId == request->hardware.leftCameraId && hw.rightCameraId == request->hardware.rightCameraId;
        if (!sameCameras) {
            const CameraRequest old = *request;
            try {
                openAll(r);
            } catch (...) {
                try {
                    openAll(old);
                } catch (const std::exception& e) {
                    markLostAfterFailedRestore(e.what());
                }
                throw;
            }
            return;
        }
        // Same cameras: check everything first, then change what changed.
        std::array<Geometry, 2> plans{cameras[0]->plan(r), cameras[1]->plan(r)};
        const bool restart = plans[0] != cameras[0]->geometry() || plans[1] != cameras[1]->geometry();
        const CameraRequest old = *request;
        try {
            if (restart) {
                for (auto& c : cameras) c->stop();
                for (size_t i = 0; i < 2; ++i) cameras[i]->applyGeometry(plans[i]);
            }
            for (auto& c : cameras) c->applyFeatures(r, reporter);
            if (restart)
                for (auto& c : cameras) c->start(options.bufferCount);
        } catch (...) {
            try {
                std::array<Geometry, 2> oldPlans{cameras[0]->plan(old), cameras[1]->plan(old)};
                if (restart) {
                    for (auto& c : cameras) c->stop();
                    for (size_t i = 0; i < 2; ++i) cameras[i]->applyGeometry(oldPlans[i]);
                }
                for (auto& c : cameras) c->applyFeatures(old, reporter);
                if (restart)
                    for (auto& c : cameras) c->start(options.bufferCount);
            } catch (const std::exception& e) {
                markLostAfterFailedRestore(e.what());
            }
            throw;
        }
        request = r;
        noteShutter(hw);
        logger().info("GenICam: configuration applied%s", restart ? " (streams restarted)" : "");
    }

    void markLostAfterFailedRestore(const std::string& why) {
        const std::string message = "could not restore the previous camera settings: " + why;
        logger().error("GenICam: %s", message.c_str());
        for (Side side : kSides) lost[static_cast<size_t>(index(side))] = true;
        failedAttempts = 0;
        setStatus(AcquisitionStatus::State::Recovering, message);
    }

    [[noreturn]] void loseCamera(Side side, const PopResult& r) {
        const size_t i = static_cast<size_t>(index(side));
        Camera& camera = *cameras[i];
        camera.abandon();
        std::string message = camera.label() + " delivered no complete frame within " +
                              std::to_string(options.frameTimeout.count()) + " ms";
        if (r.incomplete > 0)
            message += " (" + std::to_string(r.incomplete) + " incomplete, the last: " + r.lastIncomplete + ")";
        if (camera.controlLost()) message += "; its control channel is lost";
        lost[i] = true;
        failedAttempts = 0;
        ++stats.cameraLosses;
        logger().error("GenICam: %s; recovering", message.c_str());
        setStatus(AcquisitionStatus::State::Recovering, message);
        throw AcquisitionError(message);
    }

    /// One reconnection attempt for every lost camera; throws when it fails.
    void reconnect() {
        const CameraHardwareConfig& hw = request->hardware;
        std::vector<std::string> wanted;
        for (Side side : kSides) {
            const size_t i = static_cast<size_t>(index(side));
            if (!cameras[i]) lost[i] = true;
            if (!lost[i]) continue;
            cameras[i].reset();  // releases the dead device (and its stream)
            wanted.push_back(configuredId(hw, side));
        }
        ++failedAttempts;  // undone on success
        const std::string attempt =
            "reconnection attempt " + std::to_string(failedAttempts) + " of " + std::to_string(options.reconnectAttempts);
        try {
            const std::vector<DeviceInfo> devices = discover(wanted, 1);
            for (Side side : kSides) {
                const size_t i = static_cast<size_t>(index(side));
                if (!lost[i]) continue;
                const std::string& id = configuredId(hw, side);
                auto d = genicam::findDevice(devices, id);
                if (!d)
                    throw AcquisitionError(std::string(sideName(side)) + " camera \"" + id +
                                           "\" not found; cameras found: " + genicam::describeDevices(devices));
                const size_t other = 1 - i;
                if (cameras[other] && cameras[other]->device().id == d->id)
                    throw AcquisitionError(std::string(sideName(side)) + " camera \"" + id +
                                           "\" is the camera already open as the other side");
                cameras[i] = openOne(side, *d, *request);
                lost[i] = false;
                ++stats.reconnections;
                logger().notice("GenICam: %s is back (%s)", cameras[i]->label().c_str(), attempt.c_str());
            }
        } catch (const std::exception& e) {
            std::string message = std::string(e.what()) + " (" + attempt + ")";
            if (failedAttempts >= options.reconnectAttempts) {
                message = "gave up after " + std::to_string(failedAttempts) +
                          " reconnection attempts: " + e.what() + "; applyConfig() opens the cameras again";
                logger().error("GenICam: %s", message.c_str());
                setStatus(AcquisitionStatus::State::Failed, message);
            } else {
                logger().warn("GenICam: %s", message.c_str());
                setStatus(AcquisitionStatus::State::Recovering, message);
            }
            throw AcquisitionError(message);
        }
        failedAttempts = 0;
        setStatus(AcquisitionStatus::State::Ok, "");
    }

    HeldBuffer next(Side side) {
        const size_t i = static_cast<size_t>(index(side));
        PopResult r = cameras[i]->pop(options.frameTimeout);
        stats.incompleteFrames[i] += r.incomplete;
        if (!r.buffer) loseCamera(side, r);
        return std::move(r.buffer);
    }

    AcquiredPair grab() {
        {
            std::lock_guard<std::mutex> lock(statusMutex);
            if (current.state == AcquisitionStatus::State::Failed)
                throw AcquisitionError("GenICam acquisition failed: " + current.message);
        }
        if (!request) throw AcquisitionError("GenICam acquisition is not configured");
        if (lost[0] || lost[1] || !cameras[0] || !cameras[1]) reconnect();

        // Frames that waited in the pool are stale: start from the next ones.
        for (Side side : kSides) cameras[static_cast<size_t>(index(side))]->flush(stats.incompleteFrames[index(side)]);

        const auto deadline = std::chrono::steady_clock::now() + options.pairTimeout;
        HeldBuffer left = next(Side::Left);
        HeldBuffer right = next(Side::Right);
        for (;;) {
            const std::chrono::microseconds diff{left.systemTimestampUs() - right.systemTimestampUs()};
            if (std::chrono::abs(diff) <= options.pairTolerance) break;
            if (std::chrono::steady_clock::now() > deadline)
                throw AcquisitionError("left camera " + cameras[0]->device().id + " and right camera " +
                                       cameras[1]->device().id + " frames never came within " +
                                       ms(options.pairTolerance) + " of each other in " +
                                       std::to_string(options.pairTimeout.count()) + " ms (last difference " +
                                       ms(diff) + "); are both running at the same frame rate?");
            // Drop the older frame and take the next one from that camera.
            if (diff.count() < 0) {
                ++stats.unmatchedFrames[0];
                left = next(Side::Left);
            } else {
                ++stats.unmatchedFrames[1];
                right = next(Side::Right);
            }
        }

        const CameraHardwareConfig& hw = request->hardware;
        cv::Mat l = cameras[0]->copyImage(left, hw.endianSwap);
        cv::Mat r = cameras[1]->copyImage(right, hw.endianSwap);
        AcquisitionId id;
        id.left = CameraStamp{hw.leftCameraId, left.systemTimestampUs()};
        id.right = CameraStamp{hw.rightCameraId, right.systemTimestampUs()};
        left.release();
        right.release();
        PairLayout layout;
        layout.format = hw.channels == 3 ? PixelFormat::Bgr : hw.bayer ? PixelFormat::Bayer : PixelFormat::Mono;
        layout.bayerPattern = hw.bayerPattern;
        layout.bitDepth = hw.bitDepth;
        AcquiredPair out;
        out.pair = StereoImagePair(std::move(l), std::move(r), layout, id);
        ++stats.pairs;
        return out;
    }
};

// ---------------------------------------------------------------- public class

AcquireSIPGenICam::AcquireSIPGenICam(const AvatarConfig& config, GenICamOptions options, std::uint32_t groupSize)
    : AcquireStereoImagePair(groupSize) {
    const std::string problems = options.validate();
    if (!problems.empty()) throw InvalidArgument("GenICam options: " + problems);
    impl_ = std::make_unique<Impl>(std::move(options));
    impl_->configure(config.camera);
}

AcquireSIPGenICam::~AcquireSIPGenICam() = default;

AcquisitionStatus AcquireSIPGenICam::status() const {
    std::lock_guard<std::mutex> lock(impl_->statusMutex);
    return impl_->current;
}

GenICamStatistics AcquireSIPGenICam::statistics() const { return impl_->stats; }

GenICamReadback AcquireSIPGenICam::readBack(Side side) const {
    const size_t i = static_cast<size_t>(index(side));
    if (!impl_->cameras[i] || impl_->lost[i])
        throw AcquisitionError(std::string(sideName(side)) + " camera is not open (lost or not configured)");
    return impl_->cameras[i]->readBack();
}

std::vector<std::string> AcquireSIPGenICam::listDevices() {
    std::vector<std::string> out;
    for (const auto& d : genicam::discoverDevices()) out.push_back(d.describe());
    return out;
}

std::array<CameraFeatureReadback, 2> AcquireSIPGenICam::readFeatures() const {
    std::array<CameraFeatureReadback, 2> out;
    for (Side side : kSides) {
        const size_t i = static_cast<size_t>(index(side));
        if (!impl_->cameras[i] || impl_->lost[i] || !impl_->request)
            throw AcquisitionError(std::string(sideName(side)) + " camera is not open (lost or not configured)");
        out[i] = impl_->cameras[i]->readFeatures();
        out[i].cameraId = configuredId(impl_->request->hardware, side);
    }
    return out;
}

BackendSurvey AcquireSIPGenICam::survey() {
    BackendSurvey s;
    s.backend = "genicam";
    std::string interfaces;
    const unsigned n = arv_get_n_interfaces();
    for (unsigned i = 0; i < n; ++i) {
        const char* id = arv_get_interface_id(i);
        if (id != nullptr) interfaces += std::string(interfaces.empty() ? "" : ", ") + id;
    }
    s.checks.push_back({"Aravis",
                        true,
                        "library " + std::to_string(arv_get_major_version()) + "." +
                            std::to_string(arv_get_minor_version()) + "." + std::to_string(arv_get_micro_version()) +
                            ", interfaces: " +
                            (interfaces.empty() ? std::string("none") : interfaces)});
    const std::vector<DeviceInfo> devices = genicam::discoverDevices();
    BackendCheck discovery{"Aravis discovery", !devices.empty(), ""};
    if (devices.empty())
        discovery.detail =
            "no GenICam camera answered: check power and cable; GigE Vision cameras must be on a subnet of one of "
            "this host's interfaces, with UDP port 3956 open in the firewall; USB3 Vision cameras need read/write "
            "access to their /dev/bus/usb node (a udev rule)";
    else
        discovery.detail = std::to_string(devices.size()) + " camera(s): " + genicam::describeDevices(devices);
    s.checks.push_back(discovery);
    for (const DeviceInfo& d : devices) {
        CameraListing c;
        c.id = d.id;
        c.address = d.address;
        std::string vendor = d.vendor;
        std::string model = d.model;
        const std::string problem = genicam::probeDevice(d, vendor, model);
        c.model = vendor.empty() ? model : model.empty() ? vendor : vendor + " " + model;
        c.reachable = problem.empty();
        c.detail = d.protocol + (d.serial.empty() ? "" : ", serial " + d.serial) +
                   (d.physicalId.empty() ? "" : ", " + d.physicalId);
        if (!c.reachable) c.detail += "; cannot be opened: " + problem;
        s.cameras.push_back(std::move(c));
        if (!problem.empty())
            s.checks.push_back({d.id, false, "found by discovery but cannot be opened (another program may control "
                                             "it, or it is on another subnet): " + problem});
    }
    return s;
}

AcquiredPair AcquireSIPGenICam::grab() { return impl_->grab(); }

void AcquireSIPGenICam::configure(const AvatarConfig& config) { impl_->configure(config.camera); }

}  // namespace avatar
