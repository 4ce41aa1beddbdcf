// TAUNet on the wire: a real server on an ephemeral loopback port over a real
// VisionInterface (simulation backend at 640x480, or the replay backend on the
// bundled lab session), driven by raw Boost.Asio clients that build and parse
// frames by hand from docs/protocol.md (WireSupport.h). Every loop is bounded
// in time. Authentication and the Unix-domain socket: TauNetAuthTest.cpp.

#include "SphereScene.h"
#include "WireSupport.h"

#include <avatar/acquire/RawDataAcquire.h>
#include <avatar/config/ConfigXml.h>
#include <avatar/tau/TauUnit.h>

#include <gtest/gtest.h>
#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>

#include <algorithm>
#include <atomic>
#include <cstring>

using namespace avatar;
using namespace avatar::test::wire;

// ---- session and framing ----------------------------------------------------

TEST(TauNet, HelloReplyIsExact) {
    Daemon d;
    Client c(d.port());
    ASSERT_TRUE(c.send(frame(kHello, 0xDEADBEEF, helloPayload(1, "wire-test"))));
    Bytes expected;
    put16(expected, 1);
    putStr(expected, "TAUNet");
    putStr(expected, "simulation");
    EXPECT_EQ(c.next().bytes, frame(0x8001, 0xDEADBEEF, expected));
    // A second HELLO is answered like the first, in the version it asks for.
    ASSERT_TRUE(c.send(frame(kHello, 2, helloPayload(1, "again"))));
    EXPECT_EQ(c.next().bytes, frame(0x8001, 2, expected));
    ASSERT_TRUE(c.send(frame(kHello, 3, helloPayload(2, "version two"))));
    Bytes two;
    put16(two, 2);
    putStr(two, "TAUNet");
    putStr(two, "simulation");
    EXPECT_EQ(c.next().bytes, frame(0x8001, 3, two));
}

TEST(TauNet, StatusBeforeTheFirstIterationFieldByField) {
    Daemon d;
    Client c(d.port());
    c.hello();
    std::this_thread::sleep_for(250ms);  // the idle loop beats every 100 ms
    const RawFrame f = c.request(kStatus, 7);
    ASSERT_EQ(f.type, 0x8009);
    EXPECT_EQ(f.request, 7u);
    EXPECT_EQ(f.reserved, 0u);
    Fields r(f.payload);
    EXPECT_EQ(r.u8(), 0);         // state idle
    EXPECT_EQ(r.str(), "");       // error
    const std::uint64_t heartbeat = r.u64();
    EXPECT_GE(heartbeat, 2u);
    EXPECT_EQ(r.u64(), 0u);       // iteration
    EXPECT_EQ(r.u32(), 1u);       // configVersion
    EXPECT_EQ(r.u64(), 1u);       // configIteration: the first iteration will use it
    EXPECT_EQ(r.u64(), 0u);       // targetsIteration
    EXPECT_EQ(r.u64(), 0u);       // imagesIteration
    EXPECT_EQ(r.u8(), 0);         // acquisition ok
    EXPECT_EQ(r.str(), "");       // acquisitionMessage
    EXPECT_EQ(r.u8(), 0);         // visibility unknown
    EXPECT_EQ(r.str(), "");       // visibilityReason
    EXPECT_EQ(r.u64(), 0u);       // recordBacklog
    EXPECT_EQ(r.u64(), 0u);       // recorded
    EXPECT_EQ(r.u64(), 0u);       // unrecorded
    EXPECT_EQ(r.str(), "");       // recordError
    EXPECT_EQ(r.str(), "simulation");
    EXPECT_TRUE(r.done());
    // The heartbeat goes on.
    std::this_thread::sleep_for(250ms);
    Fields again(c.request(kStatus, 8).payload);
    again.u8();
    again.str();
    EXPECT_GE(again.u64(), heartbeat + 2);
}

TEST(TauNet, FirstMessageMustBeHello) {
    Daemon d;
    Client c(d.port());
    ASSERT_TRUE(c.send(frame(kStatus, 41)));
    EXPECT_EQ(c.next().bytes, errorFrame(41, 3, "the first message must be HELLO, not STATUS"));
    EXPECT_TRUE(c.closedWithin(5s));
    // An unknown type first is the same error.
    Client u(d.port());
    ASSERT_TRUE(u.send(frame(0x0042, 9)));
    EXPECT_EQ(u.next().bytes, errorFrame(9, 3, "the first message must be HELLO, not 0x0042"));
    EXPECT_TRUE(u.closedWithin(5s));
}

TEST(TauNet, OtherVersionIsRefusedAndClosed) {
    Daemon d;
    for (const std::uint16_t version : {std::uint16_t{4}, std::uint16_t{0}}) {
        Client c(d.port());
        Bytes future;
        put16(future, version);
        putStr(future, "future client");
        future.push_back(0x55);  // whatever that version adds: the version is checked first
        ASSERT_TRUE(c.send(frame(kHello, 3, future)));
        EXPECT_EQ(c.next().bytes, errorFrame(3, 4,
                                             "protocol version " + std::to_string(version) +
                                                 " is not supported; this server speaks versions 1 to 3"));
        EXPECT_TRUE(c.closedWithin(5s));
    }
}

TEST(TauNet, MalformedHeaderIsAnsweredWithRequestZeroAndClosed) {
    Daemon d;
    Client c(d.port());
    c.hello();
    const Bytes bad = frame(kStatus, 5, {}, /*reserved*/ 1);
    ASSERT_TRUE(c.send(bad));
    const RawFrame f = c.next();
    EXPECT_EQ(f.bytes, errorFrame(0, 1, framingMessage(bad)));
    EXPECT_NE(errorMessage(f).find("reserved"), std::string::npos) << errorMessage(f);
    EXPECT_TRUE(c.closedWithin(5s));
    // Everyone else is still served.
    Client other(d.port());
    other.hello();
    EXPECT_EQ(other.request(kStatus, 1).type, 0x8009);
}

TEST(TauNet, OversizedFrameIsRefusedFromItsHeaderAlone) {
    Daemon d;
    Client c(d.port());
    c.hello();
    Bytes header;
    put32(header, tau::kMaxRequestPayload + 1);
    put16(header, kSendConfig);
    put16(header, 0);
    put32(header, 77);
    ASSERT_TRUE(c.send(header));  // no payload follows: the header is enough
    const RawFrame f = c.next(5s);
    EXPECT_EQ(f.bytes, errorFrame(0, 2, framingMessage(header)));
    EXPECT_NE(errorMessage(f).find("1048577"), std::string::npos) << errorMessage(f);
    EXPECT_TRUE(c.closedWithin(5s));
}

TEST(TauNet, PayloadOfExactlyTheLimitIsReadAndJudgedByItsFields) {
    Daemon d;
    Client c(d.port());
    c.hello();
    ASSERT_TRUE(c.send(frame(kStatus, 12, Bytes(tau::kMaxRequestPayload, 0xAB))));
    const RawFrame f = c.next();
    EXPECT_EQ(f.type, 0xFFFF);
    EXPECT_EQ(f.request, 12u);
    EXPECT_EQ(errorCode(f), 6);  // BAD_PAYLOAD, connection kept
    EXPECT_EQ(c.request(kStatus, 13).type, 0x8009);
}

