#include "Terminal.h"

#include <avatar/common/Error.h>

#include <cerrno>
#include <cstring>
#include <iostream>

#include <poll.h>
#include <unistd.h>

namespace avatar::tui {

namespace {
void writeAll(const std::string& s) {
    std::size_t done = 0;
    while (done < s.size()) {
        const ssize_t n = ::write(STDOUT_FILENO, s.data() + done, s.size() - done);
        if (n < 0) {
            if (errno == EINTR) continue;
            return;  // the terminal went away; nothing sensible to do
        }
        done += static_cast<std::size_t>(n);
    }
}
}  // namespace

RawTerminal::RawTerminal() {
    if (::tcgetattr(STDIN_FILENO, &saved_) != 0)
        throw IoError(std::string("standard input is not a terminal: ") + std::strerror(errno));
    raw();
    writeAll("\033[?1049h\033[?25l");  // alternate screen, hide the cursor
}

RawTerminal::~RawTerminal() {
    cooked();
    writeAll("\033[?25h\033[?1049l");
}

void RawTerminal::raw() {
    termios t = saved_;
    t.c_lflag &= static_cast<tcflag_t>(~(ICANON | ECHO));
    t.c_cc[VMIN] = 1;
    t.c_cc[VTIME] = 0;
    ::tcsetattr(STDIN_FILENO, TCSANOW, &t);
}

void RawTerminal::cooked() { ::tcsetattr(STDIN_FILENO, TCSANOW, &saved_); }

std::optional<char> RawTerminal::readKey(std::chrono::milliseconds timeout) {
    pollfd p{STDIN_FILENO, POLLIN, 0};
    const int n = ::poll(&p, 1, static_cast<int>(timeout.count()));
    if (n <= 0) return std::nullopt;
    char c = 0;
    if (::read(STDIN_FILENO, &c, 1) != 1) return std::nullopt;
    return c;
}

void RawTerminal::draw(const std::vector<std::string>& lines) {
    std::string out = "\033[H\033[2J";
    for (const std::string& l : lines) out += l + "\r\n";
    writeAll(out);
}

std::optional<std::string> RawTerminal::prompt(const std::string& text) {
    cooked();
    writeAll("\033[?25h" + text);
    std::string line;
    const bool got = static_cast<bool>(std::getline(std::cin, line));
    writeAll("\033[?25l");
    raw();
    if (!got) {
        std::cin.clear();
        return std::nullopt;
    }
    return line;
}

}  // namespace avatar::tui
