#include <avatar/common/Error.h>
#include <avatar/common/Logging.h>

#include <log4cpp/Category.hh>
#include <log4cpp/OstreamAppender.hh>
#include <log4cpp/PatternLayout.hh>
#include <log4cpp/Priority.hh>
#include <log4cpp/PropertyConfigurator.hh>

#include <algorithm>
#include <iostream>
#include <string>

namespace avatar::logging {
namespace {

log4cpp::Priority::Value toLog4cpp(Priority p) {
    switch (p) {
        case Priority::Debug: return log4cpp::Priority::DEBUG;
        case Priority::Info: return log4cpp::Priority::INFO;
        case Priority::Notice: return log4cpp::Priority::NOTICE;
        case Priority::Warn: return log4cpp::Priority::WARN;
        case Priority::Error: return log4cpp::Priority::ERROR;
    }
    return log4cpp::Priority::NOTICE;
}

}  // namespace

Priority parsePriority(std::string_view text) {
    std::string t(text);
    std::transform(t.begin(), t.end(), t.begin(), [](unsigned char c) { return std::tolower(c); });
    if (t == "debug") return Priority::Debug;
    if (t == "info") return Priority::Info;
    if (t == "notice") return Priority::Notice;
    if (t == "warn" || t == "warning") return Priority::Warn;
    if (t == "error") return Priority::Error;
    throw InvalidArgument("unknown log priority '" + std::string(text) +
                          "' (expected debug, info, notice, warn or error)");
}

void configure(Priority threshold) {
    log4cpp::Category& root = log4cpp::Category::getRoot();
    root.removeAllAppenders();
    auto* appender = new log4cpp::OstreamAppender("stderr", &std::cerr);  // owned by root
    auto* layout = new log4cpp::PatternLayout();                          // owned by appender
    layout->setConversionPattern("%d{%H:%M:%S,%l} %-6p %c: %m%n");
    appender->setLayout(layout);
    root.addAppender(appender);
    root.setPriority(toLog4cpp(threshold));
}

void configureFromFile(const std::filesystem::path& propertyFile) {
    if (!std::filesystem::exists(propertyFile))
        throw IoError("no such log4cpp property file: " + propertyFile.string());
    try {
        log4cpp::PropertyConfigurator::configure(propertyFile.string());
    } catch (const log4cpp::ConfigureFailure& e) {
        throw FormatError("log4cpp property file " + propertyFile.string() + ": " + e.what());
    }
}

log4cpp::Category& category(std::string_view module) {
    return log4cpp::Category::getInstance("avatar." + std::string(module));
}

}  // namespace avatar::logging
