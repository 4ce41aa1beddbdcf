#include <avatar/tau/VisionInterface.h>

#include <avatar/acquire/SessionRecorder.h>
#include <avatar/analyze/AnalyzeStereoImagePair.h>
#include <avatar/common/Logging.h>
#include <avatar/config/ConfigXml.h>

#include <log4cpp/Category.hh>

#include <algorithm>
#include <atomic>
#include <condition_variable>
#include <deque>
#include <filesystem>
#include <functional>
#include <future>
#include <mutex>
#include <thread>
#include <vector>

#include <unistd.h>

namespace avatar {

const char* toString(VisionState state) {
    switch (state) {
        case VisionState::Idle: return "idle";
        case VisionState::Searching: return "searching";
        case VisionState::Snapshot: return "snapshot";
        case VisionState::Error: return "error";
    }
    return "?";
}

namespace {

log4cpp::Category& log() { return logging::category("vision"); }

// How often the loop wakes when idle.
constexpr std::chrono::milliseconds kIdleTick{100};
// The heartbeat's period: its own timer, so it ticks at 20 per second however
// long an iteration takes (docs/protocol.md promises at least 10).
constexpr std::chrono::milliseconds kHeartbeatPeriod{50};

// The source errors of a configuration sent to applyConfig() name.
constexpr const char* kSentSource = "sent configuration";

}  // namespace

/// The vision thread and everything it owns. Members above the mutex are
/// touched only by the vision thread (or before it starts); members below it
/// are shared and guarded by it.
class VisionInterface::Loop {
public:
    Loop(std::unique_ptr<AcquireStereoImagePair> backend, const AvatarConfig& config, VisionOptions options)
        : backend_(std::move(backend)), options_(std::move(options)) {
        if (!backend_) throw InvalidArgument("VisionInterface: no acquisition backend");
        backendName_ = backend_->name();
        install(config);  // throws: nothing started yet
        if (options_.recordDirectory) {
            SessionRecorderOptions recorderOptions;
            recorderOptions.queueCapacity = options_.recordQueue;
            recorder_ = std::make_unique<SessionRecorder>(
                std::make_unique<SessionLogSink>(*options_.recordDirectory,
                                                 options_.recordPng ? Compression::Png : Compression::None),
                recorderOptions);
        }
        thread_ = std::thread([this] { run(); });
        heartbeat_ = std::thread([this] { beat(); });
    }

    ~Loop() {
        {
            std::lock_guard<std::mutex> lock(mutex_);
            stop_ = true;
        }
        wake_.notify_all();
        beatWake_.notify_all();
        thread_.join();
        heartbeat_.join();
        if (recorder_) recorder_->flush();
    }

    void startSearching() {
        std::lock_guard<std::mutex> lock(mutex_);
        if (status_.state == VisionState::Error) throw InvalidState("cannot start searching: " + status_.error);
        if (status_.acquisition.state == AcquisitionStatus::State::Finished)
            throw InvalidState("cannot start searching: the " + backendName_ + " backend has no more pairs (" +
                               status_.acquisition.message + ")");
        searching_ = true;
        wake_.notify_all();
    }

    void stopSearching() {
        std::lock_guard<std::mutex> lock(mutex_);
        searching_ = false;
    }

    VisionTargets snapshot(std::chrono::milliseconds timeout) {
        std::future<VisionTargets> result;
        {
            std::lock_guard<std::mutex> lock(mutex_);
            if (status_.state == VisionState::Error)
                throw AcquisitionError("cannot take a snapshot: " + status_.error);
            snapshots_.emplace_back();
            result = snapshots_.back().get_future();
        }
        wake_.notify_all();
        if (result.wait_for(timeout) != std::future_status::ready)
            throw TimedOut("snapshot timed out after " + std::to_string(timeout.count()) + " ms");
        return result.get();
    }

