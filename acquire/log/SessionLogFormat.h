#pragma once
// Internal: the text encoding of session log lines (docs/formats.md, "Session log").
// Parse and check functions throw avatar::FormatError whose message describes
// the problem without a file or line prefix; callers add it.

#include <avatar/common/internal/Text.h>
#include <avatar/acquire/SessionLog.h>

#include <cstdint>
#include <string>
#include <string_view>

namespace avatar::sessionlog {

/// Percent-encodes the bytes that may not appear raw in a field value.
std::string escape(std::string_view text);
/// Reverses escape(); throws FormatError for a malformed %XX sequence.
std::string unescape(std::string_view text);

/// Shortest text that reads back to exactly @p value (std::to_chars).
using text::formatDouble;

/// "AVATAR-SESSION-LOG 2\n".
std::string headerLine();
/// Parses a header line (without its line end) and returns its version;
/// throws FormatError if it is not a header or the version is not supported.
int parseHeader(std::string_view line);

/// The complete line of a record, checksum and line end included. Does not
/// check consistency (see checkRecord).
std::string formatRecord(const SessionRecord& record);
/// Parses one record line without its line end, written in format @p version.
SessionRecord parseRecord(std::string_view line, int version = kSessionLogVersion);

/// Checks that @p fileName parses as a RawImageName of @p side, @p group and
/// @p member; @p field names the field in messages.
void checkFileName(std::string_view field, const std::string& fileName, Side side,
                   std::uint32_t group, std::uint32_t member);

/// A short printable rendition of arbitrary bytes for messages: quoted, at most
/// @p maxChars bytes, control and non-ASCII bytes as %XX, "..." when cut.
std::string quote(std::string_view text, std::size_t maxChars = 40);

}  // namespace avatar::sessionlog
