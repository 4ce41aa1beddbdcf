#pragma once
/// @file ConfigXml.h
/// Reading, validating and writing the AVATAR XML configuration (thesis 4.2.4).
///
/// A document is accepted whole or rejected whole: the functions either return
/// a complete, validated AvatarConfig or throw ConfigError; nothing half-applies.
///
/// The validator is the one source of truth for every rule of a configuration
/// value. The algorithms that take part of a configuration (the matcher, the
/// lighting corrector, the colour filter, the analysis) call the same checks
/// (validateMatchConfig() and the others below), so a configuration that
/// validates always builds, and one that does not is rejected with the same
/// message whichever way it arrives.

#include <avatar/common/Error.h>
#include <avatar/config/AvatarConfig.h>

#include <filesystem>
#include <string>

namespace avatar {

/// A configuration that cannot be accepted (a DocumentError, and an
/// InvalidArgument: the configuration given cannot be used). what() reads
///   "<source>:<line>: <element path>: <problem>"
/// e.g. "scorpion.xml:42: /avatar/targets/target[2]/redGreen/min: expected a number, got 'abc'".
/// The source is the file path as given to readConfigFile, the name given to
/// readConfigString (default "<string>"), or "<memory>" for a value checked in code.
class ConfigError : public DocumentError<InvalidArgument> {
public:
    using DocumentError::DocumentError;
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

/// One <target> element, as a configuration holds it inside <targets>
/// (docs/config.md), e.g. for a tool that proposes a target type. Validated
/// first (validateTargetType()).
std::string writeTargetString(const TargetType& type);
/// Reads one <target> element on its own, as writeTargetString() writes it;
/// ConfigError naming @p sourceName, the line and the element ("/target/...").
TargetType readTargetString(const std::string& xml, const std::string& sourceName = "<string>");

/// A ConfigError for a rule checked outside the validator, at @p elementPath
/// of @p config: "<file>:<line>: <path>: <problem>" with the line of the
/// element (or its nearest ancestor) when the configuration was read from a
/// document, "<memory>:0: ..." otherwise.
ConfigError configErrorAt(const AvatarConfig& config, const std::string& elementPath, const std::string& problem);

/// Checks every field of a configuration built in code; throws ConfigError
/// (source "<memory>", line 0) naming the first bad field by the element path
/// it would have in a document.
void validateConfig(const AvatarConfig& config);

/// The rules of one part, for an algorithm that is given only that part. Each
/// throws ConfigError (source "<memory>", line 0) naming the first bad field
/// by its element path, exactly as validateConfig() would.
/// Matching: box and depth ranges not empty, weights, limits.
void validateMatchConfig(const MatchConfig& match);
/// Calibration and registration, except what needs the image size (the
/// principal points inside the image, checked by validateConfig()).
void validateStereoConfig(const StereoSystemConfig& stereo);
/// Gains, falloff and the template path.
void validateLightingConfig(const LightingConfig& lighting);
/// One target type, except its search window (which needs the image size);
/// errors name it as /avatar/targets/target[@name='<name>'].
void validateTargetType(const TargetType& type);
/// The form of the stage list (names, no repeats) and the analysis options.
void validateAnalysisConfig(const AnalysisConfig& analysis);

/// The visual-servo tuning, except that its type names name target types
/// (which needs the document's <targets>; validateConfig() checks that too).
void validateServoConfig(const ServoConfig& servo);

/// Resolves a path stored in a configuration (e.g. LightingConfig::templateImagePath)
/// against the directory of @p configFile, the file it was read from. Absolute
/// and empty paths are returned unchanged.
std::filesystem::path resolveConfigPath(const std::filesystem::path& configFile, const std::string& stored);

}  // namespace avatar
