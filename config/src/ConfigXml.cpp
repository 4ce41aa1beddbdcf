#include <avatar/config/ConfigXml.h>

#include "ConfigReader.h"
#include "ConfigValidate.h"
#include "ConfigWriter.h"

#include <avatar/common/internal/FileUtil.h>

#include <cerrno>
#include <fstream>
#include <sstream>
#include <system_error>
#include <utility>

namespace avatar {

AvatarConfig readConfigString(const std::string& xml, const std::string& sourceName) {
    config_internal::ParsedDocument parsed = config_internal::parseDocument(xml, sourceName);
    config_internal::validate(parsed.config, config_internal::ErrorSite(sourceName, &parsed.lines));
    parsed.config.origin.source = sourceName;
    parsed.config.origin.lines = std::make_shared<const config_internal::LineMap>(std::move(parsed.lines));
    return std::move(parsed.config);
}

AvatarConfig readConfigFile(const std::filesystem::path& path) {
    std::error_code ec;
    if (std::filesystem::is_directory(path, ec)) {
        throw IoError("cannot read config file '" + path.string() + "': it is a directory");
    }
    std::ifstream in(path, std::ios::binary);
    if (!in) {
        throw IoError("cannot open config file '" + path.string() + "': " + fileutil::errnoText(errno));
    }
    std::ostringstream text;
    text << in.rdbuf();
    if (in.bad()) {
        throw IoError("cannot read config file '" + path.string() + "': " + fileutil::errnoText(errno));
    }
    return readConfigString(text.str(), path.string());
}

std::string writeConfigString(const AvatarConfig& config) {
    validateConfig(config);
    return config_internal::formatDocument(config);
}

void writeConfigFile(const AvatarConfig& config, const std::filesystem::path& path) {
    const std::string text = writeConfigString(config);  // validates before touching the disk
    fileutil::replaceFileAtomically(path, text, "config file");
}

std::string writeTargetString(const TargetType& type) {
    validateTargetType(type);
    return config_internal::formatTarget(type);
}

TargetType readTargetString(const std::string& xml, const std::string& sourceName) {
    config_internal::LineMap lines;
    TargetType type = config_internal::parseTarget(xml, sourceName, lines);
    config_internal::validateTargetAt(type, config_internal::ErrorSite(sourceName, &lines), "/target");
    return type;
}

ConfigError configErrorAt(const AvatarConfig& config, const std::string& elementPath, const std::string& problem) {
    const config_internal::ErrorSite site(config.origin.source, config.origin.lines.get());
    return ConfigError(config.origin.source, site.lineOf(elementPath), elementPath, problem);
}

void validateConfig(const AvatarConfig& config) {
    config_internal::validate(config, config_internal::ErrorSite("<memory>", nullptr));
}

std::filesystem::path resolveConfigPath(const std::filesystem::path& configFile, const std::string& stored) {
    const std::filesystem::path p(stored);
    if (p.empty() || p.is_absolute()) {
        return p;
    }
    return configFile.parent_path() / p;
}

}  // namespace avatar
