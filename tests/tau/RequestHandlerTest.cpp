// The one table from the kind of a failure to the TAU protocol's error code
// (tau/net/src/RequestHandler.cpp, docs/protocol.md "Errors"): by the
// exception's type alone, whatever the request and whatever the message says.
#include "RequestHandler.h"

#include <avatar/acquire/AcquireStereoImagePair.h>
#include <avatar/common/Error.h>
#include <avatar/config/ConfigXml.h>
#include <avatar/tau/Protocol.h>

#include <gtest/gtest.h>

#include <stdexcept>
#include <string>

namespace avatar::tau {
namespace {

ErrorReply replyFor(const std::exception_ptr& e, MessageType request) {
    return detail::errorReplyFor(e, static_cast<std::uint16_t>(request));
}

template <typename E>
std::exception_ptr error(E e) {
    return std::make_exception_ptr(std::move(e));
}

TEST(ErrorTable, EachKindOfFailureHasItsCode) {
    struct Case {
        std::exception_ptr error;
        MessageType request;
        ErrorCode code;
        std::string message;
    };
    const Case cases[] = {
        {error(ProtocolError(ErrorCode::BadPayload, "TAKE_SNAPSHOT: missing timeoutMs")), MessageType::TakeSnapshot,
         ErrorCode::BadPayload, "TAKE_SNAPSHOT: missing timeoutMs"},
        {error(ConfigError("sent configuration", 4, "/avatar/camera/width", "expected a number, got 'x'")),
         MessageType::SendConfig, ErrorCode::ConfigRejected,
         "sent configuration:4: /avatar/camera/width: expected a number, got 'x'"},
        {error(AcquisitionError("left camera 0x00b09d01004a2c1f sent no frame within 1000 ms")),
         MessageType::TakeSnapshot, ErrorCode::AcquisitionFailed,
         "left camera 0x00b09d01004a2c1f sent no frame within 1000 ms"},
        {error(TimedOut("snapshot timed out after 5 ms")), MessageType::TakeSnapshot, ErrorCode::Timeout,
         "snapshot timed out after 5 ms"},
        {error(NotAvailable("no images yet")), MessageType::GetImages, ErrorCode::NotAvailable, "no images yet"},
        {error(InvalidState("cannot start searching: the replay backend has no more pairs")),
         MessageType::StartSearching, ErrorCode::InvalidState,
         "cannot start searching: the replay backend has no more pairs"},
        // Everything else is INTERNAL, named by the request: an InvalidArgument
        // is not a rejected configuration, even on SEND_CONFIG.
        {error(InvalidArgument("a value out of range")), MessageType::SendConfig, ErrorCode::Internal,
         "SEND_CONFIG failed: a value out of range"},
        {error(IoError("cannot read /data/x")), MessageType::GetImages, ErrorCode::Internal,
         "GET_IMAGES failed: cannot read /data/x"},
        {error(std::runtime_error("boom")), MessageType::Status, ErrorCode::Internal, "STATUS failed: boom"},
        {std::make_exception_ptr(42), MessageType::GetConfig, ErrorCode::Internal,
         "GET_CONFIG failed: an exception that is not a std::exception"},
    };
    for (const Case& c : cases) {
        const ErrorReply reply = replyFor(c.error, c.request);
        EXPECT_EQ(reply.code, c.code) << c.message;
        EXPECT_EQ(reply.message, c.message);
    }
}

TEST(ErrorTable, AnErrorAnswerCarriesWhatItEncodes) {
    const detail::Answer a = detail::errorAnswer(77, {ErrorCode::NotAvailable, "no target data yet"});
    ASSERT_TRUE(a.error);
    FrameDecoder decoder(kMaxReplyPayload);
    decoder.feed(a.frame.data(), a.frame.size());
    const auto frame = decoder.next();
    ASSERT_TRUE(frame);
    EXPECT_EQ(frame->header.type, static_cast<std::uint16_t>(MessageType::Error));
    EXPECT_EQ(frame->header.request, 77u);
    const ErrorReply decoded = decodeErrorReply(frame->payload);
    EXPECT_EQ(decoded.code, a.error->code);
    EXPECT_EQ(decoded.message, a.error->message);
}

}  // namespace
}  // namespace avatar::tau
