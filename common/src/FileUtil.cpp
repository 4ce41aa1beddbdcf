#include <avatar/common/internal/FileUtil.h>

#include <avatar/common/Error.h>

#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>

#include <cerrno>
#include <fstream>
#include <iterator>
#include <random>
#include <system_error>

namespace avatar::fileutil {
namespace fs = std::filesystem;

std::string errnoText(int error) { return std::generic_category().message(error); }

FileDescriptor::~FileDescriptor() {
    if (fd_ >= 0) ::close(fd_);
}

FileDescriptor& FileDescriptor::operator=(FileDescriptor&& other) noexcept {
    if (this != &other) {
        if (fd_ >= 0) ::close(fd_);
        fd_ = other.fd_;
        other.fd_ = -1;
    }
    return *this;
}

int FileDescriptor::close() {
    const int rc = ::close(fd_);
    fd_ = -1;
    return rc;
}

FileDescriptor openForReading(const fs::path& path, const std::string& what, std::size_t& size) {
    std::error_code ec;
    const bool regular = fs::is_regular_file(path, ec);
    if (!regular) {
        if (!fs::exists(path, ec)) throw IoError(what + " " + path.string() + " does not exist");
        throw IoError(what + " " + path.string() + " is not a regular file");
    }
    FileDescriptor fd(::open(path.c_str(), O_RDONLY | O_CLOEXEC));
    if (!fd.valid()) throw IoError("cannot open " + what + " " + path.string() + ": " + errnoText(errno));
    struct stat st {};
    if (::fstat(fd.get(), &st) != 0) throw IoError("cannot read " + what + " " + path.string() + ": " + errnoText(errno));
    if (!S_ISREG(st.st_mode)) throw IoError(what + " " + path.string() + " is not a regular file");
    size = static_cast<std::size_t>(st.st_size);
    return fd;
}

void readAll(int fd, void* data, std::size_t size, const fs::path& path, const std::string& what) {
    auto* p = static_cast<unsigned char*>(data);
    std::size_t done = 0;
    while (done < size) {
        const ssize_t n = ::read(fd, p + done, size - done);
        if (n < 0) {
            if (errno == EINTR) continue;
            throw IoError("cannot read " + what + " " + path.string() + ": " + errnoText(errno));
        }
        if (n == 0)
            throw IoError("cannot read " + what + " " + path.string() + ": it ended after " + std::to_string(done) +
                          " of " + std::to_string(size) + " bytes (changed while being read?)");
        done += static_cast<std::size_t>(n);
    }
}

std::vector<unsigned char> readWholeFile(const fs::path& path, const std::string& what) {
    std::size_t size = 0;
    const FileDescriptor fd = openForReading(path, what, size);
    std::vector<unsigned char> bytes(size);
    readAll(fd.get(), bytes.data(), size, path, what);
    return bytes;
}

namespace {

/// Writes all bytes, retrying short writes and EINTR; 0 or the errno of the failure.
int writeFully(int fd, const void* data, std::size_t size) {
    const auto* p = static_cast<const unsigned char*>(data);
    while (size > 0) {
        const ssize_t n = ::write(fd, p, size);
        if (n < 0) {
            if (errno == EINTR) continue;
            return errno;
        }
        p += n;
        size -= static_cast<std::size_t>(n);
    }
    return 0;
}

}  // namespace

void writeAll(int fd, const void* data, std::size_t size, const fs::path& path) {
    if (const int error = writeFully(fd, data, size)) throw IoError("cannot write " + path.string() + ": " + errnoText(error));
}

void syncDirectory(const fs::path& directory) {
    FileDescriptor dir(::open(directory.c_str(), O_RDONLY | O_DIRECTORY | O_CLOEXEC));
    if (!dir.valid() || ::fsync(dir.get()) != 0)
        throw IoError("cannot sync directory " + directory.string() + ": " + errnoText(errno));
}

namespace {

/// Removes a temporary file unless released.
class TemporaryFile {
public:
    explicit TemporaryFile(fs::path path) : path_(std::move(path)) {}
    TemporaryFile(const TemporaryFile&) = delete;
    TemporaryFile& operator=(const TemporaryFile&) = delete;
    ~TemporaryFile() {
        if (!released_) {
            std::error_code ignored;  // best effort on a path that is already failing
            fs::remove(path_, ignored);
        }
    }
    const fs::path& path() const { return path_; }
    void release() { released_ = true; }

private:
    fs::path path_;
    bool released_{false};
};

fs::path directoryOf(const fs::path& path) { return path.has_parent_path() ? path.parent_path() : fs::path("."); }

}  // namespace

void writeNewFileDurably(const fs::path& path, const void* data, std::size_t size) {
    std::error_code ec;
    if (fs::exists(path, ec))
        throw IoError("file " + path.string() + " exists already; recorded files are never overwritten");
    TemporaryFile temp(path.parent_path() / ("." + path.filename().string() + ".partial"));
    FileDescriptor fd(::open(temp.path().c_str(), O_WRONLY | O_CREAT | O_EXCL | O_CLOEXEC, 0644));
    if (!fd.valid()) {
        temp.release();  // not ours: another writer's, or it could not be created
        throw IoError("cannot create " + temp.path().string() + ": " + errnoText(errno));
    }
    writeAll(fd.get(), data, size, temp.path());
    if (::fsync(fd.get()) != 0) throw IoError("cannot sync " + temp.path().string() + ": " + errnoText(errno));
    if (fd.close() != 0) throw IoError("cannot close " + temp.path().string() + ": " + errnoText(errno));
    if (fs::exists(path, ec))
        throw IoError("file " + path.string() + " exists already; recorded files are never overwritten");
    fs::rename(temp.path(), path, ec);
    if (ec) throw IoError("cannot rename " + temp.path().string() + " to " + path.string() + ": " + ec.message());
    temp.release();
    syncDirectory(directoryOf(path));
}

void replaceFileAtomically(const fs::path& path, const std::string& data, const std::string& what) {
    // The temporary lives in the target's directory so that rename() is atomic.
    const fs::path dir = directoryOf(path);
    std::random_device entropy;
    FileDescriptor fd;
    fs::path tempPath;
    for (int attempt = 0; attempt < 100 && !fd.valid(); ++attempt) {
        tempPath = dir / ("." + path.filename().string() + ".tmp-" + std::to_string(::getpid()) + "-" +
                          std::to_string(entropy()));
        fd = FileDescriptor(::open(tempPath.c_str(), O_WRONLY | O_CREAT | O_EXCL | O_CLOEXEC, 0666));
        if (!fd.valid() && errno != EEXIST)
            throw IoError("cannot write " + what + " '" + path.string() + "': cannot create '" + tempPath.string() +
                          "': " + errnoText(errno));
    }
    if (!fd.valid())
        throw IoError("cannot write " + what + " '" + path.string() + "': no free temporary name in '" +
                      dir.string() + "'");
    TemporaryFile temp(tempPath);
    const auto failed = [&](int error) {
        return IoError("cannot write " + what + " '" + path.string() + "' (temporary '" + tempPath.string() +
                       "'): " + errnoText(error));
    };
    if (const int error = writeFully(fd.get(), data.data(), data.size())) throw failed(error);
    if (::fsync(fd.get()) != 0 || fd.close() != 0) throw failed(errno);
    if (std::rename(tempPath.c_str(), path.c_str()) != 0)
        throw IoError("cannot replace " + what + " '" + path.string() + "': " + errnoText(errno));
    temp.release();
    // Make the rename itself durable. The new file is already in place, so a
    // directory that cannot be synced (some file systems refuse) is not an error.
    FileDescriptor dirFd(::open(dir.c_str(), O_RDONLY | O_DIRECTORY | O_CLOEXEC));
    if (dirFd.valid()) static_cast<void>(::fsync(dirFd.get()));
}

}  // namespace avatar::fileutil
