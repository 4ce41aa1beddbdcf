#pragma once
/// @file ConfigXml.h
/// Reading, validating and writing the AVATAR XML configuration (thesis 4.2.4).
///
/// A document is accepted whole or rejected whole: the functions either return
/// a complete, validated AvatarConfig or throw ConfigError; nothing half-applies.

#include <avatar/common/Error.h>
#include <avatar/config/AvatarConfig.h>

#include <filesystem>
#include <string>

namespace avatar {

/// A configuration that cannot be accepted. what() reads
///   "<source>:<line>: <element path>: <problem>"
/// e.g. "scorpion.xml:42: /avatar/targets/target[2]/redGreen/min: expected a number, got 'abc'".
class ConfigError : public Error {
public:
    ConfigError(std::string source, int line, std::string elementPath, std::string problem);
    /// The file path as given to readConfigFile, the name given to
    /// readConfigString (default "<string>"), or "<memory>" for validateConfig.
    const std::string& source() const { return source_; }
    int line() const { return line_; }                          ///< 1-based, 0 if unknown
    const std::string& elementPath() const { return path_; }    ///< e.g. "/avatar/match/method"
    const std::string& problem() const { return problem_; }

private:
    std::string source_;
    int line_;
    std::string path_;
    std::string problem_;
};

/// Parses and validates a document held in memory; @p sourceName appears in errors.
AvatarConfig readConfigString(const std::string& xml, const std::string& sourceName = "<string>");
/// Reads and validates a file. A missing or unreadable file is an avatar::IoError.
AvatarConfig readConfigFile(const std::filesystem::path& path);

/// Serialises a configuration. Doubles are written in their shortest form that
/// reads back to the identical value, so write -> read round-trips exactly.
/// Throws ConfigError if @p config itself is invalid.
std::string writeConfigString(const AvatarConfig& config);
/// Writes atomically (temporary file then rename); throws avatar::IoError on failure.
void writeConfigFile(const AvatarConfig& config, const std::filesystem::path& path);

/// Checks every field of a configuration built in code; throws ConfigError
/// (source "<memory>", line 0) naming the first bad field by the element path
/// it would have in a document.
void validateConfig(const AvatarConfig& config);

/// Resolves a path stored in a configuration (e.g. LightingConfig::templateImagePath)
/// against the directory of @p configFile, the file it was read from. Absolute
/// and empty paths are returned unchanged.
std::filesystem::path resolveConfigPath(const std::filesystem::path& configFile, const std::string& stored);

}  // namespace avatar