TEST(TauNet, GarbageIsAMalformedFrame) {
    Daemon d;
    Client c(d.port());
    const std::string http = "GET / HTTP/1.1\r\nHost: vision\r\n\r\n";
    const Bytes garbage(http.begin(), http.end());
    ASSERT_TRUE(c.send(garbage));
    const RawFrame f = c.next(5s);
    EXPECT_EQ(f.bytes, errorFrame(0, 1, framingMessage(garbage)));
    EXPECT_TRUE(c.closedWithin(5s));

    // Random bytes after a good HELLO: an ERROR and a close, never a crash or a hang.
    cv::RNG rng(3);
    for (int round = 0; round < 20; ++round) {
        Client g(d.port());
        g.hello();
        Bytes noise(12 + static_cast<std::size_t>(rng.uniform(0, 300)));  // at least a header
        for (auto& b : noise) b = static_cast<std::uint8_t>(rng.uniform(0, 256));
        noise[6] = 0xFF;  // a nonzero reserved field: the header is bad for sure
        ASSERT_TRUE(g.send(noise));
        RawFrame e;
        ASSERT_EQ(g.read(e, 5s), Client::Result::Frame) << "round " << round;
        EXPECT_EQ(e.type, 0xFFFF);
        EXPECT_TRUE(errorCode(e) == 1 || errorCode(e) == 2) << errorCode(e);
        EXPECT_EQ(e.request, 0u);
        EXPECT_TRUE(g.closedWithin(5s)) << "round " << round;
    }
    Client other(d.port());
    other.hello();
    EXPECT_EQ(other.request(kStatus, 1).type, 0x8009);
}

TEST(TauNet, UnknownMessagesAreAnsweredAndTheConnectionKept) {
    Daemon d;
    Client c(d.port());
    c.hello();
    EXPECT_EQ(c.request(0x0042, 100).bytes, errorFrame(100, 5, "unknown message type 0x0042"));
    EXPECT_EQ(c.request(0x8009, 101).bytes, errorFrame(101, 5, "unknown message type " + tau::messageName(0x8009)));
    EXPECT_EQ(c.request(0xFFFF, 102).bytes, errorFrame(102, 5, "unknown message type " + tau::messageName(0xFFFF)));
    EXPECT_EQ(c.request(0x0000, 103).bytes, errorFrame(103, 5, "unknown message type " + tau::messageName(0)));
    EXPECT_EQ(c.request(kStatus, 104).type, 0x8009);
}

// docs/protocol.md: after a HELLO that does not decode the session is not
// open, even on a session that was: the next frame must be HELLO again.
TEST(TauNet, AHelloThatDoesNotDecodeClosesAnOpenSession) {
    Daemon d;
    Client c(d.port());
    c.hello();
    EXPECT_EQ(c.request(kStatus, 2).type, 0x8009);
    Bytes shortHello;
    put16(shortHello, 2);
    put32(shortHello, 50);  // a 50-byte name that is not there
    RawFrame f = c.request(kHello, 3, shortHello);
    EXPECT_EQ(f.type, 0xFFFF);
    EXPECT_EQ(errorCode(f), 6);
    f = c.request(kStatus, 4);
    EXPECT_EQ(f.type, 0xFFFF);
    EXPECT_EQ(errorCode(f), 3);  // HELLO_REQUIRED, and the connection closes
    EXPECT_TRUE(c.closedWithin(5s));
}

TEST(TauNet, BadPayloadsAreAnsweredAndTheConnectionKept) {
    Daemon d;
    Client c(d.port());
    // A HELLO that does not decode does not open the session, but is not fatal.
    Bytes shortHello;
    put16(shortHello, 1);
    put32(shortHello, 50);  // a 50-byte name that is not there
    RawFrame f = c.request(kHello, 1, shortHello);
    EXPECT_EQ(f.type, 0xFFFF);
    EXPECT_EQ(errorCode(f), 6);
    c.hello();

    struct Case {
        std::uint16_t type;
        Bytes payload;
        const char* what;
    };
    const std::vector<Case> cases = {
        {kStatus, {0}, "STATUS with a byte"},
        {kStart, {1, 2}, "START_SEARCHING with bytes"},
        {kStop, {1}, "STOP_SEARCHING with a byte"},
        {kTargets, {0}, "GET_TARGET_DATA with a byte"},
        {kGetConfig, {0, 0, 0, 0}, "GET_CONFIG with bytes"},
        {kSnapshot, {0, 1}, "TAKE_SNAPSHOT short"},
        {kSnapshot, {0, 0, 0, 1, 0}, "TAKE_SNAPSHOT long"},
        {kSendConfig, {0, 0, 0, 9, 'x'}, "SEND_CONFIG string short"},
        {kImages, imagesPayload(3, 3, 90), "GET_IMAGES kind 3"},
        {kImages, imagesPayload(0, 0, 90), "GET_IMAGES no side"},
        {kImages, imagesPayload(0, 4, 90), "GET_IMAGES side bit 2"},
        {kImages, imagesPayload(0, 3, 0), "GET_IMAGES quality 0"},
        {kImages, imagesPayload(0, 3, 101), "GET_IMAGES quality 101"},
        {kImages, {0, 3}, "GET_IMAGES short"},
    };
    std::uint32_t id = 200;
    for (const Case& k : cases) {
        f = c.request(k.type, id, k.payload);
        EXPECT_EQ(f.type, 0xFFFF) << k.what;
        EXPECT_EQ(f.request, id) << k.what;
        EXPECT_EQ(errorCode(f), 6) << k.what << ": " << errorMessage(f);
        EXPECT_FALSE(errorMessage(f).empty()) << k.what;
        ++id;
    }
    EXPECT_EQ(c.request(kStatus, id).type, 0x8009);
    EXPECT_GE(d.server->stats().protocolErrors, cases.size() + 1);
}

// ---- the requests -------------------------------------------------------------

TEST(TauNet, NothingAvailableBeforeTheFirstIteration) {
    Daemon d;
    Client c(d.port());
    c.hello();
    EXPECT_EQ(c.request(kTargets, 5).bytes, errorFrame(5, 10, "no target data yet: no iteration has been analysed"));
    EXPECT_EQ(c.request(kImages, 6, imagesPayload(0, 3, 90)).bytes,
              errorFrame(6, 10, "no images yet: no iteration has been analysed"));
}

// A version-1 client gets the version-1 Target layout (docs/protocol.md,
// "Version 1"): no model, covariances or residuals, only flag bits 0-4, and a
// target that is not whole never with the stereo bit or a position.
TEST(TauNet, VersionOneClientsGetTheVersionOneLayout) {
    Daemon d;
    Client c(d.port());
    ASSERT_TRUE(c.send(frame(kHello, 1, helloPayload(1, "old client"))));
    ASSERT_EQ(c.next().type, 0x8001);
    const RawFrame snap = c.request(kSnapshot, 2, u32Payload(20000));
    ASSERT_EQ(snap.type, 0x8004) << (snap.type == 0xFFFF ? errorMessage(snap) : "");
    const VisionTargets latest = *d.vision->latestTargets();
    EXPECT_EQ(snap.payload, tau::encode(latest, 1));
    EXPECT_THROW(tau::decodeTargetData(snap.payload, 2), tau::ProtocolError);
    const VisionTargets old = tau::decodeTargetData(snap.payload, 1);
    ASSERT_EQ(old.targets.size(), latest.targets.size());
    for (std::size_t i = 0; i < old.targets.size(); ++i) {
        const VisionTarget& v1 = old.targets[i];
        const VisionTarget& v2 = latest.targets[i];
        EXPECT_EQ(v1.flags & ~0x1Fu, 0u) << targetFlagsText(v1.flags);
        EXPECT_EQ(bool(v1.flags & kTargetStereo), bool(v2.flags & kTargetWhole));
        EXPECT_EQ(v1.positionVisionMm.has_value(), bool(v2.flags & kTargetWhole));
        EXPECT_EQ(v1.centroidLeftPx, v2.centroidLeftPx);
        EXPECT_FALSE(v1.covarianceVisionMm2);
    }
    // GET_TARGET_DATA answers in the session's version too.
    EXPECT_EQ(c.request(kTargets, 3).payload, snap.payload);
}

