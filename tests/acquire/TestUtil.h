#pragma once
// Helpers shared by the acquire tests: images, file bytes, exception messages.
#include <avatar/common/Error.h>

#include <gtest/gtest.h>
#include <opencv2/core.hpp>

#include <filesystem>
#include <fstream>
#include <iterator>
#include <string>
#include <vector>

namespace avatar::test {

/// Random samples in 0 .. 2^bits - 1, reproducible per seed.
inline cv::Mat randomImage(int rows, int cols, int cvType, int bits, std::uint64_t seed) {
    cv::Mat m(rows, cols, cvType);
    cv::RNG rng(seed);
    rng.fill(m, cv::RNG::UNIFORM, 0, 1 << bits);
    return m;
}

/// True when both images have the same size, type and samples.
inline bool sameImage(const cv::Mat& a, const cv::Mat& b) {
    if (a.size() != b.size() || a.type() != b.type()) return false;
    return a.empty() || cv::norm(a, b, cv::NORM_INF) == 0.0;
}

inline std::string readText(const std::filesystem::path& p) {
    std::ifstream in(p, std::ios::binary);
    return {std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>()};
}

inline void writeText(const std::filesystem::path& p, const std::string& text) {
    std::ofstream out(p, std::ios::binary | std::ios::trunc);
    out << text;
}

inline std::vector<unsigned char> readBytes(const std::filesystem::path& p) {
    const std::string s = readText(p);
    return {s.begin(), s.end()};
}

/// Runs @p f, which must throw exactly @p E, and returns what().
template <typename E, typename F>
std::string messageOf(F&& f) {
    try {
        f();
    } catch (const E& e) {
        return e.what();
    } catch (const std::exception& e) {
        return std::string("wrong exception type: ") + e.what();
    }
    return "no exception";
}

}  // namespace avatar::test
