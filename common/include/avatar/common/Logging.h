#pragma once
/// @file Logging.h
/// The system logger (thesis 4.2.1), built on log4cpp. Library code logs
/// through one category per module ("avatar.common", "avatar.acquire", ...)
/// and never prints. Programs configure logging once at start-up, either from a
/// priority or from a log4cpp property file.

#include <filesystem>
#include <string_view>

namespace log4cpp {
class Category;
}

namespace avatar::logging {

/// Logging thresholds, from most to least verbose.
enum class Priority { Debug, Info, Notice, Warn, Error };

/// Parses "debug", "info", "notice", "warn" or "error" (any case); throws
/// avatar::InvalidArgument naming the text otherwise.
Priority parsePriority(std::string_view text);

/// Sends everything at or above @p threshold to standard error with a
/// timestamp, priority and category; replaces any earlier configuration.
void configure(Priority threshold);

/// Configures log4cpp from a property file (log4cpp.PropertyConfigurator
/// syntax). Throws avatar::IoError if the file is missing and
/// avatar::FormatError naming the file if log4cpp rejects it.
void configureFromFile(const std::filesystem::path& propertyFile);

/// The category of one module: "avatar.<module>".
log4cpp::Category& category(std::string_view module);

}  // namespace avatar::logging
