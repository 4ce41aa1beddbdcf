#pragma once
/// @file ConfigWriter.h
/// Internal: the XML text of a configuration (not validated here).

#include <avatar/config/AvatarConfig.h>

#include <string>

namespace avatar::config_internal {

/// Every field is written, in the order of docs/config.md, indented by four
/// spaces; doubles in their shortest exact form.
std::string formatDocument(const AvatarConfig& config);
/// One <target> element, as formatDocument() writes it inside <targets>.
std::string formatTarget(const TargetType& type);

}  // namespace avatar::config_internal
