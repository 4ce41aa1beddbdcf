#include "RawImageFile.h"
#include "SessionLogFormat.h"

#include <avatar/common/internal/FileUtil.h>
#include <avatar/common/internal/Text.h>

#include <avatar/common/Error.h>
#include <avatar/common/StereoImagePairFileIO.h>

#include <array>
#include <charconv>
#include <system_error>
#include <type_traits>
#include <vector>

namespace avatar::sessionlog {
namespace {

constexpr std::string_view kChecksumKey = " crc=";

bool isReserved(unsigned char c) {
    return c <= 0x20 || c >= 0x7F || c == '%' || c == ',' || c == ';' || c == ':';
}

int hexValue(char c) {
    if (c >= '0' && c <= '9') return c - '0';
    if (c >= 'a' && c <= 'f') return c - 'a' + 10;
    if (c >= 'A' && c <= 'F') return c - 'A' + 10;
    return -1;
}

[[noreturn]] void badValue(std::string_view key, std::string_view value, std::string_view what) {
    throw FormatError("field '" + std::string(key) + "': " + quote(value) + " is not " +
                      std::string(what));
}

template <typename Int>
Int parseInt(std::string_view key, std::string_view text, std::string_view what, int base = 10) {
    Int value{};
    const char* first = text.data();
    const char* last = text.data() + text.size();
    const auto [ptr, ec] = std::from_chars(first, last, value, base);
    if (text.empty() || ec != std::errc() || ptr != last) badValue(key, text, what);
    return value;
}

double parseDouble(std::string_view key, std::string_view text) {
    double value = 0.0;
    const char* first = text.data();
    const char* last = text.data() + text.size();
    const auto [ptr, ec] = std::from_chars(first, last, value);
    if (text.empty() || ec != std::errc() || ptr != last) badValue(key, text, "a number");
    return value;
}

std::uint32_t parseHex8(std::string_view key, std::string_view text) {
    if (text.size() != 8) badValue(key, text, "8 hexadecimal digits");
    for (char c : text)
        if (hexValue(c) < 0) badValue(key, text, "8 hexadecimal digits");
    return parseInt<std::uint32_t>(key, text, "8 hexadecimal digits", 16);
}


std::string_view toText(Visibility v) {
    switch (v) {
        case Visibility::Unknown: return "unknown";
        case Visibility::Good: return "good";
        case Visibility::Poor: return "poor";
    }
    return "unknown";
}

template <typename Point>
std::string formatPoint(const std::optional<Point>& p) {
    if (!p) return "-";
    std::string out = formatDouble(p->x) + ";" + formatDouble(p->y);
    if constexpr (std::is_same_v<Point, cv::Point3d>) out += ";" + formatDouble(p->z);
    return out;
}

template <typename Point>
std::optional<Point> parsePoint(std::string_view key, std::string_view text) {
    if (text == "-") return std::nullopt;
    constexpr std::size_t dims = std::is_same_v<Point, cv::Point3d> ? 3 : 2;
    const auto parts = text::split(text, ';');
    if (parts.size() != dims)
        badValue(key, text, dims == 3 ? "'-' or x;y;z" : "'-' or x;y");
    Point p;
    p.x = parseDouble(key, parts[0]);
    p.y = parseDouble(key, parts[1]);
    if constexpr (std::is_same_v<Point, cv::Point3d>) p.z = parseDouble(key, parts[2]);
    return p;
}

/// The upper triangle of a covariance, "xx;xy;xz;yy;yz;zz", or "-".
std::string formatCovariance(const std::optional<Covariance3>& c) {
    if (!c) return "-";
    const Covariance3& m = *c;
    return formatDouble(m(0, 0)) + ";" + formatDouble(m(0, 1)) + ";" + formatDouble(m(0, 2)) + ";" +
           formatDouble(m(1, 1)) + ";" + formatDouble(m(1, 2)) + ";" + formatDouble(m(2, 2));
}

std::optional<Covariance3> parseCovariance(std::string_view key, std::string_view text) {
    if (text == "-") return std::nullopt;
    const auto parts = text::split(text, ';');
    if (parts.size() != 6) badValue(key, text, "'-' or xx;xy;xz;yy;yz;zz");
    static const int rows[6] = {0, 0, 0, 1, 1, 2}, cols[6] = {0, 1, 2, 1, 2, 2};
    Covariance3 m;
    for (int k = 0; k < 6; ++k) m(rows[k], cols[k]) = m(cols[k], rows[k]) = parseDouble(key, parts[static_cast<std::size_t>(k)]);
    return m;
}

ShapeModel parseModel(std::string_view key, std::string_view text) {
    for (const ShapeModel m : {ShapeModel::None, ShapeModel::Sphere, ShapeModel::Disc, ShapeModel::Composite})
        if (text == toString(m)) return m;
    badValue(key, text, "none, sphere, disc or composite");
}

std::string formatTarget(const VisionTarget& t) {
    return escape(t.type) + "," + std::to_string(t.flags) + "," + formatPoint(t.positionVisionMm) +
           "," + formatPoint(t.positionBaseMm) + "," + formatPoint(t.centroidLeftPx) + "," +
           formatPoint(t.centroidRightPx) + "," + formatDouble(t.areaLeftPx) + "," +
           formatDouble(t.areaRightPx) + "," + formatDouble(t.matchError) + "," + std::string(toString(t.model)) +
           "," + formatCovariance(t.covarianceVisionMm2) + "," + formatCovariance(t.covarianceBaseMm2) + "," +
           formatDouble(t.rayResidualMm) + "," + formatDouble(t.rayResidualPx);
}

VisionTarget parseTarget(std::string_view text, std::size_t index, int version) {
    const std::string key = "target[" + std::to_string(index) + "]";
    const auto parts = text::split(text, ',');
    const std::size_t expected = version == 1 ? 9 : 14;
    if (parts.size() != expected)
        throw FormatError("field '" + key + "': expected " + std::to_string(expected) +
                          " comma-separated values (type,flags,positionVision,positionBase,centroidLeft,"
                          "centroidRight,areaLeft,areaRight,matchError" +
                          (version == 1 ? "" : ",model,covarianceVision,covarianceBase,rayResidualMm,rayResidualPx") +
                          "), got " + std::to_string(parts.size()));
    VisionTarget t;
    try {
        t.type = unescape(parts[0]);
    } catch (const FormatError& e) {
        throw FormatError("field '" + key + ".type': " + e.what());
    }
    t.flags = parseInt<std::uint32_t>(key + ".flags", parts[1], "an unsigned 32-bit integer");
    t.positionVisionMm = parsePoint<cv::Point3d>(key + ".positionVision", parts[2]);
    t.positionBaseMm = parsePoint<cv::Point3d>(key + ".positionBase", parts[3]);
    t.centroidLeftPx = parsePoint<cv::Point2d>(key + ".centroidLeft", parts[4]);
    t.centroidRightPx = parsePoint<cv::Point2d>(key + ".centroidRight", parts[5]);
    t.areaLeftPx = parseDouble(key + ".areaLeft", parts[6]);
    t.areaRightPx = parseDouble(key + ".areaRight", parts[7]);
    t.matchError = parseDouble(key + ".matchError", parts[8]);
    if (version == 1) return t;
    t.model = parseModel(key + ".model", parts[9]);
    t.covarianceVisionMm2 = parseCovariance(key + ".covarianceVision", parts[10]);
    t.covarianceBaseMm2 = parseCovariance(key + ".covarianceBase", parts[11]);
    t.rayResidualMm = parseDouble(key + ".rayResidualMm", parts[12]);
    t.rayResidualPx = parseDouble(key + ".rayResidualPx", parts[13]);
    return t;
}

/// Walks the space-separated "key=value" fields of a record in order.
class Fields {
public:
    explicit Fields(std::string_view body) : tokens_(text::split(body, ' ')) {}

