#pragma once
// A uniquely named directory under the system temp dir, removed on destruction.
#include <atomic>
#include <filesystem>
#include <random>
#include <string>

namespace avatar::test {

class TempDir {
public:
    explicit TempDir(const std::string& prefix = "avatar-test") {
        std::random_device rd;
        for (int attempt = 0; attempt < 100; ++attempt) {
            auto candidate = std::filesystem::temp_directory_path() /
                             (prefix + "-" + std::to_string(rd()) + "-" + std::to_string(attempt));
            if (std::filesystem::create_directory(candidate)) {
                path_ = candidate;
                return;
            }
        }
        throw std::runtime_error("cannot create a temporary directory");
    }
    ~TempDir() {
        std::error_code ec;
        std::filesystem::remove_all(path_, ec);
    }
    TempDir(const TempDir&) = delete;
    TempDir& operator=(const TempDir&) = delete;
    const std::filesystem::path& path() const { return path_; }
    std::filesystem::path operator/(const std::string& name) const { return path_ / name; }

private:
    std::filesystem::path path_;
};

}  // namespace avatar::test
