// The TAU protocol codec against docs/protocol.md, byte for byte.

#include <avatar/tau/Authentication.h>
#include <avatar/tau/Protocol.h>

#include "TempDir.h"

#include <gtest/gtest.h>

#include <cmath>
#include <cstring>
#include <fstream>
#include <limits>

#include <sys/stat.h>

using namespace avatar;
using namespace avatar::tau;
using Bytes = std::vector<std::uint8_t>;

namespace {

VisionTargets sampleTargets() {
    VisionTargets t;
    t.iteration = 0x0102030405060708ULL;
    t.acquisition.group = 3;
    t.acquisition.member = 99998;
    t.acquisition.left = {"0x00b09d01004a2c1f", 1790000000000000LL};
    t.acquisition.right = {"right cam", -5};
    t.visibility = Visibility::Poor;
    t.visibilityReason = "left: contrast 0.0100 below 0.0200";
    VisionTarget a;
    a.type = "sample";
    a.flags = kTargetStereo | kTargetShapeCorrected | kTargetWhole;
    a.positionVisionMm = cv::Point3d(62.0, 83.5, 753.125);
    a.positionBaseMm = cv::Point3d(-1e-300, std::numeric_limits<double>::max(), -0.0);
    a.centroidLeftPx = cv::Point2d(798.68, 680.9);
    a.centroidRightPx = cv::Point2d(638.54, 675.49);
    a.areaLeftPx = 9154;
    a.areaRightPx = 9120.5;
    a.matchError = 0.0123;
    a.model = ShapeModel::Sphere;
    a.covarianceVisionMm2 = Covariance3(0.04, 0.001, -0.02, 0.001, 0.05, 0.3, -0.02, 0.3, 2.25);
    a.rayResidualMm = 0.125;
    a.rayResidualPx = 0.0625;
    VisionTarget b;
    b.type = "arm_marker";
    b.flags = kTargetLeftOnly | kTargetAtBorder;
    b.centroidLeftPx = cv::Point2d(3, 4);
    b.areaLeftPx = 81;
    t.targets = {a, b};
    t.timings = {{"demosaic", 5.25}, {"total", 25.5}};
    return t;
}

std::string errorOf(const std::function<void()>& f) {
    try {
        f();
    } catch (const ProtocolError& e) {
        return std::string(errorName(e.code())) + " | " + e.what();
    }
    return "no error";
}

TEST(Protocol, HelloVersionIsReadBeforeTheRestOfTheHello) {
    EXPECT_EQ(helloVersion(encode(Hello{1, "arm"})), std::optional<std::uint16_t>(1));
    // Another version's HELLO may have any layout after its version.
    EXPECT_EQ(helloVersion(Bytes{0x01, 0x02, 0xFF}), std::optional<std::uint16_t>(0x0102));
    EXPECT_EQ(helloVersion(Bytes{0x00}), std::nullopt);
    EXPECT_EQ(helloVersion(Bytes{}), std::nullopt);
}

TEST(Protocol, EncodedSizeOfImagesIsTheSizeOfTheirEncoding) {
    ImagesReply reply;
    EXPECT_EQ(encodedSize(reply), encode(reply).size());
    reply.iteration = 7;
    reply.images.push_back({0, 640, 480, Bytes(1234, 0xAB)});
    EXPECT_EQ(encodedSize(reply), encode(reply).size());
    reply.images.push_back({1, 640, 480, Bytes(17, 0x01)});
    EXPECT_EQ(encodedSize(reply), encode(reply).size());
    EXPECT_EQ(encodedSize(reply), 10u + 2 * 13u + 1234u + 17u);
}

}  // namespace

TEST(Protocol, StatusRequestIsTheDocumentedTwelveBytes) {
    EXPECT_EQ(encodeFrame(static_cast<std::uint16_t>(MessageType::Status), 7, {}),
              (Bytes{0, 0, 0, 0, 0, 0x09, 0, 0, 0, 0, 0, 7}));
}

