#include "ToolProgress.h"

#include <algorithm>
#include <iostream>

#include <unistd.h>

namespace avatar::tools {

Progress::Progress(std::string what, std::size_t total)
    : what_(std::move(what)), total_(total), tty_(::isatty(STDERR_FILENO) == 1) {}

Progress::~Progress() { clear(); }

void Progress::update(std::size_t done, const std::string& note) {
    if (!tty_) return;
    const std::size_t width = 30;
    const std::size_t filled = total_ == 0 ? width : std::min(width, done * width / total_);
    std::cerr << "\r[" << std::string(filled, '#') << std::string(width - filled, '.') << "] " << done << "/"
              << total_ << " " << what_ << (note.empty() ? "" : ": " + note) << "\033[K" << std::flush;
    shown_ = true;
}

std::function<void(int, int)> Progress::reporter() {
    return [this](int done, int total) {
        total_ = static_cast<std::size_t>(std::max(total, 0));
        update(static_cast<std::size_t>(std::max(done, 0)));
    };
}

void Progress::line(const std::string& text) {
    clear();
    std::cout << text << std::endl;
}

void Progress::clear() {
    if (tty_ && shown_) std::cerr << "\r\033[K" << std::flush;
    shown_ = false;
}

}  // namespace avatar::tools
