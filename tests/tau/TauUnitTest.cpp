// TAUUnit against the real taunet (replay backend on the bundled lab session,
// an ephemeral loopback port), and its behaviour without a server: options,
// refused connections, servers that never answer, the retry policy.

#include "TauUnitTestProcess.h"

#include <avatar/tau/TauUnit.h>

#include <gtest/gtest.h>

#include <cmath>

#include <memory>
#include <set>
#include <string>

#include <netinet/in.h>
#include <sys/socket.h>

using namespace avatar;
using namespace avatar::tau;
using avatar::tau::testing::TauNetProcess;
using Clock = std::chrono::steady_clock;
using namespace std::chrono_literals;

namespace {

/// A loopback TCP socket bound to an ephemeral port; listening or not.
class LoopbackSocket {
public:
    explicit LoopbackSocket(bool listening) {
        fd_ = ::socket(AF_INET, SOCK_STREAM | SOCK_CLOEXEC, 0);
        sockaddr_in a{};
        a.sin_family = AF_INET;
        a.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
        a.sin_port = 0;
        if (fd_ < 0 || ::bind(fd_, reinterpret_cast<sockaddr*>(&a), sizeof a) != 0)
            throw std::runtime_error("cannot bind a loopback socket");
        if (listening && ::listen(fd_, 4) != 0) throw std::runtime_error("cannot listen");
        socklen_t len = sizeof a;
        ::getsockname(fd_, reinterpret_cast<sockaddr*>(&a), &len);
        port_ = ntohs(a.sin_port);
    }
    ~LoopbackSocket() { ::close(fd_); }
    std::uint16_t port() const { return port_; }

private:
    int fd_{-1};
    std::uint16_t port_{0};
};

TauUnitOptions optionsFor(std::uint16_t port) {
    TauUnitOptions o;
    o.port = port;
    o.clientName = "tauunit-test";
    o.connectTimeout = 2s;
    o.requestTimeout = 20s;
    o.snapshotTimeout = 20s;
    return o;
}

template <class E, class F>
E expectThrow(F&& f) {
    try {
        f();
    } catch (const E& e) {
        return e;
    }
    ADD_FAILURE() << "expected an exception";
    throw std::logic_error("no exception");
}

long long msSince(Clock::time_point t0) {
    return std::chrono::duration_cast<std::chrono::milliseconds>(Clock::now() - t0).count();
}

}  // namespace

// ---- without a server -------------------------------------------------------

TEST(TauUnitOptionsTest, ValidationNamesTheProblem) {
    TauUnitOptions o = optionsFor(7010);
    std::string why;
    EXPECT_TRUE(o.isValid(&why)) << why;
    o.port = 0;
    EXPECT_FALSE(o.isValid(&why));
    EXPECT_EQ(why, "port is 0");
    EXPECT_THROW(TauUnit{o}, InvalidArgument);
    o = optionsFor(7010);
    o.requestTimeout = 0ms;
    EXPECT_FALSE(o.isValid(&why));
    EXPECT_NE(why.find("requestTimeout"), std::string::npos);
    o = optionsFor(7010);
    o.retry.attempts = -1;
    EXPECT_FALSE(o.isValid(&why));
    EXPECT_NE(why.find("retry.attempts"), std::string::npos);
}

TEST(TauUnitOfflineTest, NothingRetrievedIsNeverFresh) {
    TauUnit unit(optionsFor(7010));
    EXPECT_FALSE(unit.connected());
    EXPECT_EQ(unit.endpoint(), "127.0.0.1:7010");
    const TauIterations& it = unit.iterations();
    EXPECT_EQ(it.vision, 0u);
    EXPECT_EQ(it.targets, 0u);
    EXPECT_EQ(it.config, 0u);
    EXPECT_EQ(it.leftImage, 0u);
    EXPECT_EQ(it.rightImage, 0u);
    EXPECT_FALSE(unit.isTargetDataFresh());
    EXPECT_FALSE(unit.isConfigFresh());
    EXPECT_FALSE(unit.isImageFresh(Side::Left));
    EXPECT_FALSE(unit.lastTargets().has_value());
    EXPECT_TRUE(unit.timings().empty());
}

