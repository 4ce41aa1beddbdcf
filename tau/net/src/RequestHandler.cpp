#include "RequestHandler.h"

#include <avatar/acquire/AcquireStereoImagePair.h>
#include <avatar/common/Error.h>
#include <avatar/common/ImageUtils.h>
#include <avatar/config/ConfigXml.h>

#include <opencv2/imgcodecs.hpp>

#include <chrono>

namespace avatar::tau::detail {

namespace {

std::vector<std::uint8_t> replyFrame(MessageType type, std::uint32_t request, const std::vector<std::uint8_t>& payload) {
    return encodeFrame(replyType(type), request, payload);
}

}  // namespace

std::uint8_t stateCode(VisionState state) {
    switch (state) {
        case VisionState::Idle: return 0;
        case VisionState::Searching: return 1;
        case VisionState::Snapshot: return 2;
        case VisionState::Error: return 3;
    }
    return 3;
}

std::uint8_t acquisitionCode(AcquisitionStatus::State state) {
    switch (state) {
        case AcquisitionStatus::State::Ok: return 0;
        case AcquisitionStatus::State::Recovering: return 1;
        case AcquisitionStatus::State::Failed: return 2;
        case AcquisitionStatus::State::Finished: return 3;
    }
    return 2;
}

std::uint8_t visibilityCode(Visibility visibility) {
    switch (visibility) {
        case Visibility::Unknown: return 0;
        case Visibility::Good: return 1;
        case Visibility::Poor: return 2;
    }
    return 0;
}

/// How long a SEND_CONFIG may wait for the vision thread to apply it (docs/protocol.md).
constexpr std::chrono::milliseconds kConfigTimeout{std::chrono::seconds(10)};

ImageKind imageKind(ImageKindCode code) {
    switch (code) {
        case ImageKindCode::Original: return ImageKind::Original;
        case ImageKindCode::Filtered: return ImageKind::Filtered;
        case ImageKindCode::Marked: return ImageKind::Marked;
    }
    throw InvalidArgument("image kind " + std::to_string(static_cast<int>(code)) + " unknown");
}

StatusReply statusReply(const VisionStatus& status, const std::string& backend) {
    StatusReply r;
    r.state = stateCode(status.state);
    r.error = status.error;
    r.heartbeat = status.heartbeat;
    r.iteration = status.iteration;
    r.configVersion = status.configVersion;
    r.configIteration = status.configIteration;
    r.targetsIteration = status.targetsIteration;
    r.imagesIteration = status.imagesIteration;
    r.acquisitionState = acquisitionCode(status.acquisition.state);
    r.acquisitionMessage = status.acquisition.message;
    r.visibility = visibilityCode(status.visibility);
    r.visibilityReason = status.visibilityReason;
    r.recordBacklog = status.recordBacklog;
    r.recorded = status.recorded;
    r.unrecorded = status.unrecorded;
    r.recordError = status.recordError;
    r.backend = backend;
    return r;
}

ImagesReply encodeImages(const VisionImages& images, const GetImages& request) {
    ImagesReply reply;
    reply.iteration = images.iteration;
    reply.kind = request.kind;
    const PairLayout& layout = images.pair.layout();
    for (const Side side : {Side::Left, Side::Right}) {
        const std::uint8_t bit = side == Side::Left ? kLeftImage : kRightImage;
        if (!(request.sides & bit)) continue;
        const cv::Mat& image = images.pair.image(side);
        const cv::Mat colour = layout.format == PixelFormat::Bayer ? demosaic(image, layout.bayerPattern) : image;
        const cv::Mat display = toDisplay8(colour, layout.bitDepth);
        EncodedImage encoded;
        encoded.side = side == Side::Left ? 0 : 1;
        encoded.width = static_cast<std::uint32_t>(display.cols);
        encoded.height = static_cast<std::uint32_t>(display.rows);
        bool ok = false;
        try {
            ok = cv::imencode(".jpg", display, encoded.jpeg, {cv::IMWRITE_JPEG_QUALITY, request.jpegQuality});
        } catch (const cv::Exception& e) {
            throw Error(std::string("JPEG encoding failed: ") + e.what());
        }
        if (!ok) throw Error("JPEG encoding failed");
        reply.images.push_back(std::move(encoded));
    }
    if (const std::size_t size = encodedSize(reply); size > kMaxReplyPayload)
        throw Error("images of iteration " + std::to_string(images.iteration) + " need " + std::to_string(size) +
                    " bytes, above the reply limit of " + std::to_string(kMaxReplyPayload));
    return reply;
}

std::string messageOf(const ProtocolError& e) {
    std::string m = e.what();
    const std::string prefix = std::string(errorName(e.code())) + ": ";
    if (m.compare(0, prefix.size(), prefix) == 0) m.erase(0, prefix.size());
    return m;
}

ErrorReply errorReplyFor(const std::exception_ptr& error, std::uint16_t request) {
    try {
        std::rethrow_exception(error);
    } catch (const ProtocolError& e) {
        return {e.code(), messageOf(e)};
    } catch (const ConfigError& e) {
        return {ErrorCode::ConfigRejected, e.what()};
    } catch (const AcquisitionError& e) {
        return {ErrorCode::AcquisitionFailed, e.what()};
    } catch (const TimedOut& e) {
        return {ErrorCode::Timeout, e.what()};
    } catch (const NotAvailable& e) {
        return {ErrorCode::NotAvailable, e.what()};
    } catch (const InvalidState& e) {
        return {ErrorCode::InvalidState, e.what()};
    } catch (const std::exception& e) {
        return {ErrorCode::Internal, messageName(request) + " failed: " + e.what()};
    } catch (...) {
        return {ErrorCode::Internal, messageName(request) + " failed: an exception that is not a std::exception"};
    }
}

Answer errorAnswer(std::uint32_t request, ErrorReply error) {
    Answer a;
    a.frame = encodeFrame(static_cast<std::uint16_t>(MessageType::Error), request, encode(error));
    a.error = std::move(error);
    return a;
}

RequestHandler::RequestHandler(VisionInterface& vision, std::string serverName)
    : vision_(vision), serverName_(std::move(serverName)), backend_(vision.backendName()) {}

bool RequestHandler::blocks(std::uint16_t type) {
    switch (static_cast<MessageType>(type)) {
        case MessageType::TakeSnapshot:
        case MessageType::SendConfig:
        case MessageType::GetImages: return true;
        default: return false;
    }
}

bool RequestHandler::known(std::uint16_t type) {
    return type >= static_cast<std::uint16_t>(MessageType::Hello) &&
           type <= static_cast<std::uint16_t>(MessageType::Status);
}

std::vector<std::uint8_t> RequestHandler::helloReply(std::uint32_t request, std::uint16_t version,
                                                     bool authenticationRequired,
                                                     const std::vector<std::uint8_t>& challenge) const {
    return replyFrame(MessageType::Hello, request,
                      encode(HelloReply{version, serverName_, backend_, authenticationRequired, challenge}));
}

Answer RequestHandler::handle(const Frame& request, std::uint16_t version) const {
    try {
        return {answer(request, version), std::nullopt};
    } catch (...) {
        return errorAnswer(request.header.request, errorReplyFor(std::current_exception(), request.header.type));
    }
}

std::vector<std::uint8_t> RequestHandler::answer(const Frame& request, std::uint16_t protocol) const {
    const std::uint32_t id = request.header.request;
    const auto type = static_cast<MessageType>(request.header.type);
    const std::vector<std::uint8_t>& payload = request.payload;
    switch (type) {
        case MessageType::StartSearching:
            decodeEmpty(type, payload);
            vision_.startSearching();
            return replyFrame(type, id, {});
        case MessageType::StopSearching:
            decodeEmpty(type, payload);
            vision_.stopSearching();
            return replyFrame(type, id, {});
        case MessageType::TakeSnapshot: {
            const TakeSnapshot m = decodeTakeSnapshot(payload);
            return replyFrame(type, id, encode(vision_.snapshot(std::chrono::milliseconds(m.timeoutMs)), protocol));
        }
        case MessageType::GetTargetData: {
            decodeEmpty(type, payload);
            const auto targets = vision_.latestTargets();
            if (!targets) throw NotAvailable("no target data yet: no iteration has been analysed");
            return replyFrame(type, id, encode(*targets, protocol));
        }
        case MessageType::SendConfig: {
            const SendConfig m = decodeSendConfig(payload);
            const std::uint32_t version = vision_.applyConfig(m.xml, kConfigTimeout);
            // The iteration the new configuration applies from.
            const VisionStatus s = vision_.status();
            const std::uint64_t from = s.configVersion == version ? s.configIteration : s.iteration + 1;
            return replyFrame(type, id, encode(ConfigApplied{version, from}));
        }
        case MessageType::GetConfig: {
            decodeEmpty(type, payload);
            // Read the status on both sides of the XML, so the three values
            // belong to one configuration even if another client changes it.
            for (int attempt = 0;; ++attempt) {
                const VisionStatus before = vision_.status();
                std::string xml = vision_.configXml();
                const VisionStatus after = vision_.status();
                if (before.configVersion == after.configVersion || attempt == 3)
                    return replyFrame(type, id, encode(ConfigReply{after.configVersion, after.configIteration,
                                                                   std::move(xml)}));
            }
        }
        case MessageType::GetImages: {
            const GetImages m = decodeGetImages(payload);
            const VisionImages images = vision_.images(imageKind(m.kind));
            if (images.iteration == 0 || images.pair.empty())
                throw NotAvailable("no images yet: no iteration has been analysed");
            return replyFrame(type, id, encode(encodeImages(images, m)));
        }
        case MessageType::Status:
            decodeEmpty(type, payload);
            return replyFrame(type, id, encode(statusReply(vision_.status(), backend_)));
        case MessageType::Hello:         // the connection answers these two itself
        case MessageType::Authenticate:
        case MessageType::Error: break;
    }
    throw ProtocolError(ErrorCode::UnknownMessage, "unknown message type " + messageName(request.header.type));
}

}  // namespace avatar::tau::detail
