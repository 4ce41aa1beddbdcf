#include "ToolDisplay.h"

#include <cstring>

#include <sys/socket.h>
#include <sys/un.h>
#include <unistd.h>

namespace avatar::tools {

std::optional<std::string> unreachableLocalDisplay(const std::string& display) {
    if (display.empty() || display.front() != ':') return std::nullopt;
    const std::string socketPath = "/tmp/.X11-unix/X" + display.substr(1, display.find('.') - 1);
    const int fd = ::socket(AF_UNIX, SOCK_STREAM, 0);
    if (fd < 0) return std::nullopt;
    sockaddr_un address{};
    address.sun_family = AF_UNIX;
    std::strncpy(address.sun_path, socketPath.c_str(), sizeof address.sun_path - 1);
    const bool reached = ::connect(fd, reinterpret_cast<const sockaddr*>(&address), sizeof address) == 0;
    ::close(fd);
    if (reached) return std::nullopt;
    return socketPath;
}

}  // namespace avatar::tools