TEST(TauUnitOfflineTest, BadImageArgumentsAreRejectedWithoutIo) {
    TauUnit unit(optionsFor(7010));
    EXPECT_THROW(unit.getImages(ImageKindCode::Marked, 0), InvalidArgument);
    EXPECT_THROW(unit.getImages(ImageKindCode::Marked, 4), InvalidArgument);
    EXPECT_THROW(unit.getImages(ImageKindCode::Marked, kLeftImage, 0), InvalidArgument);
    EXPECT_THROW(unit.getImages(ImageKindCode::Marked, kLeftImage, 101), InvalidArgument);
    EXPECT_THROW(unit.takeSnapshot(0ms), InvalidArgument);
    EXPECT_TRUE(unit.timings().empty());
}

TEST(TauUnitOfflineTest, RefusedConnectionNamesEndpointAndRequest) {
    LoopbackSocket closed(false);  // bound, not listening: connections are refused
    TauUnit unit(optionsFor(closed.port()));
    const std::string endpoint = "127.0.0.1:" + std::to_string(closed.port());
    const auto e = expectThrow<ConnectionError>([&] { unit.connect(); });
    EXPECT_EQ(e.endpoint(), endpoint);
    EXPECT_EQ(e.request(), "HELLO");
    EXPECT_NE(std::string(e.what()).find(endpoint), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("refused"), std::string::npos) << e.what();
    bool timedOut = false;
    try {
        unit.connect();
    } catch (const TimeoutError&) {
        timedOut = true;
    } catch (const ConnectionError&) {
    }
    EXPECT_FALSE(timedOut) << "a refused connection is not a timeout";

    const auto s = expectThrow<ConnectionError>([&] { unit.status(); });
    EXPECT_EQ(s.request(), "STATUS");
    EXPECT_NE(std::string(s.what()).find("STATUS"), std::string::npos) << s.what();
    EXPECT_FALSE(unit.connected());

    // The action log: HELLO failed twice, then STATUS's own HELLO and STATUS failed.
    ASSERT_EQ(unit.timings().size(), 4u);
    EXPECT_EQ(unit.timings()[0].request, "HELLO");
    EXPECT_EQ(unit.timings()[0].outcome, Outcome::ConnectionFailed);
    EXPECT_EQ(unit.timings()[3].request, "STATUS");
    EXPECT_EQ(unit.timings()[3].outcome, Outcome::ConnectionFailed);
    EXPECT_NE(unit.timings()[3].detail.find("refused"), std::string::npos);
}

TEST(TauUnitOfflineTest, RetryPolicyTriesAgainThenFails) {
    LoopbackSocket closed(false);
    TauUnitOptions o = optionsFor(closed.port());
    o.retry.attempts = 2;
    o.retry.delay = 100ms;
    TauUnit unit(o);
    const auto t0 = Clock::now();
    EXPECT_THROW(unit.getTargetData(), ConnectionError);
    const auto elapsed = msSince(t0);
    EXPECT_GE(elapsed, 200);
    EXPECT_LT(elapsed, 2000);
    int hellos = 0;
    for (const ActionTiming& t : unit.timings()) hellos += t.request == "HELLO";
    EXPECT_EQ(hellos, 3);
    EXPECT_EQ(unit.timings().back().request, "GET_TARGET_DATA");
}

TEST(TauUnitOfflineTest, SilentServerTimesOutWithinTheLimit) {
    LoopbackSocket silent(true);  // listens (the kernel completes the handshake) but never answers
    TauUnitOptions o = optionsFor(silent.port());
    o.connectTimeout = 300ms;
    TauUnit unit(o);
    auto t0 = Clock::now();
    const auto e = expectThrow<TimeoutError>([&] { unit.connect(); });
    auto elapsed = msSince(t0);
    EXPECT_GE(elapsed, 290);
    EXPECT_LT(elapsed, 1300);
    EXPECT_EQ(e.request(), "HELLO");
    EXPECT_NE(std::string(e.what()).find("127.0.0.1:" + std::to_string(silent.port())), std::string::npos);
    EXPECT_FALSE(unit.connected());  // a connection without HELLO is dropped
    EXPECT_EQ(unit.timings().back().outcome, Outcome::Timeout);

    // A request on the unconnected client: the same limit, and it names the request.
    t0 = Clock::now();
    const auto s = expectThrow<TimeoutError>([&] { unit.takeSnapshot(); });
    elapsed = msSince(t0);
    EXPECT_LT(elapsed, 1300);
    EXPECT_EQ(s.request(), "TAKE_SNAPSHOT");
}