    bool atEnd() const { return next_ == tokens_.size(); }
    bool nextIs(std::string_view key) const {
        if (atEnd()) return false;
        const std::string_view t = tokens_[next_];
        return t.size() > key.size() && t.substr(0, key.size()) == key && t[key.size()] == '=';
    }
    /// The value of the next field, which must be @p key.
    std::string_view take(std::string_view key) {
        if (atEnd())
            throw FormatError("record ends after field '" + previous_ + "'; expected field '" +
                              std::string(key) + "='");
        if (!nextIs(key))
            throw FormatError("expected field '" + std::string(key) + "=' after field '" +
                              previous_ + "', found " + quote(tokens_[next_]));
        previous_ = std::string(key);
        return tokens_[next_++].substr(key.size() + 1);
    }
    std::string takeString(std::string_view key) {
        const std::string_view raw = take(key);
        try {
            return unescape(raw);
        } catch (const FormatError& e) {
            throw FormatError("field '" + std::string(key) + "': " + e.what());
        }
    }
    void expectEnd() const {
        if (!atEnd())
            throw FormatError("unexpected field " + quote(tokens_[next_]) + " after field '" +
                              previous_ + "'");
    }

private:
    std::vector<std::string_view> tokens_;
    std::size_t next_{0};
    std::string previous_{"iteration"};
};

}  // namespace

std::string escape(std::string_view text) {
    std::string out;
    out.reserve(text.size());
    for (char ch : text) {
        const auto c = static_cast<unsigned char>(ch);
        if (isReserved(c)) {
            out += '%';
            out += "0123456789ABCDEF"[c >> 4];
            out += "0123456789ABCDEF"[c & 0xF];
        } else {
            out += ch;
        }
    }
    return out;
}

std::string unescape(std::string_view text) {
    std::string out;
    out.reserve(text.size());
    for (std::size_t i = 0; i < text.size(); ++i) {
        const auto c = static_cast<unsigned char>(text[i]);
        if (c == '%') {
            const int hi = i + 1 < text.size() ? hexValue(text[i + 1]) : -1;
            const int lo = i + 2 < text.size() ? hexValue(text[i + 2]) : -1;
            if (hi < 0 || lo < 0)
                throw FormatError("bad escape " + quote(text.substr(i, 3)) + " at character " +
                                  std::to_string(i + 1) + " (expected %XX, two hexadecimal digits)");
            out += static_cast<char>(hi * 16 + lo);
            i += 2;
        } else if (c <= 0x20 || c >= 0x7F) {
            throw FormatError("unescaped byte " + std::to_string(c) + " at character " +
                              std::to_string(i + 1));
        } else {
            out += text[i];
        }
    }
    return out;
}


std::string quote(std::string_view text, std::size_t maxChars) {
    std::string shown;
    for (char ch : text.substr(0, maxChars)) {
        const auto c = static_cast<unsigned char>(ch);
        if (c < 0x20 || c >= 0x7F) {
            shown += '%';
            shown += "0123456789ABCDEF"[c >> 4];
            shown += "0123456789ABCDEF"[c & 0xF];
        } else {
            shown += ch;
        }
    }
    return "'" + shown + (text.size() > maxChars ? "'..." : "'");
}

std::string headerLine() {
    return std::string(kSessionLogFormatName) + " " + std::to_string(kSessionLogVersion) + "\n";
}

int parseHeader(std::string_view line) {
    const std::string prefix = std::string(kSessionLogFormatName) + " ";
    if (line.substr(0, prefix.size()) != prefix)
        throw FormatError("not an AVATAR session log: expected the header '" + prefix +
                          "<version>', found " + quote(line));
    const std::string_view versionText = line.substr(prefix.size());
    int version = 0;
    const auto [ptr, ec] =
        std::from_chars(versionText.data(), versionText.data() + versionText.size(), version);
    if (versionText.empty() || ec != std::errc() || ptr != versionText.data() + versionText.size() ||
        version < 1)
        throw FormatError("session log version " + quote(versionText) + " is not a positive integer");
    if (version < kOldestSessionLogVersion || version > kSessionLogVersion)
        throw FormatError("unsupported session log version " + std::to_string(version) + "; this reader reads versions " +
                          std::to_string(kOldestSessionLogVersion) + " to " + std::to_string(kSessionLogVersion));
    return version;
}

std::string formatRecord(const SessionRecord& r) {
    const AcquisitionId& a = r.acquisition;
    std::string line = "iteration=" + std::to_string(r.iteration) +
                       " group=" + std::to_string(a.group) + " member=" + std::to_string(a.member) +
                       " leftCamera=" + escape(a.left.cameraId) +
                       " leftTimeUs=" + std::to_string(a.left.timestampUs) +
                       " rightCamera=" + escape(a.right.cameraId) +
                       " rightTimeUs=" + std::to_string(a.right.timestampUs) +
                       " leftFile=" + escape(r.files.left.name) + " leftCrc=" + text::hex8(r.files.left.crc32) +
                       " rightFile=" + escape(r.files.right.name) +
                       " rightCrc=" + text::hex8(r.files.right.crc32) +
                       " config=" + std::to_string(r.configVersion);
    if (r.configXml) line += " configXml=" + escape(*r.configXml);
    if (!r.result) {
        line += " result=none";
    } else {
        const VisionTargets& v = *r.result;
        line += " result=" + std::string(toText(v.visibility));
        line += " reason=" + escape(v.visibilityReason);
        for (const auto& t : v.timings) line += " timing=" + escape(t.stage) + ":" + formatDouble(t.milliseconds);
        for (const auto& t : v.targets) line += " target=" + formatTarget(t);
    }
    const std::uint32_t crc = crc32(line.data(), line.size());
    line += std::string(kChecksumKey) + text::hex8(crc) + "\n";
    return line;
}

SessionRecord parseRecord(std::string_view line, int version) {
    if (line.substr(0, 10) != "iteration=")
        throw FormatError("not a session record: " + quote(line) + " does not start with 'iteration='");
    const std::size_t crcPos = line.rfind(kChecksumKey);
    if (crcPos == std::string_view::npos || line.size() - crcPos - kChecksumKey.size() != 8)
        throw FormatError("record has no line checksum: expected ' crc=<8 hexadecimal digits>' at "
                          "the end, found " + quote(line.substr(line.size() > 20 ? line.size() - 20 : 0)));
    const std::string_view body = line.substr(0, crcPos);
    const std::uint32_t recorded = parseHex8("crc", line.substr(crcPos + kChecksumKey.size()));
    const std::uint32_t computed = crc32(body.data(), body.size());
    if (recorded != computed)
        throw FormatError("line checksum mismatch: recorded " + text::hex8(recorded) + ", computed " +
                          text::hex8(computed) + " (the line was altered or damaged)");

    Fields f(body);
    SessionRecord r;
    AcquisitionId& a = r.acquisition;
    r.iteration = parseInt<std::uint64_t>("iteration", f.take("iteration"), "an unsigned 64-bit integer");
    a.group = parseInt<std::uint32_t>("group", f.take("group"), "an unsigned 32-bit integer");
    a.member = parseInt<std::uint32_t>("member", f.take("member"), "an unsigned 32-bit integer");
    a.left.cameraId = f.takeString("leftCamera");
    a.left.timestampUs = parseInt<std::int64_t>("leftTimeUs", f.take("leftTimeUs"), "a signed 64-bit integer");
    a.right.cameraId = f.takeString("rightCamera");
    a.right.timestampUs = parseInt<std::int64_t>("rightTimeUs", f.take("rightTimeUs"), "a signed 64-bit integer");
    r.files.left.name = f.takeString("leftFile");
    r.files.left.crc32 = parseHex8("leftCrc", f.take("leftCrc"));
    r.files.right.name = f.takeString("rightFile");
    r.files.right.crc32 = parseHex8("rightCrc", f.take("rightCrc"));
    checkFileName("leftFile", r.files.left.name, Side::Left, a.group, a.member);
    checkFileName("rightFile", r.files.right.name, Side::Right, a.group, a.member);
    r.configVersion = parseInt<std::uint32_t>("config", f.take("config"), "an unsigned 32-bit integer");
    if (f.nextIs("configXml")) r.configXml = f.takeString("configXml");

    const std::string_view result = f.take("result");
    if (result != "none") {
        VisionTargets v;
        if (result == "unknown") v.visibility = Visibility::Unknown;
        else if (result == "good") v.visibility = Visibility::Good;
        else if (result == "poor") v.visibility = Visibility::Poor;
        else badValue("result", result, "none, unknown, good or poor");
        v.iteration = r.iteration;
        v.acquisition = a;
        v.visibilityReason = f.takeString("reason");
        while (f.nextIs("timing")) {
            const std::string key = "timing[" + std::to_string(v.timings.size()) + "]";
            const std::string_view text = f.take("timing");
            const auto parts = text::split(text, ':');
            if (parts.size() != 2) badValue(key, text, "<stage>:<milliseconds>");
            StageTiming t;
            try {
                t.stage = unescape(parts[0]);
            } catch (const FormatError& e) {
                throw FormatError("field '" + key + ".stage': " + e.what());
            }
            t.milliseconds = parseDouble(key + ".milliseconds", parts[1]);
            v.timings.push_back(std::move(t));
        }
        while (f.nextIs("target")) v.targets.push_back(parseTarget(f.take("target"), v.targets.size(), version));
        r.result = std::move(v);
    }
    f.expectEnd();
    return r;
}

void checkFileName(std::string_view field, const std::string& fileName, Side side,
                   std::uint32_t group, std::uint32_t member) {
    RawImageName name;
    try {
        name = RawImageName::parse(fileName);
    } catch (const FormatError& e) {
        throw FormatError("field '" + std::string(field) + "': " + e.what());
    }
    if (name.side != side)
        throw FormatError("field '" + std::string(field) + "': " + quote(fileName, 200) + " is not a " +
                          (side == Side::Left ? "left (L_)" : "right (R_)") + " image file");
    if (name.group != group || name.member != member)
        throw FormatError("field '" + std::string(field) + "': " + quote(fileName, 200) +
                          " is group " + std::to_string(name.group) + " member " +
                          std::to_string(name.member) + " but the record is group " +
                          std::to_string(group) + " member " + std::to_string(member));
}

}  // namespace avatar::sessionlog
