#pragma once
// The commands of the text console (thesis 4.3.4, Figure 4-6), shared by its
// two front ends: the interactive screen and the line-by-line script mode.
// Each command returns the lines to show and whether it succeeded; nothing
// here prints.

#include <avatar/tau/TauUnit.h>

#include <cstdint>
#include <filesystem>
#include <optional>
#include <string>
#include <vector>

namespace avatar::tui {

struct Result {
    bool ok{true};
    std::vector<std::string> lines;
};

class Console {
public:
    /// Borrows @p unit. Images go into @p outDir (created when first needed).
    Console(tau::TauUnit& unit, std::filesystem::path outDir);

    /// One turn of the console's own clock: the local heartbeat advances and
    /// TAUNet's status is fetched (a failure is kept for the screen, not thrown).
    void tick();
    /// Fetches TAUNet's status for the screen without advancing the local heartbeat.
    void refresh();

    Result status();
    Result startSearching();
    Result stopSearching();
    Result snapshot();
    Result targets();
    Result sendConfig(const std::filesystem::path& file);
    Result getConfig(const std::filesystem::path& file);
    Result images(tau::ImageKindCode kind);
    Result iterations() const;
    Result timings() const;

    /// Runs one script line ("snapshot", "send-config FILE", ...). "quit" is
    /// the caller's business. Unknown commands fail with a usage line.
    Result run(const std::string& line);
    /// The commands run() knows, one per line, for --help and errors.
    static std::vector<std::string> commandHelp();

    /// The screen of Figure 4-6 above the menu: heartbeats, state, iterations.
    std::vector<std::string> statusLines() const;
    std::uint64_t localHeartbeat() const { return localHeartbeat_; }
    const std::filesystem::path& outDir() const { return outDir_; }
    /// A default file name for the configuration in the output directory.
    std::filesystem::path defaultConfigFile() const;

private:
    template <class F>
    Result guarded(const char* what, F&& f);

    tau::TauUnit& unit_;
    std::filesystem::path outDir_;
    std::uint64_t localHeartbeat_{0};
    std::optional<tau::StatusReply> lastStatus_;
    std::string statusError_;
};

/// "1:Searching" etc.
std::string stateText(std::uint8_t state);
/// "original", "filtered", "marked"; parseKind returns nullopt for other text.
const char* kindName(tau::ImageKindCode kind);
std::optional<tau::ImageKindCode> parseKind(const std::string& text);

}  // namespace avatar::tui