TEST(TauUnitOfflineTest, TimingLogKeepsItsCapacity) {
    LoopbackSocket closed(false);
    TauUnitOptions o = optionsFor(closed.port());
    o.timingCapacity = 4;
    TauUnit unit(o);
    for (int i = 0; i < 5; ++i) EXPECT_THROW(unit.status(), ConnectionError);
    EXPECT_EQ(unit.timings().size(), 4u);
    unit.clearTimings();
    EXPECT_TRUE(unit.timings().empty());
}

// ---- against the real taunet -------------------------------------------------

class TauUnitServerTest : public ::testing::Test {
protected:
    void SetUp() override { server_ = std::make_unique<TauNetProcess>(); }
    TauUnitOptions options() const { return optionsFor(server_->port()); }
    std::unique_ptr<TauNetProcess> server_;
};

TEST_F(TauUnitServerTest, HelloAndStatusBeforeAnyIteration) {
    TauUnit unit(options());
    const HelloReply hello = unit.connect();
    EXPECT_EQ(hello.version, kProtocolVersion);
    EXPECT_EQ(hello.backend, "replay");
    EXPECT_FALSE(hello.serverName.empty());
    EXPECT_TRUE(unit.connected());
    ASSERT_TRUE(unit.server().has_value());

    const StatusReply s = unit.status();
    EXPECT_EQ(s.state, 0);  // idle
    EXPECT_EQ(s.iteration, 0u);
    EXPECT_EQ(s.backend, "replay");
    EXPECT_GE(s.configVersion, 1u);

    // No data of any kind yet: NOT_AVAILABLE, and the connection stays usable.
    const auto t = expectThrow<TauError>([&] { unit.getTargetData(); });
    EXPECT_EQ(t.code(), ErrorCode::NotAvailable);
    EXPECT_NE(std::string(t.what()).find("GET_TARGET_DATA"), std::string::npos) << t.what();
    const auto i = expectThrow<TauError>([&] { unit.getImages(ImageKindCode::Original); });
    EXPECT_EQ(i.code(), ErrorCode::NotAvailable);
    EXPECT_TRUE(unit.connected());
    EXPECT_EQ(unit.timings().back().outcome, Outcome::ServerError);
    EXPECT_NE(unit.timings().back().detail.find("NOT_AVAILABLE"), std::string::npos);
    EXPECT_NO_THROW(unit.status());
}

