#include <avatar/tau/Protocol.h>

#include <avatar/tau/Authentication.h>

#include <array>
#include <cstring>
#include <utility>

namespace avatar::tau {
namespace {

/// Appends big-endian fields to a payload.
class Writer {
public:
    void u8(std::uint8_t v) { out_.push_back(v); }
    void u16(std::uint16_t v) { put(v, 2); }
    void u32(std::uint32_t v) { put(v, 4); }
    void u64(std::uint64_t v) { put(v, 8); }
    void i64(std::int64_t v) { put(static_cast<std::uint64_t>(v), 8); }
    void f64(double v) {
        std::uint64_t bits;
        std::memcpy(&bits, &v, sizeof bits);
        put(bits, 8);
    }
    void str(const std::string& s) { blob(reinterpret_cast<const std::uint8_t*>(s.data()), s.size()); }
    void bytes(const std::vector<std::uint8_t>& b) { blob(b.data(), b.size()); }
    void point2(const cv::Point2d& p) {
        f64(p.x);
        f64(p.y);
    }
    void point3(const cv::Point3d& p) {
        f64(p.x);
        f64(p.y);
        f64(p.z);
    }
    template <typename T, typename F>
    void opt(const std::optional<T>& v, F write) {
        u8(v ? 1 : 0);
        if (v) write(*v);
    }
    std::vector<std::uint8_t> take() { return std::move(out_); }

private:
    void put(std::uint64_t v, int n) {
        for (int i = n - 1; i >= 0; --i) out_.push_back(static_cast<std::uint8_t>(v >> (8 * i)));
    }
    void blob(const std::uint8_t* p, std::size_t n) {
        if (n > 0xFFFFFFFFu) throw ProtocolError(ErrorCode::Internal, "field of " + std::to_string(n) + " bytes");
        u32(static_cast<std::uint32_t>(n));
        out_.insert(out_.end(), p, p + n);
    }
    std::vector<std::uint8_t> out_;
};

/// Reads big-endian fields from a payload; every shortfall is a BadPayload
/// naming the message and the field.
class Reader {
public:
    Reader(const std::vector<std::uint8_t>& in, const char* message) : in_(in), message_(message) {}
    std::uint8_t u8(const char* field) { return static_cast<std::uint8_t>(get(1, field)); }
    std::uint16_t u16(const char* field) { return static_cast<std::uint16_t>(get(2, field)); }
    std::uint32_t u32(const char* field) { return static_cast<std::uint32_t>(get(4, field)); }
    std::uint64_t u64(const char* field) { return get(8, field); }
    std::int64_t i64(const char* field) { return static_cast<std::int64_t>(get(8, field)); }
    double f64(const char* field) {
        const std::uint64_t bits = get(8, field);
        double v;
        std::memcpy(&v, &bits, sizeof v);
        return v;
    }
    std::string str(const char* field) {
        const std::uint32_t n = u32(field);
        need(n, field);
        std::string s(reinterpret_cast<const char*>(in_.data() + pos_), n);
        pos_ += n;
        return s;
    }
    std::vector<std::uint8_t> bytes(const char* field) {
        const std::uint32_t n = u32(field);
        need(n, field);
        std::vector<std::uint8_t> b(in_.begin() + static_cast<std::ptrdiff_t>(pos_),
                                    in_.begin() + static_cast<std::ptrdiff_t>(pos_ + n));
        pos_ += n;
        return b;
    }
    cv::Point2d point2(const char* field) {
        const double x = f64(field);
        return {x, f64(field)};
    }
    cv::Point3d point3(const char* field) {
        const double x = f64(field);
        const double y = f64(field);
        return {x, y, f64(field)};
    }
    bool present(const char* field) {
        const std::uint8_t flag = u8(field);
        if (flag > 1) fail(std::string(field) + ": optional flag " + std::to_string(flag) + " is not 0 or 1");
        return flag == 1;
    }
    /// A count of items each at least @p minItemSize bytes: checked against
    /// what is left, so a forged count cannot make us allocate.
    std::uint32_t count(const char* field, std::size_t minItemSize) {
        const std::uint32_t n = u32(field);
        if (minItemSize > 0 && n > (in_.size() - pos_) / minItemSize)
            fail(std::string(field) + ": count " + std::to_string(n) + " does not fit the " +
                 std::to_string(in_.size() - pos_) + " bytes left");
        return n;
    }
    void end() {
        if (pos_ != in_.size())
            fail(std::to_string(in_.size() - pos_) + " unexpected byte(s) after the last field");
    }
    [[noreturn]] void fail(const std::string& what) {
        throw ProtocolError(ErrorCode::BadPayload, std::string(message_) + ": " + what);
    }

private:
    void need(std::size_t n, const char* field) {
        if (in_.size() - pos_ < n)
            fail(std::string(field) + ": needs " + std::to_string(n) + " byte(s), " +
                 std::to_string(in_.size() - pos_) + " left");
    }
    std::uint64_t get(int n, const char* field) {
        need(static_cast<std::size_t>(n), field);
        std::uint64_t v = 0;
        for (int i = 0; i < n; ++i) v = (v << 8) | in_[pos_++];
        return v;
    }
    const std::vector<std::uint8_t>& in_;
    const char* message_;
    std::size_t pos_{0};
};

void writeStamp(Writer& w, const CameraStamp& s) {
    w.str(s.cameraId);
    w.i64(s.timestampUs);
}

CameraStamp readStamp(Reader& r, const char* idField, const char* timeField) {
    CameraStamp s;
    s.cameraId = r.str(idField);
    s.timestampUs = r.i64(timeField);
    return s;
}

}  // namespace

ProtocolError::ProtocolError(ErrorCode code, const std::string& message)
    : avatar::Error(std::string(errorName(code)) + ": " + message), code_(code) {}

std::string messageName(std::uint16_t type) {
    const bool reply = type != 0xFFFF && (type & kReplyBit);
    const char* name = nullptr;
    switch (static_cast<MessageType>(reply ? type & ~kReplyBit : type)) {
        case MessageType::Hello: name = "HELLO"; break;
        case MessageType::StartSearching: name = "START_SEARCHING"; break;
        case MessageType::StopSearching: name = "STOP_SEARCHING"; break;
        case MessageType::TakeSnapshot: name = "TAKE_SNAPSHOT"; break;
        case MessageType::GetTargetData: name = "GET_TARGET_DATA"; break;
        case MessageType::SendConfig: name = "SEND_CONFIG"; break;
        case MessageType::GetConfig: name = "GET_CONFIG"; break;
        case MessageType::GetImages: name = "GET_IMAGES"; break;
        case MessageType::Status: name = "STATUS"; break;
        case MessageType::Authenticate: name = "AUTHENTICATE"; break;
        case MessageType::Error: name = "ERROR"; break;
    }
    if (!name) {
        char hex[8];
        std::snprintf(hex, sizeof hex, "0x%04X", type);
        return hex;
    }
    return reply ? std::string(name) + "_REPLY" : std::string(name);
}

const char* errorName(ErrorCode code) {
    switch (code) {
        case ErrorCode::MalformedFrame: return "MALFORMED_FRAME";
        case ErrorCode::FrameTooLarge: return "FRAME_TOO_LARGE";
        case ErrorCode::HelloRequired: return "HELLO_REQUIRED";
        case ErrorCode::VersionUnsupported: return "VERSION_UNSUPPORTED";
        case ErrorCode::UnknownMessage: return "UNKNOWN_MESSAGE";
        case ErrorCode::BadPayload: return "BAD_PAYLOAD";
        case ErrorCode::ConfigRejected: return "CONFIG_REJECTED";
        case ErrorCode::AcquisitionFailed: return "ACQUISITION_FAILED";
        case ErrorCode::Timeout: return "TIMEOUT";
        case ErrorCode::NotAvailable: return "NOT_AVAILABLE";
        case ErrorCode::InvalidState: return "INVALID_STATE";
        case ErrorCode::Internal: return "INTERNAL";
        case ErrorCode::AuthenticationRequired: return "AUTHENTICATION_REQUIRED";
        case ErrorCode::AuthenticationFailed: return "AUTHENTICATION_FAILED";
    }
    return "UNKNOWN_ERROR";
}

bool closesConnection(ErrorCode code) {
    return code == ErrorCode::MalformedFrame || code == ErrorCode::FrameTooLarge ||
           code == ErrorCode::HelloRequired || code == ErrorCode::VersionUnsupported ||
           code == ErrorCode::AuthenticationRequired || code == ErrorCode::AuthenticationFailed;
}

std::vector<std::uint8_t> encodeFrame(std::uint16_t type, std::uint32_t request,
                                      const std::vector<std::uint8_t>& payload) {
    if (payload.size() > kMaxReplyPayload)
        throw ProtocolError(ErrorCode::FrameTooLarge, messageName(type) + " payload of " +
                                                          std::to_string(payload.size()) + " bytes");
    Writer w;
    w.u32(static_cast<std::uint32_t>(payload.size()));
    w.u16(type);
    w.u16(0);
    w.u32(request);
    std::vector<std::uint8_t> frame = w.take();
    frame.insert(frame.end(), payload.begin(), payload.end());
    return frame;
}

FrameDecoder::FrameDecoder(std::uint32_t maxPayload) : maxPayload_(maxPayload) {}

void FrameDecoder::feed(const std::uint8_t* data, std::size_t size) {
    if (offset_ > 0 && offset_ == buffer_.size()) {
        buffer_.clear();
        offset_ = 0;
    }
    buffer_.insert(buffer_.end(), data, data + size);
}

std::optional<Frame> FrameDecoder::next() {
    if (failed_) throw ProtocolError(ErrorCode::MalformedFrame, "stream already failed");
    if (buffered() < kHeaderSize) return std::nullopt;
    const std::uint8_t* h = buffer_.data() + offset_;
    FrameHeader header;
    header.length = (std::uint32_t{h[0]} << 24) | (std::uint32_t{h[1]} << 16) | (std::uint32_t{h[2]} << 8) | h[3];
    header.type = static_cast<std::uint16_t>((h[4] << 8) | h[5]);
    header.reserved = static_cast<std::uint16_t>((h[6] << 8) | h[7]);
    header.request = (std::uint32_t{h[8]} << 24) | (std::uint32_t{h[9]} << 16) | (std::uint32_t{h[10]} << 8) | h[11];
    if (header.reserved != 0) {
        failed_ = true;
        throw ProtocolError(ErrorCode::MalformedFrame, "reserved header field is " + std::to_string(header.reserved) +
                                                           ", must be 0 (request " + std::to_string(header.request) + ")");
    }
    if (header.length > maxPayload_) {
        failed_ = true;
        throw ProtocolError(ErrorCode::FrameTooLarge, messageName(header.type) + " payload of " +
                                                          std::to_string(header.length) + " bytes exceeds the limit of " +
                                                          std::to_string(maxPayload_));
    }
    if (buffered() < kHeaderSize + header.length) return std::nullopt;
    Frame frame;
    frame.header = header;
    const auto begin = buffer_.begin() + static_cast<std::ptrdiff_t>(offset_ + kHeaderSize);
    frame.payload.assign(begin, begin + header.length);
    offset_ += kHeaderSize + header.length;
    // Compact once the consumed prefix dominates, so the buffer does not grow forever.
    if (offset_ > 65536 && offset_ * 2 > buffer_.size()) {
        buffer_.erase(buffer_.begin(), buffer_.begin() + static_cast<std::ptrdiff_t>(offset_));
        offset_ = 0;
    }
    return frame;
}

bool StatusReply::operator==(const StatusReply& o) const {
    return state == o.state && error == o.error && heartbeat == o.heartbeat && iteration == o.iteration &&
           configVersion == o.configVersion && configIteration == o.configIteration &&
           targetsIteration == o.targetsIteration && imagesIteration == o.imagesIteration &&
           acquisitionState == o.acquisitionState && acquisitionMessage == o.acquisitionMessage &&
           visibility == o.visibility && visibilityReason == o.visibilityReason &&
           recordBacklog == o.recordBacklog && recorded == o.recorded && unrecorded == o.unrecorded &&
           recordError == o.recordError && backend == o.backend;
}

// ---- encoders --------------------------------------------------------------

std::vector<std::uint8_t> encode(const Hello& m) {
    Writer w;
    w.u16(m.version);
    w.str(m.clientName);
    return w.take();
}
std::vector<std::uint8_t> encode(const HelloReply& m) {
    Writer w;
    w.u16(m.version);
    w.str(m.serverName);
    w.str(m.backend);
    if (m.version >= kAuthenticatingVersion) {
        w.u8(m.authenticationRequired ? 1 : 0);
        w.bytes(m.challenge);
    }
    return w.take();
}
std::vector<std::uint8_t> encode(const Authenticate& m) {
    Writer w;
    w.bytes(m.nonce);
    w.bytes(m.mac);
    return w.take();
}
std::vector<std::uint8_t> encode(const AuthenticateReply& m) {
    Writer w;
    w.bytes(m.mac);
    return w.take();
}
std::vector<std::uint8_t> encode(const TakeSnapshot& m) {
    Writer w;
    w.u32(m.timeoutMs);
    return w.take();
}
std::vector<std::uint8_t> encode(const SendConfig& m) {
    Writer w;
    w.str(m.xml);
    return w.take();
}
std::vector<std::uint8_t> encode(const ConfigApplied& m) {
    Writer w;
    w.u32(m.configVersion);
    w.u64(m.configIteration);
    return w.take();
}
std::vector<std::uint8_t> encode(const ConfigReply& m) {
    Writer w;
    w.u32(m.configVersion);
    w.u64(m.configIteration);
    w.str(m.xml);
    return w.take();
}
std::vector<std::uint8_t> encode(const GetImages& m) {
    Writer w;
    w.u8(static_cast<std::uint8_t>(m.kind));
    w.u8(m.sides);
    w.u8(m.jpegQuality);
    return w.take();
}
std::vector<std::uint8_t> encode(const ImagesReply& m) {
    Writer w;
    w.u64(m.iteration);
    w.u8(static_cast<std::uint8_t>(m.kind));
    if (m.images.size() > 2) throw ProtocolError(ErrorCode::Internal, "IMAGES_REPLY with more than 2 images");
    w.u8(static_cast<std::uint8_t>(m.images.size()));
    for (const EncodedImage& i : m.images) {
        w.u8(i.side);
        w.u32(i.width);
        w.u32(i.height);
        w.bytes(i.jpeg);
    }
    return w.take();
}
std::size_t encodedSize(const ImagesReply& m) {
    // iteration u64, kind u8, count u8; per image side u8, width u32, height u32, JPEG bytes (u32 length + data).
    std::size_t size = 8 + 1 + 1;
    for (const EncodedImage& i : m.images) size += 1 + 4 + 4 + 4 + i.jpeg.size();
    return size;
}

std::vector<std::uint8_t> encode(const StatusReply& m) {
    Writer w;
    w.u8(m.state);
    w.str(m.error);
    w.u64(m.heartbeat);
    w.u64(m.iteration);
    w.u32(m.configVersion);
    w.u64(m.configIteration);
    w.u64(m.targetsIteration);
    w.u64(m.imagesIteration);
    w.u8(m.acquisitionState);
    w.str(m.acquisitionMessage);
    w.u8(m.visibility);
    w.str(m.visibilityReason);
    w.u64(m.recordBacklog);
    w.u64(m.recorded);
    w.u64(m.unrecorded);
    w.str(m.recordError);
    w.str(m.backend);
    return w.take();
}
std::vector<std::uint8_t> encode(const ErrorReply& m) {
    Writer w;
    w.u16(static_cast<std::uint16_t>(m.code));
    w.str(m.message);
    return w.take();
}
namespace {

/// The upper triangle of a covariance, row by row: xx, xy, xz, yy, yz, zz.
constexpr std::array<std::pair<int, int>, 6> kCovarianceEntries{
    {{0, 0}, {0, 1}, {0, 2}, {1, 1}, {1, 2}, {2, 2}}};

/// What a version-1 client may see of a target (docs/protocol.md, "Version 1").
VisionTarget versionOneView(const VisionTarget& t) {
    VisionTarget v = t;
    v.flags &= kTargetStereo | kTargetLeftOnly | kTargetRightOnly | kTargetAtBorder | kTargetShapeCorrected;
    if (!(t.flags & kTargetWhole)) {
        v.flags &= ~static_cast<std::uint32_t>(kTargetStereo | kTargetShapeCorrected);
        v.positionVisionMm.reset();
        v.positionBaseMm.reset();
    }
    return v;
}

}  // namespace

std::vector<std::uint8_t> encode(const VisionTargets& m, std::uint16_t version) {
    if (!protocolVersionSupported(version))
        throw InvalidArgument("encode(TargetData): protocol version " + std::to_string(version) + " is not spoken");
    Writer w;
    w.u64(m.iteration);
    w.u32(m.acquisition.group);
    w.u32(m.acquisition.member);
    writeStamp(w, m.acquisition.left);
    writeStamp(w, m.acquisition.right);
    w.u8(static_cast<std::uint8_t>(m.visibility == Visibility::Good ? 1 : m.visibility == Visibility::Poor ? 2 : 0));
    w.str(m.visibilityReason);
    w.u32(static_cast<std::uint32_t>(m.targets.size()));
    for (const VisionTarget& target : m.targets) {
        const VisionTarget t = version == 1 ? versionOneView(target) : target;
        w.str(t.type);
        w.u32(t.flags);
        w.opt(t.positionVisionMm, [&](const cv::Point3d& p) { w.point3(p); });
        w.opt(t.positionBaseMm, [&](const cv::Point3d& p) { w.point3(p); });
        w.opt(t.centroidLeftPx, [&](const cv::Point2d& p) { w.point2(p); });
        w.opt(t.centroidRightPx, [&](const cv::Point2d& p) { w.point2(p); });
        w.f64(t.areaLeftPx);
        w.f64(t.areaRightPx);
        w.f64(t.matchError);
        if (version == 1) continue;
        w.u8(static_cast<std::uint8_t>(t.model));
        const auto covariance = [&](const Covariance3& c) {
            for (const auto& [i, j] : kCovarianceEntries) w.f64(c(i, j));
        };
        w.opt(t.covarianceVisionMm2, covariance);
        w.opt(t.covarianceBaseMm2, covariance);
        w.f64(t.rayResidualMm);
        w.f64(t.rayResidualPx);
    }
    w.u32(static_cast<std::uint32_t>(m.timings.size()));
    for (const StageTiming& s : m.timings) {
        w.str(s.stage);
        w.f64(s.milliseconds);
    }
    return w.take();
}

// ---- decoders --------------------------------------------------------------

Hello decodeHello(const std::vector<std::uint8_t>& payload) {
    Reader r(payload, "HELLO");
    Hello m;
    m.version = r.u16("version");
    m.clientName = r.str("clientName");
    r.end();
    return m;
}
HelloReply decodeHelloReply(const std::vector<std::uint8_t>& payload) {
    Reader r(payload, "HELLO_REPLY");
    HelloReply m;
    m.version = r.u16("version");
    m.serverName = r.str("serverName");
    m.backend = r.str("backend");
    if (m.version >= kAuthenticatingVersion) {
        const std::uint8_t required = r.u8("authentication");
        if (required > 1) r.fail("authentication: " + std::to_string(required) + " is not 0 or 1");
        m.authenticationRequired = required == 1;
        m.challenge = r.bytes("challenge");
        if (!m.challenge.empty() && m.challenge.size() != kChallengeSize)
            r.fail("challenge: " + std::to_string(m.challenge.size()) + " bytes, not 0 or " +
                   std::to_string(kChallengeSize));
        if (m.authenticationRequired && m.challenge.empty())
            r.fail("challenge: empty although authentication is required");
    }
    r.end();
    return m;
}

namespace {
std::vector<std::uint8_t> exactBytes(Reader& r, const char* field, std::size_t size) {
    std::vector<std::uint8_t> b = r.bytes(field);
    if (b.size() != size)
        r.fail(std::string(field) + ": " + std::to_string(b.size()) + " bytes, not " + std::to_string(size));
    return b;
}
}  // namespace

Authenticate decodeAuthenticate(const std::vector<std::uint8_t>& payload) {
    Reader r(payload, "AUTHENTICATE");
    Authenticate m;
    m.nonce = exactBytes(r, "nonce", kChallengeSize);
    m.mac = exactBytes(r, "mac", kMacSize);
    r.end();
    return m;
}
AuthenticateReply decodeAuthenticateReply(const std::vector<std::uint8_t>& payload) {
    Reader r(payload, "AUTHENTICATE_REPLY");
    AuthenticateReply m;
    m.mac = exactBytes(r, "mac", kMacSize);
    r.end();
    return m;
}
std::optional<std::uint16_t> helloVersion(const std::vector<std::uint8_t>& payload) {
    if (payload.size() < 2) return std::nullopt;
    return static_cast<std::uint16_t>((unsigned{payload[0]} << 8) | payload[1]);
}

TakeSnapshot decodeTakeSnapshot(const std::vector<std::uint8_t>& payload) {
    Reader r(payload, "TAKE_SNAPSHOT");
    TakeSnapshot m;
    m.timeoutMs = r.u32("timeoutMs");
    r.end();
    return m;
}
SendConfig decodeSendConfig(const std::vector<std::uint8_t>& payload) {
    Reader r(payload, "SEND_CONFIG");
    SendConfig m;
    m.xml = r.str("xml");
    r.end();
    return m;
}
ConfigApplied decodeConfigApplied(const std::vector<std::uint8_t>& payload) {
    Reader r(payload, "SEND_CONFIG_REPLY");
    ConfigApplied m;
    m.configVersion = r.u32("configVersion");
    m.configIteration = r.u64("configIteration");
    r.end();
    return m;
}
ConfigReply decodeConfigReply(const std::vector<std::uint8_t>& payload) {
    Reader r(payload, "GET_CONFIG_REPLY");
    ConfigReply m;
    m.configVersion = r.u32("configVersion");
    m.configIteration = r.u64("configIteration");
    m.xml = r.str("xml");
    r.end();
    return m;
}
GetImages decodeGetImages(const std::vector<std::uint8_t>& payload) {
    Reader r(payload, "GET_IMAGES");
    GetImages m;
    const std::uint8_t kind = r.u8("kind");
    if (kind > 2) r.fail("kind " + std::to_string(kind) + " is not 0 (original), 1 (filtered) or 2 (marked)");
    m.kind = static_cast<ImageKindCode>(kind);
    m.sides = r.u8("sides");
    if (m.sides == 0 || (m.sides & ~(kLeftImage | kRightImage)) != 0)
        r.fail("sides " + std::to_string(m.sides) + " is not 1 (left), 2 (right) or 3 (both)");
    m.jpegQuality = r.u8("jpegQuality");
    if (m.jpegQuality < 1 || m.jpegQuality > 100)
        r.fail("jpegQuality " + std::to_string(m.jpegQuality) + " is outside 1..100");
    r.end();
    return m;
}
ImagesReply decodeImagesReply(const std::vector<std::uint8_t>& payload) {
    Reader r(payload, "GET_IMAGES_REPLY");
    ImagesReply m;
    m.iteration = r.u64("iteration");
    const std::uint8_t kind = r.u8("kind");
    if (kind > 2) r.fail("kind " + std::to_string(kind) + " is not 0, 1 or 2");
    m.kind = static_cast<ImageKindCode>(kind);
    const std::uint8_t count = r.u8("count");
    if (count > 2) r.fail("count " + std::to_string(count) + " is above 2");
    for (std::uint8_t i = 0; i < count; ++i) {
        EncodedImage image;
        image.side = r.u8("side");
        if (image.side > 1) r.fail("side " + std::to_string(image.side) + " is not 0 (left) or 1 (right)");
        image.width = r.u32("width");
        image.height = r.u32("height");
        image.jpeg = r.bytes("jpeg");
        m.images.push_back(std::move(image));
    }
    r.end();
    return m;
}
StatusReply decodeStatusReply(const std::vector<std::uint8_t>& payload) {
    Reader r(payload, "STATUS_REPLY");
    StatusReply m;
    m.state = r.u8("state");
    if (m.state > 3) r.fail("state " + std::to_string(m.state) + " is not 0..3");
    m.error = r.str("error");
    m.heartbeat = r.u64("heartbeat");
    m.iteration = r.u64("iteration");
    m.configVersion = r.u32("configVersion");
    m.configIteration = r.u64("configIteration");
    m.targetsIteration = r.u64("targetsIteration");
    m.imagesIteration = r.u64("imagesIteration");
    m.acquisitionState = r.u8("acquisitionState");
    if (m.acquisitionState > 3) r.fail("acquisitionState " + std::to_string(m.acquisitionState) + " is not 0..3");
    m.acquisitionMessage = r.str("acquisitionMessage");
    m.visibility = r.u8("visibility");
    if (m.visibility > 2) r.fail("visibility " + std::to_string(m.visibility) + " is not 0..2");
    m.visibilityReason = r.str("visibilityReason");
    m.recordBacklog = r.u64("recordBacklog");
    m.recorded = r.u64("recorded");
    m.unrecorded = r.u64("unrecorded");
    m.recordError = r.str("recordError");
    m.backend = r.str("backend");
    r.end();
    return m;
}
ErrorReply decodeErrorReply(const std::vector<std::uint8_t>& payload) {
    Reader r(payload, "ERROR");
    ErrorReply m;
    const std::uint16_t code = r.u16("code");
    if (code < 1 || code > 14) r.fail("code " + std::to_string(code) + " is not 1..14");
    m.code = static_cast<ErrorCode>(code);
    m.message = r.str("message");
    r.end();
    return m;
}
VisionTargets decodeTargetData(const std::vector<std::uint8_t>& payload, std::uint16_t version) {
    if (!protocolVersionSupported(version))
        throw InvalidArgument("decodeTargetData: protocol version " + std::to_string(version) + " is not spoken");
    Reader r(payload, "TARGET_DATA");
    VisionTargets m;
    m.iteration = r.u64("iteration");
    m.acquisition.group = r.u32("group");
    m.acquisition.member = r.u32("member");
    m.acquisition.left = readStamp(r, "leftCameraId", "leftTimeUs");
    m.acquisition.right = readStamp(r, "rightCameraId", "rightTimeUs");
    const std::uint8_t visibility = r.u8("visibility");
    if (visibility > 2) r.fail("visibility " + std::to_string(visibility) + " is not 0..2");
    m.visibility = visibility == 1 ? Visibility::Good : visibility == 2 ? Visibility::Poor : Visibility::Unknown;
    m.visibilityReason = r.str("visibilityReason");
    // A target is at least 4 (type) + 4 (flags) + 4 (optional flags) + 24
    // bytes; version 2 adds 1 (model) + 2 (optional flags) + 16.
    const std::uint32_t targets = r.count("targetCount", version == 1 ? 36 : 55);
    m.targets.reserve(targets);
    for (std::uint32_t i = 0; i < targets; ++i) {
        VisionTarget t;
        t.type = r.str("type");
        t.flags = r.u32("flags");
        if (r.present("positionVision")) t.positionVisionMm = r.point3("positionVision");
        if (r.present("positionBase")) t.positionBaseMm = r.point3("positionBase");
        if (r.present("centroidLeft")) t.centroidLeftPx = r.point2("centroidLeft");
        if (r.present("centroidRight")) t.centroidRightPx = r.point2("centroidRight");
        t.areaLeftPx = r.f64("areaLeft");
        t.areaRightPx = r.f64("areaRight");
        t.matchError = r.f64("matchError");
        if (version >= 2) {
            const std::uint8_t model = r.u8("shapeModel");
            if (model > 3) r.fail("shapeModel " + std::to_string(model) + " is not 0..3");
            t.model = static_cast<ShapeModel>(model);
            const auto covariance = [&](const char* field) {
                Covariance3 c;
                for (const auto& [a, b] : kCovarianceEntries) c(a, b) = c(b, a) = r.f64(field);
                return c;
            };
            if (r.present("covarianceVision")) t.covarianceVisionMm2 = covariance("covarianceVision");
            if (r.present("covarianceBase")) t.covarianceBaseMm2 = covariance("covarianceBase");
            t.rayResidualMm = r.f64("rayResidualMm");
            t.rayResidualPx = r.f64("rayResidualPx");
        }
        m.targets.push_back(std::move(t));
    }
    const std::uint32_t timings = r.count("timingCount", 12);
    m.timings.reserve(timings);
    for (std::uint32_t i = 0; i < timings; ++i) {
        StageTiming s;
        s.stage = r.str("stage");
        s.milliseconds = r.f64("milliseconds");
        m.timings.push_back(std::move(s));
    }
    r.end();
    return m;
}
void decodeEmpty(MessageType type, const std::vector<std::uint8_t>& payload) {
    if (!payload.empty())
        throw ProtocolError(ErrorCode::BadPayload, messageName(static_cast<std::uint16_t>(type)) + ": takes no fields, got " +
                                                       std::to_string(payload.size()) + " byte(s)");
}

}  // namespace avatar::tau
