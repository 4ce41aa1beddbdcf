#include "ToolMain.h"

#include <avatar/common/Logging.h>

#include <fstream>
#include <iostream>

namespace po = boost::program_options;

namespace avatar::tools {

po::variables_map parseCommandLine(int argc, const char* const argv[], const po::options_description& options) {
    po::variables_map vm;
    po::store(po::parse_command_line(argc, argv, options), vm);
    po::notify(vm);
    return vm;
}

int printHelp(const po::options_description& options, const std::string& text) {
    std::cout << options << "\n" << text;
    return 0;
}

void configureLogging(const po::variables_map& vm) {
    if (vm.count("log-config"))
        logging::configureFromFile(vm["log-config"].as<std::string>());
    else
        logging::configure(logging::parsePriority(vm["log"].as<std::string>()));
}

void writeText(const std::filesystem::path& path, const std::string& text, const std::string& what) {
    std::ofstream out(path, std::ios::binary | std::ios::trunc);
    out << text;
    out.close();
    if (!out) throw IoError("cannot write " + what + " " + path.string());
}

int runTool(const std::string& tool, HelpHint hint, const std::function<int()>& body) {
    const std::string seeHelp = hint == HelpHint::WithName ? " (see " + tool + " --help)\n" : " (see --help)\n";
    try {
        return body();
    } catch (const UsageError& e) {
        std::cerr << tool << ": " << e.what() << seeHelp;
        return 2;
    } catch (const po::error& e) {
        std::cerr << tool << ": " << e.what() << seeHelp;
        return 2;
    } catch (const Error& e) {
        std::cerr << tool << ": " << e.what() << "\n";
        return 1;
    } catch (const std::exception& e) {
        std::cerr << tool << ": unexpected error: " << e.what() << "\n";
        return 1;
    }
}

}  // namespace avatar::tools
