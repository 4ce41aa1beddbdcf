#pragma once
// The interactive terminal of tautui: raw single-key input and ANSI redraws.
// Plain termios and escape codes; no curses.

#include <chrono>
#include <optional>
#include <string>
#include <vector>

#include <termios.h>

namespace avatar::tui {

/// Puts the terminal on standard input into raw mode (no line buffering, no
/// echo; Ctrl-C still signals) and the alternate screen, and restores both on
/// destruction.
class RawTerminal {
public:
    RawTerminal();
    ~RawTerminal();
    RawTerminal(const RawTerminal&) = delete;
    RawTerminal& operator=(const RawTerminal&) = delete;

    /// Waits at most @p timeout for a key; nullopt when none came (or a signal
    /// interrupted the wait).
    std::optional<char> readKey(std::chrono::milliseconds timeout);
    /// Clears the screen and writes @p lines from the top.
    void draw(const std::vector<std::string>& lines);
    /// Shows @p prompt on a new line, reads one line with echo and editing, and
    /// returns to raw mode. nullopt at end of input.
    std::optional<std::string> prompt(const std::string& text);

private:
    void raw();
    void cooked();
    termios saved_{};
};

}  // namespace avatar::tui