    std::uint32_t applyConfig(const std::string& xml, std::chrono::milliseconds timeout) {
        // Validate on the caller's thread: a bad document never reaches the loop.
        AvatarConfig config = readConfigString(xml, kSentSource);
        auto cancelled = std::make_shared<std::atomic<bool>>(false);
        std::packaged_task<std::uint32_t()> task([this, config, cancelled]() -> std::uint32_t {
            if (*cancelled) throw TimedOut("configuration change was cancelled (timed out)");
            install(config, Rejection::AsConfigError);
            std::lock_guard<std::mutex> lock(mutex_);
            return status_.configVersion;
        });
        auto done = task.get_future();
        {
            std::lock_guard<std::mutex> lock(mutex_);
            commands_.emplace_back(std::move(task));
        }
        wake_.notify_all();
        if (done.wait_for(timeout) != std::future_status::ready) {
            *cancelled = true;  // if it has not started, it never will
            if (done.wait_for(std::chrono::milliseconds(0)) != std::future_status::ready)
                throw TimedOut("configuration change timed out after " + std::to_string(timeout.count()) +
                               " ms; the previous configuration stays in force");
        }
        return done.get();
    }

    std::optional<VisionTargets> latestTargets() const {
        std::lock_guard<std::mutex> lock(mutex_);
        return latest_;
    }

    VisionImages images(ImageKind kind) const {
        std::shared_ptr<const AnalysisFrame> frame;
        {
            std::lock_guard<std::mutex> lock(mutex_);
            frame = frame_;
        }
        VisionImages out;
        if (!frame) return out;
        out.iteration = frame->result.iteration;
        switch (kind) {
            case ImageKind::Original: out.pair = frame->original; break;
            case ImageKind::Filtered: out.pair = AnalyzeStereoImagePair::filteredImages(*frame); break;
            case ImageKind::Marked: out.pair = AnalyzeStereoImagePair::markedImages(*frame); break;
        }
        return out;
    }

    std::string configXml() const {
        std::lock_guard<std::mutex> lock(mutex_);
        return configXml_;
    }
    AvatarConfig config() const {
        std::lock_guard<std::mutex> lock(mutex_);
        return config_;
    }
    VisionStatus status() const {
        VisionStatus s;
        {
            std::lock_guard<std::mutex> lock(mutex_);
            s = status_;
        }
        if (recorder_) {
            const SessionRecorderStatus r = recorder_->status();
            s.recordBacklog = r.backlog;
            s.recorded = r.recorded;
            s.unrecorded = r.unrecorded();
            s.recordError = r.lastError;
        }
        return s;
    }
    std::string backendName() const { return backendName_; }

private:
    /// How install() reports a configuration that validated but cannot be used.
    enum class Rejection {
        AsThrown,       ///< the constructor and recorded configurations: the error as it is
        AsConfigError   ///< a configuration a client sent: ConfigError naming the part that refused it
    };

    /// Applies a configuration to the backend and the analysis, all or nothing.
    /// A sent configuration may name a lighting template only inside the data
    /// directory (VisionOptions::configDirectory), and whatever is wrong with
    /// it the client hears one message: no client can probe which files exist
    /// on the vision computer. The reason is logged here.
    void checkSentTemplate(const LightingConfig& lighting) const {
        if (!lighting.patternEnabled || lighting.templateImagePath.empty()) return;
        namespace fs = std::filesystem;
        std::error_code ec;
        const fs::path base = fs::weakly_canonical(
            options_.configDirectory.empty() ? fs::current_path(ec) : options_.configDirectory, ec);
        fs::path path = lighting.templateImagePath;
        if (path.is_relative()) path = base / path;
        const fs::path resolved = fs::weakly_canonical(path, ec);
        std::string why;
        const auto [end, ignored] = std::mismatch(base.begin(), base.end(), resolved.begin(), resolved.end());
        if (ec || end != base.end()) why = "outside the data directory " + base.string();
        else if (!fs::is_regular_file(resolved, ec)) why = "not a regular file";
        else if (::access(resolved.c_str(), R_OK) != 0) why = "not readable";
        if (why.empty()) return;  // its contents are checked when the analysis is built
        log().info("sent configuration refused: lighting template '%s' (%s) is %s",
                   lighting.templateImagePath.c_str(), resolved.c_str(), why.c_str());
        throw ConfigError(kSentSource, 0, "/avatar/lighting/pattern/templateImage",
                          "cannot be used: '" + lighting.templateImagePath +
                              "' is not a readable lighting template in the data directory");
    }