TEST_F(TauUnitServerTest, EveryRequest) {
    TauUnit unit(options());
    // Snapshot: the first pair of the lab session, with its two targets.
    const VisionTargets snap = unit.takeSnapshot();
    EXPECT_EQ(snap.iteration, 1u);
    EXPECT_EQ(snap.acquisition.group, 1u);
    EXPECT_EQ(snap.acquisition.member, 0u);
    ASSERT_EQ(snap.ofType("sample").size(), 1u);
    ASSERT_EQ(snap.ofType("arm_marker").size(), 1u);
    const VisionTarget sample = snap.ofType("sample").front();
    ASSERT_TRUE(sample.positionVisionMm.has_value());
    ASSERT_TRUE(sample.centroidLeftPx.has_value());
    // Recorded result of the pair (session.log): (62.0, 83.5, 753.0) mm, whole,
    // with its covariance and ray residual (protocol version 2).
    EXPECT_NEAR(sample.positionVisionMm->x, 62.0, 2.0);
    EXPECT_NEAR(sample.positionVisionMm->y, 83.5, 2.0);
    EXPECT_NEAR(sample.positionVisionMm->z, 753.0, 10.0);
    EXPECT_TRUE(sample.flags & kTargetWhole) << targetFlagsText(sample.flags);
    ASSERT_TRUE(sample.covarianceVisionMm2.has_value());
    EXPECT_GT((*sample.covarianceVisionMm2)(2, 2), 0.0);
    ASSERT_TRUE(sample.covarianceBaseMm2.has_value());
    EXPECT_GT(sample.rayResidualPx, 0.0);
    EXPECT_FALSE(snap.timings.empty());

    // Target data: the same result.
    EXPECT_EQ(unit.getTargetData(), snap);
    ASSERT_TRUE(unit.lastTargets().has_value());
    EXPECT_EQ(*unit.lastTargets(), snap);

    // Images of every kind, both sides and one side, decoded.
    for (const ImageKindCode kind : {ImageKindCode::Original, ImageKindCode::Filtered, ImageKindCode::Marked}) {
        const TauImages images = unit.getImages(kind);
        EXPECT_EQ(images.iteration, 1u);
        EXPECT_EQ(images.kind, kind);
        ASSERT_EQ(images.images.size(), 2u);
        EXPECT_EQ(images.images[0].side, Side::Left);
        EXPECT_EQ(images.images[1].side, Side::Right);
        for (const TauImage& image : images.images) {
            EXPECT_EQ(image.image.cols, 1280);
            EXPECT_EQ(image.image.rows, 960);
            EXPECT_EQ(image.image.depth(), CV_8U);
            EXPECT_GT(image.jpeg.size(), 1000u);
            EXPECT_EQ(image.jpeg[0], 0xFF);  // JPEG SOI
            EXPECT_EQ(image.jpeg[1], 0xD8);
        }
    }
    const TauImages right = unit.getImages(ImageKindCode::Marked, kRightImage, 50);
    ASSERT_EQ(right.images.size(), 1u);
    EXPECT_EQ(right.side(Side::Left), nullptr);
    ASSERT_NE(right.side(Side::Right), nullptr);
    EXPECT_EQ(right.images[0].image.channels(), 3);

    // Configuration: get, send the same document back, get again.
    const ConfigReply before = unit.getConfig();
    EXPECT_NE(before.xml.find("<avatar"), std::string::npos);
    const ConfigApplied applied = unit.sendConfig(before.xml);
    EXPECT_EQ(applied.configVersion, before.configVersion + 1);
    EXPECT_GT(applied.configIteration, 1u);
    const ConfigReply after = unit.getConfig();
    EXPECT_EQ(after.configVersion, applied.configVersion);
    EXPECT_EQ(after.configIteration, applied.configIteration);

    // Searching: iterations advance; stopping returns to idle. Both are idempotent.
    unit.startSearching();
    unit.startSearching();
    // The lab session has three pairs: searching ends when they are replayed.
    StatusReply s = unit.status();
    const auto deadline = Clock::now() + 20s;
    while (s.iteration < 2 && Clock::now() < deadline) {
        std::this_thread::sleep_for(20ms);
        s = unit.status();
    }
    EXPECT_GE(s.iteration, 2u);
    unit.stopSearching();
    unit.stopSearching();
    s = unit.status();
    const auto idleBy = Clock::now() + 10s;
    while (s.state == 1 && Clock::now() < idleBy) {
        std::this_thread::sleep_for(20ms);
        s = unit.status();
    }
    EXPECT_NE(s.state, 1);

    // Every request is in the action log, successful.
    std::set<std::string> names;
    for (const ActionTiming& t : unit.timings()) {
        if (t.outcome == Outcome::Ok) names.insert(t.request);
        EXPECT_GE(t.duration.count(), 0);
    }
    for (const char* n : {"HELLO", "TAKE_SNAPSHOT", "GET_TARGET_DATA", "GET_IMAGES", "GET_CONFIG", "SEND_CONFIG",
                          "START_SEARCHING", "STOP_SEARCHING", "STATUS"})
        EXPECT_EQ(names.count(n), 1u) << n;
}

