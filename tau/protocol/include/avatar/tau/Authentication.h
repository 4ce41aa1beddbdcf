#pragma once
/// @file Authentication.h
/// The shared-secret challenge-response of protocol version 3
/// (docs/protocol.md, "Authentication"): HMAC-SHA256 (OpenSSL) over a
/// server challenge and a client nonce, proved in both directions, so a
/// client knows the key too and a fake daemon cannot feed an arm targets.
///
/// Error policy: readAuthKeyFile throws avatar::IoError (the file cannot be
/// read) or avatar::InvalidArgument (it is readable by others, or too short);
/// randomBytes throws avatar::Error when the system has no randomness.

#include <cstddef>
#include <cstdint>
#include <filesystem>
#include <string>
#include <vector>

namespace avatar::tau {

inline constexpr std::size_t kChallengeSize = 32;  ///< bytes of the server's challenge and the client's nonce
inline constexpr std::size_t kMacSize = 32;        ///< bytes of an HMAC-SHA256
inline constexpr std::size_t kMinAuthKeySize = 16; ///< a shorter secret is refused

/// The secret in @p path: the file's bytes without trailing whitespace
/// (`openssl rand -hex 32 > key` makes a good one). The file must be a
/// regular file that neither group nor others may read or write (chmod 600),
/// since whoever reads it can command the vision system, and hold at least
/// kMinAuthKeySize bytes. Every message names the file.
std::string readAuthKeyFile(const std::filesystem::path& path);

/// @p n bytes from OpenSSL's CSPRNG.
std::vector<std::uint8_t> randomBytes(std::size_t n);

/// The client's proof: HMAC-SHA256(key, "TAU3 client" || challenge || nonce).
std::vector<std::uint8_t> clientProof(const std::string& key, const std::vector<std::uint8_t>& challenge,
                                      const std::vector<std::uint8_t>& nonce);
/// The server's proof: HMAC-SHA256(key, "TAU3 server" || challenge || nonce).
/// The labels differ, so neither side's proof can be replayed as the other's.
std::vector<std::uint8_t> serverProof(const std::string& key, const std::vector<std::uint8_t>& challenge,
                                      const std::vector<std::uint8_t>& nonce);

/// Compares two MACs in time independent of where they differ (CRYPTO_memcmp).
bool macsEqual(const std::vector<std::uint8_t>& a, const std::vector<std::uint8_t>& b);

}  // namespace avatar::tau
