#pragma once
/// @file Text.h
/// Internal to the AVATAR libraries (not installed): the small text helpers
/// that the file names, the session log, the configuration and the scene
/// files all use, written once.

#include <cstddef>
#include <cstdint>
#include <string>
#include <string_view>
#include <vector>

namespace avatar::text {

/// The fields of @p text between the separators: "a,,b" -> {"a", "", "b"};
/// "" -> {""}. The views point into @p text.
std::vector<std::string_view> split(std::string_view text, char separator);

/// The shortest text that reads back to exactly @p value (std::to_chars):
/// "0.1", "1e+300", "-0", "inf", "nan".
std::string formatDouble(double value);

/// The first @p count values (anything indexable by [i]) joined by single
/// spaces, each as formatDouble() writes it: "1049.13 1050.38".
template <typename Values>
std::string formatDoubles(const Values& values, std::size_t count) {
    std::string out;
    for (std::size_t i = 0; i < count; ++i) out += (i == 0 ? "" : " ") + formatDouble(values[i]);
    return out;
}

/// @p text with every control character (below 0x20, and 0x7f) written as
/// "\xNN", and, when @p backslashes, every backslash too ("\x5c"), so the
/// result cannot be told from an escape: for messages and logs that quote
/// text from outside.
std::string escapeControl(std::string_view text, bool backslashes = false);

/// 8 lowercase hexadecimal digits: "04c11db7".
std::string hex8(std::uint32_t value);

}  // namespace avatar::text
