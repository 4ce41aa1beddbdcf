// Who may command the vision system (docs/protocol.md, "Authentication" and
// "Unix-domain socket"): the version-3 challenge-response byte for byte
// against a real TauNetServer, TAUUnit's side of it (including a server that
// cannot prove the key), the Unix-domain socket and its permissions (checked
// with a real unprivileged process when the tests run as root), and the taunet
// executable's refusals.

#include "TempDir.h"
#include "WireSupport.h"

#include <avatar/tau/Authentication.h>
#include <avatar/tau/TauUnit.h>

#include <boost/asio/local/stream_protocol.hpp>
#include <boost/asio/read.hpp>

#include <gtest/gtest.h>

#include <cerrno>
#include <sys/socket.h>
#include <sys/stat.h>
#include <sys/un.h>

using namespace avatar;
using namespace avatar::test::wire;

namespace {

const std::string kKey = "0123456789abcdef0123456789abcdef";
constexpr std::uint16_t kAuthenticate = 0x000A;

tau::TauNetOptions keyed() {
    tau::TauNetOptions o;
    o.authKey = kKey;
    return o;
}

/// The fields of a version-3 HELLO_REPLY.
struct Hello3 {
    std::uint16_t version{0};
    std::string serverName, backend;
    std::uint8_t required{0};
    Bytes challenge;
};

Hello3 parseHello3(const RawFrame& f) {
    Fields r(f.payload);
    Hello3 h;
    h.version = r.u16();
    h.serverName = r.str();
    h.backend = r.str();
    h.required = r.u8();
    const std::string c = r.str();
    h.challenge.assign(c.begin(), c.end());
    if (!r.done()) throw std::runtime_error("HELLO_REPLY has bytes after the challenge");
    return h;
}

Bytes authenticatePayload(const Bytes& nonce, const Bytes& mac) {
    Bytes p;
    for (const Bytes* field : {&nonce, &mac}) {
        put32(p, static_cast<std::uint32_t>(field->size()));
        for (const std::uint8_t b : *field) p.push_back(b);
    }
    return p;
}

Bytes nonceOf(std::uint8_t seed) { return Bytes(32, seed); }

tau::TauUnitOptions unitOptions(std::uint16_t port, const std::string& key = {}) {
    tau::TauUnitOptions o;
    o.port = port;
    o.authKey = key;
    return o;
}

std::string authFailure(tau::TauUnit& unit) {
    try {
        unit.status();
    } catch (const tau::AuthenticationError& e) {
        return e.what();
    }
    return "(no AuthenticationError)";
}

/// Connects to the Unix-domain socket @p path; 0 or the errno.
int connectUnix(const std::string& path) {
    const int fd = ::socket(AF_UNIX, SOCK_STREAM | SOCK_CLOEXEC, 0);
    if (fd < 0) return errno;
    sockaddr_un a{};
    a.sun_family = AF_UNIX;
    std::memcpy(a.sun_path, path.data(), path.size());
    const int rc = ::connect(fd, reinterpret_cast<const sockaddr*>(&a), sizeof a);
    const int err = rc == 0 ? 0 : errno;
    ::close(fd);
    return err;
}

/// connectUnix(@p path) from a child process running as nobody (uid/gid 65534).
int connectUnixAsNobody(const std::string& path) {
    const pid_t pid = ::fork();
    if (pid == 0) {
        if (::setgid(65534) != 0 || ::setuid(65534) != 0) ::_exit(250);
        ::_exit(connectUnix(path) & 0xFF);
    }
    int status = 0;
    ::waitpid(pid, &status, 0);
    return WIFEXITED(status) ? WEXITSTATUS(status) : 251;
}

mode_t permissions(const std::filesystem::path& p) {
    struct stat st {};
    if (::lstat(p.c_str(), &st) != 0) return 07777;
    return st.st_mode & 0777;
}

}  // namespace

// ---- the handshake on the wire ----------------------------------------------

