#pragma once
/// @file ConfigReader.h
/// Internal: turns an XML document into an AvatarConfig. Checks the structure
/// (elements, attributes, value syntax, required parts); the value rules are
/// ConfigValidate's.

#include "ConfigValidate.h"

#include <avatar/config/AvatarConfig.h>

#include <string>

namespace avatar::config_internal {

struct ParsedDocument {
    AvatarConfig config;
    LineMap lines;  ///< line of every element read, for ConfigValidate's messages
};

/// Throws ConfigError (with @p source and the offending line) on the first
/// structural problem. The result is not yet value-validated.
ParsedDocument parseDocument(const std::string& xml, const std::string& source);

/// One <target> element on its own (path "/target"); structure only, like parseDocument().
TargetType parseTarget(const std::string& xml, const std::string& source, LineMap& lines);

}  // namespace avatar::config_internal