TEST(TauNet, SnapshotReturnsTheTargetsAndTargetDataRepeatsThem) {
    Daemon d;
    Client c(d.port());
    c.hello();
    const RawFrame snap = c.request(kSnapshot, 20, u32Payload(20000));
    ASSERT_EQ(snap.type, 0x8004) << (snap.type == 0xFFFF ? errorMessage(snap) : "");
    EXPECT_EQ(snap.request, 20u);
    const VisionTargets t = tau::decodeTargetData(snap.payload);
    EXPECT_EQ(t.iteration, 1u);
    EXPECT_EQ(t.acquisition.group, 1u);
    EXPECT_EQ(t.acquisition.member, 0u);
    EXPECT_EQ(t.acquisition.left.cameraId, "sim-left");
    EXPECT_EQ(t.acquisition.right.cameraId, "sim-right");
    EXPECT_EQ(t.visibility, Visibility::Good);
    ASSERT_EQ(t.targets.size(), 1u);
    EXPECT_EQ(t.targets[0].type, "sample");
    EXPECT_TRUE(t.targets[0].flags & kTargetStereo);
    ASSERT_TRUE(t.targets[0].positionVisionMm.has_value());
    EXPECT_LT(cv::norm(*t.targets[0].positionVisionMm - kSphereMm), 3.0);
    EXPECT_FALSE(t.timings.empty());
    // The server's encoding is the codec's encoding of VisionInterface's result.
    EXPECT_EQ(snap.payload, tau::encode(*d.vision->latestTargets()));

    // GET_TARGET_DATA: the same data, byte for byte.
    const RawFrame data = c.request(kTargets, 21);
    EXPECT_EQ(data.bytes, frame(0x8005, 21, snap.payload));

    // The vision loop turns idle on its next turn after the snapshot.
    RawFrame status;
    ASSERT_TRUE(eventually([&] { return Fields((status = c.request(kStatus, 22)).payload).u8() == 0; }, 10s));
    Fields s(status.payload);
    EXPECT_EQ(s.u8(), 0);    // idle again
    s.str();
    s.u64();
    EXPECT_EQ(s.u64(), 1u);  // iteration
    EXPECT_EQ(s.u32(), 1u);
    EXPECT_EQ(s.u64(), 1u);
    EXPECT_EQ(s.u64(), 1u);  // targetsIteration
    EXPECT_EQ(s.u64(), 1u);  // imagesIteration
    EXPECT_EQ(s.u8(), 0);
    s.str();
    EXPECT_EQ(s.u8(), 1);    // visibility good
}

TEST(TauNet, SnapshotTimeoutIsTimeout) {
    Daemon d;
    Client c(d.port());
    c.hello();
    const RawFrame f = c.request(kSnapshot, 30, u32Payload(0));  // nothing renders in 0 ms
    EXPECT_EQ(f.type, 0xFFFF);
    EXPECT_EQ(f.request, 30u);
    EXPECT_EQ(errorCode(f), 9) << errorMessage(f);
    EXPECT_NE(errorMessage(f).find("timed out"), std::string::npos) << errorMessage(f);
    EXPECT_EQ(c.request(kStatus, 31).type, 0x8009);
}

TEST(TauNet, ImagesOfEveryKindAndSide) {
    Daemon d;
    Client c(d.port());
    c.hello();
    ASSERT_EQ(c.request(kSnapshot, 1, u32Payload(20000)).type, 0x8004);
    std::uint32_t id = 40;
    for (std::uint8_t kind = 0; kind < 3; ++kind) {
        for (std::uint8_t sides = 1; sides <= 3; ++sides) {
            const RawFrame f = c.request(kImages, id, imagesPayload(kind, sides, 80));
            ASSERT_EQ(f.type, 0x8008) << int(kind) << "/" << int(sides) << ": "
                                      << (f.type == 0xFFFF ? errorMessage(f) : "");
            EXPECT_EQ(f.request, id);
            Fields r(f.payload);
            EXPECT_EQ(r.u64(), 1u);  // iteration
            EXPECT_EQ(r.u8(), kind);
            const std::uint8_t count = r.u8();
            EXPECT_EQ(count, sides == 3 ? 2 : 1);
            std::vector<std::uint8_t> seen;
            for (std::uint8_t i = 0; i < count; ++i) {
                const std::uint8_t side = r.u8();
                seen.push_back(side);
                EXPECT_EQ(r.u32(), 640u);
                EXPECT_EQ(r.u32(), 480u);
                const std::string jpeg = r.str();
                ASSERT_GT(jpeg.size(), 2u);
                EXPECT_EQ(static_cast<std::uint8_t>(jpeg[0]), 0xFF);  // SOI
                EXPECT_EQ(static_cast<std::uint8_t>(jpeg[1]), 0xD8);
                const cv::Mat img = cv::imdecode(cv::Mat(1, static_cast<int>(jpeg.size()), CV_8U,
                                                         const_cast<char*>(jpeg.data())),
                                                 cv::IMREAD_UNCHANGED);
                EXPECT_EQ(img.size(), cv::Size(640, 480));
                EXPECT_EQ(img.type(), CV_8UC3);
            }
            EXPECT_TRUE(r.done());
            const std::vector<std::uint8_t> expectedSides =
                sides == 1 ? std::vector<std::uint8_t>{0} : sides == 2 ? std::vector<std::uint8_t>{1}
                                                                       : std::vector<std::uint8_t>{0, 1};
            EXPECT_EQ(seen, expectedSides);
            ++id;
        }
    }
}

TEST(TauNet, RejectedConfigurationKeepsTheOldOne) {
    Daemon d;
    Client c(d.port());
    c.hello();
    const std::string before = d.vision->configXml();
    RawFrame f = c.request(kGetConfig, 1);
    ASSERT_EQ(f.type, 0x8007);
    {
        Fields r(f.payload);
        EXPECT_EQ(r.u32(), 1u);
        EXPECT_EQ(r.u64(), 1u);
        EXPECT_EQ(r.str(), before);
        EXPECT_TRUE(r.done());
    }

    std::string bad = before;
    bad.replace(bad.find("<width>640</width>"), 18, "<width>wide</width>");
    std::string expected;
    try {
        readConfigString(bad, "sent configuration");
    } catch (const ConfigError& e) {
        expected = e.what();
    }
    ASSERT_NE(expected.find("/avatar/camera/width"), std::string::npos) << expected;
    EXPECT_EQ(c.request(kSendConfig, 2, strPayload(bad)).bytes, errorFrame(2, 7, expected));

    // Valid XML whose analysis cannot be built: rejected too.
    AvatarConfig broken = test::sphereSceneConfig();
    broken.analysis.stages = {"demosaic", "match"};
    f = c.request(kSendConfig, 3, strPayload(writeConfigString(broken)));
    EXPECT_EQ(f.type, 0xFFFF);
    EXPECT_EQ(errorCode(f), 7) << errorMessage(f);

    // Not XML at all.
    f = c.request(kSendConfig, 4, strPayload("<avatar"));
    EXPECT_EQ(errorCode(f), 7) << errorMessage(f);

    f = c.request(kGetConfig, 5);
    Fields r(f.payload);
    EXPECT_EQ(r.u32(), 1u);
    EXPECT_EQ(r.u64(), 1u);
    EXPECT_EQ(r.str(), before);
    // And it still works with it.
    const RawFrame snap = c.request(kSnapshot, 6, u32Payload(20000));
    ASSERT_EQ(snap.type, 0x8004);
    EXPECT_EQ(tau::decodeTargetData(snap.payload).targets.size(), 1u);
}

