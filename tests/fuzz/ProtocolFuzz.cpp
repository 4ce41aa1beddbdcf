// libFuzzer target over the TAU frame decoder and every message parser: any
// byte string must either decode or be rejected with ProtocolError; nothing
// else (no crash, no other exception, no sanitizer report, no huge allocation).

#include <avatar/tau/Protocol.h>

#include <cstddef>
#include <cstdint>
#include <vector>

using namespace avatar::tau;

namespace {

void decodeAs(std::uint16_t type, const std::vector<std::uint8_t>& payload) {
    try {
        switch (type & 0x7FFF) {
            case 0x0001: (type & kReplyBit) ? (void)decodeHelloReply(payload) : (void)decodeHello(payload); break;
            case 0x0004: (type & kReplyBit) ? (void)decodeTargetData(payload) : (void)decodeTakeSnapshot(payload); break;
            case 0x0005: decodeTargetData(payload); break;
            case 0x0006: (type & kReplyBit) ? (void)decodeConfigApplied(payload) : (void)decodeSendConfig(payload); break;
            case 0x0007: decodeConfigReply(payload); break;
            case 0x0008: (type & kReplyBit) ? (void)decodeImagesReply(payload) : (void)decodeGetImages(payload); break;
            case 0x0009: decodeStatusReply(payload); break;
            case 0x000A: (type & kReplyBit) ? (void)decodeAuthenticateReply(payload) : (void)decodeAuthenticate(payload); break;
            case 0x7FFF: decodeErrorReply(payload); break;
            default: decodeEmpty(MessageType::Status, payload); break;
        }
    } catch (const ProtocolError&) {
    }
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
    // 1. As a stream, in two pieces split by the first byte.
    FrameDecoder decoder(4096);
    const std::size_t split = size > 0 ? data[0] % (size + 1) : 0;
    try {
        decoder.feed(data, split);
        while (auto f = decoder.next()) decodeAs(f->header.type, f->payload);
        decoder.feed(data + split, size - split);
        while (auto f = decoder.next()) decodeAs(f->header.type, f->payload);
    } catch (const ProtocolError&) {
    }
    // 2. As a bare payload of every message type.
    const std::vector<std::uint8_t> payload(data, data + size);
    for (std::uint16_t type : {0x0001, 0x8001, 0x0004, 0x8004, 0x0006, 0x8006, 0x8007, 0x0008, 0x8008, 0x8009, 0xFFFF, 0x0002})
        decodeAs(type, payload);
    return 0;
}
