#include <avatar/acquire/AcquireSIPFileLoader.h>

#include <avatar/common/Logging.h>
#include <avatar/common/StereoImagePairFileIO.h>

#include <log4cpp/Category.hh>

#include <chrono>

namespace avatar {
namespace {

log4cpp::Category& logger() { return logging::category("acquire"); }

/// A printf-style pattern split at its one integer conversion.
struct ParsedPattern {
    std::string prefix;  ///< literal text before the conversion (%% already turned into %)
    std::string suffix;  ///< literal text after it
    std::size_t width{0};
    bool zeroPad{false};
};

ParsedPattern parsePattern(const std::string& pattern, const char* side) {
    auto fail = [&](const std::string& problem) {
        return InvalidArgument(std::string("file pattern (") + side + ") '" + pattern + "': " + problem);
    };
    ParsedPattern parsed;
    bool found = false;
    for (std::size_t i = 0; i < pattern.size(); ++i) {
        const char c = pattern[i];
        std::string& text = found ? parsed.suffix : parsed.prefix;
        if (c != '%') {
            text += c;
            continue;
        }
        if (i + 1 < pattern.size() && pattern[i + 1] == '%') {
            text += '%';
            ++i;
            continue;
        }
        if (found) throw fail("more than one conversion (only one integer conversion such as %04d is allowed)");
        std::size_t j = i + 1;
        if (j < pattern.size() && pattern[j] == '0') {
            parsed.zeroPad = true;
            ++j;
        }
        std::size_t width = 0;
        while (j < pattern.size() && pattern[j] >= '0' && pattern[j] <= '9') {
            width = width * 10 + static_cast<std::size_t>(pattern[j] - '0');
            if (width > 20) throw fail("field width above 20");
            ++j;
        }
        if (j >= pattern.size() || (pattern[j] != 'd' && pattern[j] != 'u'))
            throw fail("conversion at offset " + std::to_string(i) + " is not %d, %u, %<width>d or %0<width>d");
        parsed.width = width;
        found = true;
        i = j;
    }
    if (!found) throw fail("no integer conversion (such as %04d)");
    return parsed;
}

std::string expand(const ParsedPattern& p, std::uint64_t index) {
    std::string digits = std::to_string(index);
    if (digits.size() < p.width) digits.insert(0, p.width - digits.size(), p.zeroPad ? '0' : ' ');
    return p.prefix + digits + p.suffix;
}

std::int64_t nowUs() {
    return std::chrono::duration_cast<std::chrono::microseconds>(
               std::chrono::system_clock::now().time_since_epoch())
        .count();
}

}  // namespace

void StereoFilePattern::validate() const {
    parsePattern(left, "left");
    parsePattern(right, "right");
}

StereoFilePaths StereoFilePattern::at(std::uint64_t index) const {
    return {expand(parsePattern(left, "left"), index), expand(parsePattern(right, "right"), index)};
}

AcquireSIPFileLoader::AcquireSIPFileLoader(std::vector<StereoFilePaths> pairs, std::uint32_t groupSize)
    : AcquireStereoImagePair(groupSize), list_(std::move(pairs)) {
    if (!peek()) finish();
}

AcquireSIPFileLoader::AcquireSIPFileLoader(StereoFilePattern pattern, std::uint32_t groupSize)
    : AcquireStereoImagePair(groupSize), pattern_(std::move(pattern)) {
    pattern_->validate();
    position_ = pattern_->start;
    if (!peek()) finish();
}

AcquisitionStatus AcquireSIPFileLoader::status() const {
    std::lock_guard<std::mutex> lock(mutex_);
    return status_;
}

std::size_t AcquireSIPFileLoader::deliveredCount() const {
    std::lock_guard<std::mutex> lock(mutex_);
    return delivered_;
}

std::size_t AcquireSIPFileLoader::failedCount() const {
    std::lock_guard<std::mutex> lock(mutex_);
    return failed_;
}

void AcquireSIPFileLoader::finish() {
    std::lock_guard<std::mutex> lock(mutex_);
    status_.state = AcquisitionStatus::State::Finished;
    status_.message = "files: all pairs delivered (" + std::to_string(delivered_) + " read, " +
                      std::to_string(failed_) + " unreadable" +
                      (lastError_.empty() ? std::string() : "; last error: " + lastError_) + ")";
    logger().notice("%s", status_.message.c_str());
}

std::optional<StereoFilePaths> AcquireSIPFileLoader::peek() const {
    if (!pattern_) {
        if (position_ >= list_.size()) return std::nullopt;
        return list_[position_];
    }
    if (pattern_->count && position_ - pattern_->start >= *pattern_->count) return std::nullopt;
    StereoFilePaths paths = pattern_->at(position_);
    if (!pattern_->count) {
        std::error_code ec;
        const bool left = std::filesystem::exists(paths.left, ec);
        const bool right = std::filesystem::exists(paths.right, ec);
        if (!left && !right) return std::nullopt;  // the end of an open-ended sequence
    }
    return paths;
}

AcquiredPair AcquireSIPFileLoader::grab() {
    const std::optional<StereoFilePaths> paths = peek();
    if (!paths) {
        if (status().state != AcquisitionStatus::State::Finished) finish();
        throw AcquisitionError("files: no more pairs: " + status().message);
    }
    ++position_;
    AcquiredPair out;
    std::string error;
    try {
        const std::int64_t t = nowUs();
        AcquisitionId id;
        id.left.timestampUs = t;
        id.right.timestampUs = t;
        cv::Mat left = StereoImagePairFileIO::readDisplay(paths->left);
        cv::Mat right = StereoImagePairFileIO::readDisplay(paths->right);
        if (left.size() != right.size())
            throw FormatError(paths->left.string() + " (" + std::to_string(left.cols) + "x" +
                              std::to_string(left.rows) + ") and " + paths->right.string() + " (" +
                              std::to_string(right.cols) + "x" + std::to_string(right.rows) +
                              ") are not the same size");
        out.pair = StereoImagePair(std::move(left), std::move(right), {PixelFormat::Bgr, BayerPattern::BG, 8}, id);
    } catch (const Error& e) {
        error = std::string("files: ") + e.what();
    }
    {
        std::lock_guard<std::mutex> lock(mutex_);
        if (error.empty()) {
            ++delivered_;
            status_ = {};
        } else {
            ++failed_;
            lastError_ = error;
            status_.state = AcquisitionStatus::State::Recovering;
            status_.message = error;
        }
    }
    if (!peek()) finish();  // say Finished with the last pair, before a caller asks for more
    if (!error.empty()) {
        logger().warn("%s", error.c_str());
        throw AcquisitionError(error);
    }
    return out;
}

}  // namespace avatar
