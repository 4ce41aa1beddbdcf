#include "ConfigText.h"

#include <charconv>
#include <system_error>

namespace avatar::config_internal {

std::string formatDouble(double value) {
    // 32 characters hold any shortest double ("-2.2250738585072014e-308" is 24).
    std::array<char, 32> buffer{};
    const auto [end, ec] = std::to_chars(buffer.data(), buffer.data() + buffer.size(), value);
    if (ec != std::errc()) {
        return "?";  // cannot happen with 32 characters; keeps the function total
    }
    return std::string(buffer.data(), end);
}

}  // namespace avatar::config_internal
