#include <avatar/acquire/RawDataAcquire.h>

#include <avatar/common/Logging.h>
#include <avatar/common/internal/WorkerThread.h>
#include <avatar/config/ConfigXml.h>

#include <log4cpp/Category.hh>

#include <charconv>
#include <cmath>
#include <cstring>
#include <type_traits>

namespace avatar {
namespace {

log4cpp::Category& logger() { return logging::category("acquire"); }

}  // namespace

/// The next pair's files, read on a thread of their own.
struct RawDataAcquire::ReadAhead {
    detail::WorkerThread thread;
    std::size_t index{0};                   ///< the entry being read
    std::future<StereoImagePair> pair;      ///< valid while one is read
};

RawDataAcquire::RawDataAcquire(std::filesystem::path sessionDirectory)
    : reader_(std::move(sessionDirectory)), readAhead_(std::make_unique<ReadAhead>()) {
    logger().info("replay of %s: %zu records, %zu damaged lines", reader_.directory().string().c_str(),
                  reader_.entries().size(), reader_.errors().size());
    updateEndState();
    readAhead();
}

RawDataAcquire::~RawDataAcquire() = default;

void RawDataAcquire::readAhead() {
    const auto& entries = reader_.entries();
    if (position_ >= entries.size() || !entries[position_].ok()) return;
    const SessionRecord* record = &*entries[position_].record;
    readAhead_->index = position_;
    readAhead_->pair = readAhead_->thread.submit([this, record] { return reader_.loadPair(*record); });
}

StereoImagePair RawDataAcquire::loadEntry(std::size_t index, const SessionRecord& record) {
    if (readAhead_->pair.valid()) {
        std::future<StereoImagePair> pending = std::move(readAhead_->pair);
        if (readAhead_->index == index) return pending.get();  // rethrows what the read threw
        pending.wait();  // another entry's: never read twice at once
    }
    return reader_.loadPair(record);
}

std::string RawDataAcquire::configSource(std::uint32_t version) const {
    return reader_.logPath().string() + " (configuration " + std::to_string(version) + ")";
}

RecordedConfig RawDataAcquire::initialConfig() const {
    const auto records = reader_.records();
    if (records.empty())
        throw NotAvailable("session " + reader_.directory().string() +
                           " has no intact record to take the configuration from");
    const std::uint32_t version = records.front().configVersion;
    const auto xml = reader_.configXml(version);
    if (!xml) {
        // Say why: the record that applied it is most likely a damaged one before.
        std::string why;
        for (const SessionLogEntry& entry : reader_.entries()) {
            if (entry.ok()) break;
            why += "; damaged before it: " + entry.error;
        }
        throw NotAvailable("session " + reader_.directory().string() + " does not hold configuration " +
                           std::to_string(version) + " of its first intact record (" + reader_.logPath().string() +
                           ":" + std::to_string(firstIntactLine()) + ")" + why);
    }
    return {readConfigString(*xml, configSource(version)), version, configSource(version)};
}

std::array<CameraFeatureReadback, 2> RawDataAcquire::readFeatures() const {
    AvatarConfig config;
    AcquisitionId ids;
    if (lastRecord_) {
        const std::uint32_t version = lastRecord_->configVersion;
        const auto xml = reader_.configXml(version);
        if (!xml)
            throw NotAvailable("session " + reader_.directory().string() + " does not hold configuration " +
                               std::to_string(version) + " (the record that applied it is damaged)");
        config = readConfigString(*xml, configSource(version));
        ids = lastRecord_->acquisition;
    } else {
        config = initialConfig().config;
        ids = reader_.records().front().acquisition;  // initialConfig() found an intact record
    }
    const CameraFeatureSet& f = config.camera.features;
    const auto reading = [](const std::string& name, const CameraFeature& feature) {
        FeatureReading r;
        r.name = name;
        r.present = true;
        r.automatic = feature.automatic;
        r.value = feature.value;
        r.note = "recorded: a replay cannot adjust it";
        return r;
    };
    std::array<CameraFeatureReadback, 2> out;
    for (const Side side : {Side::Left, Side::Right}) {
        CameraFeatureReadback& r = out[side == Side::Left ? 0 : 1];
        r.side = side;
        r.cameraId = side == Side::Left ? ids.left.cameraId : ids.right.cameraId;
        FeatureReading wb = reading("whiteBalance", {f.whiteBalance.blueU, f.whiteBalance.automatic});
        wb.redV = f.whiteBalance.redV;
        r.features = {reading("exposure", f.exposure), reading("shutter", f.shutter), reading("gain", f.gain), wb,
                      reading("brightness", f.brightness), reading("gamma", f.gamma)};
    }
    return out;
}

std::size_t RawDataAcquire::firstIntactLine() const {
    for (const SessionLogEntry& entry : reader_.entries())
        if (entry.ok()) return entry.line;
    return 0;
}

AcquisitionStatus RawDataAcquire::status() const {
    std::lock_guard<std::mutex> lock(mutex_);
    return status_;
}

std::size_t RawDataAcquire::deliveredCount() const {
    std::lock_guard<std::mutex> lock(mutex_);
    return delivered_;
}

std::size_t RawDataAcquire::damagedCount() const {
    std::lock_guard<std::mutex> lock(mutex_);
    return damaged_;
}

void RawDataAcquire::updateEndState() {
    if (position_ < reader_.entries().size()) return;
    std::lock_guard<std::mutex> lock(mutex_);
    status_.state = AcquisitionStatus::State::Finished;
    status_.message = "replay of " + reader_.directory().string() + " finished: " + std::to_string(delivered_) +
                      " pairs replayed, " + std::to_string(damaged_) + " damaged records" +
                      (lastError_.empty() ? std::string() : " (last: " + lastError_ + ")");
}

AcquiredPair RawDataAcquire::grab() {
    const auto& entries = reader_.entries();
    if (position_ >= entries.size()) {
        updateEndState();
        throw AcquisitionError("replay: no more records: " + status().message);
    }
    std::string error;
    AcquiredPair out;
    try {
        out = next();
    } catch (const Error& e) {
        error = e.what();
    }
    readAhead();
    {
        std::lock_guard<std::mutex> lock(mutex_);
        if (error.empty()) {
            ++delivered_;
            status_ = {};
        } else {
            ++damaged_;
            lastError_ = error;
            status_.state = AcquisitionStatus::State::Recovering;
            status_.message = error;
        }
    }
    updateEndState();
    if (!error.empty()) {
        logger().warn("%s", error.c_str());
        throw AcquisitionError(error + " (replay goes on with the next record)");
    }
    return out;
}

AcquiredPair RawDataAcquire::next() {
    const std::size_t index = position_++;
    const SessionLogEntry& entry = reader_.entries()[index];
    if (!entry.ok()) throw FormatError(entry.error);
    const SessionRecord& record = *entry.record;
    const std::string where = reader_.logPath().string() + ":" + std::to_string(entry.line) + ": ";

    const bool versionChanged = !deliveredVersion_ || *deliveredVersion_ != record.configVersion;
    std::optional<std::string> xml = record.configXml;
    if (!xml && versionChanged) {
        xml = reader_.configXml(record.configVersion);
        if (!xml)
            throw FormatError(where + "iteration " + std::to_string(record.iteration) + ": configuration " +
                              std::to_string(record.configVersion) +
                              " is not in the log (the record that applied it is damaged); the pair is not "
                              "replayed without its configuration");
    }
    AcquiredPair out;
    try {
        out.pair = loadEntry(index, record);
    } catch (const Error& e) {
        throw FormatError(where + e.what());
    }
    out.recordedIteration = record.iteration;
    if (xml && (versionChanged || record.configXml)) {
        out.recordedConfigXml = std::move(xml);
        out.recordedConfigSource = configSource(record.configVersion);
    }
    out.recordedResult = record.result;
    deliveredVersion_ = record.configVersion;
    lastRecord_ = record;
    return out;
}

// ---------------------------------------------------------------------------
// Regression check

namespace {

std::string text(double v) {
    char buf[64];
    const auto r = std::to_chars(buf, buf + sizeof buf, v);
    return std::string(buf, r.ptr);
}

bool sameBits(double a, double b) {
    if (std::isnan(a) && std::isnan(b)) return true;
    return std::memcmp(&a, &b, sizeof a) == 0;
}

std::string text(const std::optional<cv::Point3d>& p) {
    return p ? text(p->x) + ";" + text(p->y) + ";" + text(p->z) : "-";
}
std::string text(const std::optional<cv::Point2d>& p) { return p ? text(p->x) + ";" + text(p->y) : "-"; }

const char* text(Visibility v) {
    switch (v) {
        case Visibility::Good: return "good";
        case Visibility::Poor: return "poor";
        case Visibility::Unknown: break;
    }
    return "unknown";
}

std::string text(const std::optional<Covariance3>& c) {
    if (!c) return "-";
    std::string s;
    for (int i = 0; i < 3; ++i)
        for (int j = i; j < 3; ++j) s += (s.empty() ? "" : ";") + text((*c)(i, j));
    return s;
}

std::string describe(const VisionTarget& t) {
    return t.type + "," + std::to_string(t.flags) + "," + text(t.positionVisionMm) + "," + text(t.positionBaseMm) +
           "," + text(t.centroidLeftPx) + "," + text(t.centroidRightPx) + "," + text(t.areaLeftPx) + "," +
           text(t.areaRightPx) + "," + text(t.matchError) + "," + std::string(toString(t.model)) + "," +
           text(t.covarianceVisionMm2) + "," + text(t.covarianceBaseMm2) + "," + text(t.rayResidualMm) + "," +
           text(t.rayResidualPx);
}

class Comparer {
public:
    std::vector<ResultDifference> out;

