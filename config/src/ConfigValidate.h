#pragma once
/// @file ConfigValidate.h
/// Internal: the value rules of a configuration, shared by the XML reader
/// (which knows the line of every element it read) and validateConfig() (which
/// checks a configuration built in code).

#include <avatar/config/AvatarConfig.h>

#include <map>
#include <string>

namespace avatar::config_internal {

/// The line of each element path that was read from a document, e.g.
/// "/avatar/camera/width" -> 4. Attribute paths ("/avatar/targets/target[1]/@name")
/// carry the line of their element.
using LineMap = std::map<std::string, int>;

/// Where errors are reported: a source name and, for a parsed document, the
/// lines of its elements. A path that was not in the document (a field left at
/// its default) is reported at the line of its nearest ancestor that was.
class ErrorSite {
public:
    ErrorSite(std::string source, const LineMap* lines) : source_(std::move(source)), lines_(lines) {}
    /// Throws ConfigError for @p path.
    [[noreturn]] void fail(const std::string& path, const std::string& problem) const;
    int lineOf(const std::string& path) const;

private:
    std::string source_;
    const LineMap* lines_;
};

/// Checks every field of @p config; throws ConfigError naming the first bad one.
void validate(const AvatarConfig& config, const ErrorSite& site);
/// Checks one target type (not its window, which needs the image size) at @p path.
void validateTargetAt(const TargetType& type, const ErrorSite& site, const std::string& path);

}  // namespace avatar::config_internal
