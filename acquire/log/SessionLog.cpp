#include <avatar/common/internal/FileUtil.h>
#include <avatar/common/internal/Text.h>
#include "RawImageFile.h"
#include "SessionLogFormat.h"

#include <avatar/acquire/SessionLog.h>
#include <avatar/common/Error.h>
#include <avatar/common/Logging.h>

#include <fcntl.h>
#include <unistd.h>

#include <log4cpp/Category.hh>

#include <cerrno>
#include <system_error>
#include <utility>

namespace avatar {
namespace fs = std::filesystem;

namespace {

log4cpp::Category& logger() { return logging::category("acquire"); }

bool sameStamp(const CameraStamp& a, const CameraStamp& b) {
    return a.cameraId == b.cameraId && a.timestampUs == b.timestampUs;
}

bool sameAcquisition(const AcquisitionId& a, const AcquisitionId& b) {
    return a.group == b.group && a.member == b.member && sameStamp(a.left, b.left) &&
           sameStamp(a.right, b.right);
}

}  // namespace

// ---------------------------------------------------------------- writer

SessionLogWriter::SessionLogWriter(fs::path sessionDirectory)
    : directory_(std::move(sessionDirectory)), logPath_(directory_ / kSessionLogFileName) {
    std::error_code ec;
    fs::create_directories(directory_, ec);
    if (ec) throw IoError("cannot create session directory " + directory_.string() + ": " + ec.message());
    fd_ = ::open(logPath_.c_str(), O_WRONLY | O_CREAT | O_EXCL | O_APPEND | O_CLOEXEC, 0644);
    if (fd_ < 0) {
        const int err = errno;
        if (err == EEXIST)
            throw IoError("session log " + logPath_.string() +
                          " exists already; a session is never appended to or overwritten");
        throw IoError("cannot create session log " + logPath_.string() + ": " +
                      std::generic_category().message(err));
    }
    try {
        const std::string header = sessionlog::headerLine();
        fileutil::writeAll(fd_, header.data(), header.size(), logPath_);
        if (::fsync(fd_) != 0)
            throw IoError("cannot sync session log " + logPath_.string() + ": " +
                          std::generic_category().message(errno));
        fileutil::syncDirectory(directory_);
    } catch (...) {
        ::close(fd_);
        throw;
    }
    logger().info("recording session log %s (format version %d)", logPath_.c_str(), kSessionLogVersion);
}

SessionLogWriter::~SessionLogWriter() {
    if (fd_ >= 0 && ::close(fd_) != 0)
        logger().error("closing session log %s failed: %s", logPath_.c_str(),
                       std::generic_category().message(errno).c_str());
}

PairFiles SessionLogWriter::writePair(const StereoImagePair& pair, Compression compression,
                                      ByteOrder rawByteOrder) {
    if (pair.empty()) throw InvalidArgument("session " + directory_.string() + ": cannot record an empty pair");
    PairFiles files;
    for (Side side : {Side::Left, Side::Right}) {
        RawImageName name;
        name.side = side;
        name.group = pair.id().group;
        name.member = pair.id().member;
        name.geometry = geometryOf(pair.image(side), pair.layout(), rawByteOrder);
        try {
            (side == Side::Left ? files.left : files.right) =
                writeImageFile(directory_, pair.image(side), name, compression);
        } catch (...) {
            // The right image failed: the left one, already under its final name, goes too.
            if (side == Side::Right) {
                std::error_code ec;
                fs::remove(directory_ / files.left.name, ec);
            }
            throw;
        }
    }
    logger().debug("session %s: wrote %s and %s", directory_.c_str(), files.left.name.c_str(),
                   files.right.name.c_str());
    return files;
}

void SessionLogWriter::append(const SessionRecord& record) {
    const std::string where =
        "session log " + logPath_.string() + ", record of iteration " + std::to_string(record.iteration) + ": ";
    if (count_ > 0 && record.iteration <= lastIteration_)
        throw InvalidArgument(where + "iteration does not follow the previous record's " +
                              std::to_string(lastIteration_));
    const AcquisitionId& a = record.acquisition;
    try {
        sessionlog::checkFileName("leftFile", record.files.left.name, Side::Left, a.group, a.member);
        sessionlog::checkFileName("rightFile", record.files.right.name, Side::Right, a.group, a.member);
    } catch (const FormatError& e) {
        throw InvalidArgument(where + e.what());
    }
    for (const auto* file : {&record.files.left, &record.files.right}) {
        std::error_code ec;
        if (!fs::is_regular_file(directory_ / file->name, ec))
            throw InvalidArgument(where + "image file " + (directory_ / file->name).string() + " does not exist");
    }
    const bool versionChanges = count_ == 0 || record.configVersion != lastConfigVersion_;
    if (versionChanges && !record.configXml)
        throw InvalidArgument(where + "configuration version " + std::to_string(record.configVersion) +
                              (count_ == 0 ? " is the first" : " differs from the previous record's " +
                                                                   std::to_string(lastConfigVersion_)) +
                              " but the record does not carry its XML (configXml)");
    if (record.result) {
        if (record.result->iteration != record.iteration)
            throw InvalidArgument(where + "the result is of iteration " +
                                  std::to_string(record.result->iteration));
        if (!sameAcquisition(record.result->acquisition, a))
            throw InvalidArgument(where + "the result's acquisition (group " +
                                  std::to_string(record.result->acquisition.group) + " member " +
                                  std::to_string(record.result->acquisition.member) +
                                  ", camera stamps) differs from the record's");
    }

    if (failed_)
        throw IoError("session log " + logPath_.string() +
                      ": an earlier write failed, the log may end in a partial line; start a new session");
    const std::string line = sessionlog::formatRecord(record);
    failed_ = true;  // until the line is known to be on disk
    fileutil::writeAll(fd_, line.data(), line.size(), logPath_);
    if (::fdatasync(fd_) != 0)
        throw IoError("cannot sync session log " + logPath_.string() + ": " +
                      std::generic_category().message(errno));
    failed_ = false;
    ++count_;
    lastIteration_ = record.iteration;
    lastConfigVersion_ = record.configVersion;
    logger().debug("session log %s: iteration %llu recorded", logPath_.c_str(),
                   static_cast<unsigned long long>(record.iteration));
}

// ---------------------------------------------------------------- reader

SessionLogReader::SessionLogReader(fs::path sessionDirectory)
    : directory_(std::move(sessionDirectory)), logPath_(directory_ / kSessionLogFileName) {
    const std::vector<unsigned char> bytes = fileutil::readWholeFile(logPath_, "session log");
    const std::string_view text(reinterpret_cast<const char*>(bytes.data()), bytes.size());
    const std::string prefix = logPath_.string() + ":";
    if (text.empty())
        throw FormatError(prefix + "1: empty file; expected the header '" + std::string(kSessionLogFormatName) +
                          " " + std::to_string(kSessionLogVersion) + "'");
    std::size_t end = text.find('\n');
    if (end == std::string_view::npos)
        throw FormatError(prefix + "1: the header line has no line end (writing was interrupted)");
    try {
        version_ = sessionlog::parseHeader(text.substr(0, end));
    } catch (const FormatError& e) {
        throw FormatError(prefix + "1: " + e.what());
    }

    std::size_t lineNo = 1;
    for (std::size_t start = end + 1; start < text.size(); start = end + 1) {
        ++lineNo;
        SessionLogEntry entry;
        entry.line = lineNo;
        end = text.find('\n', start);
        if (end == std::string_view::npos) {
            entry.error = prefix + std::to_string(lineNo) + ": truncated record: the last line has no line end (" +
                          std::to_string(text.size() - start) + " bytes; writing was probably interrupted)";
            entries_.push_back(std::move(entry));
            break;
        }
        try {
            entry.record = sessionlog::parseRecord(text.substr(start, end - start), version_);
        } catch (const FormatError& e) {
            entry.error = prefix + std::to_string(lineNo) + ": " + e.what();
        }
        entries_.push_back(std::move(entry));
    }

    // Iterations increase and pairs are acquired in order: a record that
    // repeats or goes back (a duplicated line, two lines swapped) is damage.
    const SessionRecord* previous = nullptr;
    std::size_t previousLine = 0;
    for (auto& e : entries_) {
        if (!e.ok()) continue;
        const SessionRecord& r = *e.record;
        std::string problem;
        if (previous && r.iteration <= previous->iteration) {
            problem = "iteration " + std::to_string(r.iteration) + " does not follow iteration " +
                      std::to_string(previous->iteration) + " of line " + std::to_string(previousLine) +
                      " (a record repeated or out of order)";
        } else if (previous && r.acquisition.left.timestampUs > 0 && previous->acquisition.left.timestampUs > 0 &&
                   r.acquisition.left.timestampUs < previous->acquisition.left.timestampUs) {
            problem = "its pair was acquired " +
                      std::to_string(previous->acquisition.left.timestampUs - r.acquisition.left.timestampUs) +
                      " us before that of line " + std::to_string(previousLine) + " (a record out of order)";
        }
        if (!problem.empty()) {
            e.error = prefix + std::to_string(e.line) + ": " + problem;
            e.record.reset();
            continue;
        }
        previous = &*e.record;
        previousLine = e.line;
    }

    std::size_t damaged = 0;
    for (const auto& e : entries_) damaged += e.ok() ? 0 : 1;
    if (damaged > 0)
        logger().warn("session log %s: %zu of %zu records damaged", logPath_.c_str(), damaged, entries_.size());
    else
        logger().info("session log %s: %zu records", logPath_.c_str(), entries_.size());
}

std::vector<SessionRecord> SessionLogReader::records() const {
    std::vector<SessionRecord> out;
    for (const auto& e : entries_)
        if (e.record) out.push_back(*e.record);
    return out;
}

std::vector<std::string> SessionLogReader::errors() const {
    std::vector<std::string> out;
    for (const auto& e : entries_)
        if (!e.ok()) out.push_back(e.error);
    return out;
}

std::optional<std::string> SessionLogReader::configXml(std::uint32_t configVersion) const {
    for (const auto& e : entries_)
        if (e.record && e.record->configVersion == configVersion && e.record->configXml)
            return e.record->configXml;
    return std::nullopt;
}

StereoImagePair SessionLogReader::loadPair(const SessionRecord& record) const {
    const std::string where = "iteration " + std::to_string(record.iteration) + ": ";
    const AcquisitionId& a = record.acquisition;
    RawImageName names[2];
    cv::Mat images[2];
    const ImageFileRef* files[2] = {&record.files.left, &record.files.right};
    for (int i = 0; i < 2; ++i) {
        const Side side = i == 0 ? Side::Left : Side::Right;
        try {
            sessionlog::checkFileName(side == Side::Left ? "leftFile" : "rightFile", files[i]->name, side,
                                      a.group, a.member);
        } catch (const FormatError& e) {
            throw FormatError(where + e.what());
        }
        names[i] = RawImageName::parse(files[i]->name);
        try {
            images[i] = readImageFile(directory_ / files[i]->name, files[i]->crc32);
        } catch (const IoError& e) {
            throw IoError(where + e.what());
        } catch (const FormatError& e) {
            throw FormatError(where + e.what());
        }
    }
    const RawImageGeometry& l = names[0].geometry;
    const RawImageGeometry& r = names[1].geometry;
    if (l.width != r.width || l.height != r.height || l.bitDepth != r.bitDepth || l.format != r.format ||
        (l.format == PixelFormat::Bayer && l.bayerPattern != r.bayerPattern))
        throw FormatError(where + files[0]->name + " and " + files[1]->name +
                          " do not describe images of the same size and layout");
    const PairLayout layout{l.format, l.bayerPattern, l.bitDepth};
    try {
        return StereoImagePair(images[0], images[1], layout, a);
    } catch (const InvalidArgument& e) {
        throw FormatError(where + files[0]->name + " and " + files[1]->name + " do not form a pair: " + e.what());
    }
}

}  // namespace avatar
