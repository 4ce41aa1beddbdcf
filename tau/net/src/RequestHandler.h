#pragma once
/// @file RequestHandler.h
/// Internal: answers one decoded TAU request from a VisionInterface. This is
/// the whole mapping between the vision layer and the protocol (status codes,
/// target data, images, errors); the connection code around it only moves
/// frames. No sockets in here.

#include <avatar/tau/Protocol.h>
#include <avatar/tau/VisionInterface.h>

#include <cstdint>
#include <exception>
#include <optional>
#include <string>
#include <vector>

namespace avatar::tau::detail {

/// VisionState -> Status.state (0 idle, 1 searching, 2 snapshot, 3 error).
std::uint8_t stateCode(VisionState state);
/// AcquisitionStatus::State -> Status.acquisitionState (0 ok, 1 recovering, 2 failed, 3 finished).
std::uint8_t acquisitionCode(AcquisitionStatus::State state);
/// Visibility -> 0 unknown, 1 good, 2 poor.
std::uint8_t visibilityCode(Visibility visibility);
ImageKind imageKind(ImageKindCode code);

/// The Status payload of a VisionStatus (recorder fields 0/empty when not recording).
StatusReply statusReply(const VisionStatus& status, const std::string& backend);

/// The requested sides of @p images as JPEG (Bayer demosaiced, 16-bit scaled
/// to 8 from the layout's bit depth). Throws avatar::Error when encoding fails
/// or the reply would exceed kMaxReplyPayload.
ImagesReply encodeImages(const VisionImages& images, const GetImages& request);

/// The ERROR payload for a failure: the one table from the kind of failure
/// (the exception's type, never its text) to the protocol's error code
/// (docs/protocol.md, "Errors"):
///   ProtocolError          its own code (BAD_PAYLOAD, UNKNOWN_MESSAGE, ...)
///   ConfigError            CONFIG_REJECTED
///   AcquisitionError       ACQUISITION_FAILED
///   avatar::TimedOut       TIMEOUT
///   avatar::NotAvailable   NOT_AVAILABLE
///   avatar::InvalidState   INVALID_STATE
///   anything else          INTERNAL ("<REQUEST> failed: <what>")
/// @p error is the exception being handled; @p request names the request.
ErrorReply errorReplyFor(const std::exception_ptr& error, std::uint16_t request);

/// A reply frame and, when it is an ERROR, what it says (for the log).
struct Answer {
    std::vector<std::uint8_t> frame;
    std::optional<ErrorReply> error;
};

/// An ERROR answer.
Answer errorAnswer(std::uint32_t request, ErrorReply error);

/// The message of a ProtocolError without the "CODE: " prefix of its what():
/// the ERROR frame carries the code already.
std::string messageOf(const ProtocolError& e);

class RequestHandler {
public:
    RequestHandler(VisionInterface& vision, std::string serverName);

    /// True for the requests that may block (they go to the worker pool).
    static bool blocks(std::uint16_t type);
    /// True for the types this version answers (HELLO included).
    static bool known(std::uint16_t type);

    /// The reply (the request's reply, or ERROR) to a request other than
    /// HELLO. Never throws: every failure becomes an ERROR whose code
    /// errorReplyFor() gives.
    /// @p version is the session's protocol version (its HELLO's).
    Answer handle(const Frame& request, std::uint16_t version) const;

    /// HELLO_REPLY for a HELLO whose version was accepted: that version, and
    /// from version 3 on whether the connection must authenticate and the
    /// challenge to prove the key on (empty when the server has none).
    std::vector<std::uint8_t> helloReply(std::uint32_t request, std::uint16_t version,
                                         bool authenticationRequired = false,
                                         const std::vector<std::uint8_t>& challenge = {}) const;

    const std::string& backend() const { return backend_; }

private:
    std::vector<std::uint8_t> answer(const Frame& request, std::uint16_t version) const;

    VisionInterface& vision_;
    std::string serverName_;
    std::string backend_;
};

}  // namespace avatar::tau::detail