    void text(const std::string& field, const std::string& a, const std::string& b) {
        if (a != b) out.push_back({field, a, b});
    }
    template <typename Int>
    void integer(const std::string& field, Int a, Int b) {
        if (a != b) out.push_back({field, std::to_string(a), std::to_string(b)});
    }
    void number(const std::string& field, double a, double b) {
        if (!sameBits(a, b)) out.push_back({field, avatar::text(a), avatar::text(b)});
    }
    /// A 2-D or 3-D point, coordinate by coordinate.
    template <typename Point>
    void point(const std::string& field, const std::optional<Point>& a, const std::optional<Point>& b) {
        if (a.has_value() != b.has_value()) {
            out.push_back({field, avatar::text(a), avatar::text(b)});
            return;
        }
        if (!a) return;
        number(field + ".x", a->x, b->x);
        number(field + ".y", a->y, b->y);
        if constexpr (std::is_same_v<Point, cv::Point3d>) number(field + ".z", a->z, b->z);
    }
    /// A covariance, entry by entry of its upper triangle.
    void covariance(const std::string& field, const std::optional<Covariance3>& a,
                    const std::optional<Covariance3>& b) {
        if (a.has_value() != b.has_value()) {
            out.push_back({field, avatar::text(a), avatar::text(b)});
            return;
        }
        if (!a) return;
        for (int i = 0; i < 3; ++i)
            for (int j = i; j < 3; ++j)
                number(field + "(" + std::to_string(i) + "," + std::to_string(j) + ")", (*a)(i, j), (*b)(i, j));
    }
};

}  // namespace

std::vector<ResultDifference> compareResults(const VisionTargets& recorded, const VisionTargets& replayed) {
    Comparer c;
    c.integer("iteration", recorded.iteration, replayed.iteration);
    const AcquisitionId& a = recorded.acquisition;
    const AcquisitionId& b = replayed.acquisition;
    c.integer("acquisition.group", a.group, b.group);
    c.integer("acquisition.member", a.member, b.member);
    c.text("acquisition.left.cameraId", a.left.cameraId, b.left.cameraId);
    c.integer("acquisition.left.timestampUs", a.left.timestampUs, b.left.timestampUs);
    c.text("acquisition.right.cameraId", a.right.cameraId, b.right.cameraId);
    c.integer("acquisition.right.timestampUs", a.right.timestampUs, b.right.timestampUs);
    c.text("visibility", text(recorded.visibility), text(replayed.visibility));
    c.text("visibilityReason", recorded.visibilityReason, replayed.visibilityReason);

    // Timings: the stages and their order, never the milliseconds.
    auto stages = [](const VisionTargets& v) {
        std::string s;
        for (const StageTiming& t : v.timings) s += (s.empty() ? "" : " ") + t.stage;
        return s;
    };
    c.text("timings.stages", stages(recorded), stages(replayed));

    const std::size_t common = std::min(recorded.targets.size(), replayed.targets.size());
    c.integer("targets.size", recorded.targets.size(), replayed.targets.size());
    for (std::size_t i = 0; i < common; ++i) {
        const VisionTarget& x = recorded.targets[i];
        const VisionTarget& y = replayed.targets[i];
        const std::string p = "targets[" + std::to_string(i) + "].";
        c.text(p + "type", x.type, y.type);
        c.integer(p + "flags", x.flags, y.flags);
        c.point(p + "positionVisionMm", x.positionVisionMm, y.positionVisionMm);
        c.point(p + "positionBaseMm", x.positionBaseMm, y.positionBaseMm);
        c.point(p + "centroidLeftPx", x.centroidLeftPx, y.centroidLeftPx);
        c.point(p + "centroidRightPx", x.centroidRightPx, y.centroidRightPx);
        c.number(p + "areaLeftPx", x.areaLeftPx, y.areaLeftPx);
        c.number(p + "areaRightPx", x.areaRightPx, y.areaRightPx);
        c.number(p + "matchError", x.matchError, y.matchError);
        c.text(p + "model", std::string(toString(x.model)), std::string(toString(y.model)));
        c.covariance(p + "covarianceVisionMm2", x.covarianceVisionMm2, y.covarianceVisionMm2);
        c.covariance(p + "covarianceBaseMm2", x.covarianceBaseMm2, y.covarianceBaseMm2);
        c.number(p + "rayResidualMm", x.rayResidualMm, y.rayResidualMm);
        c.number(p + "rayResidualPx", x.rayResidualPx, y.rayResidualPx);
    }
    for (std::size_t i = common; i < recorded.targets.size(); ++i)
        c.out.push_back({"targets[" + std::to_string(i) + "]", describe(recorded.targets[i]), "-"});
    for (std::size_t i = common; i < replayed.targets.size(); ++i)
        c.out.push_back({"targets[" + std::to_string(i) + "]", "-", describe(replayed.targets[i])});
    return std::move(c.out);
}

}  // namespace avatar
