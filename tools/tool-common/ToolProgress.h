#pragma once
/// @file ToolProgress.h
/// The progress bar of the command-line tools: redrawn in place on standard
/// error when it is a terminal, nothing otherwise (then the lines a tool
/// prints are its progress), so redirected output holds no bar.

#include <cstddef>
#include <functional>
#include <string>

namespace avatar::tools {

/// "[#########.....................] 3/10 pairs: note", on a terminal only.
class Progress {
public:
    Progress(std::string what, std::size_t total);
    ~Progress();
    Progress(const Progress&) = delete;
    Progress& operator=(const Progress&) = delete;
    /// Redraws the bar: @p done of the total, and a short note.
    void update(std::size_t done, const std::string& note = {});
    /// A (done, total) callback that redraws the bar, for the functions that
    /// report their progress so (the total they give replaces this one's).
    /// Valid while this bar lives.
    std::function<void(int, int)> reporter();
    /// Prints @p text as a line of standard output, above the bar.
    void line(const std::string& text);
    /// Removes the bar.
    void clear();

private:
    std::string what_;
    std::size_t total_;
    bool tty_;
    bool shown_{false};
};

}  // namespace avatar::tools
