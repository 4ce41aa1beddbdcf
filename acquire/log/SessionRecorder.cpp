#include <avatar/acquire/SessionRecorder.h>

#include <avatar/common/Error.h>
#include <avatar/common/Logging.h>

#include <log4cpp/Category.hh>

namespace avatar {
namespace {

log4cpp::Category& logger() { return logging::category("acquire"); }

}  // namespace

// ---------------------------------------------------------------------------
// SessionLogSink

SessionLogSink::SessionLogSink(std::filesystem::path sessionDirectory, Compression compression,
                               ByteOrder rawByteOrder)
    : base_(std::move(sessionDirectory)),
      writer_(std::make_unique<SessionLogWriter>(base_)),
      sessions_{base_},
      compression_(compression),
      byteOrder_(rawByteOrder) {}

void SessionLogSink::continueInNewSession() {
    namespace fs = std::filesystem;
    for (unsigned part = 2;; ++part) {
        const fs::path next = base_.string() + ".part" + std::to_string(part);
        std::error_code ec;
        if (fs::exists(next, ec) || ec) continue;  // never write into something that is there
        try {
            writer_ = std::make_unique<SessionLogWriter>(next);
        } catch (const Error& e) {
            // No room yet: leave nothing behind, try again with the next pair.
            fs::remove_all(next, ec);
            throw IoError("session " + writer_->directory().string() +
                          " cannot take more records and no new session can be started yet: " + e.what());
        }
        sessions_.push_back(next);
        logger().notice("session %s cannot take more records (its log could not be written); recording continues in %s",
                        base_.string().c_str(), next.string().c_str());
        return;
    }
}

PairFiles SessionLogSink::writePair(const StereoImagePair& pair) {
    if (writer_->failed()) continueInNewSession();
    return writer_->writePair(pair, compression_, byteOrder_);
}

void SessionLogSink::append(const SessionRecord& record) {
    try {
        writer_->append(record);
    } catch (...) {
        // No record will name them: remove the pair's images rather than leave orphans.
        for (const ImageFileRef* file : {&record.files.left, &record.files.right}) {
            if (file->name.empty()) continue;
            std::error_code ec;
            std::filesystem::remove(writer_->directory() / file->name, ec);
        }
        throw;
    }
}

std::string SessionLogSink::describe() const { return writer_->directory().string(); }

bool SessionLogSink::atSessionStart() const { return writer_->recordCount() == 0; }

// ---------------------------------------------------------------------------
// SessionRecorder

void SessionRecorderOptions::validate() const {
    if (queueCapacity < 1 || queueCapacity > 1024)
        throw InvalidArgument("SessionRecorderOptions.queueCapacity " + std::to_string(queueCapacity) +
                              " outside 1..1024");
}

SessionRecorder::SessionRecorder(std::unique_ptr<SessionSink> sink, SessionRecorderOptions options)
    : sink_(std::move(sink)), options_(options) {
    options_.validate();
    if (!sink_) throw InvalidArgument("SessionRecorder: no sink");
    thread_ = std::thread([this] { run(); });
}

SessionRecorder::~SessionRecorder() {
    {
        std::lock_guard<std::mutex> lock(mutex_);
        stop_ = true;
    }
    wake_.notify_all();
    thread_.join();
    const SessionRecorderStatus s = status();
    if (s.unrecorded() > 0)
        logger().warn("recording of %s ended: %zu pairs recorded, %zu NOT recorded (%zu queue full, %zu write "
                      "errors; last: %s)",
                      sink_->describe().c_str(), s.recorded, s.unrecorded(), s.dropped, s.failed,
                      s.lastError.c_str());
    else
        logger().info("recording of %s ended: %zu pairs recorded", sink_->describe().c_str(), s.recorded);
}

bool SessionRecorder::record(const StereoImagePair& pair, std::uint64_t iteration, std::uint32_t configVersion,
                             std::optional<std::string> configXml, std::optional<VisionTargets> result) {
    std::unique_lock<std::mutex> lock(mutex_);
    // Remember every configuration, even that of a pair that is dropped, so a
    // later pair of the same version can carry it.
    if (configXml) xmlByVersion_[configVersion] = std::make_shared<const std::string>(std::move(*configXml));
    if (queue_.size() >= options_.queueCapacity) {
        ++status_.dropped;
        status_.lastError = "iteration " + std::to_string(iteration) + " not recorded: the queue of " +
                            std::to_string(options_.queueCapacity) + " pairs is full (" + sink_->describe() +
                            " is slower than the acquisition)";
        const std::string message = status_.lastError + "; " + std::to_string(status_.unrecorded()) +
                                    " pairs not recorded so far";
        const bool change = !losing_;
        losing_ = true;
        lock.unlock();
        // A loss of recording is a state change: logged once, then once more when it ends.
        if (change) logger().warn("%s", message.c_str());
        else logger().debug("%s", message.c_str());
        return false;
    }
    Item item;
    item.pair = pair.ownsPixels() ? pair : pair.clone();
    item.iteration = iteration;
    item.configVersion = configVersion;
    item.xmlApplied = configXml.has_value();
    const auto known = xmlByVersion_.find(configVersion);
    if (known != xmlByVersion_.end()) item.versionXml = known->second;
    item.result = std::move(result);
    queue_.push_back(std::move(item));
    status_.backlog = queue_.size();
    lock.unlock();
    wake_.notify_one();
    return true;
}

void SessionRecorder::flush() {
    std::unique_lock<std::mutex> lock(mutex_);
    idle_.wait(lock, [this] { return queue_.empty() && !writing_; });
}

SessionRecorderStatus SessionRecorder::status() const {
    std::lock_guard<std::mutex> lock(mutex_);
    return status_;
}

void SessionRecorder::run() {
    for (;;) {
        Item item;
        {
            std::unique_lock<std::mutex> lock(mutex_);
            wake_.wait(lock, [this] { return stop_ || !queue_.empty(); });
            if (queue_.empty()) return;  // stop_ and everything written
            item = std::move(queue_.front());
            queue_.pop_front();
            writing_ = true;
        }
        write(item);
        {
            std::lock_guard<std::mutex> lock(mutex_);
            writing_ = false;
            status_.backlog = queue_.size();
            if (queue_.empty()) idle_.notify_all();
        }
    }
}

void SessionRecorder::fail(const std::string& message) {
    std::size_t unrecorded = 0;
    bool change = false;
    {
        std::lock_guard<std::mutex> lock(mutex_);
        ++status_.failed;
        status_.lastError = message;
        unrecorded = status_.unrecorded();
        change = !losing_;
        losing_ = true;
    }
    if (change) logger().error("%s; %zu pairs not recorded so far", message.c_str(), unrecorded);
    else logger().debug("%s; %zu pairs not recorded so far", message.c_str(), unrecorded);
}

void SessionRecorder::write(Item& item) {
    const std::string what = "iteration " + std::to_string(item.iteration) + " not recorded in " +
                             sink_->describe() + ": ";
    try {
        SessionRecord record;
        record.iteration = item.iteration;
        record.acquisition = item.pair.id();
        record.configVersion = item.configVersion;
        record.result = std::move(item.result);
        record.files = sink_->writePair(item.pair);  // may start a new session (SessionLogSink)
        // A session's first record carries the configuration, as does a record where it changed.
        if (sink_->atSessionStart()) appendedVersion_.reset();
        const bool versionChanged = !appendedVersion_ || *appendedVersion_ != item.configVersion;
        if (item.versionXml && (item.xmlApplied || versionChanged)) record.configXml = *item.versionXml;
        sink_->append(record);
        appendedVersion_ = item.configVersion;
        std::size_t unrecorded = 0;
        bool resumed = false;
        {
            std::lock_guard<std::mutex> lock(mutex_);
            ++status_.recorded;
            resumed = losing_;
            losing_ = false;
            unrecorded = status_.unrecorded();
        }
        if (resumed)
            logger().notice("recording resumed in %s at iteration %llu (%zu pairs not recorded so far)",
                            sink_->describe().c_str(), static_cast<unsigned long long>(item.iteration), unrecorded);
    } catch (const std::exception& e) {
        // avatar::Error names the file; anything else (bad_alloc) is reported the same way.
        fail(what + e.what());
    }
}

}  // namespace avatar