TEST(Protocol, HelloEncodesBigEndianFieldsAndLengthPrefixedStrings) {
    EXPECT_EQ(encode(Hello{1, "tui"}), (Bytes{0, 1, 0, 0, 0, 3, 't', 'u', 'i'}));
    const auto frame = encodeFrame(static_cast<std::uint16_t>(MessageType::Hello), 0x01020304, encode(Hello{1, "tui"}));
    EXPECT_EQ(frame, (Bytes{0, 0, 0, 9, 0, 1, 0, 0, 1, 2, 3, 4, 0, 1, 0, 0, 0, 3, 't', 'u', 'i'}));
    EXPECT_EQ(encode(ErrorReply{ErrorCode::HelloRequired, "x"}), (Bytes{0, 3, 0, 0, 0, 1, 'x'}));
    EXPECT_EQ(encode(ConfigApplied{2, 5}), (Bytes{0, 0, 0, 2, 0, 0, 0, 0, 0, 0, 0, 5}));
}

TEST(Protocol, DoublesAreIeeeBigEndian) {
    VisionTargets t;
    VisionTarget x;
    x.type = "";
    x.areaLeftPx = 1.0;  // 0x3FF0000000000000
    t.targets = {x};
    const Bytes b = encode(t);
    // iteration 8, group 4, member 4, two stamps (4+0+8 each), visibility 1, reason 4, count 4,
    // type 4, flags 4, four absent optionals 4, then areaLeft.
    const std::size_t at = 8 + 4 + 4 + 12 + 12 + 1 + 4 + 4 + 4 + 4 + 4;
    EXPECT_EQ(Bytes(b.begin() + at, b.begin() + at + 8), (Bytes{0x3F, 0xF0, 0, 0, 0, 0, 0, 0}));
}

TEST(Protocol, EveryMessageRoundTrips) {
    EXPECT_EQ(decodeHello(encode(Hello{1, "controller"})).clientName, "controller");
    const HelloReply hr = decodeHelloReply(encode(HelloReply{1, "taunet", "replay", false, {}}));
    EXPECT_EQ(hr.serverName, "taunet");
    EXPECT_EQ(hr.backend, "replay");
    EXPECT_EQ(decodeTakeSnapshot(encode(TakeSnapshot{1234})).timeoutMs, 1234u);
    EXPECT_EQ(decodeSendConfig(encode(SendConfig{"<avatar version=\"1\">\n</avatar>"})).xml,
              "<avatar version=\"1\">\n</avatar>");
    const ConfigApplied ca = decodeConfigApplied(encode(ConfigApplied{7, 1ULL << 40}));
    EXPECT_EQ(ca.configVersion, 7u);
    EXPECT_EQ(ca.configIteration, 1ULL << 40);
    const ConfigReply cr = decodeConfigReply(encode(ConfigReply{2, 9, "<x/>"}));
    EXPECT_EQ(cr.xml, "<x/>");
    EXPECT_EQ(cr.configIteration, 9u);
    const GetImages gi = decodeGetImages(encode(GetImages{ImageKindCode::Marked, kRightImage, 75}));
    EXPECT_EQ(gi.kind, ImageKindCode::Marked);
    EXPECT_EQ(gi.sides, kRightImage);
    EXPECT_EQ(gi.jpegQuality, 75);
    ImagesReply ir;
    ir.iteration = 12;
    ir.kind = ImageKindCode::Filtered;
    ir.images = {{0, 1280, 960, {0xFF, 0xD8, 0xFF}}, {1, 1280, 960, {0xFF, 0xD9}}};
    const ImagesReply ir2 = decodeImagesReply(encode(ir));
    ASSERT_EQ(ir2.images.size(), 2u);
    EXPECT_EQ(ir2.images[1].jpeg, (Bytes{0xFF, 0xD9}));
    EXPECT_EQ(ir2.images[0].width, 1280u);
    StatusReply s;
    s.state = 1;
    s.error = "last: camera left timed out";
    s.heartbeat = 99;
    s.iteration = 5;
    s.configVersion = 2;
    s.configIteration = 4;
    s.targetsIteration = 5;
    s.imagesIteration = 5;
    s.acquisitionState = 1;
    s.acquisitionMessage = "left camera 0x00b0 recovering";
    s.visibility = 1;
    s.recordBacklog = 3;
    s.recorded = 100;
    s.unrecorded = 2;
    s.recordError = "disk full";
    s.backend = "firewire";
    EXPECT_EQ(decodeStatusReply(encode(s)), s);
    const ErrorReply er = decodeErrorReply(encode(ErrorReply{ErrorCode::ConfigRejected, "t.xml:3: /avatar: bad"}));
    EXPECT_EQ(er.code, ErrorCode::ConfigRejected);
    EXPECT_EQ(er.message, "t.xml:3: /avatar: bad");
    const VisionTargets t = sampleTargets();
    const VisionTargets back = decodeTargetData(encode(t));
    EXPECT_EQ(back, t);  // bit for bit, -0.0 and extremes included
    EXPECT_TRUE(std::signbit(back.targets[0].positionBaseMm->z));
}

