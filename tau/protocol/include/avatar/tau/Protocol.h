#pragma once
/// @file Protocol.h
/// The TAU protocol, version 3 (docs/protocol.md; versions 1 and 2 are still served where no
/// authentication is required): frames, messages and their
/// byte encodings, shared by TAUNet and TAUUnit. Pure data and functions: no
/// sockets, no threads, no analysis types beyond the plain result records.
///
/// Error policy: decoding untrusted bytes never throws anything but
/// ProtocolError, whose code() is the error code the server answers with.

#include <avatar/common/Error.h>
#include <avatar/common/VisionTargets.h>

#include <cstddef>
#include <cstdint>
#include <optional>
#include <string>
#include <vector>

namespace avatar::tau {

/// The version this build speaks by default (TAUUnit asks for it).
inline constexpr std::uint16_t kProtocolVersion = 3;
/// The first version with authentication (HELLO_REPLY's challenge, AUTHENTICATE).
inline constexpr std::uint16_t kAuthenticatingVersion = 3;
/// The oldest version a server still serves. Version 1 differs in the Target
/// record only (docs/protocol.md, "Version 1"); versions 1 and 2 have no
/// authentication and are refused where it is required.
inline constexpr std::uint16_t kOldestProtocolVersion = 1;
/// True for the versions this build speaks.
constexpr bool protocolVersionSupported(std::uint16_t version) {
    return version >= kOldestProtocolVersion && version <= kProtocolVersion;
}
inline constexpr std::size_t kHeaderSize = 12;
inline constexpr std::uint32_t kMaxRequestPayload = 1u << 20;   ///< 1 MiB
inline constexpr std::uint32_t kMaxReplyPayload = 64u << 20;    ///< 64 MiB

/// Message types (docs/protocol.md). A reply's type is its request's | kReplyBit.
enum class MessageType : std::uint16_t {
    Hello = 0x0001,
    StartSearching = 0x0002,
    StopSearching = 0x0003,
    TakeSnapshot = 0x0004,
    GetTargetData = 0x0005,
    SendConfig = 0x0006,
    GetConfig = 0x0007,
    GetImages = 0x0008,
    Status = 0x0009,
    Authenticate = 0x000A,  ///< version 3
    Error = 0xFFFF
};
inline constexpr std::uint16_t kReplyBit = 0x8000;
/// The reply type of a request type.
constexpr std::uint16_t replyType(MessageType request) { return static_cast<std::uint16_t>(request) | kReplyBit; }
/// "HELLO", "START_SEARCHING", ... or "0x1234" for an unknown type.
std::string messageName(std::uint16_t type);

enum class ErrorCode : std::uint16_t {
    MalformedFrame = 1,
    FrameTooLarge = 2,
    HelloRequired = 3,
    VersionUnsupported = 4,
    UnknownMessage = 5,
    BadPayload = 6,
    ConfigRejected = 7,
    AcquisitionFailed = 8,
    Timeout = 9,
    NotAvailable = 10,
    InvalidState = 11,
    Internal = 12,
    AuthenticationRequired = 13,  ///< a request before AUTHENTICATE where it is required
    AuthenticationFailed = 14     ///< AUTHENTICATE's proof is wrong
};
/// "MALFORMED_FRAME", ...
const char* errorName(ErrorCode code);
/// True for the codes after which the server closes the connection.
bool closesConnection(ErrorCode code);

/// Bytes that do not follow the protocol.
class ProtocolError : public avatar::Error {
public:
    ProtocolError(ErrorCode code, const std::string& message);
    ErrorCode code() const { return code_; }

private:
    ErrorCode code_;
};

struct FrameHeader {
    std::uint32_t length{0};
    std::uint16_t type{0};
    std::uint16_t reserved{0};
    std::uint32_t request{0};
};

/// One whole frame.
struct Frame {
    FrameHeader header;
    std::vector<std::uint8_t> payload;
};

/// Header + payload as bytes.
std::vector<std::uint8_t> encodeFrame(std::uint16_t type, std::uint32_t request,
                                      const std::vector<std::uint8_t>& payload);

/// Incremental frame reassembly from a byte stream (TCP delivers arbitrary
/// pieces). Feed bytes as they arrive, take whole frames out.
class FrameDecoder {
public:
    explicit FrameDecoder(std::uint32_t maxPayload);
    /// Appends received bytes.
    void feed(const std::uint8_t* data, std::size_t size);
    /// The next whole frame, or std::nullopt if more bytes are needed. Throws
    /// ProtocolError (MalformedFrame: reserved != 0; FrameTooLarge: length above
    /// the limit) as soon as the header shows it; the decoder is then unusable.
    std::optional<Frame> next();
    /// Bytes received but not yet returned as frames.
    std::size_t buffered() const { return buffer_.size() - offset_; }

private:
    std::uint32_t maxPayload_;
    std::vector<std::uint8_t> buffer_;
    std::size_t offset_{0};
    bool failed_{false};
};

// ---- message payloads ----------------------------------------------------

struct Hello {
    std::uint16_t version{kProtocolVersion};
    std::string clientName;
};
struct HelloReply {
    std::uint16_t version{kProtocolVersion};
    std::string serverName;
    std::string backend;
    // Version 3 only (not encoded for versions 1 and 2):
    /// The connection must AUTHENTICATE before any other request.
    bool authenticationRequired{false};
    /// kChallengeSize fresh random bytes when the server has a key, else empty.
    std::vector<std::uint8_t> challenge;
};
/// Version 3: the client's proof of the key (docs/protocol.md, "Authentication").
struct Authenticate {
    std::vector<std::uint8_t> nonce;  ///< kChallengeSize random bytes chosen by the client
    std::vector<std::uint8_t> mac;    ///< clientProof(key, challenge, nonce)
};
/// Version 3: the server's proof of the key.
struct AuthenticateReply {
    std::vector<std::uint8_t> mac;  ///< serverProof(key, challenge, nonce)
};
struct TakeSnapshot {
    std::uint32_t timeoutMs{10000};
};
struct SendConfig {
    std::string xml;
};
struct ConfigApplied {
    std::uint32_t configVersion{0};
    std::uint64_t configIteration{0};
};
struct ConfigReply {
    std::uint32_t configVersion{0};
    std::uint64_t configIteration{0};
    std::string xml;
};

enum class ImageKindCode : std::uint8_t { Original = 0, Filtered = 1, Marked = 2 };
inline constexpr std::uint8_t kLeftImage = 1u << 0;
inline constexpr std::uint8_t kRightImage = 1u << 1;

struct GetImages {
    ImageKindCode kind{ImageKindCode::Original};
    std::uint8_t sides{kLeftImage | kRightImage};  ///< not 0, no other bits
    std::uint8_t jpegQuality{90};                  ///< 1..100
};
struct EncodedImage {
    std::uint8_t side{0};  ///< 0 left, 1 right
    std::uint32_t width{0};
    std::uint32_t height{0};
    std::vector<std::uint8_t> jpeg;
};
struct ImagesReply {
    std::uint64_t iteration{0};
    ImageKindCode kind{ImageKindCode::Original};
    std::vector<EncodedImage> images;  ///< at most 2
};

/// The Status payload (docs/protocol.md), field for field.
struct StatusReply {
    std::uint8_t state{0};  ///< 0 idle, 1 searching, 2 snapshot, 3 error
    std::string error;
    std::uint64_t heartbeat{0};
    std::uint64_t iteration{0};
    std::uint32_t configVersion{0};
    std::uint64_t configIteration{0};
    std::uint64_t targetsIteration{0};
    std::uint64_t imagesIteration{0};
    std::uint8_t acquisitionState{0};  ///< 0 ok, 1 recovering, 2 failed, 3 finished
    std::string acquisitionMessage;
    std::uint8_t visibility{0};  ///< 0 unknown, 1 good, 2 poor
    std::string visibilityReason;
    std::uint64_t recordBacklog{0};
    std::uint64_t recorded{0};
    std::uint64_t unrecorded{0};
    std::string recordError;
    std::string backend;
    bool operator==(const StatusReply& o) const;
};

struct ErrorReply {
    ErrorCode code{ErrorCode::Internal};
    std::string message;
};

// Encoders produce the payload only (no header). Decoders take a whole payload,
// check it is consumed exactly and every value is in range, and throw
// ProtocolError(BadPayload, "<message name>: <what is wrong>") otherwise.
std::vector<std::uint8_t> encode(const Hello& m);
/// In the layout of m.version (the authentication fields from version 3 on).
std::vector<std::uint8_t> encode(const HelloReply& m);
std::vector<std::uint8_t> encode(const Authenticate& m);
std::vector<std::uint8_t> encode(const AuthenticateReply& m);
std::vector<std::uint8_t> encode(const TakeSnapshot& m);
std::vector<std::uint8_t> encode(const SendConfig& m);
std::vector<std::uint8_t> encode(const ConfigApplied& m);
std::vector<std::uint8_t> encode(const ConfigReply& m);
std::vector<std::uint8_t> encode(const GetImages& m);
std::vector<std::uint8_t> encode(const ImagesReply& m);
std::vector<std::uint8_t> encode(const StatusReply& m);
std::vector<std::uint8_t> encode(const ErrorReply& m);
/// TargetData: every field of docs/protocol.md in the layout of @p version.
/// Version 1 has no shape model, covariances or ray residuals and knows flag
/// bits 0-4 only; a target that is not whole (kTargetWhole clear) goes to a
/// version-1 client without the stereo bit and without positions, because
/// such a client reads the stereo bit as "position valid".
std::vector<std::uint8_t> encode(const VisionTargets& m, std::uint16_t version = kProtocolVersion);

/// The size of encode(@p m) in bytes, computed without encoding: a server can
/// refuse a reply above kMaxReplyPayload before building it.
std::size_t encodedSize(const ImagesReply& m);

/// The protocol version a HELLO payload announces: its first field, read
/// before the rest is decoded, since a client of another version may send
/// another HELLO layout (docs/protocol.md). std::nullopt when the payload is
/// too short to hold it.
std::optional<std::uint16_t> helloVersion(const std::vector<std::uint8_t>& payload);

Hello decodeHello(const std::vector<std::uint8_t>& payload);
/// In the layout of the version it starts with.
HelloReply decodeHelloReply(const std::vector<std::uint8_t>& payload);
Authenticate decodeAuthenticate(const std::vector<std::uint8_t>& payload);
AuthenticateReply decodeAuthenticateReply(const std::vector<std::uint8_t>& payload);
TakeSnapshot decodeTakeSnapshot(const std::vector<std::uint8_t>& payload);
SendConfig decodeSendConfig(const std::vector<std::uint8_t>& payload);
ConfigApplied decodeConfigApplied(const std::vector<std::uint8_t>& payload);
ConfigReply decodeConfigReply(const std::vector<std::uint8_t>& payload);
GetImages decodeGetImages(const std::vector<std::uint8_t>& payload);
ImagesReply decodeImagesReply(const std::vector<std::uint8_t>& payload);
StatusReply decodeStatusReply(const std::vector<std::uint8_t>& payload);
ErrorReply decodeErrorReply(const std::vector<std::uint8_t>& payload);
VisionTargets decodeTargetData(const std::vector<std::uint8_t>& payload,
                               std::uint16_t version = kProtocolVersion);
/// Requests without fields: throws BadPayload unless @p payload is empty.
void decodeEmpty(MessageType type, const std::vector<std::uint8_t>& payload);

}  // namespace avatar::tau
