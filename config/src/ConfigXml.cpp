#include <avatar/config/ConfigXml.h>

#include "ConfigReader.h"
#include "ConfigValidate.h"
#include "ConfigWriter.h"

#include <fcntl.h>
#include <unistd.h>

#include <cerrno>
#include <cstdio>
#include <cstring>
#include <fstream>
#include <random>
#include <sstream>
#include <system_error>
#include <utility>

namespace avatar {

namespace {

std::string errnoText(int error) {
    return std::generic_category().message(error);
}

/// Owns a file descriptor.
class Fd {
public:
    explicit Fd(int fd) : fd_(fd) {}
    Fd(const Fd&) = delete;
    Fd& operator=(const Fd&) = delete;
    ~Fd() {
        if (fd_ >= 0) {
            ::close(fd_);
        }
    }
    int get() const { return fd_; }
    /// Closes now and reports the result (close can report a deferred write error).
    int close() {
        const int result = ::close(fd_);
        fd_ = -1;
        return result;
    }

private:
    int fd_;
};

/// Removes a temporary file unless released.
class TempFileGuard {
public:
    explicit TempFileGuard(std::filesystem::path path) : path_(std::move(path)) {}
    TempFileGuard(const TempFileGuard&) = delete;
    TempFileGuard& operator=(const TempFileGuard&) = delete;
    ~TempFileGuard() {
        if (!released_) {
            std::error_code ignored;  // best effort on a path that is already failing
            std::filesystem::remove(path_, ignored);
        }
    }
    void release() { released_ = true; }

private:
    std::filesystem::path path_;
    bool released_{false};
};

void writeAll(int fd, const std::string& data, const std::filesystem::path& tempPath,
              const std::filesystem::path& target) {
    std::size_t done = 0;
    while (done < data.size()) {
        const ssize_t n = ::write(fd, data.data() + done, data.size() - done);
        if (n < 0) {
            if (errno == EINTR) {
                continue;
            }
            throw IoError("cannot write config file '" + target.string() + "' (temporary '" + tempPath.string() +
                          "'): " + errnoText(errno));
        }
        done += static_cast<std::size_t>(n);
    }
}

}  // namespace

ConfigError::ConfigError(std::string source, int line, std::string elementPath, std::string problem)
    : Error(source + ":" + std::to_string(line) + ": " + elementPath + ": " + problem),
      source_(std::move(source)),
      line_(line),
      path_(std::move(elementPath)),
      problem_(std::move(problem)) {}

AvatarConfig readConfigString(const std::string& xml, const std::string& sourceName) {
    config_internal::ParsedDocument parsed = config_internal::parseDocument(xml, sourceName);
    config_internal::validate(parsed.config, config_internal::ErrorSite(sourceName, &parsed.lines));
    return std::move(parsed.config);
}

AvatarConfig readConfigFile(const std::filesystem::path& path) {
    std::error_code ec;
    if (std::filesystem::is_directory(path, ec)) {
        throw IoError("cannot read config file '" + path.string() + "': it is a directory");
    }
    std::ifstream in(path, std::ios::binary);
    if (!in) {
        throw IoError("cannot open config file '" + path.string() + "': " + errnoText(errno));
    }
    std::ostringstream text;
    text << in.rdbuf();
    if (in.bad()) {
        throw IoError("cannot read config file '" + path.string() + "': " + errnoText(errno));
    }
    return readConfigString(text.str(), path.string());
}

std::string writeConfigString(const AvatarConfig& config) {
    validateConfig(config);
    return config_internal::formatDocument(config);
}

void writeConfigFile(const AvatarConfig& config, const std::filesystem::path& path) {
    const std::string text = writeConfigString(config);  // validates before touching the disk

    // The temporary lives in the target's directory so that rename() is atomic.
    const std::filesystem::path dir = path.has_parent_path() ? path.parent_path() : std::filesystem::path(".");
    std::random_device entropy;
    int fd = -1;
    std::filesystem::path tempPath;
    for (int attempt = 0; attempt < 100 && fd < 0; ++attempt) {
        tempPath = dir / ("." + path.filename().string() + ".tmp-" + std::to_string(::getpid()) + "-" +
                          std::to_string(entropy()));
        fd = ::open(tempPath.c_str(), O_WRONLY | O_CREAT | O_EXCL | O_CLOEXEC, 0666);
        if (fd < 0 && errno != EEXIST) {
            throw IoError("cannot write config file '" + path.string() + "': cannot create '" + tempPath.string() +
                          "': " + errnoText(errno));
        }
    }
    if (fd < 0) {
        throw IoError("cannot write config file '" + path.string() + "': no free temporary name in '" +
                      dir.string() + "'");
    }
    Fd file(fd);
    TempFileGuard guard(tempPath);

    writeAll(file.get(), text, tempPath, path);
    if (::fsync(file.get()) != 0 || file.close() != 0) {
        throw IoError("cannot write config file '" + path.string() + "' (temporary '" + tempPath.string() +
                      "'): " + errnoText(errno));
    }
    if (std::rename(tempPath.c_str(), path.c_str()) != 0) {
        throw IoError("cannot replace config file '" + path.string() + "': " + errnoText(errno));
    }
    guard.release();

    // Make the rename itself durable. The new file is already in place, so a
    // directory that cannot be synced (some file systems refuse) is not an error.
    const int dirFd = ::open(dir.c_str(), O_RDONLY | O_DIRECTORY | O_CLOEXEC);
    if (dirFd >= 0) {
        Fd dirFile(dirFd);
        static_cast<void>(::fsync(dirFile.get()));
    }
}

void validateConfig(const AvatarConfig& config) {
    config_internal::validate(config, config_internal::ErrorSite("<memory>", nullptr));
}

std::filesystem::path resolveConfigPath(const std::filesystem::path& configFile, const std::string& stored) {
    const std::filesystem::path p(stored);
    if (p.empty() || p.is_absolute()) {
        return p;
    }
    return configFile.parent_path() / p;
}

}  // namespace avatar