TEST(TauNetAuth, VersionsWithoutAuthenticationAreRefusedClearly) {
    Daemon d(keyed());
    for (const std::uint16_t version : {1, 2}) {
        Client c(d.port());
        ASSERT_TRUE(c.send(frame(kHello, 5, helloPayload(version))));
        EXPECT_EQ(c.next().bytes,
                  errorFrame(5, 4,
                             "protocol version " + std::to_string(version) +
                                 " has no authentication, which this server requires on TCP connections; speak "
                                 "version 3 and AUTHENTICATE"));
        EXPECT_TRUE(c.closedWithin(5s));
    }
}

TEST(TauNetAuth, HelloReplyCarriesAFreshChallengeEachTime) {
    Daemon d(keyed());
    Client c(d.port());
    const RawFrame first = c.request(kHello, 1, helloPayload(3));
    ASSERT_EQ(first.type, 0x8001);
    const Hello3 a = parseHello3(first);
    EXPECT_EQ(a.version, 3);
    EXPECT_EQ(a.serverName, "TAUNet");
    EXPECT_EQ(a.backend, "simulation");
    EXPECT_EQ(a.required, 1);
    ASSERT_EQ(a.challenge.size(), 32u);
    const Hello3 b = parseHello3(c.request(kHello, 2, helloPayload(3)));
    EXPECT_NE(a.challenge, b.challenge);
}

TEST(TauNetAuth, NothingButAuthenticateBeforeTheProof) {
    Daemon d(keyed());
    Client c(d.port());
    c.request(kHello, 1, helloPayload(3));
    EXPECT_EQ(c.request(kStatus, 2).bytes,
              errorFrame(2, 13, "STATUS before AUTHENTICATE: this connection must prove the key first"));
    EXPECT_TRUE(c.closedWithin(5s));
}

TEST(TauNetAuth, AWrongProofIsRefusedAndCloses) {
    Daemon d(keyed());
    Client c(d.port());
    const Hello3 h = parseHello3(c.request(kHello, 1, helloPayload(3)));
    const Bytes nonce = nonceOf(7);
    const Bytes wrong = tau::clientProof("not the key of this server", h.challenge, nonce);
    EXPECT_EQ(c.request(kAuthenticate, 2, authenticatePayload(nonce, wrong)).bytes,
              errorFrame(2, 14, "the proof does not match this server's key"));
    EXPECT_TRUE(c.closedWithin(5s));
    EXPECT_EQ(d.server->stats().authFailures, 1u);
}

TEST(TauNetAuth, TheRightProofOpensTheSessionAndTheServerProvesTheKeyInReturn) {
    Daemon d(keyed());
    Client c(d.port());
    const Hello3 h = parseHello3(c.request(kHello, 1, helloPayload(3)));
    const Bytes nonce = nonceOf(9);
    const RawFrame r = c.request(kAuthenticate, 2, authenticatePayload(nonce, tau::clientProof(kKey, h.challenge, nonce)));
    Bytes expected;
    const Bytes serverMac = tau::serverProof(kKey, h.challenge, nonce);
    put32(expected, 32);
    for (const std::uint8_t b : serverMac) expected.push_back(b);
    EXPECT_EQ(r.bytes, frame(0x800A, 2, expected));
    EXPECT_EQ(c.request(kStatus, 3).type, 0x8009);
    // A challenge is used once.
    EXPECT_EQ(c.request(kAuthenticate, 4, authenticatePayload(nonce, tau::clientProof(kKey, h.challenge, nonce))).bytes,
              errorFrame(4, 11, "no challenge outstanding: send HELLO first (each challenge is used once)"));
    // A re-HELLO on an authenticated session keeps it open and asks nothing more.
    const Hello3 again = parseHello3(c.request(kHello, 5, helloPayload(3)));
    EXPECT_EQ(again.required, 0);
    EXPECT_EQ(c.request(kStatus, 6).type, 0x8009);
    // The proof of the earlier challenge does not fit the new one (no replay).
    EXPECT_EQ(c.request(kAuthenticate, 7, authenticatePayload(nonce, tau::clientProof(kKey, h.challenge, nonce))).bytes,
              errorFrame(7, 14, "the proof does not match this server's key"));
    EXPECT_TRUE(c.closedWithin(5s));
}