TEST(FrameDecoder, ReassemblesFramesFedOneByteAtATime) {
    Bytes stream;
    for (std::uint32_t id = 1; id <= 3; ++id) {
        const auto f = encodeFrame(static_cast<std::uint16_t>(MessageType::Hello), id, encode(Hello{1, "c" + std::to_string(id)}));
        stream.insert(stream.end(), f.begin(), f.end());
    }
    FrameDecoder d(kMaxRequestPayload);
    std::vector<Frame> frames;
    for (std::uint8_t byte : stream) {
        d.feed(&byte, 1);
        while (auto f = d.next()) frames.push_back(*f);
    }
    ASSERT_EQ(frames.size(), 3u);
    EXPECT_EQ(frames[2].header.request, 3u);
    EXPECT_EQ(decodeHello(frames[2].payload).clientName, "c3");
    EXPECT_EQ(d.buffered(), 0u);
}

TEST(FrameDecoder, SeveralFramesInOneChunkAndAPartialTail) {
    Bytes stream = encodeFrame(2, 1, {});
    const auto second = encodeFrame(3, 2, {});
    stream.insert(stream.end(), second.begin(), second.end());
    stream.insert(stream.end(), {0, 0, 0, 5, 0});  // start of a third
    FrameDecoder d(kMaxRequestPayload);
    d.feed(stream.data(), stream.size());
    EXPECT_EQ(d.next()->header.type, 2);
    EXPECT_EQ(d.next()->header.type, 3);
    EXPECT_FALSE(d.next().has_value());
    EXPECT_EQ(d.buffered(), 5u);
}

TEST(FrameDecoder, RejectsReservedBitsAndOversizeFramesFromTheHeaderAlone) {
    FrameDecoder bad(kMaxRequestPayload);
    const Bytes reserved{0, 0, 0, 0, 0, 9, 0, 1, 0, 0, 0, 42};
    bad.feed(reserved.data(), reserved.size());
    EXPECT_EQ(errorOf([&] { bad.next(); }),
              "MALFORMED_FRAME | MALFORMED_FRAME: reserved header field is 1, must be 0 (request 42)");
    EXPECT_THROW(bad.next(), ProtocolError);  // stays failed

    FrameDecoder big(kMaxRequestPayload);
    const Bytes header{0x00, 0x10, 0x00, 0x01, 0, 6, 0, 0, 0, 0, 0, 1};  // 1 MiB + 1, no payload sent yet
    big.feed(header.data(), header.size());
    EXPECT_EQ(errorOf([&] { big.next(); }),
              "FRAME_TOO_LARGE | FRAME_TOO_LARGE: SEND_CONFIG payload of 1048577 bytes exceeds the limit of 1048576");
}