TEST(TauNet, AppliedConfigurationIsReportedAndServed) {
    Daemon d;
    Client c(d.port());
    c.hello();
    ASSERT_EQ(c.request(kSnapshot, 1, u32Payload(20000)).type, 0x8004);
    AvatarConfig narrower = test::sphereSceneConfig();
    narrower.targets.targets[0].area = {100, 200};  // the sphere is larger: filtered out
    const std::string xml = writeConfigString(narrower);
    Bytes applied;
    put32(applied, 2);  // configVersion
    put32(applied, 0);
    put32(applied, 2);  // configIteration: the next iteration
    EXPECT_EQ(c.request(kSendConfig, 2, strPayload(xml)).bytes, frame(0x8006, 2, applied));

    const RawFrame f = c.request(kGetConfig, 3);
    Fields r(f.payload);
    EXPECT_EQ(r.u32(), 2u);
    EXPECT_EQ(r.u64(), 2u);
    EXPECT_EQ(r.str(), xml);
    const VisionTargets t = tau::decodeTargetData(c.request(kSnapshot, 4, u32Payload(20000)).payload);
    EXPECT_EQ(t.iteration, 2u);
    EXPECT_EQ(t.acquisition.group, 2u);
    EXPECT_TRUE(t.targets.empty());
}

TEST(TauNet, RepliesComeInRequestOrderWhateverTheirDuration) {
    Daemon d;
    Client c(d.port());
    c.hello();
    // One write: a slow request between fast ones, and an error in the middle.
    Bytes burst;
    const std::vector<std::pair<std::uint16_t, Bytes>> requests = {
        {kStatus, {}}, {kSnapshot, u32Payload(20000)}, {kStatus, {}}, {0x0077, {}}, {kGetConfig, {}},
        {kImages, imagesPayload(2, 1, 50)}, {kTargets, {}}, {kStatus, {0}}, {kStatus, {}}};
    std::uint32_t id = 1000;
    for (const auto& [type, payload] : requests) {
        const Bytes f = frame(type, id++, payload);
        burst.insert(burst.end(), f.begin(), f.end());
    }
    ASSERT_TRUE(c.send(burst));
    const std::vector<std::uint16_t> expectedTypes = {0x8009, 0x8004, 0x8009, 0xFFFF, 0x8007,
                                                      0x8008, 0x8005, 0xFFFF, 0x8009};
    std::vector<RawFrame> replies;
    for (std::size_t i = 0; i < requests.size(); ++i) {
        replies.push_back(c.next());
        EXPECT_EQ(replies.back().request, 1000 + i);
        EXPECT_EQ(replies.back().type, expectedTypes[i])
            << "reply " << i << (replies.back().type == 0xFFFF ? ": " + errorMessage(replies.back()) : "");
    }
    // Processed in order: the images and target data are the snapshot's.
    EXPECT_EQ(replies[6].payload, replies[1].payload);
    EXPECT_EQ(Fields(replies[5].payload).u64(), 1u);
}

TEST(TauNet, SearchingStartsAndStopsAndIsIdempotent) {
    Daemon d;
    Client c(d.port());
    c.hello();
    EXPECT_EQ(c.request(kStop, 1).bytes, frame(0x8003, 1));  // while idle: fine
    EXPECT_EQ(c.request(kStart, 2).bytes, frame(0x8002, 2));
    EXPECT_EQ(c.request(kStart, 3).bytes, frame(0x8002, 3));  // while searching: fine
    ASSERT_TRUE(eventually([&] { return d.vision->status().iteration >= 2; }));
    Fields s(c.request(kStatus, 4).payload);
    EXPECT_EQ(s.u8(), 1);  // searching
    EXPECT_EQ(c.request(kStop, 5).bytes, frame(0x8003, 5));
    ASSERT_TRUE(eventually([&] { return d.vision->status().state == VisionState::Idle; }));
    // A snapshot while searching is the next iteration's result.
    EXPECT_EQ(c.request(kStart, 6).type, 0x8002);
    const auto before = d.vision->status().iteration;
    const VisionTargets t = tau::decodeTargetData(c.request(kSnapshot, 7, u32Payload(20000)).payload);
    EXPECT_GT(t.iteration, before);
    EXPECT_EQ(c.request(kStop, 8).type, 0x8003);
}

TEST(TauNet, ReplayEndsInAcquisitionFailedAndInvalidState) {
    const std::filesystem::path session = std::filesystem::path(AVATAR_DATA_DIR) / "sessions" / "lab";
    auto replay = std::make_unique<RawDataAcquire>(session);
    const auto records = replay->reader().records();
    ASSERT_EQ(records.size(), 3u);
    const AvatarConfig config = readConfigString(*replay->reader().configXml(records.front().configVersion));
    Daemon d({}, std::move(replay), config, session);
    Client c(d.port());
    ASSERT_TRUE(c.send(frame(kHello, 1, helloPayload())));
    Bytes expected;
    put16(expected, 2);
    putStr(expected, "TAUNet");
    putStr(expected, "replay");
    EXPECT_EQ(c.next().bytes, frame(0x8001, 1, expected));

    for (std::uint32_t i = 1; i <= 3; ++i) {
        const RawFrame f = c.request(kSnapshot, 10 + i, u32Payload(30000));
        ASSERT_EQ(f.type, 0x8004) << (f.type == 0xFFFF ? errorMessage(f) : "");
        const VisionTargets t = tau::decodeTargetData(f.payload);
        EXPECT_EQ(t.iteration, records[i - 1].iteration);
        EXPECT_EQ(t.acquisition, records[i - 1].acquisition);
    }
    RawFrame f = c.request(kSnapshot, 20, u32Payload(30000));
    EXPECT_EQ(f.type, 0xFFFF);
    EXPECT_EQ(errorCode(f), 8) << errorMessage(f);  // ACQUISITION_FAILED
    EXPECT_FALSE(errorMessage(f).empty());
    f = c.request(kStart, 21);
    EXPECT_EQ(f.type, 0xFFFF);
    EXPECT_EQ(errorCode(f), 11) << errorMessage(f);  // INVALID_STATE
    // The loop records the error just after failing the snapshot.
    RawFrame status;
    ASSERT_TRUE(eventually([&] {
        Fields r((status = c.request(kStatus, 22)).payload);
        r.u8();
        return !r.str().empty();
    }, 10s));
    Fields s(status.payload);
    s.u8();
    EXPECT_FALSE(s.str().empty());  // the last error
    s.u64();
    EXPECT_EQ(s.u64(), records.back().iteration);
    s.u32();
    s.u64();
    s.u64();
    s.u64();
    EXPECT_EQ(s.u8(), 3);  // acquisition finished
    // Idle, with the last iteration's data and the configuration still served.
    EXPECT_EQ(Fields(c.request(kStatus, 23).payload).u8(), 0);
    const RawFrame last = c.request(kTargets, 24);
    ASSERT_EQ(last.type, 0x8005);
    EXPECT_EQ(tau::decodeTargetData(last.payload, 2).iteration, records.back().iteration);
    EXPECT_EQ(c.request(kImages, 25, imagesPayload(0, 3, 80)).type, 0x8008);
    EXPECT_EQ(c.request(kGetConfig, 26).type, 0x8007);
}

// ---- docs/protocol.md's corners, as the daemon behaves ------------------------------