TEST(TauNetAuth, AnUnprovenSessionTimesOutLikeAMissingHello) {
    tau::TauNetOptions o = keyed();
    o.helloTimeout = 300ms;
    Daemon d(o);
    Client c(d.port());
    c.request(kHello, 1, helloPayload(3));
    EXPECT_TRUE(c.closedWithin(5s));
    EXPECT_EQ(d.server->stats().helloTimeouts, 1u);
}

TEST(TauNetAuth, AServerWithoutAKeyAsksNoProofAndRefusesOne) {
    Daemon d;
    Client c(d.port());
    const Hello3 h = parseHello3(c.request(kHello, 1, helloPayload(3)));
    EXPECT_EQ(h.required, 0);
    EXPECT_TRUE(h.challenge.empty());
    EXPECT_EQ(c.request(kAuthenticate, 2, authenticatePayload(nonceOf(1), Bytes(32, 0))).bytes,
              errorFrame(2, 11, "this server has no authentication key"));
    EXPECT_EQ(c.request(kStatus, 3).type, 0x8009);
    // Version 2 does not know the message.
    Client old(d.port());
    old.hello();
    EXPECT_EQ(errorCode(old.request(kAuthenticate, 2, authenticatePayload(nonceOf(1), Bytes(32, 0)))), 5);
}

TEST(TauNetAuth, ListeningBeyondLoopbackNeedsAKey) {
    auto vision = std::make_unique<VisionInterface>(test::sphereSimulation(), test::sphereSceneConfig());
    tau::TauNetOptions open;
    open.listenAddress = "0.0.0.0";
    open.port = 0;
    try {
        tau::TauNetServer server(*vision, open);
        ADD_FAILURE() << "listening on 0.0.0.0 without a key was allowed";
    } catch (const InvalidArgument& e) {
        EXPECT_STREQ(e.what(), "listening on 0.0.0.0:0 reaches other machines, which needs an authentication key "
                               "(TauNetOptions::authKey, taunet --auth-key FILE)");
    }
    tau::TauNetOptions withKey = keyed();
    withKey.listenAddress = "0.0.0.0";
    withKey.port = 0;
    tau::TauNetServer server(*vision, withKey);
    tau::TauUnit unit(unitOptions(server.port(), kKey));
    EXPECT_EQ(unit.connect().version, 3);
    EXPECT_EQ(unit.status().backend, "simulation");
    tau::TauNetOptions shortKey;
    shortKey.authKey = "0123456789";
    EXPECT_THROW(tau::TauNetServer(*vision, shortKey), InvalidArgument);
}

// ---- TAUUnit's side ----------------------------------------------------------------

TEST(TauUnitAuth, TheRightKeyConnectsAndEveryMismatchIsAnAuthenticationError) {
    Daemon d(keyed());
    {
        tau::TauUnit unit(unitOptions(d.port(), kKey));
        EXPECT_EQ(unit.status().backend, "simulation");
        EXPECT_EQ(unit.timings().front().request, "HELLO");
        EXPECT_EQ(unit.timings().front().outcome, tau::Outcome::Ok);
    }
    const std::string at = "TAUNet 127.0.0.1:" + std::to_string(d.port()) + ": HELLO: authentication: ";
    {
        tau::TauUnit unit(unitOptions(d.port()));
        EXPECT_EQ(authFailure(unit),
                  at + "the server requires it and no key is set (TauUnitOptions::authKey) (before STATUS)");
        EXPECT_FALSE(unit.connected());
        EXPECT_EQ(unit.timings().front().outcome, tau::Outcome::AuthenticationFailed);
    }
    {
        tau::TauUnitOptions o = unitOptions(d.port(), "another key of 32 bytes, wrong!!");
        o.retry.attempts = 3;  // never retried: it cannot help
        tau::TauUnit unit(o);
        EXPECT_EQ(authFailure(unit), at + "the server refused the key: the proof does not match this server's key "
                                          "(before STATUS)");
        std::size_t hellos = 0;
        for (const auto& t : unit.timings()) hellos += t.request == "HELLO";
        EXPECT_EQ(hellos, 1u);
    }
    EXPECT_TRUE(eventually([&] { return d.server->stats().authFailures == 1; }, 5s));
    Daemon plain;
    tau::TauUnit unit(unitOptions(plain.port(), kKey));
    EXPECT_EQ(authFailure(unit), "TAUNet 127.0.0.1:" + std::to_string(plain.port()) +
                                     ": HELLO: authentication: the server has no key, so it cannot prove it is the "
                                     "daemon the key belongs to (before STATUS)");
}

