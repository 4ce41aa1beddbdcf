#include <avatar/tau/Authentication.h>

#include <avatar/common/Error.h>

#include <openssl/crypto.h>
#include <openssl/evp.h>
#include <openssl/hmac.h>
#include <openssl/rand.h>

#include <cerrno>
#include <cstdio>
#include <cstring>
#include <fstream>
#include <iterator>
#include <sstream>

#include <sys/stat.h>

namespace avatar::tau {

namespace {

std::vector<std::uint8_t> proof(const char* label, const std::string& key, const std::vector<std::uint8_t>& challenge,
                                const std::vector<std::uint8_t>& nonce) {
    std::vector<std::uint8_t> message(label, label + std::strlen(label));
    message.insert(message.end(), challenge.begin(), challenge.end());
    message.insert(message.end(), nonce.begin(), nonce.end());
    std::vector<std::uint8_t> mac(EVP_MAX_MD_SIZE);
    unsigned int size = 0;
    if (!HMAC(EVP_sha256(), key.data(), static_cast<int>(key.size()), message.data(), message.size(), mac.data(),
              &size) ||
        size != kMacSize)
        throw Error("HMAC-SHA256 failed (OpenSSL)");
    mac.resize(size);
    return mac;
}

std::string octal(unsigned mode) {
    char text[8];
    std::snprintf(text, sizeof text, "%04o", mode & 07777u);
    return text;
}

}  // namespace

std::string readAuthKeyFile(const std::filesystem::path& path) {
    const std::string name = path.string();
    struct stat st {};
    if (::stat(name.c_str(), &st) != 0)
        throw IoError("authentication key file " + name + ": " + std::strerror(errno));
    if (!S_ISREG(st.st_mode)) throw InvalidArgument("authentication key file " + name + " is not a regular file");
    if (st.st_mode & (S_IRWXG | S_IRWXO))
        throw InvalidArgument("authentication key file " + name + " may be read or written by group or others (mode " +
                              octal(st.st_mode) + "); make it readable by the service only: chmod 600 " + name);
    std::ifstream in(path, std::ios::binary);
    if (!in) throw IoError("authentication key file " + name + ": cannot be opened: " + std::strerror(errno));
    std::ostringstream content;
    content << in.rdbuf();
    if (in.bad()) throw IoError("authentication key file " + name + ": read failed");
    std::string key = content.str();
    while (!key.empty() && (key.back() == '\n' || key.back() == '\r' || key.back() == ' ' || key.back() == '\t'))
        key.pop_back();
    if (key.size() < kMinAuthKeySize)
        throw InvalidArgument("authentication key file " + name + " holds " + std::to_string(key.size()) +
                              " bytes; at least " + std::to_string(kMinAuthKeySize) +
                              " are needed (openssl rand -hex 32 makes one)");
    return key;
}

std::vector<std::uint8_t> randomBytes(std::size_t n) {
    std::vector<std::uint8_t> out(n);
    if (n > 0 && RAND_bytes(out.data(), static_cast<int>(n)) != 1)
        throw Error("no random bytes from OpenSSL (RAND_bytes failed)");
    return out;
}

std::vector<std::uint8_t> clientProof(const std::string& key, const std::vector<std::uint8_t>& challenge,
                                      const std::vector<std::uint8_t>& nonce) {
    return proof("TAU3 client", key, challenge, nonce);
}

std::vector<std::uint8_t> serverProof(const std::string& key, const std::vector<std::uint8_t>& challenge,
                                      const std::vector<std::uint8_t>& nonce) {
    return proof("TAU3 server", key, challenge, nonce);
}

bool macsEqual(const std::vector<std::uint8_t>& a, const std::vector<std::uint8_t>& b) {
    return a.size() == b.size() && CRYPTO_memcmp(a.data(), b.data(), a.size()) == 0;
}

}  // namespace avatar::tau