TEST(Decoders, RejectShortLongAndOutOfRangePayloadsByName) {
    const std::vector<std::pair<std::function<void()>, std::string>> cases = {
        {[] { decodeHello({0}); }, "HELLO: version: needs 2 byte(s), 1 left"},
        {[] { decodeHello({0, 1, 0, 0, 0, 5, 'a'}); }, "HELLO: clientName: needs 5 byte(s), 1 left"},
        {[] { decodeTakeSnapshot({0, 0, 0, 1, 9}); }, "TAKE_SNAPSHOT: 1 unexpected byte(s) after the last field"},
        {[] { decodeGetImages({3, 1, 90}); }, "GET_IMAGES: kind 3 is not 0 (original), 1 (filtered) or 2 (marked)"},
        {[] { decodeGetImages({0, 0, 90}); }, "GET_IMAGES: sides 0 is not 1 (left), 2 (right) or 3 (both)"},
        {[] { decodeGetImages({0, 4, 90}); }, "GET_IMAGES: sides 4 is not 1 (left), 2 (right) or 3 (both)"},
        {[] { decodeGetImages({0, 3, 0}); }, "GET_IMAGES: jpegQuality 0 is outside 1..100"},
        {[] { decodeGetImages({0, 3, 101}); }, "GET_IMAGES: jpegQuality 101 is outside 1..100"},
        {[] { decodeEmpty(MessageType::Status, {1}); }, "STATUS: takes no fields, got 1 byte(s)"},
        {[] { decodeErrorReply({0, 15, 0, 0, 0, 0}); }, "ERROR: code 15 is not 1..14"},
    };
    for (const auto& [f, message] : cases) {
        SCOPED_TRACE(message);
        EXPECT_EQ(errorOf(f), "BAD_PAYLOAD | BAD_PAYLOAD: " + message);
    }
}

// Version 2's additions to Target, byte for byte: u8 shapeModel, two
// opt<cov3> (xx, xy, xz, yy, yz, zz), f64 rayResidualMm, f64 rayResidualPx.
TEST(Protocol, VersionTwoTargetEndsWithModelCovariancesAndResiduals) {
    VisionTargets t;
    VisionTarget x;
    x.model = ShapeModel::Disc;
    x.covarianceBaseMm2 = Covariance3(1, 2, 3, 2, 4, 5, 3, 5, 6);
    x.rayResidualMm = 1.0;
    x.rayResidualPx = -2.0;
    t.targets = {x};
    const Bytes b = encode(t);
    // As in DoublesAreIeeeBigEndian up to areaLeft, then areaLeft, areaRight, matchError.
    std::size_t at = 8 + 4 + 4 + 12 + 12 + 1 + 4 + 4 + 4 + 4 + 4 + 3 * 8;
    EXPECT_EQ(b[at], 2);          // disc
    EXPECT_EQ(b[at + 1], 0);      // no vision covariance
    EXPECT_EQ(b[at + 2], 1);      // base covariance follows
    at += 3;
    const double expected[] = {1, 2, 3, 4, 5, 6, 1.0, -2.0};
    for (const double v : expected) {
        std::uint64_t bits;
        std::memcpy(&bits, &v, 8);
        Bytes want;
        for (int k = 7; k >= 0; --k) want.push_back(static_cast<std::uint8_t>(bits >> (8 * k)));
        EXPECT_EQ(Bytes(b.begin() + static_cast<std::ptrdiff_t>(at), b.begin() + static_cast<std::ptrdiff_t>(at + 8)), want) << v;
        at += 8;
    }
    EXPECT_EQ(at + 4, b.size());  // then only the timing count
    EXPECT_EQ(decodeTargetData(b), t);
    Bytes badModel = b;
    badModel[8 + 4 + 4 + 12 + 12 + 1 + 4 + 4 + 4 + 4 + 4 + 3 * 8] = 4;
    EXPECT_EQ(errorOf([&] { decodeTargetData(badModel); }),
              "BAD_PAYLOAD | BAD_PAYLOAD: TARGET_DATA: shapeModel 4 is not 0..3");
}