// A listener that speaks version 3 but does not know the key: it hands out a
// challenge and answers AUTHENTICATE with a made-up proof. TAUUnit must not
// take it for the daemon.
TEST(TauUnitAuth, AServerThatCannotProveTheKeyIsRefused) {
    asio::io_context io;
    tcp::acceptor acceptor(io, tcp::endpoint(asio::ip::make_address("127.0.0.1"), 0));
    const std::uint16_t port = acceptor.local_endpoint().port();
    std::thread impostor([&] {
        tcp::socket s(io);
        acceptor.accept(s);
        auto readFrame = [&](std::uint16_t& type, std::uint32_t& id) {
            std::array<std::uint8_t, 12> h{};
            asio::read(s, asio::buffer(h));
            Fields f(Bytes(h.begin(), h.end()));
            const std::uint32_t length = f.u32();
            type = f.u16();
            f.u16();
            id = f.u32();
            Bytes payload(length);
            asio::read(s, asio::buffer(payload));
        };
        std::uint16_t type = 0;
        std::uint32_t id = 0;
        readFrame(type, id);
        Bytes reply;
        put16(reply, 3);
        putStr(reply, "impostor");
        putStr(reply, "replay");
        reply.push_back(1);
        putStr(reply, std::string(32, 'c'));
        asio::write(s, asio::buffer(frame(0x8001, id, reply)));
        readFrame(type, id);
        Bytes mac;
        putStr(mac, std::string(32, 'm'));
        asio::write(s, asio::buffer(frame(0x800A, id, mac)));
        boost::system::error_code ec;
        std::array<std::uint8_t, 64> sink{};
        s.read_some(asio::buffer(sink), ec);  // until TAUUnit closes
    });
    tau::TauUnit unit(unitOptions(port, kKey));
    try {
        unit.connect();
        ADD_FAILURE() << "TAUUnit accepted a server that does not know the key";
    } catch (const tau::AuthenticationError& e) {
        EXPECT_EQ(std::string(e.what()), "TAUNet 127.0.0.1:" + std::to_string(port) +
                                             ": HELLO: authentication: the server's proof does not match the key: it "
                                             "is not the daemon the key belongs to");
    }
    EXPECT_FALSE(unit.connected());
    impostor.join();
}

// ---- the Unix-domain socket -----------------------------------------------------------

TEST(TauNetUnix, TheSocketFileDecidesWhoConnectsAndAsksNoProof) {
    test::TempDir dir("taunet-unix");
    ASSERT_EQ(::chmod(dir.path().c_str(), 0755), 0);
    const std::string path = (dir / "taunet.sock").string();
    tau::TauNetOptions o = keyed();
    o.listenAddress.clear();  // no TCP at all
    o.unixSocketPath = path;
    {
        Daemon d(o);
        EXPECT_EQ(d.server->port(), 0);
        EXPECT_EQ(d.server->address(), "");
        EXPECT_EQ(d.server->unixSocketPath(), path);
        EXPECT_EQ(permissions(path), 0600u);
        tau::TauUnitOptions u;
        u.unixSocket = path;
        tau::TauUnit unit(u);
        EXPECT_EQ(unit.endpoint(), "unix:" + path);
        EXPECT_EQ(unit.connect().version, 3);
        EXPECT_EQ(unit.status().backend, "simulation");
        // A client with the key may still have the server prove it.
        u.authKey = kKey;
        tau::TauUnit proving(u);
        EXPECT_EQ(proving.status().backend, "simulation");
        if (::geteuid() == 0) {
            EXPECT_EQ(connectUnixAsNobody(path), EACCES);
        }
    }
    EXPECT_FALSE(std::filesystem::exists(path)) << "the socket file outlived the server";
    if (::geteuid() == 0) {
        o.unixSocketMode = 0666;
        Daemon d(o);
        EXPECT_EQ(permissions(path), 0666u);
        EXPECT_EQ(connectUnixAsNobody(path), 0);
    }
}