TEST(TauNet, ReservedBitsWinOverOversizeAndHelloRequiredOnAFirstFrame) {
    Daemon d;
    Client c(d.port());
    Bytes header;
    put32(header, 2u << 20);  // 2 MiB: over the limit too
    put16(header, kStatus);   // and not HELLO
    put16(header, 4);         // reserved
    put32(header, 77);
    ASSERT_TRUE(c.send(header));
    const RawFrame f = c.next();
    EXPECT_EQ(errorCode(f), 1) << errorMessage(f);  // MALFORMED_FRAME
    EXPECT_EQ(f.request, 0u);
    EXPECT_TRUE(c.closedWithin(5s));
}

TEST(TauNet, ClientNamesAreBytesNotCheckedAsUtf8) {
    Daemon d;
    Client c(d.port());
    const RawFrame f = c.request(kHello, 1, helloPayload(3, std::string("arm \xff\xfe\xc3")));
    EXPECT_EQ(f.type, 0x8001);
    EXPECT_EQ(c.request(kStatus, 2).type, 0x8009);
}

TEST(TauNet, ConfigVersionCountsEveryConfigurationPutInForce) {
    Daemon d;
    Client c(d.port());
    c.hello();
    Fields config(c.request(kGetConfig, 2).payload);
    config.u32();
    config.u64();
    const std::string xml = config.str();
    auto versionOf = [](const RawFrame& f) { return Fields(f.payload).u32(); };
    EXPECT_EQ(versionOf(c.request(kSendConfig, 3, strPayload(xml))), 2u);  // the same document counts
    EXPECT_EQ(errorCode(c.request(kSendConfig, 4, strPayload("<avatar version=\"1\"/>"))), 7);  // rejected: not
    EXPECT_EQ(versionOf(c.request(kSendConfig, 5, strPayload(xml))), 3u);
    Fields status(c.request(kStatus, 6).payload);
    status.u8();
    status.str();
    status.u64();
    status.u64();
    EXPECT_EQ(status.u32(), 3u);
}

TEST(TauNet, ATimedOutSnapshotStillUsesUpAReplayPair) {
    const std::filesystem::path session = std::filesystem::path(AVATAR_DATA_DIR) / "sessions" / "lab";
    auto replay = std::make_unique<RawDataAcquire>(session);
    const auto records = replay->reader().records();
    ASSERT_EQ(records.size(), 3u);
    const AvatarConfig config = readConfigString(*replay->reader().configXml(records.front().configVersion));
    Daemon d({}, std::move(replay), config, session);
    Client c(d.port());
    c.hello();
    EXPECT_EQ(errorCode(c.request(kSnapshot, 1, u32Payload(0))), 9);  // TIMEOUT
    // The loop still takes the first pair for it ...
    ASSERT_TRUE(eventually([&] { return c.request(kTargets, 2).type == 0x8005; }, 20s));
    EXPECT_EQ(tau::decodeTargetData(c.request(kTargets, 3).payload, 2).iteration, records[0].iteration);
    // ... so the next snapshot gets the second.
    const RawFrame next = c.request(kSnapshot, 4, u32Payload(30000));
    ASSERT_EQ(next.type, 0x8004);
    EXPECT_EQ(tau::decodeTargetData(next.payload, 2).iteration, records[1].iteration);
}

// ---- many clients, bad clients --------------------------------------------------

TEST(TauNet, FiftyClientsPollTargetDataWhileSearching) {
    Daemon d;
    {
        Client c(d.port());
        c.hello();
        ASSERT_EQ(c.request(kStart, 1).type, 0x8002);
    }
    ASSERT_TRUE(eventually([&] { return d.vision->status().iteration >= 1; }));
    constexpr int kClients = 50;
    std::atomic<int> failures{0};
    std::vector<std::uint64_t> first(kClients), last(kClients), replies(kClients);
    std::vector<std::string> problems(kClients);
    std::vector<std::thread> threads;
    const auto until = std::chrono::steady_clock::now() + 2s;
    for (int i = 0; i < kClients; ++i) {
        threads.emplace_back([&, i] {
            try {
                Client c(d.port());
                c.hello();
                std::uint32_t id = 10;
                std::uint64_t previous = 0;
                while (std::chrono::steady_clock::now() < until) {
                    const RawFrame f = c.request(kTargets, id);
                    if (f.type != 0x8005 || f.request != id) throw std::runtime_error("bad reply type or id");
                    const VisionTargets t = tau::decodeTargetData(f.payload);
                    if (t.iteration < previous) throw std::runtime_error("iteration went backwards");
                    if (previous == 0) first[i] = t.iteration;
                    previous = t.iteration;
                    ++replies[i];
                    ++id;
                }
                last[i] = previous;
            } catch (const std::exception& e) {
                problems[i] = e.what();
                ++failures;
            }
        });
    }
    // Meanwhile another client is served too.
    Client watcher(d.port());
    watcher.hello();
    EXPECT_EQ(watcher.request(kStatus, 1).type, 0x8009);
    for (auto& t : threads) t.join();
    EXPECT_EQ(failures.load(), 0);
    for (int i = 0; i < kClients; ++i) {
        EXPECT_TRUE(problems[i].empty()) << "client " << i << ": " << problems[i];
        EXPECT_GE(replies[i], 10u) << "client " << i;
        EXPECT_GE(first[i], 1u);
        EXPECT_GE(last[i], first[i]);
    }
    EXPECT_GT(*std::max_element(last.begin(), last.end()), *std::min_element(first.begin(), first.end()))
        << "the vision loop did not advance while being polled";
    EXPECT_EQ(watcher.request(kStop, 2).type, 0x8003);
}

TEST(TauNet, ClientsVanishingMidFrameDoNotDisturbOthers) {
    Daemon d;
    Client good(d.port());
    good.hello();
    for (int i = 0; i < 10; ++i) {
        Client c(d.port());
        c.hello();
        Bytes half = frame(kSendConfig, 5, strPayload(std::string(1000, 'x')));
        half.resize(static_cast<std::size_t>(i == 0 ? 3 : 12 + i * 50));  // in the header, or in the payload
        ASSERT_TRUE(c.send(half));
        c.close();
        EXPECT_EQ(good.request(kStatus, static_cast<std::uint32_t>(i)).type, 0x8009);
    }
    EXPECT_TRUE(eventually([&] { return d.server->stats().connections == 1; }, 5s));
}

TEST(TauNet, PartialFramesAreClosedAfterTheIdleTimeout) {
    tau::TauNetOptions options;
    options.idleTimeout = 300ms;
    Daemon d(options);
    Client good(d.port());
    good.hello();
    for (const std::size_t cut : {std::size_t{5}, std::size_t{12 + 40}}) {
        Client c(d.port());
        c.hello();
        Bytes partial = frame(kSendConfig, 5, strPayload(std::string(100, 'x')));
        partial.resize(cut);
        ASSERT_TRUE(c.send(partial));
        const auto start = std::chrono::steady_clock::now();
        EXPECT_TRUE(c.closedWithin(5s)) << "cut " << cut;  // closed, no ERROR frame
        const auto took = std::chrono::steady_clock::now() - start;
        EXPECT_GE(took, 250ms);
        EXPECT_LT(took, 3s);
        EXPECT_EQ(good.request(kStatus, 1).type, 0x8009);
    }
    // A connection without a partial frame is not idle-closed.
    Client quiet(d.port());
    quiet.hello();
    std::this_thread::sleep_for(600ms);
    EXPECT_EQ(quiet.request(kStatus, 2).type, 0x8009);
    EXPECT_EQ(d.server->stats().idleTimeouts, 2u);
}