    /// With Rejection::AsConfigError an analysis that cannot be built from it
    /// (a stage order, a lighting template that cannot be read) and a backend
    /// that cannot use it (InvalidArgument) are ConfigErrors of the sent
    /// configuration; a backend that fails (AcquisitionError) stays one.
    /// Vision thread only (or the constructor).
    void install(const AvatarConfig& config, Rejection rejection = Rejection::AsThrown) {
        const auto rejected = [&](const char* part, const Error& e) {
            if (rejection == Rejection::AsThrown || dynamic_cast<const ConfigError*>(&e)) throw;
            throw ConfigError(kSentSource, 0, part, std::string("cannot be applied: ") + e.what());
        };
        if (rejection == Rejection::AsConfigError) checkSentTemplate(config.lighting);
        std::unique_ptr<AnalyzeStereoImagePair> analyzer;
        try {
            analyzer = std::make_unique<AnalyzeStereoImagePair>(config, options_.configDirectory);
        } catch (const Error& e) {
            rejected("/avatar/analysis", e);
        }
        try {
            backend_->applyConfig(config);  // throws and keeps the old settings
        } catch (const InvalidArgument& e) {
            rejected("/avatar/camera", e);
        }
        analyzer_ = std::move(analyzer);
        const std::string xml = writeConfigString(config);
        std::lock_guard<std::mutex> lock(mutex_);
        const bool first = configXml_.empty();
        config_ = config;
        configXml_ = xml;
        if (!first) ++status_.configVersion;
        status_.configIteration = status_.iteration + 1;
        log().notice("configuration %u in force from iteration %llu", status_.configVersion,
                     static_cast<unsigned long long>(status_.configIteration));
    }

    /// One acquisition and analysis. Vision thread only.
    VisionTargets iterate() {
        AcquiredPair acquired = backend_->acquire();
        // A replay reached a recorded configuration change: apply it as it was applied then.
        if (const std::optional<AvatarConfig> recorded = acquired.recordedConfig(); recorded && *recorded != config())
            install(*recorded);
        std::uint64_t iteration;
        {
            std::lock_guard<std::mutex> lock(mutex_);
            iteration = acquired.recordedIteration.value_or(status_.iteration + 1);
        }
        VisionTargets result = analyzer_->analyze(acquired.pair, iteration);
        auto frame = std::make_shared<const AnalysisFrame>(analyzer_->lastFrame());
        if (recorder_) {
            // Never blocks: a full queue is counted and reported by the recorder.
            std::uint32_t version;
            std::optional<std::string> xml;
            {
                std::lock_guard<std::mutex> lock(mutex_);
                version = status_.configVersion;
                if (version != recordedVersion_) xml = configXml_;
            }
            recordedVersion_ = version;
            recorder_->record(acquired.pair, iteration, version, std::move(xml), result);
        }
        std::lock_guard<std::mutex> lock(mutex_);
        latest_ = result;
        frame_ = std::move(frame);
        status_.iteration = iteration;
        status_.targetsIteration = iteration;
        status_.imagesIteration = iteration;
        status_.visibility = result.visibility;
        status_.visibilityReason = result.visibilityReason;
        status_.acquisition = backend_->status();
        return result;
    }

    /// The heartbeat: ticks while the vision thread runs, whatever it is doing.
    void beat() {
        std::unique_lock<std::mutex> lock(mutex_);
        while (!stop_ && visionRunning_) {
            ++status_.heartbeat;
            beatWake_.wait_for(lock, kHeartbeatPeriod, [this] { return stop_ || !visionRunning_; });
        }
    }

