#pragma once
/// @file RequestHandler.h
/// Internal: answers one decoded TAU request from a VisionInterface. This is
/// the whole mapping between the vision layer and the protocol (status codes,
/// target data, images, errors); the connection code around it only moves
/// frames. No sockets in here.

#include <avatar/tau/Protocol.h>
#include <avatar/tau/VisionInterface.h>

#include <cstdint>
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
/// to 8 from the layout's bit depth). Throws avatar::Error when encoding fails.
ImagesReply encodeImages(const VisionImages& images, const GetImages& request);

/// The message of a ProtocolError without the "CODE: " prefix of its what():
/// the ERROR frame carries the code already.
std::string messageOf(const ProtocolError& e);

/// An ERROR frame.
std::vector<std::uint8_t> errorFrame(std::uint32_t request, ErrorCode code, const std::string& message);

class RequestHandler {
public:
    RequestHandler(VisionInterface& vision, std::string serverName);

    /// True for the requests that may block (they go to the worker pool).
    static bool blocks(std::uint16_t type);
    /// True for the types this version answers (HELLO included).
    static bool known(std::uint16_t type);

    /// The reply frame (the request's reply, or ERROR) to a request other than
    /// HELLO. Never throws: every failure becomes an ERROR frame whose code
    /// follows docs/protocol.md.
    std::vector<std::uint8_t> handle(const Frame& request) const;

    /// HELLO_REPLY for a HELLO whose version was accepted.
    std::vector<std::uint8_t> helloReply(std::uint32_t request) const;

    const std::string& backend() const { return backend_; }

private:
    std::vector<std::uint8_t> answer(const Frame& request) const;

    VisionInterface& vision_;
    std::string serverName_;
    std::string backend_;
};

}  // namespace avatar::tau::detail