// A slowloris trickling one byte at a time into a frame used to restart the
// timer with every byte and was never closed: the deadline now runs from the
// frame's first byte.
TEST(TauNet, TricklingBytesDoNotExtendTheFrameDeadline) {
    tau::TauNetOptions options;
    options.idleTimeout = 600ms;
    Daemon d(options);
    Client c(d.port());
    c.hello();
    const Bytes big = frame(kSendConfig, 5, strPayload(std::string(100000, 'x')));
    const auto start = std::chrono::steady_clock::now();
    bool closed = false;
    for (std::size_t i = 0; i < 40 && !closed; ++i) {  // 40 bytes over 4 s, well past the deadline
        closed = !c.send(Bytes(big.begin() + static_cast<std::ptrdiff_t>(i), big.begin() + static_cast<std::ptrdiff_t>(i) + 1)) ||
                 c.closedWithin(100ms);
    }
    const auto took = std::chrono::steady_clock::now() - start;
    EXPECT_TRUE(closed);
    EXPECT_GE(took, 550ms);
    EXPECT_LT(took, 2500ms);
    EXPECT_EQ(d.server->stats().idleTimeouts, 1u);
}

TEST(TauNet, AConnectionThatNeverSaysHelloIsClosed) {
    tau::TauNetOptions options;
    options.helloTimeout = 300ms;
    Daemon d(options);
    Client silent(d.port());
    const auto start = std::chrono::steady_clock::now();
    EXPECT_TRUE(silent.closedWithin(5s));
    EXPECT_GE(std::chrono::steady_clock::now() - start, 250ms);
    EXPECT_EQ(d.server->stats().helloTimeouts, 1u);
    // One that says HELLO in time stays.
    Client prompt(d.port());
    prompt.hello();
    std::this_thread::sleep_for(500ms);
    EXPECT_EQ(prompt.request(kStatus, 2).type, 0x8009);
}

TEST(TauNet, AnIdleSessionIsClosedAndTauUnitConnectsAgain) {
    tau::TauNetOptions options;
    options.sessionIdleTimeout = 400ms;
    Daemon d(options);
    Client raw(d.port());
    raw.hello();
    EXPECT_EQ(raw.request(kStatus, 2).type, 0x8009);
    const auto start = std::chrono::steady_clock::now();
    EXPECT_TRUE(raw.closedWithin(5s));
    EXPECT_GE(std::chrono::steady_clock::now() - start, 350ms);
    EXPECT_EQ(d.server->stats().sessionTimeouts, 1u);

    // TAUUnit: the request after the close fails (its contract: a lost
    // connection is a ConnectionError), the next one connects again; with a
    // retry policy the caller never sees it.
    tau::TauUnitOptions uo;
    uo.port = d.port();
    tau::TauUnit unit(uo);
    unit.status();
    std::this_thread::sleep_for(800ms);  // the server closes the idle session meanwhile
    EXPECT_THROW(unit.status(), tau::ConnectionError);
    EXPECT_NO_THROW(unit.status());
    uo.retry.attempts = 1;
    uo.retry.delay = 10ms;
    tau::TauUnit patient(uo);
    patient.status();
    std::this_thread::sleep_for(800ms);
    EXPECT_NO_THROW(patient.status());
    EXPECT_GE(d.server->stats().sessionTimeouts, 3u);
}

// 256 silent connections locked every other client out: at the limit the
// silent (or else the idlest) connection makes room.
TEST(TauNet, SilentOrIdleConnectionsCannotLockClientsOut) {
    tau::TauNetOptions options;
    options.maxConnections = 4;
    options.evictAfter = 100ms;
    Daemon d(options);
    std::vector<std::unique_ptr<Client>> silent;
    for (int i = 0; i < 4; ++i) silent.push_back(std::make_unique<Client>(d.port()));
    ASSERT_TRUE(eventually([&] { return d.server->stats().connections == 4; }, 5s));
    std::this_thread::sleep_for(200ms);
    Client good(d.port());
    good.hello();
    EXPECT_EQ(good.request(kStatus, 2).type, 0x8009);
    EXPECT_EQ(d.server->stats().evicted, 1u);
    EXPECT_EQ(d.server->stats().rejected, 0u);

    // With every connection said HELLO and idle, the idlest one goes.
    std::vector<std::unique_ptr<Client>> idle;
    silent.clear();
    ASSERT_TRUE(eventually([&] { return d.server->stats().connections == 1; }, 5s));
    for (int i = 0; i < 3; ++i) {
        idle.push_back(std::make_unique<Client>(d.port()));
        idle.back()->hello();
    }
    std::this_thread::sleep_for(200ms);
    EXPECT_EQ(good.request(kStatus, 3).type, 0x8009);  // good is now the most recently active
    Client late(d.port());
    late.hello();
    EXPECT_EQ(late.request(kStatus, 2).type, 0x8009);
    EXPECT_EQ(d.server->stats().evicted, 2u);
    EXPECT_EQ(good.request(kStatus, 4).type, 0x8009);  // not the one evicted
}

// Six clients asking for images and never reading held 1.5 GB: the budget of
// all clients together disconnects the one with the most waiting, and a
// client that reads is served throughout.
TEST(TauNet, TheSendBudgetOfAllClientsDisconnectsTheWorstOffender) {
    tau::TauNetOptions options;
    options.maxSendQueueBytes = 64u << 20;       // no single client reaches its own limit
    options.maxTotalSendQueueBytes = 2u << 20;   // but together they reach this
    Daemon d(options);
    Client good(d.port());
    good.hello();
    std::vector<std::unique_ptr<Client>> greedy;
    for (int i = 0; i < 3; ++i) {
        greedy.push_back(std::make_unique<Client>(d.port()));
        greedy.back()->hello();
    }
    Bytes burst;
    for (std::uint32_t i = 0; i < 2000; ++i) {
        const Bytes f = frame(kGetConfig, i);
        burst.insert(burst.end(), f.begin(), f.end());
    }
    std::atomic<bool> stop{false};
    std::vector<std::thread> writers;
    for (auto& g : greedy)
        writers.emplace_back([&, c = g.get()] {
            const auto until = std::chrono::steady_clock::now() + 20s;
            while (!stop && std::chrono::steady_clock::now() < until)
                if (!c->send(burst)) break;
        });
    bool served = true;
    std::uint32_t id = 1;
    const auto until = std::chrono::steady_clock::now() + 20s;
    while (served && d.server->stats().slowClients < 3 && std::chrono::steady_clock::now() < until)
        served = good.request(kStatus, id++).type == 0x8009;
    stop = true;
    for (auto& w : writers) w.join();
    EXPECT_TRUE(served);
    EXPECT_EQ(d.server->stats().slowClients, 3u);  // each greedy one, in turn the worst
    EXPECT_EQ(good.request(kStatus, id).type, 0x8009);
    EXPECT_TRUE(eventually([&] { return d.server->stats().connections == 1; }, 10s));
}

TEST(TauNet, AClientThatNeverReadsIsDisconnectedAndOthersAreServed) {
    tau::TauNetOptions options;
    options.maxSendQueueBytes = 256 * 1024;
    Daemon d(options);
    Client good(d.port());
    good.hello();
    Client slow(d.port());
    slow.hello();
    // Tens of megabytes of GET_CONFIG replies asked for, none read.
    Bytes burst;
    for (std::uint32_t i = 0; i < 2000; ++i) {
        const Bytes f = frame(kGetConfig, i);
        burst.insert(burst.end(), f.begin(), f.end());
    }
    std::atomic<bool> writing{true};
    std::thread writer([&] {
        const auto until = std::chrono::steady_clock::now() + 20s;
        while (std::chrono::steady_clock::now() < until && d.server->stats().slowClients == 0)
            if (!slow.send(burst)) break;  // the server hung up
        writing = false;
    });
    // Meanwhile others are served as usual.
    std::uint32_t id = 1;
    bool served = true;
    while (writing && served && id < 100000) served = good.request(kStatus, id++).type == 0x8009;
    EXPECT_TRUE(served);
    writer.join();
    EXPECT_EQ(d.server->stats().slowClients, 1u);
    std::size_t received = 0;
    EXPECT_TRUE(slow.closedWithin(20s, &received));  // what was sent arrives, then the close
    EXPECT_GT(received, 0u);
    EXPECT_EQ(good.request(kStatus, id).type, 0x8009);
    EXPECT_TRUE(eventually([&] { return d.server->stats().connections == 1; }, 5s));
}

