// Reading and writing configuration files: errors that name the path, atomic replacement.

#include "TestConfigs.h"

#include <avatar/config/ConfigXml.h>

#include <gtest/gtest.h>


#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <set>
#include <sstream>
#include <string>

namespace avatar {
namespace {

namespace fs = std::filesystem;

/// A fresh directory, removed with its contents at the end of the test.
class ConfigFiles : public ::testing::Test {
protected:
    void SetUp() override {
        std::string pattern = (fs::temp_directory_path() / "avatar-config-test-XXXXXX").string();
        ASSERT_NE(::mkdtemp(pattern.data()), nullptr);
        dir_ = pattern;
    }
    void TearDown() override {
        std::error_code ec;
        fs::remove_all(dir_, ec);
    }

    static std::string slurp(const fs::path& p) {
        std::ifstream in(p, std::ios::binary);
        return std::string(std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>());
    }
    static void spit(const fs::path& p, const std::string& text) {
        std::ofstream out(p, std::ios::binary);
        out << text;
    }
    std::set<std::string> entries() const {
        std::set<std::string> names;
        for (const auto& e : fs::directory_iterator(dir_)) {
            names.insert(e.path().filename().string());
        }
        return names;
    }

    fs::path dir_;
};

TEST_F(ConfigFiles, WriteThenRead) {
    const AvatarConfig c = test::unusualConfig();
    const fs::path path = dir_ / "avatar.xml";
    writeConfigFile(c, path);
    EXPECT_EQ(slurp(path), writeConfigString(c));
    EXPECT_TRUE(readConfigFile(path) == c);
    EXPECT_EQ(entries(), (std::set<std::string>{"avatar.xml"}));  // no temporary left behind
}

TEST_F(ConfigFiles, OverwriteReplacesTheWholeFile) {
    const fs::path path = dir_ / "avatar.xml";
    spit(path, std::string(100000, 'x'));  // longer than the new document
    const AvatarConfig c = test::unusualConfig();
    writeConfigFile(c, path);
    EXPECT_EQ(slurp(path), writeConfigString(c));
    EXPECT_EQ(entries(), (std::set<std::string>{"avatar.xml"}));
}

TEST_F(ConfigFiles, WriteIntoMissingDirectoryFails) {
    const fs::path path = dir_ / "no-such-dir" / "avatar.xml";
    try {
        writeConfigFile(test::unusualConfig(), path);
        ADD_FAILURE() << "written";
    } catch (const IoError& e) {
        EXPECT_NE(std::string(e.what()).find(path.string()), std::string::npos) << e.what();
    }
    EXPECT_FALSE(fs::exists(dir_ / "no-such-dir"));
    EXPECT_TRUE(entries().empty());
}

TEST_F(ConfigFiles, FailedReplaceLeavesTargetAndNoTemporary) {
    // rename() onto a non-empty directory fails after the temporary was written.
    const fs::path path = dir_ / "avatar.xml";
    fs::create_directory(path);
    spit(path / "keep", "kept");
    EXPECT_THROW(writeConfigFile(test::unusualConfig(), path), IoError);
    EXPECT_TRUE(fs::is_directory(path));
    EXPECT_EQ(slurp(path / "keep"), "kept");
    EXPECT_EQ(entries(), (std::set<std::string>{"avatar.xml"}));
}

TEST_F(ConfigFiles, InvalidConfigLeavesTargetUnchanged) {
    const fs::path path = dir_ / "avatar.xml";
    const AvatarConfig good = test::unusualConfig();
    writeConfigFile(good, path);
    const std::string before = slurp(path);

    AvatarConfig bad = good;
    bad.camera.bitDepth = 17;
    EXPECT_THROW(writeConfigFile(bad, path), ConfigError);
    EXPECT_EQ(slurp(path), before);
    EXPECT_EQ(entries(), (std::set<std::string>{"avatar.xml"}));
}

TEST_F(ConfigFiles, ReadMissingFileNamesThePath) {
    const fs::path path = dir_ / "missing.xml";
    try {
        readConfigFile(path);
        ADD_FAILURE() << "read";
    } catch (const IoError& e) {
        EXPECT_NE(std::string(e.what()).find("'" + path.string() + "'"), std::string::npos) << e.what();
    }
}

TEST_F(ConfigFiles, ReadDirectoryIsAnIoError) {
    EXPECT_THROW(readConfigFile(dir_), IoError);
}

TEST_F(ConfigFiles, ErrorsNameTheFileAsGiven) {
    const fs::path path = dir_ / "bad.xml";
    spit(path, "<?xml version=\"1.0\"?>\n<avatar version=\"1\">\n  <camera/>\n</avatar>\n");
    try {
        readConfigFile(path);
        ADD_FAILURE() << "read";
    } catch (const ConfigError& e) {
        EXPECT_EQ(e.source(), path.string());
        EXPECT_EQ(std::string(e.what()), path.string() + ":3: /avatar/camera: missing required element <width>");
    }
}

TEST_F(ConfigFiles, ResolveConfigPath) {
    EXPECT_EQ(resolveConfigPath("/etc/avatar/seabed.xml", "strobe.exr"), fs::path("/etc/avatar/strobe.exr"));
    EXPECT_EQ(resolveConfigPath("/etc/avatar/seabed.xml", "lighting/strobe.exr"),
              fs::path("/etc/avatar/lighting/strobe.exr"));
    EXPECT_EQ(resolveConfigPath("/etc/avatar/seabed.xml", "/data/strobe.exr"), fs::path("/data/strobe.exr"));
    EXPECT_EQ(resolveConfigPath("seabed.xml", "strobe.exr"), fs::path("strobe.exr"));
    EXPECT_EQ(resolveConfigPath("/etc/avatar/seabed.xml", ""), fs::path());
}

}  // namespace
}  // namespace avatar
