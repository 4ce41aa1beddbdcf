#pragma once
/// @file ToolMain.h
/// The main() of a command-line tool (docs/tools/): the command line parsed,
/// --help, logging from --log or --log-config, reports written, and the exit
/// status every tool gives: 0 done, 1 an input, file or camera at fault (the
/// message, on standard error after "<tool>: ", names it), 2 usage.
///
/// The shape of a main():
///
///     po::options_description options("avatar-x: ...\nUsage: ...\n\nOptions");
///     options.add_options()("help,h", "show this help") ...;
///     return tools::runTool("avatar-x", tools::HelpHint::WithName, [&] {
///         const po::variables_map vm = tools::parseCommandLine(argc, argv, options);
///         if (vm.count("help")) return tools::printHelp(options, tools::kInputExitStatus);
///         if (...) throw tools::UsageError("...");
///         tools::configureLogging(vm);
///         ...
///         return 0;
///     });

#include <avatar/common/Error.h>

#include <boost/program_options.hpp>

#include <filesystem>
#include <functional>
#include <string>

namespace avatar::tools {

/// A command line that cannot be used: exit status 2.
class UsageError : public InvalidArgument {
public:
    using InvalidArgument::InvalidArgument;
};

/// The last line of the --help of a tool that reads inputs and writes results.
inline constexpr const char* kInputExitStatus =
    "Exit status: 0 done, 1 an input cannot be used (the message names it), 2 usage.\n";

/// The command line parsed against @p options (stored and notified). Throws
/// boost::program_options::error, which runTool() turns into exit status 2.
boost::program_options::variables_map parseCommandLine(int argc, const char* const argv[],
                                                       const boost::program_options::options_description& options);

/// For --help: writes @p options and, after a blank line, @p text (which ends
/// with the exit statuses) to standard output. Returns exit status 0.
int printHelp(const boost::program_options::options_description& options, const std::string& text);

/// Configures logging from --log (a priority), or from --log-config (a log4cpp
/// property file) when the tool has that option and it is given.
void configureLogging(const boost::program_options::variables_map& vm);

/// Writes @p text to @p path; on failure IoError "cannot write <what> <path>"
/// (@p what: "report", "the report", "target element").
void writeText(const std::filesystem::path& path, const std::string& text, const std::string& what);

/// How a usage error points to the help.
enum class HelpHint {
    WithName,  ///< "(see avatar-camtest --help)"
    Short,     ///< "(see --help)"
};

/// Runs @p body and turns what it throws into the exit status, with the
/// message on standard error after "<tool>: ": UsageError and
/// boost::program_options::error 2 (followed by @p hint), any other
/// avatar::Error 1, any other exception 1 ("unexpected error: ...").
int runTool(const std::string& tool, HelpHint hint, const std::function<int()>& body);

}  // namespace avatar::tools