    void run() {
        std::unique_lock<std::mutex> lock(mutex_);
        while (!stop_) {
            while (!commands_.empty()) {
                auto command = std::move(commands_.front());
                commands_.pop_front();
                lock.unlock();
                command();  // its exception goes to the caller's future
                lock.lock();
            }
            if (!searching_ && snapshots_.empty()) {
                if (status_.state != VisionState::Error) status_.state = VisionState::Idle;
                wake_.wait_for(lock, kIdleTick);
                continue;
            }
            status_.state = searching_ ? VisionState::Searching : VisionState::Snapshot;
            auto waiting = std::move(snapshots_);
            snapshots_.clear();
            lock.unlock();
            // The state is settled before any snapshot caller is released, so a
            // caller that asks for the status right after its snapshot sees the
            // state that follows it (idle after a lone snapshot), never a stale one.
            try {
                const VisionTargets result = iterate();
                lastLoggedError_.clear();
                lock.lock();
                if (!searching_ && snapshots_.empty()) status_.state = VisionState::Idle;
                for (auto& p : waiting) p.set_value(result);
            } catch (const std::exception& e) {
                const auto backendStatus = backend_->status();
                lock.lock();
                status_.acquisition = backendStatus;
                status_.error = e.what();
                // A state change is logged once, at its level: the normal end of a
                // replay is a notice, a failure an error; the same again is debug.
                const bool finished = backendStatus.state == AcquisitionStatus::State::Finished;
                if (status_.error == lastLoggedError_) {
                    log().debug("iteration failed again: %s", e.what());
                } else {
                    log().log(finished ? log4cpp::Priority::NOTICE : log4cpp::Priority::ERROR, "%s: %s",
                              finished ? "acquisition finished" : "iteration failed", e.what());
                    lastLoggedError_ = status_.error;
                }
                if (backendStatus.state == AcquisitionStatus::State::Failed) {
                    status_.state = VisionState::Error;
                    searching_ = false;
                } else if (backendStatus.state == AcquisitionStatus::State::Finished) {
                    searching_ = false;
                }
                if (status_.state != VisionState::Error && !searching_ && snapshots_.empty())
                    status_.state = VisionState::Idle;
                for (auto& p : waiting) p.set_exception(std::current_exception());
            }
            if (searching_ && options_.searchPeriod.count() > 0)
                wake_.wait_for(lock, options_.searchPeriod, [this] { return stop_ || !commands_.empty(); });
        }
        // Nobody will fulfil these any more.
        for (auto& p : snapshots_) p.set_exception(std::make_exception_ptr(InvalidState("vision interface stopped")));
        visionRunning_ = false;
        beatWake_.notify_all();
    }

    // Vision thread only.
    std::unique_ptr<AcquireStereoImagePair> backend_;
    std::unique_ptr<AnalyzeStereoImagePair> analyzer_;
    const VisionOptions options_;
    std::string backendName_;
    std::uint32_t recordedVersion_{0};  ///< configuration version of the last recorded pair
    std::string lastLoggedError_;       ///< the failure logged last (the same one is not logged again)
    std::unique_ptr<SessionRecorder> recorder_;  ///< thread-safe itself

    // Shared, guarded by mutex_.
    mutable std::mutex mutex_;
    std::condition_variable wake_;
    std::condition_variable beatWake_;
    bool stop_{false};
    bool visionRunning_{true};  ///< false once the vision thread has left its loop
    bool searching_{false};
    std::deque<std::packaged_task<std::uint32_t()>> commands_;
    std::vector<std::promise<VisionTargets>> snapshots_;
    AvatarConfig config_;
    std::string configXml_;
    std::optional<VisionTargets> latest_;
    std::shared_ptr<const AnalysisFrame> frame_;
    VisionStatus status_;

    std::thread thread_;     // last: start after everything above exists
    std::thread heartbeat_;
};

VisionInterface::VisionInterface(std::unique_ptr<AcquireStereoImagePair> backend, const AvatarConfig& config,
                                 VisionOptions options)
    : loop_(std::make_unique<Loop>(std::move(backend), config, std::move(options))) {}
VisionInterface::~VisionInterface() = default;
void VisionInterface::startSearching() { loop_->startSearching(); }
void VisionInterface::stopSearching() { loop_->stopSearching(); }
VisionTargets VisionInterface::snapshot(std::chrono::milliseconds timeout) { return loop_->snapshot(timeout); }
std::optional<VisionTargets> VisionInterface::latestTargets() const { return loop_->latestTargets(); }
VisionImages VisionInterface::images(ImageKind kind) const { return loop_->images(kind); }
std::uint32_t VisionInterface::applyConfig(const std::string& xml, std::chrono::milliseconds timeout) {
    return loop_->applyConfig(xml, timeout);
}
std::string VisionInterface::configXml() const { return loop_->configXml(); }
AvatarConfig VisionInterface::config() const { return loop_->config(); }
VisionStatus VisionInterface::status() const { return loop_->status(); }
std::string VisionInterface::backendName() const { return loop_->backendName(); }

}  // namespace avatar
