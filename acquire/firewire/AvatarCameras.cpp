#include "AvatarCameras.h"

#include <avatar/common/Logging.h>

#include <log4cpp/Category.hh>

#include <array>
#include <cmath>
#include <cstdlib>
#include <map>
#include <sstream>
#include <thread>
#include <utility>
#include <vector>

namespace avatar {
namespace {

log4cpp::Category& logger() {
    static log4cpp::Category& category = logging::category("acquire");
    return category;
}

std::string str(std::chrono::milliseconds d) { return std::to_string(d.count()) + " ms"; }

std::string str(double v) {
    std::ostringstream s;
    s << v;
    return s.str();
}

std::string listGuids(const std::vector<FirewireGuid>& guids) {
    if (guids.empty()) return "none";
    std::string text;
    for (const FirewireGuid g : guids) text += (text.empty() ? "" : ", ") + formatGuid(g);
    return text;
}

/// The single-valued features in the order they are written to a camera.
std::array<std::pair<FirewireFeature, const CameraFeature*>, 5> singleFeatures(const CameraFeatureSet& set) {
    return {{{FirewireFeature::Exposure, &set.exposure},
             {FirewireFeature::Shutter, &set.shutter},
             {FirewireFeature::Gain, &set.gain},
             {FirewireFeature::Brightness, &set.brightness},
             {FirewireFeature::Gamma, &set.gamma}}};
}

/// The single-valued feature whose config name is @p name ("gain").
FirewireFeature firewireFeatureNamed(const std::string& name) {
    for (const FirewireFeature f : {FirewireFeature::Exposure, FirewireFeature::Shutter, FirewireFeature::Gain,
                                    FirewireFeature::Brightness, FirewireFeature::Gamma})
        if (toString(f) == name) return f;
    throw InvalidArgument("'" + name + "' is not a single-valued FireWire feature");
}

/// IIDC feature values are 12-bit unsigned integers.
constexpr double kMaxFeatureValue = 4095.0;
bool isIidcValue(double v) { return std::isfinite(v) && v >= 0.0 && v <= kMaxFeatureValue && v == std::floor(v); }

FirewireGuid requireGuid(const std::string& id, const char* field, const char* side) {
    if (id.empty())
        throw InvalidArgument(std::string("FireWire needs camera.") + field + ", the GUID of the " + side +
                              " camera: the stereo calibration holds for one left/right assignment only");
    const std::optional<FirewireGuid> guid = parseGuid(id);
    if (!guid)
        throw InvalidArgument(std::string("camera.") + field + " '" + id +
                              "' is not an IIDC GUID (expected 0x and 1 to 16 hex digits, e.g. 0x00b09d01004a2c1f)");
    return *guid;
}

/// Why @p e does not give us the pair; empty when it does.
std::string problemWith(const Enumeration& e, FirewireGuid left, FirewireGuid right) {
    if (!e.status.isOk())
        return "enumeration failed (" + std::string(toString(e.status.code())) + "): " + e.status.detail();
    std::map<FirewireGuid, int> counts;
    for (const FirewireGuid g : e.guids) ++counts[g];
    const std::string found = "; found: " + listGuids(e.guids);
    for (const auto& [guid, n] : counts)
        if (n > 1)
            return "GUID " + formatGuid(guid) + " appears " + std::to_string(n) +
                   " times on the bus (a misrecognised camera)" + found;
    const bool hasLeft = counts.count(left) > 0;
    const bool hasRight = counts.count(right) > 0;
    if (!hasLeft && !hasRight)
        return AvatarCameras::describe(Side::Left, left) + " and " + AvatarCameras::describe(Side::Right, right) +
               " not found" + found;
    if (!hasLeft) return AvatarCameras::describe(Side::Left, left) + " not found" + found;
    if (!hasRight) return AvatarCameras::describe(Side::Right, right) + " not found" + found;
    return {};
}

}  // namespace

std::string FirewireOptions::validate() const {
    std::vector<std::string> problems;
    if (settleDelay.count() < 0) problems.push_back("settleDelay: must be >= 0 ms, got " + str(settleDelay));
    if (settleRetries < 0) problems.push_back("settleRetries: must be >= 0, got " + std::to_string(settleRetries));
    if (maxBusResets < 0) problems.push_back("maxBusResets: must be >= 0, got " + std::to_string(maxBusResets));
    if (dequeueTimeout.count() <= 0)
        problems.push_back("dequeueTimeout: must be > 0 ms, got " + str(dequeueTimeout));
    if (timestampTolerance.count() < 0)
        problems.push_back("timestampTolerance: must be >= 0 us, got " + std::to_string(timestampTolerance.count()) +
                           " us");
    if (maxResyncDrops < 0) problems.push_back("maxResyncDrops: must be >= 0, got " + std::to_string(maxResyncDrops));
    if (dmaBuffers < 1 || dmaBuffers > 64)
        problems.push_back("dmaBuffers: must be 1..64, got " + std::to_string(dmaBuffers));
    if (maxRecoveryAttempts < 0)
        problems.push_back("maxRecoveryAttempts: must be >= 0, got " + std::to_string(maxRecoveryAttempts));
    std::string text;
    for (const std::string& p : problems) text += (text.empty() ? "" : "; ") + p;
    return text;
}

std::string_view toString(CameraChange change) {
    switch (change) {
    case CameraChange::None: return "none";
    case CameraChange::Features: return "features";
    case CameraChange::Capture: return "capture";
    case CameraChange::Cameras: return "cameras";
    }
    return "unknown";
}

AvatarCameras::AvatarCameras(std::unique_ptr<FirewireBus> bus, FirewireOptions options, SleepFunction sleep)
    : bus_(std::move(bus)), options_(options), sleep_(std::move(sleep)) {
    if (!bus_) throw InvalidArgument("AvatarCameras: no FireWire bus given");
    const std::string problems = options_.validate();
    if (!problems.empty()) throw InvalidArgument("FireWire options: " + problems);
    if (!sleep_) sleep_ = [](std::chrono::milliseconds d) { std::this_thread::sleep_for(d); };
    left_.side = Side::Left;
    right_.side = Side::Right;
    status_ = {AcquisitionStatus::State::Failed, "FireWire cameras not started: no configuration applied yet"};
}

AvatarCameras::~AvatarCameras() { closeCameras(); }

std::string AvatarCameras::describe(Side side, FirewireGuid guid) {
    return std::string(side == Side::Left ? "left" : "right") + " camera " + formatGuid(guid);
}

void AvatarCameras::check(const CameraHardwareConfig& camera) {
    const FirewireGuid left = requireGuid(camera.leftCameraId, "leftCameraId", "left");
    const FirewireGuid right = requireGuid(camera.rightCameraId, "rightCameraId", "right");
    if (left == right)
        throw InvalidArgument("camera.leftCameraId and camera.rightCameraId name the same camera " +
                              formatGuid(left) + ": a stereo pair needs two cameras");
    if (camera.width < 1 || camera.height < 1)
        throw InvalidArgument("camera: FireWire ROI " + std::to_string(camera.width) + "x" +
                              std::to_string(camera.height) + " is empty");
    if (camera.bitDepth < 1 || camera.bitDepth > 16)
        throw InvalidArgument("camera.bitDepth must be 1..16, got " + std::to_string(camera.bitDepth));
    if (camera.channels != 1 && camera.channels != 3)
        throw InvalidArgument("camera.channels must be 1 or 3 for FireWire, got " + std::to_string(camera.channels));
    if (camera.channels == 3 && camera.bayer)
        throw InvalidArgument("camera.bayer: a Bayer mosaic has 1 channel, not 3");
    for (const auto& [feature, value] : singleFeatures(camera.features))
        if (!isIidcValue(value->value))
            throw InvalidArgument("camera.features." + std::string(toString(feature)) +
                                  ".value must be an integer in 0..4095 (IIDC), got " + str(value->value));
    const WhiteBalance& wb = camera.features.whiteBalance;
    if (!isIidcValue(wb.blueU))
        throw InvalidArgument("camera.features.whiteBalance.blueU must be an integer in 0..4095 (IIDC), got " +
                              str(wb.blueU));
    if (!isIidcValue(wb.redV))
        throw InvalidArgument("camera.features.whiteBalance.redV must be an integer in 0..4095 (IIDC), got " +
                              str(wb.redV));
}

Format7Settings AvatarCameras::format7For(const CameraHardwareConfig& camera) {
    Format7Settings f;
    f.width = camera.width;
    f.height = camera.height;
    const bool wide = camera.bitDepth > 8;
    if (camera.channels == 3)
        f.coding = wide ? PixelCoding::Rgb16 : PixelCoding::Rgb8;
    else if (camera.bayer)
        f.coding = wide ? PixelCoding::Raw16 : PixelCoding::Raw8;
    else
        f.coding = wide ? PixelCoding::Mono16 : PixelCoding::Mono8;
    return f;
}

CameraChange AvatarCameras::configure(const CameraHardwareConfig& camera) {
    check(camera);
    releaseFrames();
    const FirewireGuid left = *parseGuid(camera.leftCameraId);
    const FirewireGuid right = *parseGuid(camera.rightCameraId);

    CameraChange change = CameraChange::None;
    if (!active_ || needsRecovery_ || !left_.handle || !right_.handle || left != left_.guid || right != right_.guid)
        change = CameraChange::Cameras;
    else if (format7For(*active_) != format7For(camera))
        change = CameraChange::Capture;
    else if (!(active_->features == camera.features))
        change = CameraChange::Features;

    if (change != CameraChange::None) {
        try {
            switch (change) {
            case CameraChange::Features: applyFeatures(camera.features); break;
            case CameraChange::Capture:
                stopCapture();
                startCapture(camera);
                break;
            case CameraChange::Cameras: bringUp(camera, options_.maxBusResets); break;
            case CameraChange::None: break;
            }
        } catch (const AcquisitionError& e) {
            logger().error("FireWire: cannot apply camera settings (" + std::string(toString(change)) +
                           "): " + e.what());
            if (active_) {
                restore(*active_, change, e.what());
            } else {
                closeCameras();
                setStatus(AcquisitionStatus::State::Failed, e.what());
            }
            throw;
        }
    }
    active_ = camera;
    needsRecovery_ = false;
    failedRecoveries_ = 0;
    setStatus(AcquisitionStatus::State::Ok, "");
    logger().info("FireWire: " + describe(Side::Left, left) + ", " + describe(Side::Right, right) + ", " +
                  std::to_string(camera.width) + "x" + std::to_string(camera.height) + " " +
                  std::string(toString(format7For(camera).coding)) + "; applied: " +
                  std::string(toString(change)));
    return change;
}

void AvatarCameras::restore(const CameraHardwareConfig& previous, CameraChange change, const std::string& cause) {
    try {
        switch (change) {
        case CameraChange::Features: applyFeatures(previous.features); break;
        case CameraChange::Capture:
            stopCapture();
            startCapture(previous);
            break;
        case CameraChange::Cameras: bringUp(previous, 0); break;
        case CameraChange::None: break;
        }
        logger().notice("FireWire: previous camera settings restored");
    } catch (const AcquisitionError& e) {
        closeCameras();
        needsRecovery_ = true;
        lostReason_ = "could not restore the previous camera settings: " + std::string(e.what());
        setStatus(AcquisitionStatus::State::Recovering,
                  "could not apply new camera settings (" + cause + ") nor restore the previous ones (" + e.what() +
                      "); recovering at the next grab");
    }
}

void AvatarCameras::stop() {
    closeCameras();
    active_.reset();
    needsRecovery_ = false;
    failedRecoveries_ = 0;
    setStatus(AcquisitionStatus::State::Failed, "FireWire cameras stopped");
}

void AvatarCameras::bringUp(const CameraHardwareConfig& camera, int busResets) {
    const FirewireGuid left = *parseGuid(camera.leftCameraId);
    const FirewireGuid right = *parseGuid(camera.rightCameraId);
    closeCameras();
    findCameras(left, right, options_.settleRetries, busResets);
    openCameras(left, right);
    startCapture(camera);
}

void AvatarCameras::findCameras(FirewireGuid left, FirewireGuid right, int settleRetries, int busResets) {
    int settles = 0;
    int resets = 0;
    int count = 0;
    std::string problem;
    for (;;) {
        const Enumeration e = bus_->enumerate();
        ++count;
        ++diagnostics_.enumerations;
        problem = problemWith(e, left, right);
        if (problem.empty()) {
            logger().info("FireWire: found " + describe(Side::Left, left) + " and " + describe(Side::Right, right) +
                          " (enumeration " + std::to_string(count) + ", " + std::to_string(resets) +
                          " bus reset(s))");
            return;
        }
        logger().warn("FireWire enumeration " + std::to_string(count) + ": " + problem);
        if (e.status.code() == BusStatus::Code::Unavailable) break;  // waiting will not bring a driver
        if (settles < settleRetries) {
            ++settles;
            sleep_(options_.settleDelay);
            continue;
        }
        if (resets < busResets) {
            ++resets;
            ++diagnostics_.busResets;
            const BusStatus s = bus_->resetBus();
            if (!s.isOk())
                logger().warn("FireWire bus reset " + std::to_string(resets) + " failed (" +
                              std::string(toString(s.code())) + "): " + s.detail());
            sleep_(options_.settleDelay);
            continue;
        }
        break;
    }
    throw AcquisitionError("FireWire cameras not found after " + std::to_string(count) + " enumeration(s) (" +
                           std::to_string(settles) + " settle retries, " + std::to_string(resets) +
                           " bus resets, " + str(options_.settleDelay) + " settle delay): " + problem);
}

void AvatarCameras::openCameras(FirewireGuid left, FirewireGuid right) {
    for (auto [camera, guid] : {std::pair{&left_, left}, std::pair{&right_, right}}) {
        OpenResult r = bus_->open(guid);
        if (!r.status.isOk() || !r.camera)
            throw AcquisitionError(describe(camera->side, guid) + ": cannot open (" +
                                   std::string(toString(r.status.code())) + "): " + r.status.detail());
        camera->handle = std::move(r.camera);
        camera->guid = guid;
        camera->capturing = false;
        camera->held.reset();
    }
}

void AvatarCameras::startCapture(const CameraHardwareConfig& config) {
    const Format7Settings format = format7For(config);
    for (Camera* camera : {&left_, &right_}) {
        const BusStatus s = camera->handle->setFormat7(format);
        if (!s.isOk())
            throw AcquisitionError(describe(camera->side, camera->guid) + ": Format7 " + std::to_string(format.width) +
                                   "x" + std::to_string(format.height) + " " + std::string(toString(format.coding)) +
                                   " rejected: " + s.detail());
        applyFeatures(*camera, config.features);
    }
    for (Camera* camera : {&left_, &right_}) {
        const BusStatus s = camera->handle->startCapture(options_.dmaBuffers);
        if (!s.isOk())
            throw AcquisitionError(describe(camera->side, camera->guid) + ": cannot start capture with " +
                                   std::to_string(options_.dmaBuffers) + " DMA buffers: " + s.detail());
        camera->capturing = true;
    }
}

void AvatarCameras::stopCapture() {
    for (Camera* camera : {&left_, &right_}) {
        camera->held.reset();  // stopping capture frees the DMA buffers
        if (camera->handle && camera->capturing) {
            const BusStatus s = camera->handle->stopCapture();
            if (!s.isOk())
                logger().warn(describe(camera->side, camera->guid) + ": stopping capture: " + s.detail());
        }
        camera->capturing = false;
    }
}

void AvatarCameras::closeCameras() {
    stopCapture();
    left_.handle.reset();
    right_.handle.reset();
}

void AvatarCameras::applyFeatures(const CameraFeatureSet& features) {
    applyFeatures(left_, features);
    applyFeatures(right_, features);
}

void AvatarCameras::noteMissing(const Camera& camera, std::string_view feature, bool automatic,
                                const std::string& detail) {
    const std::string key = formatGuid(camera.guid) + "/" + std::string(feature) + (automatic ? "/auto" : "/manual");
    for (const std::string& k : reportedMissing_)
        if (k == key) return;
    reportedMissing_.push_back(key);
    logger().warn("FireWire: " + describe(camera.side, camera.guid) + ": " + detail + " (config feature <" +
                  std::string(feature) + ">" + (automatic ? ", automatic" : "") + "); skipped");
}

void AvatarCameras::applyFeatures(Camera& camera, const CameraFeatureSet& features) {
    for (const auto& [feature, value] : singleFeatures(features)) {
        const BusStatus s =
            camera.handle->setFeature(feature, static_cast<std::uint32_t>(value->value), value->automatic);
        if (s.code() == BusStatus::Code::NotFound) {  // the camera lacks it: reported, not an error
            noteMissing(camera, toString(feature), value->automatic, s.detail());
            continue;
        }
        if (!s.isOk())
            throw AcquisitionError(describe(camera.side, camera.guid) + ": cannot set " +
                                   std::string(toString(feature)) +
                                   (value->automatic ? " to automatic" : " to " + str(value->value)) + ": " +
                                   s.detail());
    }
    const WhiteBalance& wb = features.whiteBalance;
    const BusStatus s = camera.handle->setWhiteBalance(static_cast<std::uint32_t>(wb.blueU),
                                                       static_cast<std::uint32_t>(wb.redV), wb.automatic);
    if (s.code() == BusStatus::Code::NotFound) {
        noteMissing(camera, "whiteBalance", wb.automatic, s.detail());
        return;
    }
    if (!s.isOk())
        throw AcquisitionError(describe(camera.side, camera.guid) + ": cannot set white balance " +
                               (wb.automatic ? "to automatic" : "to " + str(wb.blueU) + "/" + str(wb.redV)) + ": " +
                               s.detail());
}

std::array<CameraFeatureReadback, 2> AvatarCameras::readFeatures() const {
    if (!active_ || !left_.handle || !right_.handle)
        throw AcquisitionError("FireWire cameras not started: apply a configuration first");
    std::array<CameraFeatureReadback, 2> out;
    std::size_t i = 0;
    for (const Camera* camera : {&left_, &right_}) {
        CameraFeatureReadback& r = out[i++];
        r.side = camera->side;
        r.cameraId = formatGuid(camera->guid);
        for (const std::string& name : cameraFeatureNames()) {
            FeatureState state;
            if (name == "whiteBalance") {
                state = camera->handle->getWhiteBalance();
            } else {
                state = camera->handle->getFeature(firewireFeatureNamed(name));
            }
            FeatureReading reading;
            reading.name = name;
            if (state.status.code() == BusStatus::Code::NotFound) {
                reading.note = state.status.detail();
            } else if (!state.status.isOk()) {
                throw AcquisitionError(describe(camera->side, camera->guid) + ": cannot read " + name + " (" +
                                       std::string(toString(state.status.code())) + "): " + state.status.detail());
            } else {
                reading.present = true;
                reading.autoAvailable = state.autoAvailable;
                reading.automatic = state.automatic;
                reading.value = state.value;
                reading.redV = state.redV;
                if (!state.autoAvailable) reading.note = "no automatic mode";
            }
            r.features.push_back(std::move(reading));
        }
    }
    return out;
}

RawFramePair AvatarCameras::grabRawImagePair() {
    if (!active_) throw AcquisitionError("FireWire cameras not started: apply a configuration first");
    {
        const AcquisitionStatus current = status();
        if (current.state == AcquisitionStatus::State::Failed) throw AcquisitionError(current.message);
    }
    releaseFrames();
    if (needsRecovery_) recover();

    FirewireFrame left = dequeue(left_);
    FirewireFrame right = dequeue(right_);
    const std::int64_t tolerance = options_.timestampTolerance.count();
    int drops = 0;
    while (std::llabs(left.timestampUs - right.timestampUs) > tolerance) {
        if (drops >= options_.maxResyncDrops) {
            const std::string message = "left and right frames do not belong together: capture times " +
                                        std::to_string(left.timestampUs) + " and " +
                                        std::to_string(right.timestampUs) + " us differ by more than " +
                                        std::to_string(tolerance) + " us after dropping " + std::to_string(drops) +
                                        " frame(s)";
            releaseFrames();
            setStatus(AcquisitionStatus::State::Recovering, message);
            logger().error("FireWire: " + message);
            throw AcquisitionError(message);
        }
        const bool leftOlder = left.timestampUs < right.timestampUs;
        Camera& older = leftOlder ? left_ : right_;
        logger().debug("FireWire: dropping " + describe(older.side, older.guid) + " frame at " +
                       std::to_string(leftOlder ? left.timestampUs : right.timestampUs) +
                       " us to resynchronise the pair");
        giveBack(older);
        ++drops;
        ++diagnostics_.framesDroppedForSync;
        (leftOlder ? left : right) = dequeue(older);
    }
    ++diagnostics_.pairsGrabbed;
    if (status().state != AcquisitionStatus::State::Ok) setStatus(AcquisitionStatus::State::Ok, "");
    return {left, right, left_.guid, right_.guid};
}

FirewireFrame AvatarCameras::dequeue(Camera& camera) {
    const DequeueResult d = camera.handle->dequeue(options_.dequeueTimeout);
    if (!d.status.isOk()) {
        if (d.status.code() == BusStatus::Code::Timeout)
            cameraLost(camera, "no frame within " + str(options_.dequeueTimeout));
        cameraLost(camera, "capture failed (" + std::string(toString(d.status.code())) + "): " + d.status.detail());
    }
    camera.held = d.frame;
    const FirewireFrame& f = d.frame;
    const std::size_t rowBytes =
        static_cast<std::size_t>(active_->width) * static_cast<std::size_t>(bytesPerPixel(format7For(*active_).coding));
    const std::size_t height = static_cast<std::size_t>(active_->height);
    if (f.data == nullptr || f.width != active_->width || f.height != active_->height || f.stride < rowBytes ||
        f.bytes < f.stride * (height - 1) + rowBytes)
        cameraLost(camera, "frame of " + std::to_string(f.width) + "x" + std::to_string(f.height) + " (stride " +
                               std::to_string(f.stride) + ", " + std::to_string(f.bytes) +
                               " bytes) does not fit the configured " + std::to_string(active_->width) + "x" +
                               std::to_string(active_->height) + " " +
                               std::string(toString(format7For(*active_).coding)));
    return f;
}

void AvatarCameras::cameraLost(Camera& camera, const std::string& what) {
    const std::string message = describe(camera.side, camera.guid) + ": " + what;
    ++diagnostics_.cameraFailures;
    releaseFrames();
    needsRecovery_ = true;
    lostReason_ = message;
    logger().error("FireWire: " + message);
    if (options_.maxRecoveryAttempts == 0) {
        closeCameras();
        setStatus(AcquisitionStatus::State::Failed, message + "; recovery disabled (maxRecoveryAttempts 0)");
    } else {
        setStatus(AcquisitionStatus::State::Recovering,
                  message + "; recovering at the next grab (attempt 1 of " +
                      std::to_string(options_.maxRecoveryAttempts) + ")");
    }
    throw AcquisitionError(message);
}

void AvatarCameras::recover() {
    const int attempt = failedRecoveries_ + 1;
    const std::string of = std::to_string(attempt) + " of " + std::to_string(options_.maxRecoveryAttempts);
    logger().notice("FireWire: recovery attempt " + of + " after: " + lostReason_);
    try {
        closeCameras();
        ++diagnostics_.busResets;
        const BusStatus s = bus_->resetBus();
        if (!s.isOk())
            logger().warn("FireWire: bus reset before recovery failed (" + std::string(toString(s.code())) +
                          "): " + s.detail());
        sleep_(options_.settleDelay);
        bringUp(*active_, 0);
    } catch (const AcquisitionError& e) {
        closeCameras();
        ++failedRecoveries_;
        if (failedRecoveries_ >= options_.maxRecoveryAttempts) {
            const std::string message = "gave up after " + std::to_string(failedRecoveries_) +
                                        " recovery attempt(s); lost " + lostReason_ + "; last attempt: " + e.what();
            setStatus(AcquisitionStatus::State::Failed, message);
            logger().error("FireWire: " + message);
            throw AcquisitionError(message);
        }
        const std::string message = "recovery attempt " + of + " failed: " + e.what() + " (lost " + lostReason_ + ")";
        setStatus(AcquisitionStatus::State::Recovering, message);
        logger().error("FireWire: " + message);
        throw AcquisitionError(message);
    }
    needsRecovery_ = false;
    failedRecoveries_ = 0;
    ++diagnostics_.recoveries;
    setStatus(AcquisitionStatus::State::Ok, "");
    logger().notice("FireWire: cameras recovered (attempt " + of + ")");
}

void AvatarCameras::giveBack(Camera& camera) {
    if (!camera.held) return;
    const FirewireFrame frame = *camera.held;
    camera.held.reset();
    if (!camera.handle || !camera.capturing) return;
    const BusStatus s = camera.handle->enqueue(frame);
    if (!s.isOk()) {
        // The ring is a buffer short; the next grab restarts capture rather than run it dry.
        const std::string message =
            describe(camera.side, camera.guid) + ": cannot give frame buffer back: " + s.detail();
        logger().error("FireWire: " + message);
        if (!needsRecovery_) {
            needsRecovery_ = true;
            lostReason_ = message;
            setStatus(AcquisitionStatus::State::Recovering, message + "; recovering at the next grab");
        }
    }
}

void AvatarCameras::releaseFrames() {
    giveBack(left_);
    giveBack(right_);
}

AcquisitionStatus AvatarCameras::status() const {
    std::lock_guard<std::mutex> lock(statusMutex_);
    return status_;
}

void AvatarCameras::setStatus(AcquisitionStatus::State state, std::string message) {
    std::lock_guard<std::mutex> lock(statusMutex_);
    status_.state = state;
    status_.message = std::move(message);
}

}  // namespace avatar