// Version 1 (docs/protocol.md, "Version 1"): the old Target layout, flag bits
// 0-4 only, and a target that is not whole without stereo bit or positions.
TEST(Protocol, VersionOneSeesOnlyWholeTargetsAsStereo) {
    VisionTargets t = sampleTargets();
    VisionTarget partial = t.targets[0];
    partial.flags = kTargetStereo | kTargetOccludedLeft | kTargetShapeCorrected;
    t.targets.push_back(partial);
    const Bytes v1 = encode(t, 1);
    EXPECT_LT(v1.size(), encode(t, 2).size());
    const VisionTargets back = decodeTargetData(v1, 1);
    ASSERT_EQ(back.targets.size(), 3u);
    EXPECT_EQ(back.targets[0].flags, kTargetStereo | kTargetShapeCorrected);
    EXPECT_EQ(back.targets[0].positionVisionMm, t.targets[0].positionVisionMm);
    EXPECT_EQ(back.targets[0].model, ShapeModel::None);
    EXPECT_FALSE(back.targets[0].covarianceVisionMm2);
    EXPECT_EQ(back.targets[1].flags, t.targets[1].flags);
    EXPECT_EQ(back.targets[2].flags, 0u);  // occluded: neither stereo nor shape-corrected for version 1
    EXPECT_FALSE(back.targets[2].positionVisionMm);
    EXPECT_FALSE(back.targets[2].positionBaseMm);
    EXPECT_EQ(back.targets[2].centroidLeftPx, partial.centroidLeftPx);
    EXPECT_THROW(decodeTargetData(v1, 2), ProtocolError);
    EXPECT_EQ(encode(t, 3), encode(t, 2));  // version 3 changed the handshake only
    EXPECT_THROW(encode(t, 4), InvalidArgument);
}

TEST(Decoders, ForgedCountsAndFlagsCannotMakeTheDecoderAllocateOrMisread) {
    Bytes b = encode(sampleTargets());
    // The target count sits after iteration 8, group 4, member 4, left stamp
    // (4 + 18 + 8), right stamp (4 + 9 + 8), visibility 1 and the reason (4 + 34).
    const std::size_t countAt = 8 + 4 + 4 + 30 + 21 + 1 + 38;
    ASSERT_EQ(b[countAt + 3], 2);
    Bytes forged = b;
    forged[countAt] = 0xFF;  // 4 billion targets
    EXPECT_EQ(errorOf([&] { decodeTargetData(forged); }).substr(0, 60),
              "BAD_PAYLOAD | BAD_PAYLOAD: TARGET_DATA: targetCount: count 4");
    Bytes flag = b;
    // First optional flag of the first target: after count 4, type (4 + 6), flags 4.
    flag[countAt + 4 + 10 + 4] = 2;
    EXPECT_EQ(errorOf([&] { decodeTargetData(flag); }),
              "BAD_PAYLOAD | BAD_PAYLOAD: TARGET_DATA: positionVision: optional flag 2 is not 0 or 1");
    for (std::size_t cut = 0; cut < b.size(); cut += 7)
        EXPECT_THROW(decodeTargetData(Bytes(b.begin(), b.begin() + static_cast<std::ptrdiff_t>(cut))), ProtocolError);
}

TEST(Protocol, NamesAndConnectionPolicy) {
    EXPECT_EQ(messageName(0x0009), "STATUS");
    EXPECT_EQ(messageName(0x8009), "STATUS_REPLY");
    EXPECT_EQ(messageName(0xFFFF), "ERROR");
    EXPECT_EQ(messageName(0x0042), "0x0042");
    EXPECT_TRUE(closesConnection(ErrorCode::FrameTooLarge));
    EXPECT_TRUE(closesConnection(ErrorCode::HelloRequired));
    EXPECT_FALSE(closesConnection(ErrorCode::BadPayload));
    EXPECT_FALSE(closesConnection(ErrorCode::UnknownMessage));
}

// ---- version 3: authentication (docs/protocol.md, "Authentication") --------

