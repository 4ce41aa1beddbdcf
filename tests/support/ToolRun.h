#pragma once
// Running a command-line tool from a test: through the shell, with its exit
// status and what it printed (tests/tools/).
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>

#include <sys/wait.h>

namespace avatar::test {

/// The whole of a file ("" when it cannot be read).
inline std::string slurp(const std::filesystem::path& path) {
    std::ifstream in(path);
    std::stringstream s;
    s << in.rdbuf();
    return s.str();
}

/// Runs @p command through the shell; its exit status (-1 when it did not exit).
inline int run(const std::string& command) {
    const int raw = std::system(command.c_str());
    return WIFEXITED(raw) ? WEXITSTATUS(raw) : -1;
}

/// A tool's exit status and what it printed.
struct ToolRun {
    int status{-1};
    std::string out, err;
};

/// Runs @p command through the shell with standard output into the file @p out
/// and standard error into @p err; the exit status and what each holds.
inline ToolRun runCaptured(const std::string& command, const std::filesystem::path& out,
                           const std::filesystem::path& err) {
    ToolRun r;
    r.status = run(command + " >" + out.string() + " 2>" + err.string());
    r.out = slurp(out);
    r.err = slurp(err);
    return r;
}

}  // namespace avatar::test
