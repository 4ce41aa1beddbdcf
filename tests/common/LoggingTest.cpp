#include "TempDir.h"

#include <avatar/common/Error.h>
#include <avatar/common/Logging.h>

#include <gtest/gtest.h>
#include <log4cpp/Category.hh>

#include <fstream>
#include <sstream>

using namespace avatar;
using avatar::test::TempDir;

TEST(Logging, ParsesPriorities) {
    EXPECT_EQ(logging::parsePriority("debug"), logging::Priority::Debug);
    EXPECT_EQ(logging::parsePriority("INFO"), logging::Priority::Info);
    EXPECT_EQ(logging::parsePriority("Warning"), logging::Priority::Warn);
    EXPECT_EQ(logging::parsePriority("error"), logging::Priority::Error);
    try {
        logging::parsePriority("loud");
        FAIL();
    } catch (const InvalidArgument& e) {
        EXPECT_STREQ(e.what(), "unknown log priority 'loud' (expected debug, info, notice, warn or error)");
    }
}

TEST(Logging, CategoriesAreNamedPerModule) {
    EXPECT_EQ(logging::category("acquire").getName(), "avatar.acquire");
}

TEST(Logging, PriorityThresholdApplies) {
    logging::configure(logging::Priority::Warn);
    EXPECT_FALSE(logging::category("common").isInfoEnabled());
    EXPECT_TRUE(logging::category("common").isWarnEnabled());
    logging::configure(logging::Priority::Debug);
    EXPECT_TRUE(logging::category("common").isDebugEnabled());
}

TEST(Logging, PropertyFileSendsMessagesToItsAppender) {
    TempDir dir;
    const auto logFile = dir / "avatar.log";
    {
        std::ofstream props(dir / "log.properties");
        props << "log4cpp.rootCategory=INFO, file\n"
                 "log4cpp.appender.file=FileAppender\n"
                 "log4cpp.appender.file.fileName=" << logFile.string() << "\n"
                 "log4cpp.appender.file.layout=PatternLayout\n"
                 "log4cpp.appender.file.layout.ConversionPattern=%p %c: %m%n\n";
    }
    logging::configureFromFile(dir / "log.properties");
    logging::category("test").info("hello %d", 42);
    logging::category("test").debug("not shown");
    log4cpp::Category::getRoot().removeAllAppenders();  // closes the file
    std::ifstream in(logFile);
    std::stringstream content;
    content << in.rdbuf();
    EXPECT_EQ(content.str(), "INFO avatar.test: hello 42\n");
}

TEST(Logging, BadPropertyFilesAreReported) {
    TempDir dir;
    EXPECT_THROW(logging::configureFromFile(dir / "none.properties"), IoError);
    std::ofstream(dir / "bad.properties") << "log4cpp.rootCategory=INFO, a\nlog4cpp.appender.a=NoSuchAppender\n";
    try {
        logging::configureFromFile(dir / "bad.properties");
        FAIL();
    } catch (const FormatError& e) {
        EXPECT_NE(std::string(e.what()).find("bad.properties"), std::string::npos) << e.what();
    }
}