// Found in the hour's soak: a daemon stopped after its socket file had been
// removed and a new daemon had made its own at the same path (with the inode
// number the removed one freed) took the new daemon's socket file with it.
TEST(TauNetUnix, AStoppingServerLeavesAnotherServersSocketAlone) {
    test::TempDir dir("taunet-unix");
    const std::string path = (dir / "taunet.sock").string();
    tau::TauNetOptions o;
    o.listenAddress.clear();
    o.unixSocketPath = path;
    auto first = std::make_unique<Daemon>(o);
    struct stat before {};
    ASSERT_EQ(::lstat(path.c_str(), &before), 0);
    ASSERT_EQ(::unlink(path.c_str()), 0);  // an operator clears the way for a new daemon
    Daemon second(o);
    struct stat after {};
    ASSERT_EQ(::lstat(path.c_str(), &after), 0);
    first.reset();  // the old daemon stops only now
    ASSERT_TRUE(std::filesystem::is_socket(path)) << "the old daemon removed the new one's socket (inode "
                                                  << before.st_ino << ", then " << after.st_ino << ")";
    tau::TauUnitOptions u;
    u.unixSocket = path;
    tau::TauUnit unit(u);
    EXPECT_EQ(unit.status().backend, "simulation");
}

TEST(TauNetUnix, AStaleSocketIsReplacedAndAnythingElseInTheWayIsAnError) {
    test::TempDir dir("taunet-unix");
    const std::string path = (dir / "taunet.sock").string();
    {
        // A socket file left behind by a server that died.
        asio::io_context io;
        asio::local::stream_protocol::acceptor stale(io, asio::local::stream_protocol::endpoint(path));
    }
    ASSERT_TRUE(std::filesystem::is_socket(path));
    tau::TauNetOptions o;
    o.listenAddress.clear();
    o.unixSocketPath = path;
    Daemon d(o);
    tau::TauUnitOptions u;
    u.unixSocket = path;
    tau::TauUnit unit(u);
    EXPECT_EQ(unit.status().backend, "simulation");
    auto vision = std::make_unique<VisionInterface>(test::sphereSimulation(), test::sphereSceneConfig());
    try {
        tau::TauNetServer second(*vision, o);
        ADD_FAILURE() << "two servers on one socket";
    } catch (const IoError& e) {
        EXPECT_EQ(std::string(e.what()), "cannot listen on unix:" + path + ": another server is listening on it");
    }
    tau::TauNetOptions onFile = o;
    onFile.unixSocketPath = (dir / "notes.txt").string();
    std::ofstream(onFile.unixSocketPath) << "keep me\n";
    try {
        tau::TauNetServer third(*vision, onFile);
        ADD_FAILURE() << "a regular file was taken for a socket";
    } catch (const IoError& e) {
        EXPECT_EQ(std::string(e.what()),
                  "cannot listen on unix:" + onFile.unixSocketPath + ": a file that is not a socket is in the way");
    }
    EXPECT_EQ(slurp(onFile.unixSocketPath), "keep me\n");
    tau::TauNetOptions nothing;
    nothing.listenAddress.clear();
    EXPECT_THROW(tau::TauNetServer(*vision, nothing), InvalidArgument);
    tau::TauUnitOptions missing;
    missing.unixSocket = (dir / "none.sock").string();
    tau::TauUnit lost(missing);
    try {
        lost.status();
        ADD_FAILURE() << "connected to a socket that does not exist";
    } catch (const tau::ConnectionError& e) {
        EXPECT_EQ(e.endpoint(), "unix:" + missing.unixSocket);
        EXPECT_NE(std::string(e.what()).find("No such file or directory"), std::string::npos) << e.what();
    }
}