TEST_F(TauUnitServerTest, TargetDataIsStaleUntilRetrievedAgain) {
    TauUnit unit(options());
    TauUnit other(options());  // another client moves the vision system on

    unit.takeSnapshot();
    unit.status();
    EXPECT_EQ(unit.iterations().vision, 1u);
    EXPECT_EQ(unit.iterations().targets, 1u);
    EXPECT_TRUE(unit.isTargetDataFresh());

    unit.getImages(ImageKindCode::Original, kLeftImage);
    EXPECT_EQ(unit.iterations().leftImage, 1u);
    EXPECT_EQ(unit.iterations().rightImage, 0u);
    EXPECT_TRUE(unit.isImageFresh(Side::Left));
    EXPECT_FALSE(unit.isImageFresh(Side::Right));

    other.takeSnapshot();       // iteration 2
    EXPECT_TRUE(unit.isTargetDataFresh());  // the client does not know yet
    unit.status();
    EXPECT_EQ(unit.iterations().vision, 2u);
    EXPECT_FALSE(unit.isTargetDataFresh());
    EXPECT_FALSE(unit.isImageFresh(Side::Left));

    const VisionTargets again = unit.getTargetData();
    EXPECT_EQ(again.iteration, 2u);
    EXPECT_EQ(unit.iterations().targets, 2u);
    EXPECT_TRUE(unit.isTargetDataFresh());
    unit.getImages(ImageKindCode::Marked);
    EXPECT_TRUE(unit.isImageFresh(Side::Left));
    EXPECT_TRUE(unit.isImageFresh(Side::Right));
}

TEST_F(TauUnitServerTest, ConfigIterationAfterSendConfig) {
    TauUnit unit(options());
    TauUnit other(options());
    unit.takeSnapshot();
    const ConfigReply current = unit.getConfig();
    EXPECT_TRUE(unit.isConfigFresh());
    EXPECT_EQ(unit.iterations().configVersion, current.configVersion);

    // A new configuration applies from a later iteration: the data in hand was
    // computed with the old one.
    const ConfigApplied applied = unit.sendConfig(current.xml);
    EXPECT_EQ(unit.iterations().configVersion, applied.configVersion);
    EXPECT_EQ(unit.iterations().config, applied.configIteration);
    EXPECT_GT(applied.configIteration, unit.iterations().targets);
    EXPECT_TRUE(unit.isConfigFresh());
    EXPECT_FALSE(unit.isTargetDataFresh());
    const VisionTargets next = unit.takeSnapshot();
    EXPECT_GE(next.iteration, applied.configIteration);
    unit.status();
    EXPECT_TRUE(unit.isTargetDataFresh());

    // Another client changes the configuration: ours is stale once we know it.
    other.sendConfig(current.xml);
    unit.status();
    EXPECT_FALSE(unit.isConfigFresh());
    unit.getConfig();
    EXPECT_TRUE(unit.isConfigFresh());
}

TEST_F(TauUnitServerTest, RejectedConfigKeepsTheOldOne) {
    TauUnit unit(options());
    const ConfigReply before = unit.getConfig();
    std::string broken = before.xml;
    const auto at = broken.find("<width>1280</width>");
    ASSERT_NE(at, std::string::npos);
    broken.replace(at, std::string("<width>1280</width>").size(), "<width>banana</width>");

    const auto e = expectThrow<ConfigRejectedError>([&] { unit.sendConfig(broken); });
    EXPECT_EQ(e.code(), ErrorCode::ConfigRejected);
    EXPECT_NE(e.serverMessage().find("width"), std::string::npos) << e.serverMessage();
    EXPECT_NE(std::string(e.what()).find("CONFIG_REJECTED"), std::string::npos) << e.what();
    EXPECT_EQ(unit.timings().back().outcome, Outcome::ServerError);
    EXPECT_THROW(unit.sendConfig("not xml at all"), ConfigRejectedError);

    EXPECT_TRUE(unit.connected());
    const ConfigReply after = unit.getConfig();
    EXPECT_EQ(after.configVersion, before.configVersion);
    EXPECT_EQ(after.configIteration, before.configIteration);
    EXPECT_EQ(after.xml, before.xml);
}