TEST(TauNet, StatusReportsTheRecording) {
    const std::filesystem::path dir =
        std::filesystem::path(::testing::TempDir()) / ("taunet_status_record_" + std::to_string(::getpid()));
    std::filesystem::remove_all(dir);
    {
        auto vision = [&] {
            VisionOptions vo;
            vo.recordDirectory = dir;
            return std::make_unique<VisionInterface>(test::sphereSimulation(), test::sphereSceneConfig(), vo);
        }();
        tau::TauNetOptions options;
        options.port = 0;
        tau::TauNetServer server(*vision, options);
        Client c(server.port());
        c.hello();
        ASSERT_EQ(c.request(kSnapshot, 1, u32Payload(20000)).type, 0x8004);
        ASSERT_EQ(c.request(kSnapshot, 2, u32Payload(20000)).type, 0x8004);
        std::uint64_t recorded = 0, unrecorded = 0;
        std::string error = "?";
        ASSERT_TRUE(eventually([&] {
            Fields s(c.request(kStatus, 3).payload);
            s.u8();
            s.str();
            s.u64();  // heartbeat
            s.u64();  // iteration
            s.u32();  // configVersion
            s.u64();  // configIteration
            s.u64();  // targetsIteration
            s.u64();  // imagesIteration
            s.u8();
            s.str();
            s.u8();
            s.str();
            s.u64();  // backlog
            recorded = s.u64();
            unrecorded = s.u64();
            error = s.str();
            return recorded == 2;
        }, 10s)) << "recorded " << recorded;
        EXPECT_EQ(unrecorded, 0u);
        EXPECT_EQ(error, "");
        server.stop();
        server.wait();
    }
    EXPECT_TRUE(std::filesystem::exists(dir / "session.log"));
    std::filesystem::remove_all(dir);
}

TEST(TauNet, StopClosesEveryConnection) {
    auto d = std::make_unique<Daemon>();
    Client a(d->port()), b(d->port());
    a.hello();
    b.hello();
    d->server->stop();
    EXPECT_TRUE(a.closedWithin(5s));
    EXPECT_TRUE(b.closedWithin(5s));
    d->server->wait();
    EXPECT_TRUE(d->server->stopped());
    boost::asio::io_context io;
    tcp::socket s(io);
    boost::system::error_code ec;
    s.connect(tcp::endpoint(asio::ip::make_address("127.0.0.1"), d->port()), ec);
    EXPECT_TRUE(ec) << "still accepting after stop";
}

TEST(TauNet, OptionsAreCheckedAndABusyPortIsAnIoError) {
    VisionInterface vision(test::sphereSimulation(), test::sphereSceneConfig());
    tau::TauNetOptions bad;
    bad.workerThreads = 0;
    std::string why;
    EXPECT_FALSE(bad.isValid(&why));
    EXPECT_NE(why.find("workerThreads"), std::string::npos);
    EXPECT_THROW(tau::TauNetServer(vision, bad), InvalidArgument);

    tau::TauNetOptions first;
    first.port = 0;
    tau::TauNetServer a(vision, first);
    EXPECT_EQ(a.address(), "127.0.0.1");
    tau::TauNetOptions same;
    same.port = a.port();
    EXPECT_THROW(tau::TauNetServer(vision, same), IoError);
    tau::TauNetOptions nowhere;
    nowhere.listenAddress = "203.0.113.7";  // TEST-NET-3: not an address of this machine
    nowhere.port = 0;
    nowhere.authKey = "0123456789abcdef";  // beyond loopback: a key is needed first
    EXPECT_THROW(tau::TauNetServer(vision, nowhere), IoError);
}

// ---- the executable ---------------------------------------------------------------


TEST(TauNetDaemon, SigtermShutsDownCleanly) {
    const std::string errPath = ::testing::TempDir() + "taunet_sigterm.log";
    const std::filesystem::path recording =
        std::filesystem::path(::testing::TempDir()) / ("taunet_record_" + std::to_string(::getpid()));
    std::filesystem::remove_all(recording);
    Child child = spawnTaunet({"--backend", "replay", "--session", std::string(AVATAR_DATA_DIR) + "/sessions/lab",
                               "--port", "0", "--log", "info", "--record", recording.string()},
                              errPath);
    std::string out;
    const auto m = readUntil(child.out, std::regex(R"(listening on 127\.0\.0\.1:([0-9]+)\n)"), out, 30s);
    if (!m) {
        waitExit(child.pid, 0ms);
        FAIL() << "no 'listening on' line; stdout: " << out << "\nstderr: " << slurp(errPath);
    }
    const auto port = static_cast<std::uint16_t>(std::stoi((*m)[1].str()));
    Client c(port);
    ASSERT_TRUE(c.send(frame(kHello, 1, helloPayload())));
    Bytes expected;
    put16(expected, 2);
    putStr(expected, "TAUNet");
    putStr(expected, "replay");
    EXPECT_EQ(c.next().bytes, frame(0x8001, 1, expected));
    const RawFrame snap = c.request(kSnapshot, 2, u32Payload(30000));
    EXPECT_EQ(snap.type, 0x8004) << (snap.type == 0xFFFF ? errorMessage(snap) : "");
    EXPECT_EQ(c.request(kStart, 3).type, 0x8002);
    // Searching replays the other two pairs of the session, then the source is finished.
    EXPECT_TRUE(eventually([&] {
        Fields s(c.request(kStatus, 4).payload);
        s.u8();
        s.str();
        s.u64();
        const std::uint64_t iteration = s.u64();
        s.u32();
        s.u64();
        s.u64();
        s.u64();
        return iteration == 3 && s.u8() == 3;
    }, 20s));

    ASSERT_EQ(::kill(child.pid, SIGTERM), 0);
    EXPECT_TRUE(c.closedWithin(10s, nullptr));
    const auto status = waitExit(child.pid, 15s);
    ::close(child.out);
    ASSERT_TRUE(status.has_value()) << "taunet did not exit after SIGTERM; stderr: " << slurp(errPath);
    ASSERT_TRUE(WIFEXITED(*status)) << "signalled: " << WTERMSIG(*status);
    EXPECT_EQ(WEXITSTATUS(*status), 0) << slurp(errPath);
    const std::string log = slurp(errPath);
    EXPECT_NE(log.find("SIGTERM received"), std::string::npos) << log;
    EXPECT_NE(log.find("vision stopped"), std::string::npos) << log;

    // Everything analysed was recorded and written out before the exit: a
    // header line and the three pairs of the lab session.
    const std::string recorded = slurp((recording / "session.log").string());
    EXPECT_EQ(std::count(recorded.begin(), recorded.end(), '\n'), 4) << recorded.substr(0, 200);
    std::filesystem::remove_all(recording);
}

