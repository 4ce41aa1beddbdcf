#include "FileUtil.h"

#include <avatar/common/Error.h>

#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>

#include <cerrno>
#include <cstring>
#include <fstream>
#include <iterator>
#include <system_error>

namespace avatar::fileutil {
namespace fs = std::filesystem;

namespace {

std::string errnoText(int err) { return std::generic_category().message(err); }

// Closes a file descriptor when it goes out of scope.
class Fd {
public:
    explicit Fd(int fd) : fd_(fd) {}
    ~Fd() {
        if (fd_ >= 0) ::close(fd_);
    }
    Fd(const Fd&) = delete;
    Fd& operator=(const Fd&) = delete;
    int get() const { return fd_; }
    /// Closes now and reports failure (close can report a delayed write error).
    int close() {
        const int rc = ::close(fd_);
        fd_ = -1;
        return rc;
    }

private:
    int fd_;
};

}  // namespace

std::string hex8(std::uint32_t value) {
    static const char digits[] = "0123456789abcdef";
    std::string out(8, '0');
    for (int i = 7; i >= 0; --i, value >>= 4) out[static_cast<std::size_t>(i)] = digits[value & 0xF];
    return out;
}

std::vector<unsigned char> readWholeFile(const fs::path& path, const std::string& what) {
    std::error_code ec;
    const bool regular = fs::is_regular_file(path, ec);
    if (!regular) {
        if (!fs::exists(path, ec)) throw IoError(what + " " + path.string() + " does not exist");
        throw IoError(what + " " + path.string() + " is not a regular file");
    }
    std::ifstream in(path, std::ios::binary);
    if (!in) throw IoError("cannot open " + what + " " + path.string() + ": " + errnoText(errno));
    std::vector<unsigned char> bytes((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
    if (in.bad()) throw IoError("cannot read " + what + " " + path.string());
    return bytes;
}

void writeAll(int fd, const void* data, std::size_t size, const fs::path& path) {
    const auto* p = static_cast<const unsigned char*>(data);
    while (size > 0) {
        const ssize_t n = ::write(fd, p, size);
        if (n < 0) {
            if (errno == EINTR) continue;
            throw IoError("cannot write " + path.string() + ": " + errnoText(errno));
        }
        p += n;
        size -= static_cast<std::size_t>(n);
    }
}

void syncDirectory(const fs::path& directory) {
    Fd dir(::open(directory.c_str(), O_RDONLY | O_DIRECTORY | O_CLOEXEC));
    if (dir.get() < 0 || ::fsync(dir.get()) != 0)
        throw IoError("cannot sync directory " + directory.string() + ": " + errnoText(errno));
}

void writeNewFileDurably(const fs::path& path, const void* data, std::size_t size) {
    std::error_code ec;
    if (fs::exists(path, ec))
        throw IoError("file " + path.string() + " exists already; recorded files are never overwritten");
    const fs::path temp = path.parent_path() / ("." + path.filename().string() + ".partial");
    Fd fd(::open(temp.c_str(), O_WRONLY | O_CREAT | O_EXCL | O_CLOEXEC, 0644));
    if (fd.get() < 0) throw IoError("cannot create " + temp.string() + ": " + errnoText(errno));
    try {
        writeAll(fd.get(), data, size, temp);
        if (::fsync(fd.get()) != 0) throw IoError("cannot sync " + temp.string() + ": " + errnoText(errno));
        if (fd.close() != 0) throw IoError("cannot close " + temp.string() + ": " + errnoText(errno));
        if (fs::exists(path, ec))
            throw IoError("file " + path.string() + " exists already; recorded files are never overwritten");
        fs::rename(temp, path, ec);
        if (ec) throw IoError("cannot rename " + temp.string() + " to " + path.string() + ": " + ec.message());
    } catch (...) {
        fs::remove(temp, ec);
        throw;
    }
    syncDirectory(path.parent_path().empty() ? fs::path(".") : path.parent_path());
}

}  // namespace avatar::fileutil