namespace {

Bytes sequence(std::uint8_t from, std::size_t n) {
    Bytes b(n);
    for (std::size_t i = 0; i < n; ++i) b[i] = static_cast<std::uint8_t>(from + i);
    return b;
}

Bytes fromHex(const std::string& hex) {
    Bytes b;
    for (std::size_t i = 0; i + 1 < hex.size(); i += 2) b.push_back(static_cast<std::uint8_t>(std::stoi(hex.substr(i, 2), nullptr, 16)));
    return b;
}

}  // namespace

TEST(Protocol, HelloReplyCarriesTheChallengeFromVersionThreeOnly) {
    const Bytes challenge = sequence(0, kChallengeSize);
    Bytes expected{0, 3, 0, 0, 0, 1, 'T', 0, 0, 0, 1, 'r', 1, 0, 0, 0, 32};
    expected.insert(expected.end(), challenge.begin(), challenge.end());
    EXPECT_EQ(encode(HelloReply{3, "T", "r", true, challenge}), expected);
    const HelloReply back = decodeHelloReply(expected);
    EXPECT_TRUE(back.authenticationRequired);
    EXPECT_EQ(back.challenge, challenge);
    // Version 2 has no such fields: the same record encodes as before.
    EXPECT_EQ(encode(HelloReply{2, "T", "r", true, challenge}), (Bytes{0, 2, 0, 0, 0, 1, 'T', 0, 0, 0, 1, 'r'}));
    EXPECT_EQ(encode(HelloReply{3, "T", "r", false, {}}), (Bytes{0, 3, 0, 0, 0, 1, 'T', 0, 0, 0, 1, 'r', 0, 0, 0, 0, 0}));
}

TEST(Protocol, HelloReplyWithABadChallengeIsRefused) {
    auto message = [](const Bytes& payload) {
        try {
            decodeHelloReply(payload);
        } catch (const ProtocolError& e) {
            EXPECT_EQ(e.code(), ErrorCode::BadPayload);
            return std::string(e.what());
        }
        return std::string("accepted");
    };
    Bytes head{0, 3, 0, 0, 0, 1, 'T', 0, 0, 0, 1, 'r'};
    Bytes flagTwo = head;
    flagTwo.insert(flagTwo.end(), {2, 0, 0, 0, 0});
    EXPECT_EQ(message(flagTwo), "BAD_PAYLOAD: HELLO_REPLY: authentication: 2 is not 0 or 1");
    Bytes shortChallenge = head;
    shortChallenge.insert(shortChallenge.end(), {0, 0, 0, 0, 5, 1, 2, 3, 4, 5});
    EXPECT_EQ(message(shortChallenge), "BAD_PAYLOAD: HELLO_REPLY: challenge: 5 bytes, not 0 or 32");
    Bytes requiredEmpty = head;
    requiredEmpty.insert(requiredEmpty.end(), {1, 0, 0, 0, 0});
    EXPECT_EQ(message(requiredEmpty), "BAD_PAYLOAD: HELLO_REPLY: challenge: empty although authentication is required");
    EXPECT_EQ(message(head), "BAD_PAYLOAD: HELLO_REPLY: authentication: needs 1 byte(s), 0 left");
}