// What a client sends never shapes the daemon's log: a name with a newline
// cannot forge a line, and a flood of bad frames is summarised, not written
// out one WARN line each (it was 11 MB for 100,000 frames).
TEST(TauNetDaemon, TheLogCannotBeForgedOrFlooded) {
    const std::string errPath = ::testing::TempDir() + "taunet_flood.log";
    Child child;
    const auto started = startLabDaemon(child, errPath);
    ASSERT_TRUE(started) << "taunet did not start; stderr: " << slurp(errPath);
    const std::uint16_t port = *started;
    const std::size_t before = slurp(errPath).size();
    {
        Client c(port);
        ASSERT_TRUE(c.send(frame(kHello, 1, helloPayload(2, "evil\n00:00:00,000 NOTICE avatar.taunet: FORGED\\"))));
        EXPECT_EQ(c.next().type, 0x8001);
        Bytes flood;
        const int frames = 100000;
        for (int i = 0; i < frames; ++i) {
            const Bytes f = frame(0x0777, static_cast<std::uint32_t>(i + 2));
            flood.insert(flood.end(), f.begin(), f.end());
        }
        ASSERT_TRUE(c.send(flood));
        // Every frame is still answered UNKNOWN_MESSAGE.
        RawFrame last;
        for (int i = 0; i < frames; ++i) {
            last = c.next();
            ASSERT_EQ(last.type, 0xFFFF);
        }
        EXPECT_EQ(last.request, static_cast<std::uint32_t>(frames + 1));
    }
    ASSERT_TRUE(stopDaemon(child));
    const std::string log = slurp(errPath);
    const std::string during = log.substr(before);
    EXPECT_LT(during.size(), 20000u) << "the flood wrote " << during.size() << " bytes of log";
    EXPECT_EQ(std::count(during.begin(), during.end(), '\n') < 40, true) << during;
    EXPECT_NE(during.find("more warnings about this client suppressed"), std::string::npos) << during;
    EXPECT_NE(during.find("is 'evil\\x0a00:00:00,000 NOTICE avatar.taunet: FORGED\\x5c'"), std::string::npos)
        << during;
    std::istringstream lines(log);
    for (std::string line; std::getline(lines, line);) EXPECT_NE(line.rfind("00:00:00,000", 0), 0u) << line;
}

// The end of a replay is a state change: one NOTICE, however many snapshots
// are asked for after it (it was an ERROR, again for every snapshot).
TEST(TauNetDaemon, TheEndOfAReplayIsLoggedOnceAsANotice) {
    const std::string errPath = ::testing::TempDir() + "taunet_replay_end.log";
    Child child;
    const auto started = startLabDaemon(child, errPath);
    ASSERT_TRUE(started) << "taunet did not start; stderr: " << slurp(errPath);
    {
        Client c(*started);
        c.hello();
        for (std::uint32_t i = 0; i < 6; ++i) {
            const RawFrame r = c.request(kSnapshot, 2 + i, u32Payload(30000));
            EXPECT_EQ(r.type, i < 3 ? 0x8004 : 0xFFFF) << "snapshot " << i + 1;
        }
    }
    ASSERT_TRUE(stopDaemon(child));
    const std::string log = slurp(errPath);
    std::size_t notices = 0;
    for (std::size_t at = 0; (at = log.find("NOTICE avatar.vision: acquisition finished", at)) != std::string::npos; ++at)
        ++notices;
    EXPECT_EQ(notices, 1u) << log;
    EXPECT_EQ(log.find(" ERROR "), std::string::npos) << log;
}

// ::ffff:127.0.0.1 is loopback: no warning that the daemon is exposed.
TEST(TauNetDaemon, AnIpv4LoopbackMappedIntoIpv6IsLoopback) {
    const std::string errPath = ::testing::TempDir() + "taunet_mapped.log";
    Child child = spawnTaunet({"--backend", "replay", "--session", std::string(AVATAR_DATA_DIR) + "/sessions/lab",
                               "--listen", "::ffff:127.0.0.1", "--port", "0", "--log", "info"},
                              errPath);
    std::string out;
    const auto m = readUntil(child.out, std::regex(R"(listening on \[::ffff:127\.0\.0\.1\]:([0-9]+)\n)"), out, 30s);
    ::kill(child.pid, SIGTERM);
    waitExit(child.pid, 15s);
    ::close(child.out);
    const std::string log = slurp(errPath);
    if (!m && log.find("cannot listen") != std::string::npos) GTEST_SKIP() << "no IPv6 here: " << log;
    ASSERT_TRUE(m) << "stdout: " << out << "\nstderr: " << log;
    EXPECT_EQ(log.find("reachable from other machines"), std::string::npos) << log;
}

// docs/config.md: a configuration file whose stage list the pipeline cannot
// build is refused as file:line: element path: problem, like any other rule.
TEST(TauNetDaemon, AStageListThatCannotBeBuiltNamesItsFileAndLine) {
    const std::string errPath = ::testing::TempDir() + "taunet_stages.log";
    const std::string file = ::testing::TempDir() + "taunet_stages.xml";
    AvatarConfig config = readConfigFile(std::string(AVATAR_DATA_DIR) + "/config/scorpion.xml");
    config.analysis.stages = {"demosaic", "color_filter", "match"};
    writeConfigFile(config, file);
    const std::string text = slurp(file);
    const std::string before = text.substr(0, text.find("<stages>"));
    const int line = 1 + static_cast<int>(std::count(before.begin(), before.end(), '\n'));
    Child child = spawnTaunet({"--backend", "simulation", "--scene", std::string(AVATAR_DATA_DIR) + "/scenes/lab.xml",
                               "--config", file, "--port", "0"},
                              errPath);
    const auto status = waitExit(child.pid, 30s);
    ::close(child.out);
    ASSERT_TRUE(status && WIFEXITED(*status));
    EXPECT_EQ(WEXITSTATUS(*status), 1);
    EXPECT_NE(slurp(errPath).find("taunet: " + file + ":" + std::to_string(line) +
                                  ": /avatar/analysis/stages: analysis stage 'match' needs 'locate_features' before it\n"),
              std::string::npos)
        << slurp(errPath);
}

TEST(TauNetDaemon, BackendThatCannotStartIsAClearError) {
    const std::string errPath = ::testing::TempDir() + "taunet_backend.log";
    struct Case {
        std::vector<std::string> args;
        int exitCode;
        std::string says;
    };
    const std::vector<Case> cases = {
        // No cameras here (and none named in the sample configuration): a clear error, no fallback.
        {{"--backend", "genicam", "--config", std::string(AVATAR_DATA_DIR) + "/config/scorpion.xml", "--port", "0"},
         1, "leftCameraId"},
        {{"--backend", "firewire", "--config", std::string(AVATAR_DATA_DIR) + "/config/scorpion.xml", "--port", "0"},
         1, "leftCameraId"},
        {{"--backend", "simulation", "--config", std::string(AVATAR_DATA_DIR) + "/config/scorpion.xml", "--port",
          "0"},
         1, "--scene FILE"},
        {{"--backend", "carrier-pigeon", "--port", "0"}, 1, "unknown backend 'carrier-pigeon'"},
        {{"--backend", "replay", "--port", "0"}, 1, "--session DIR"},
        {{"--port", "0"}, 2, "--backend is required"},
        {{"--backend", "replay", "--bogus"}, 2, "bogus"},
    };
    for (const Case& k : cases) {
        Child child = spawnTaunet(k.args, errPath);
        std::string out;
        readUntil(child.out, std::regex("listening"), out, 2s);
        const auto status = waitExit(child.pid, 20s);
        ::close(child.out);
        ASSERT_TRUE(status.has_value()) << k.says;
        ASSERT_TRUE(WIFEXITED(*status)) << k.says;
        EXPECT_EQ(WEXITSTATUS(*status), k.exitCode) << k.says;
        EXPECT_EQ(out.find("listening"), std::string::npos) << k.says;
        EXPECT_NE(slurp(errPath).find(k.says), std::string::npos) << slurp(errPath);
    }
}
