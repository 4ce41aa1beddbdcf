#pragma once
/// @file TauNetServer.h
/// TAUNet (thesis 4.3.2): the TAU protocol (docs/protocol.md) served over TCP
/// and/or a Unix-domain socket, a thin adapter over one VisionInterface. Sockets, threads and the protocol
/// stay in here; the vision layer knows nothing of them.
///
/// Threads: one or more network threads (Boost.Asio; every connection's
/// handlers run on its own strand), a small worker pool for the requests that
/// block (TAKE_SNAPSHOT, SEND_CONFIG, GET_IMAGES with its JPEG encoding), and
/// the VisionInterface's own thread, which the server never waits on from a
/// network thread. A slow or stuck client therefore slows neither the vision
/// loop nor any other client.
///
/// Per connection, requests are handled one after the other in arrival order
/// (a blocking request holds back that connection's later requests, never
/// another connection's). Limits per connection: requests of at most
/// kMaxRequestPayload bytes; at most maxSendQueueBytes of replies waiting for
/// a client that does not read (beyond that it is disconnected); a frame not
/// completed within idleTimeout of its first byte, a HELLO not received
/// within helloTimeout and a session without a request for
/// sessionIdleTimeout close the connection; at maxConnections the silent or
/// idlest connection makes room for a new one.
///
/// Access: with an authentication key every TCP connection must prove it
/// (protocol version 3's AUTHENTICATE) before any other request; listening
/// beyond loopback without a key is refused. On the Unix-domain socket the
/// file's permissions decide who may connect, and no proof is asked.
///
/// Error policy: construction throws avatar::InvalidArgument (bad options, or
/// an address beyond loopback without a key) or avatar::IoError (the address
/// cannot be bound). Once running, nothing a
/// client does throws: protocol errors are answered on the wire as
/// docs/protocol.md says and logged (log4cpp category "avatar.taunet").

#include <chrono>
#include <cstddef>
#include <cstdint>
#include <memory>
#include <string>

namespace avatar {
class VisionInterface;
}

namespace avatar::tau {

/// How the server listens and its limits. Defaults suit the vision computer.
struct TauNetOptions {
    /// TCP address to listen on. The default accepts local clients only;
    /// listening on another interface must be asked for explicitly ("0.0.0.0",
    /// "::", an address) and needs authKey. Empty: no TCP (unixSocketPath then
    /// must be set).
    std::string listenAddress{"127.0.0.1"};
    /// TCP port; 0 picks a free one (see TauNetServer::port()).
    std::uint16_t port{7010};
    /// Sent in HELLO_REPLY.
    std::string serverName{"TAUNet"};
    /// The shared secret (readAuthKeyFile(), at least kMinAuthKeySize bytes)
    /// every TCP client must prove it knows; empty: no authentication, which
    /// is allowed on loopback addresses only.
    std::string authKey;
    /// A Unix-domain socket to listen on as well (empty: none). A stale socket
    /// file is replaced; any other file in the way, or a live server on it, is
    /// an error. The file is removed when the server stops.
    std::string unixSocketPath;
    /// Permissions of the socket file, set before the server listens on it:
    /// they decide who may connect (write permission is needed). Default: the
    /// service's user only.
    unsigned unixSocketMode{0600};
    /// Network threads (>= 1).
    std::size_t networkThreads{1};
    /// Threads for blocking requests (>= 1). More concurrent blocking requests
    /// than workers wait their turn; they never hold up a network thread.
    std::size_t workerThreads{4};
    /// Replies waiting for one client, in bytes; a client that lets more pile
    /// up (it does not read) is disconnected. One reply is always accepted into
    /// an empty queue, so a single image reply larger than this still goes out.
    std::size_t maxSendQueueBytes{std::size_t{256} << 20};
    /// Replies waiting for all clients together, in bytes. When a reply would
    /// exceed it, the client with the most waiting is disconnected (a client
    /// whose queue is empty still gets its one reply).
    std::size_t maxTotalSendQueueBytes{std::size_t{512} << 20};
    /// Simultaneous connections; further ones are accepted and closed at once.
    std::size_t maxConnections{256};
    /// A frame must be complete this long after its first byte, or the
    /// connection is closed (a client trickling bytes gains nothing).
    std::chrono::milliseconds idleTimeout{std::chrono::seconds(30)};
    /// A connection that has not completed HELLO this long after it opened is closed.
    std::chrono::milliseconds helloTimeout{std::chrono::seconds(10)};
    /// A session with no request for this long is closed (0: never). A TAUUnit
    /// client's next request fails and the one after connects again (or its
    /// RetryPolicy reconnects at once).
    std::chrono::milliseconds sessionIdleTimeout{std::chrono::hours(1)};
    /// When maxConnections are open, a new connection evicts the one that has
    /// not said HELLO, or else the one idle longest (at least evictAfter
    /// without a request and none in progress); only when none qualifies is
    /// the new one refused. So silent connections cannot lock clients out.
    std::chrono::milliseconds evictAfter{std::chrono::seconds(2)};
    /// After a closing ERROR, how long the server keeps reading (and discarding)
    /// so the client receives the ERROR before the close.
    std::chrono::milliseconds lingerTimeout{std::chrono::seconds(2)};

    /// True when every option is usable; otherwise false and @p error (if not
    /// null) says which option is wrong and why.
    bool isValid(std::string* error = nullptr) const;
};

/// Counters for monitoring and tests.
struct TauNetStats {
    std::size_t connections{0};         ///< open now
    std::uint64_t accepted{0};          ///< since start
    std::uint64_t rejected{0};          ///< closed at once: maxConnections reached
    std::uint64_t requests{0};          ///< frames received and answered or being answered
    std::uint64_t protocolErrors{0};    ///< MALFORMED_FRAME .. BAD_PAYLOAD answered
    std::uint64_t slowClients{0};       ///< disconnected: send queue over the limit
    std::uint64_t idleTimeouts{0};      ///< disconnected: partial frame not completed in time
    std::uint64_t helloTimeouts{0};     ///< disconnected: no HELLO in time
    std::uint64_t sessionTimeouts{0};   ///< disconnected: no request for sessionIdleTimeout
    std::uint64_t evicted{0};           ///< disconnected to make room at maxConnections
    std::uint64_t authFailures{0};      ///< AUTHENTICATE with a wrong proof (each closed)
};

class TauNetServer {
public:
    /// Binds and listens, then starts the network and worker threads. Borrows
    /// @p vision, which must outlive the server. Throws avatar::InvalidArgument
    /// for invalid options and avatar::IoError when the address cannot be bound.
    TauNetServer(VisionInterface& vision, TauNetOptions options);
    /// stop() and wait().
    ~TauNetServer();
    TauNetServer(const TauNetServer&) = delete;
    TauNetServer& operator=(const TauNetServer&) = delete;

    /// The TCP address and port actually listened on (port() is the chosen one
    /// when the options asked for 0); "" and 0 without TCP.
    std::string address() const;
    std::uint16_t port() const;
    /// The Unix-domain socket listened on, or "" without one.
    std::string unixSocketPath() const;

    /// Stops accepting and closes every connection (replies in progress are
    /// dropped). Does not touch the VisionInterface; its owner stops it.
    /// Thread-safe, idempotent, returns at once (also from a server thread).
    void stop();
    /// Blocks until stop() was called and every thread has finished. Blocking
    /// requests still running (a snapshot waits at most its timeout) are let
    /// finish first. Must not be called from a server thread.
    void wait();
    bool stopped() const;

    TauNetStats stats() const;

private:
    class Impl;
    std::unique_ptr<Impl> impl_;
};

}  // namespace avatar::tau