TEST(Protocol, AuthenticateMessagesRoundTripAndHoldExactSizes) {
    const Authenticate a{sequence(32, 32), sequence(100, 32)};
    const Bytes b = encode(a);
    ASSERT_EQ(b.size(), 4u + 32 + 4 + 32);
    EXPECT_EQ(Bytes(b.begin(), b.begin() + 4), (Bytes{0, 0, 0, 32}));
    const Authenticate back = decodeAuthenticate(b);
    EXPECT_EQ(back.nonce, a.nonce);
    EXPECT_EQ(back.mac, a.mac);
    EXPECT_EQ(decodeAuthenticateReply(encode(AuthenticateReply{sequence(7, 32)})).mac, sequence(7, 32));
    try {
        decodeAuthenticate(encode(Authenticate{sequence(0, 16), sequence(0, 32)}));
        ADD_FAILURE() << "a 16-byte nonce was accepted";
    } catch (const ProtocolError& e) {
        EXPECT_STREQ(e.what(), "BAD_PAYLOAD: AUTHENTICATE: nonce: 16 bytes, not 32");
    }
    EXPECT_THROW(decodeAuthenticateReply(encode(AuthenticateReply{sequence(0, 31)})), ProtocolError);
    EXPECT_EQ(messageName(0x000A), "AUTHENTICATE");
    EXPECT_EQ(messageName(0x800A), "AUTHENTICATE_REPLY");
    EXPECT_STREQ(errorName(ErrorCode::AuthenticationRequired), "AUTHENTICATION_REQUIRED");
    EXPECT_STREQ(errorName(ErrorCode::AuthenticationFailed), "AUTHENTICATION_FAILED");
    EXPECT_TRUE(closesConnection(ErrorCode::AuthenticationRequired));
    EXPECT_TRUE(closesConnection(ErrorCode::AuthenticationFailed));
}

// The test vector of docs/protocol.md, computed independently (Python's hmac).
TEST(Authentication, ProofsMatchTheDocumentedVector) {
    const std::string key = "0123456789abcdef0123456789abcdef";
    const Bytes challenge = sequence(0, 32), nonce = sequence(32, 32);
    EXPECT_EQ(clientProof(key, challenge, nonce),
              fromHex("1885e119c411799fe26d17c778a93c703b712424972f0c3db70d5dea292aae4a"));
    EXPECT_EQ(serverProof(key, challenge, nonce),
              fromHex("783ab7f8d9911c268e5d1d030a291cd32d24fd8c281a9e87d945228e3251bcd9"));
    EXPECT_TRUE(macsEqual(clientProof(key, challenge, nonce), clientProof(key, challenge, nonce)));
    EXPECT_FALSE(macsEqual(clientProof(key, challenge, nonce), serverProof(key, challenge, nonce)));
    EXPECT_FALSE(macsEqual(clientProof(key, challenge, nonce), Bytes(31, 0)));
    const Bytes r1 = randomBytes(32), r2 = randomBytes(32);
    EXPECT_EQ(r1.size(), 32u);
    EXPECT_NE(r1, r2);
}

TEST(Authentication, KeyFileMustBePrivateAndLongEnough) {
    test::TempDir dir("avatar-key");
    const auto write = [&](const std::string& name, const std::string& content, mode_t mode) {
        const auto path = dir / name;
        std::ofstream(path) << content;
        ::chmod(path.c_str(), mode);
        return path;
    };
    EXPECT_EQ(readAuthKeyFile(write("good", "6f1d2c3b4a5968778695a4b3c2d1e0f0\n", 0600)),
              "6f1d2c3b4a5968778695a4b3c2d1e0f0");
    const auto open = write("open", "6f1d2c3b4a5968778695a4b3c2d1e0f0\n", 0644);
    try {
        readAuthKeyFile(open);
        ADD_FAILURE() << "a world-readable key was accepted";
    } catch (const InvalidArgument& e) {
        EXPECT_EQ(std::string(e.what()), "authentication key file " + open.string() +
                                             " may be read or written by group or others (mode 0644); make it "
                                             "readable by the service only: chmod 600 " + open.string());
    }
    const auto tiny = write("tiny", "short\n", 0600);
    try {
        readAuthKeyFile(tiny);
        ADD_FAILURE() << "a 5-byte key was accepted";
    } catch (const InvalidArgument& e) {
        EXPECT_EQ(std::string(e.what()), "authentication key file " + tiny.string() +
                                             " holds 5 bytes; at least 16 are needed (openssl rand -hex 32 makes one)");
    }
    EXPECT_THROW(readAuthKeyFile(dir / "missing"), IoError);
    EXPECT_THROW(readAuthKeyFile(dir.path()), InvalidArgument);  // a directory
}
