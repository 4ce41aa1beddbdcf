#pragma once
/// @file FileUtil.h
/// Internal to the AVATAR libraries (not installed): POSIX file handling with
/// avatar::IoError messages that name the file. One home for the RAII file
/// descriptor, whole-file reads and durable/atomic writes that the session log
/// (acquire) and the configuration writer (config) both need.

#include <cstddef>
#include <filesystem>
#include <string>
#include <vector>

namespace avatar::fileutil {

/// The text of an errno value ("No space left on device").
std::string errnoText(int error);

/// Owns a POSIX file descriptor; closes it when it goes out of scope.
class FileDescriptor {
public:
    explicit FileDescriptor(int fd = -1) : fd_(fd) {}
    ~FileDescriptor();
    FileDescriptor(FileDescriptor&& other) noexcept : fd_(other.fd_) { other.fd_ = -1; }
    FileDescriptor& operator=(FileDescriptor&& other) noexcept;
    FileDescriptor(const FileDescriptor&) = delete;
    FileDescriptor& operator=(const FileDescriptor&) = delete;

    int get() const { return fd_; }
    bool valid() const { return fd_ >= 0; }
    /// Closes now and returns close()'s result (it can report a delayed write
    /// error); the descriptor is invalid afterwards either way.
    int close();

private:
    int fd_;
};

/// The bytes of a file. @p what ("image file", "session log") starts the
/// IoError message for a file that is missing, not regular or unreadable.
std::vector<unsigned char> readWholeFile(const std::filesystem::path& path, const std::string& what);

/// Opens a regular file for reading and gives its size, with the IoError
/// messages of readWholeFile(), so a caller can read() it straight into a
/// buffer of its own (an image's samples) instead of through a copy.
FileDescriptor openForReading(const std::filesystem::path& path, const std::string& what, std::size_t& size);

/// Reads exactly @p size bytes (retrying short reads and EINTR); IoError
/// "cannot read <what> <path>: ..." on an error or an early end of file.
void readAll(int fd, void* data, std::size_t size, const std::filesystem::path& path, const std::string& what);

/// Writes all @p size bytes to @p fd (retrying short writes and EINTR);
/// throws avatar::IoError naming @p path.
void writeAll(int fd, const void* data, std::size_t size, const std::filesystem::path& path);

/// fsync of a directory, so that a new or renamed entry in it survives a
/// power loss. Throws avatar::IoError naming the directory.
void syncDirectory(const std::filesystem::path& directory);

/// Writes a file that must not exist yet: to a hidden temporary name in the
/// same directory, fsync, rename, fsync of the directory. The file appears
/// whole or not at all; an existing file is never overwritten. On failure the
/// temporary file is removed and avatar::IoError names @p path.
void writeNewFileDurably(const std::filesystem::path& path, const void* data, std::size_t size);

/// Replaces (or creates) @p path atomically: writes a uniquely named
/// temporary file in the same directory, fsyncs it and renames it over
/// @p path, then syncs the directory where the file system allows. Readers
/// see the old or the new content, never a mixture. @p what ("config file")
/// starts every IoError message, which names @p path and the temporary file.
void replaceFileAtomically(const std::filesystem::path& path, const std::string& data, const std::string& what);

}  // namespace avatar::fileutil