// ---- the executable ---------------------------------------------------------------------

TEST(TauNetDaemonAuth, RefusesAnOpenAddressWithoutAKeyAndAKeyOthersCanRead) {
    test::TempDir dir("taunet-auth");
    const std::string err = (dir / "err.log").string();
    const std::string lab = std::string(AVATAR_DATA_DIR) + "/sessions/lab";
    Child open = spawnTaunet({"--backend", "replay", "--session", lab, "--listen", "0.0.0.0", "--port", "0"}, err);
    const auto status = waitExit(open.pid, 30s);
    ::close(open.out);
    ASSERT_TRUE(status);
    EXPECT_EQ(WEXITSTATUS(*status), 1);
    // The last line (the backend's start is logged before).
    const std::string refusal = "taunet: listening on 0.0.0.0:0 reaches other machines, which needs an "
                                "authentication key (TauNetOptions::authKey, taunet --auth-key FILE)\n";
    const std::string log = slurp(err);
    ASSERT_GE(log.size(), refusal.size()) << log;
    EXPECT_EQ(log.substr(log.size() - refusal.size()), refusal);
    const std::string key = (dir / "key").string();
    std::ofstream(key) << kKey << "\n";
    ::chmod(key.c_str(), 0640);
    Child readable = spawnTaunet({"--backend", "replay", "--session", lab, "--port", "0", "--auth-key", key}, err);
    const auto status2 = waitExit(readable.pid, 30s);
    ::close(readable.out);
    ASSERT_TRUE(status2);
    EXPECT_EQ(WEXITSTATUS(*status2), 1);
    EXPECT_EQ(slurp(err), "taunet: authentication key file " + key +
                              " may be read or written by group or others (mode 0640); make it readable by the "
                              "service only: chmod 600 " + key + "\n");
}

TEST(TauNetDaemonAuth, ServesAuthenticatedTcpAndAUnixSocketAtOnce) {
    test::TempDir dir("taunet-auth");
    const std::string err = (dir / "err.log").string();
    const std::string key = (dir / "key").string();
    const std::string sock = (dir / "taunet.sock").string();
    std::ofstream(key) << kKey << "\n";
    ::chmod(key.c_str(), 0600);
    Child child = spawnTaunet({"--backend", "replay", "--session", std::string(AVATAR_DATA_DIR) + "/sessions/lab",
                               "--listen", "0.0.0.0", "--port", "0", "--auth-key", key, "--unix-socket", sock,
                               "--unix-socket-mode", "660", "--log", "info"},
                              err);
    std::string out;
    const auto m = readUntil(child.out, std::regex(R"(listening on 0\.0\.0\.0:([0-9]+)\nlistening on unix:(.*)\n)"),
                             out, 30s);
    ASSERT_TRUE(m) << out << slurp(err);
    EXPECT_EQ((*m)[2].str(), sock);
    EXPECT_EQ(permissions(sock), 0660u);
    const auto port = static_cast<std::uint16_t>(std::stoi((*m)[1].str()));
    tau::TauUnit remote(unitOptions(port, tau::readAuthKeyFile(key)));
    const VisionTargets t = remote.takeSnapshot();
    EXPECT_EQ(t.targets.size(), 2u);
    tau::TauUnit stranger(unitOptions(port));
    EXPECT_THROW(stranger.status(), tau::AuthenticationError);
    tau::TauUnitOptions u;
    u.unixSocket = sock;
    tau::TauUnit local(u);
    EXPECT_EQ(local.status().iteration, 1u);
    EXPECT_TRUE(stopDaemon(child));
    EXPECT_FALSE(std::filesystem::exists(sock));
    const std::string log = slurp(err);
    EXPECT_NE(log.find("clients must authenticate"), std::string::npos) << log;
    EXPECT_NE(log.find("listening on unix:" + sock + " (mode 0660"), std::string::npos) << log;
    EXPECT_NE(log.find("authenticated"), std::string::npos) << log;
    EXPECT_NE(log.find("(unix, uid "), std::string::npos) << log;
}
