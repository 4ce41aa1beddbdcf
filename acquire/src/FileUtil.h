#pragma once
// Internal: whole-file reads and durable writes (POSIX), with avatar::IoError
// messages that name the file.

#include <cstddef>
#include <cstdint>
#include <filesystem>
#include <string>
#include <vector>

namespace avatar::fileutil {

/// 8 lowercase hexadecimal digits.
std::string hex8(std::uint32_t value);

/// The bytes of a file; @p what ("image file", "session log") starts the
/// IoError message for a missing or unreadable file.
std::vector<unsigned char> readWholeFile(const std::filesystem::path& path, const std::string& what);

/// Writes a file that must not exist yet: to a hidden temporary name in the
/// same directory, fsync, rename, fsync of the directory. On failure the
/// temporary file is removed and avatar::IoError names @p path.
void writeNewFileDurably(const std::filesystem::path& path, const void* data, std::size_t size);

/// Writes all @p size bytes to @p fd (retrying short writes and EINTR);
/// throws avatar::IoError naming @p path.
void writeAll(int fd, const void* data, std::size_t size, const std::filesystem::path& path);

/// fsync of a directory, so that a new or renamed entry in it survives a power loss.
void syncDirectory(const std::filesystem::path& directory);

}  // namespace avatar::fileutil