// Values a hostile or careless client could send that once corrupted every
// position ((nan, -inf, nan) flagged valid), and XML that tinyxml2 alone lets
// through: each is refused by the daemon and the old configuration stays.
TEST_F(TauUnitServerTest, ExtremeValuesAndTrickyXmlAreRejected) {
    TauUnit unit(options());
    const ConfigReply before = unit.getConfig();
    const auto edited = [&](const std::string& from, const std::string& to) {
        std::string xml = before.xml;
        const auto at = xml.find(from);
        EXPECT_NE(at, std::string::npos) << from;
        if (at != std::string::npos) xml.replace(at, from.size(), to);
        return xml;
    };
    const auto translation = before.xml.find("<translationMm>");
    ASSERT_NE(translation, std::string::npos);
    const std::string firstTranslation =
        before.xml.substr(translation, before.xml.find("</translationMm>", translation) + 16 - translation);
    const std::vector<std::pair<std::string, std::string>> bad = {
        {edited(firstTranslation, "<translationMm>1e308 1e308 1e308</translationMm>"), "baseline"},
        {edited(firstTranslation, "<translationMm>1e-320 0 0</translationMm>"), "baseline"},
        {edited("<fc>1049.13 1050.38</fc>", "<fc>1e300 1050.38</fc>"), "/fc"},
        {edited("<fc>1049.13 1050.38</fc>", "<fc>1e-300 1050.38</fc>"), "/fc"},
        {edited("<om>0.002 0.003 0.047</om>", "<om>1e200 0 0</om>"), "/om"},
        {before.xml + std::string(1, '\0') + "junk", "NUL byte"},
        {edited("<width>1280</width>", "<width>&w;</width>"), "undeclared entity '&w;'"},
    };
    for (const auto& [xml, expected] : bad) {
        SCOPED_TRACE(expected);
        const auto e = expectThrow<ConfigRejectedError>([&] { unit.sendConfig(xml); });
        EXPECT_NE(e.serverMessage().find(expected), std::string::npos) << e.serverMessage();
    }
    const ConfigReply after = unit.getConfig();
    EXPECT_EQ(after.configVersion, before.configVersion);
    EXPECT_EQ(after.xml, before.xml);
    // And the targets are still finite.
    for (const VisionTarget& t : unit.takeSnapshot().targets) {
        if (!t.positionBaseMm) continue;
        EXPECT_TRUE(std::isfinite(t.positionBaseMm->x) && std::isfinite(t.positionBaseMm->y) &&
                    std::isfinite(t.positionBaseMm->z));
    }
}

TEST_F(TauUnitServerTest, ReconnectAfterTheServerRestarts) {
    TauUnit unit(options());
    unit.takeSnapshot();
    const std::uint16_t port = server_->port();
    server_.reset();  // stop taunet
    server_ = std::make_unique<TauNetProcess>(port);  // again, on the same port
    ASSERT_EQ(server_->port(), port);

    // The old connection is gone: the request fails, naming the request.
    const auto e = expectThrow<ConnectionError>([&] { unit.status(); });
    EXPECT_EQ(e.request(), "STATUS");
    EXPECT_EQ(e.endpoint(), "127.0.0.1:" + std::to_string(port));
    EXPECT_FALSE(unit.connected());

    // An explicit reconnect, and the new server's state.
    const HelloReply hello = unit.reconnect();
    EXPECT_EQ(hello.backend, "replay");
    EXPECT_EQ(unit.status().iteration, 0u);
    EXPECT_EQ(unit.iterations().vision, 0u);

    // With a retry policy the next restart is invisible to the caller.
    TauUnitOptions o = options();
    o.retry.attempts = 3;
    o.retry.delay = 100ms;
    TauUnit patient(o);
    patient.status();
    server_.reset();
    server_ = std::make_unique<TauNetProcess>(port);
    const StatusReply s = patient.status();
    EXPECT_EQ(s.iteration, 0u);
    int hellos = 0;
    for (const ActionTiming& t : patient.timings()) hellos += t.request == "HELLO" && t.outcome == Outcome::Ok;
    EXPECT_EQ(hellos, 2);
}
