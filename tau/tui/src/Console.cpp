#include "Console.h"

#include <avatar/common/Error.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdarg>
#include <cstdio>
#include <fstream>
#include <sstream>
#include <thread>

namespace avatar::tui {

namespace fs = std::filesystem;

namespace {

__attribute__((format(printf, 1, 2))) std::string format(const char* fmt, ...) {
    char buffer[512];
    va_list args;
    va_start(args, fmt);
    const int n = std::vsnprintf(buffer, sizeof buffer, fmt, args);
    va_end(args);
    if (n < 0) return {};
    if (static_cast<std::size_t>(n) < sizeof buffer) return std::string(buffer, static_cast<std::size_t>(n));
    std::string big(static_cast<std::size_t>(n) + 1, '\0');
    va_start(args, fmt);
    std::vsnprintf(big.data(), big.size(), fmt, args);
    va_end(args);
    big.resize(static_cast<std::size_t>(n));
    return big;
}

unsigned long long ull(std::uint64_t v) { return static_cast<unsigned long long>(v); }

std::string point3(const std::optional<cv::Point3d>& p) {
    return p ? format("(%.1f, %.1f, %.1f) mm", p->x, p->y, p->z) : std::string("-");
}
std::string point2(const std::optional<cv::Point2d>& p) {
    return p ? format("(%.2f, %.2f)", p->x, p->y) : std::string("-");
}

const char* visibilityText(Visibility v) {
    return v == Visibility::Good ? "good" : v == Visibility::Poor ? "POOR" : "unknown";
}

void targetLines(const VisionTargets& t, const char* label, std::vector<std::string>& out) {
    out.push_back(format("%s: iteration %llu (group %u member %u), %zu target(s), visibility %s%s%s", label,
                         ull(t.iteration), t.acquisition.group, t.acquisition.member, t.targets.size(),
                         visibilityText(t.visibility), t.visibilityReason.empty() ? "" : ": ",
                         t.visibilityReason.c_str()));
    for (const VisionTarget& v : t.targets) {
        std::string line = format("  %s [%s] vision %s base %s L %s R %s", v.type.c_str(),
                                  targetFlagsText(v.flags).c_str(), point3(v.positionVisionMm).c_str(),
                                  point3(v.positionBaseMm).c_str(), point2(v.centroidLeftPx).c_str(),
                                  point2(v.centroidRightPx).c_str());
        // What a stereo target's number is worth: the model it came from, the
        // standard deviation of each coordinate and how well the rays met.
        if (v.flags & kTargetStereo) {
            line += format(" model %s", std::string(toString(v.model)).c_str());
            if (v.covarianceVisionMm2) {
                const Covariance3& c = *v.covarianceVisionMm2;
                line += format(" sigma (%.2f, %.2f, %.2f) mm", std::sqrt(std::max(c(0, 0), 0.0)),
                               std::sqrt(std::max(c(1, 1), 0.0)), std::sqrt(std::max(c(2, 2), 0.0)));
            }
            line += format(" rays %.2f mm %.2f px", v.rayResidualMm, v.rayResidualPx);
        }
        if ((v.flags & kTargetStereo) && !(v.flags & kTargetWhole)) line += "  NOT WHOLE";
        out.push_back(std::move(line));
    }
}

/// An iteration as the screen shows it: the number, and "(stale)" when a newer one exists.
std::string iterationText(std::uint64_t value, bool fresh) {
    if (value == 0) return "-";
    return std::to_string(value) + (fresh ? "" : " (stale)");
}

std::vector<std::string> splitWords(const std::string& line) {
    std::istringstream in(line);
    std::vector<std::string> words;
    for (std::string w; in >> w;) words.push_back(w);
    return words;
}

}  // namespace

std::string stateText(std::uint8_t state) {
    static const char* const names[] = {"Idle", "Searching", "Snapshot", "Error"};
    return std::to_string(state) + ":" + (state < 4 ? names[state] : "Unknown");
}

const char* kindName(tau::ImageKindCode kind) {
    switch (kind) {
        case tau::ImageKindCode::Original: return "original";
        case tau::ImageKindCode::Filtered: return "filtered";
        case tau::ImageKindCode::Marked: return "marked";
    }
    return "?";
}

std::optional<tau::ImageKindCode> parseKind(const std::string& text) {
    for (auto k : {tau::ImageKindCode::Original, tau::ImageKindCode::Filtered, tau::ImageKindCode::Marked})
        if (text == kindName(k)) return k;
    return std::nullopt;
}

Console::Console(tau::TauUnit& unit, fs::path outDir) : unit_(unit), outDir_(std::move(outDir)) {}

template <class F>
Result Console::guarded(const char* what, F&& f) {
    Result r;
    try {
        f(r);
    } catch (const tau::ConfigRejectedError& e) {
        r.ok = false;
        r.lines.push_back(std::string(what) + ": configuration rejected, the previous one stays in force: " +
                          e.serverMessage());
    } catch (const tau::TauError& e) {
        r.ok = false;
        r.lines.push_back(std::string(what) + ": TAUNet answered " + tau::errorName(e.code()) + ": " +
                          e.serverMessage());
    } catch (const avatar::Error& e) {  // connection, timeout, files
        r.ok = false;
        r.lines.push_back(std::string(what) + ": " + e.what());
    } catch (const fs::filesystem_error& e) {
        r.ok = false;
        r.lines.push_back(std::string(what) + ": " + e.what());
    }
    return r;
}

void Console::tick() {
    ++localHeartbeat_;
    refresh();
}

void Console::refresh() {
    try {
        lastStatus_ = unit_.status();
        statusError_.clear();
    } catch (const avatar::Error& e) {
        lastStatus_.reset();
        statusError_ = e.what();
    }
}

Result Console::status() {
    return guarded("status", [&](Result& r) {
        const tau::StatusReply s = unit_.status();
        lastStatus_ = s;
        statusError_.clear();
        r.lines.push_back(format("status: heartbeat %llu, state %s, iteration %llu, config version %u from iteration "
                                 "%llu, targets iteration %llu, images iteration %llu, backend %s",
                                 ull(s.heartbeat), stateText(s.state).c_str(), ull(s.iteration), s.configVersion,
                                 ull(s.configIteration), ull(s.targetsIteration), ull(s.imagesIteration),
                                 s.backend.c_str()));
        if (!s.error.empty()) r.lines.push_back("status: error: " + s.error);
        if (s.acquisitionState != 0)
            r.lines.push_back(format("status: acquisition %s: %s",
                                     s.acquisitionState == 1   ? "recovering"
                                     : s.acquisitionState == 2 ? "FAILED"
                                                               : "finished",
                                     s.acquisitionMessage.c_str()));
    });
}

Result Console::startSearching() {
    return guarded("start", [&](Result& r) {
        unit_.startSearching();
        r.lines.push_back("start: searching");
    });
}

Result Console::stopSearching() {
    return guarded("stop", [&](Result& r) {
        unit_.stopSearching();
        r.lines.push_back("stop: idle after the current iteration");
    });
}

Result Console::snapshot() {
    return guarded("snapshot", [&](Result& r) { targetLines(unit_.takeSnapshot(), "snapshot", r.lines); });
}

Result Console::targets() {
    return guarded("targets", [&](Result& r) { targetLines(unit_.getTargetData(), "targets", r.lines); });
}

Result Console::sendConfig(const fs::path& file) {
    return guarded("send-config", [&](Result& r) {
        std::ifstream in(file, std::ios::binary);
        if (!in) throw IoError("cannot read " + file.string());
        std::ostringstream text;
        text << in.rdbuf();
        const tau::ConfigApplied applied = unit_.sendConfig(text.str());
        r.lines.push_back(format("send-config: %s applied as version %u from iteration %llu", file.c_str(),
                                 applied.configVersion, ull(applied.configIteration)));
    });
}

Result Console::getConfig(const fs::path& file) {
    return guarded("get-config", [&](Result& r) {
        const tau::ConfigReply config = unit_.getConfig();
        if (file.has_parent_path()) fs::create_directories(file.parent_path());
        const fs::path partial = file.string() + ".part";
        {
            std::ofstream out(partial, std::ios::binary | std::ios::trunc);
            out << config.xml;
            out.close();
            if (!out) throw IoError("cannot write " + partial.string());
        }
        fs::rename(partial, file);
        r.lines.push_back(format("get-config: version %u from iteration %llu written to %s (%zu bytes)",
                                 config.configVersion, ull(config.configIteration), file.c_str(), config.xml.size()));
    });
}

Result Console::images(tau::ImageKindCode kind) {
    const std::string label = std::string("images ") + kindName(kind);
    return guarded(label.c_str(), [&](Result& r) {
        const tau::TauImages images = unit_.getImages(kind);
        fs::create_directories(outDir_);
        std::string line = format("%s: iteration %llu:", label.c_str(), ull(images.iteration));
        for (const tau::TauImage& image : images.images) {
            const char* side = image.side == Side::Left ? "left" : "right";
            const fs::path file = outDir_ / format("%s_%06llu_%s.jpg", kindName(kind), ull(images.iteration), side);
            std::ofstream out(file, std::ios::binary | std::ios::trunc);
            out.write(reinterpret_cast<const char*>(image.jpeg.data()), static_cast<std::streamsize>(image.jpeg.size()));
            out.close();
            if (!out) throw IoError("cannot write " + file.string());
            line += format(" %s %dx%d %s", side, image.image.cols, image.image.rows, file.c_str());
        }
        r.lines.push_back(line);
    });
}

Result Console::iterations() const {
    const tau::TauIterations& it = unit_.iterations();
    Result r;
    r.lines.push_back(format("iterations: vision %llu, config %llu (version %u)%s, targets %llu%s, left image %llu%s, "
                             "right image %llu%s",
                             ull(it.vision), ull(it.config), it.configVersion, unit_.isConfigFresh() ? "" : " stale",
                             ull(it.targets), unit_.isTargetDataFresh() ? "" : " stale", ull(it.leftImage),
                             unit_.isImageFresh(Side::Left) ? "" : " stale", ull(it.rightImage),
                             unit_.isImageFresh(Side::Right) ? "" : " stale"));
    return r;
}

Result Console::timings() const {
    Result r;
    for (const tau::ActionTiming& t : unit_.timings())
        r.lines.push_back(format("timing: %s #%u %.1f ms %s%s%s", t.request.c_str(), t.requestId,
                                 static_cast<double>(t.duration.count()) / 1000.0, tau::toString(t.outcome),
                                 t.detail.empty() ? "" : ": ", t.detail.c_str()));
    return r;
}

std::vector<std::string> Console::commandHelp() {
    return {"status                 TAUNet's state and iterations",
            "start | stop           start or stop searching",
            "snapshot               take a snapshot and print its targets",
            "targets                print the latest target data",
            "send-config FILE       send a configuration document",
            "get-config FILE        write the configuration in force to FILE",
            "images KIND            save the images (original, filtered, marked) into --out",
            "iterations             the iterations last retrieved by this console",
            "timings                the log of requests and their durations",
            "sleep MS               wait (0..600000 ms)",
            "quit                   end the script"};
}

Result Console::run(const std::string& line) {
    const std::vector<std::string> w = splitWords(line);
    auto usage = [&](const std::string& why) {
        Result r{false, {why}};
        for (const std::string& h : commandHelp()) r.lines.push_back("  " + h);
        return r;
    };
    if (w.empty()) return {};
    const std::string& c = w[0];
    const std::size_t args = w.size() - 1;
    if (c == "status" && args == 0) return status();
    if (c == "start" && args == 0) return startSearching();
    if (c == "stop" && args == 0) return stopSearching();
    if (c == "snapshot" && args == 0) return snapshot();
    if (c == "targets" && args == 0) return targets();
    if (c == "send-config" && args == 1) return sendConfig(w[1]);
    if (c == "get-config" && args == 1) return getConfig(w[1]);
    if (c == "iterations" && args == 0) return iterations();
    if (c == "timings" && args == 0) return timings();
    if (c == "images" && args == 1) {
        if (const auto kind = parseKind(w[1])) return images(*kind);
        return usage("images: unknown kind '" + w[1] + "' (original, filtered, marked)");
    }
    if (c == "sleep" && args == 1) {
        char* end = nullptr;
        const long ms = std::strtol(w[1].c_str(), &end, 10);
        if (*end != '\0' || ms < 0 || ms > 600000) return usage("sleep: not a time in ms: '" + w[1] + "'");
        std::this_thread::sleep_for(std::chrono::milliseconds(ms));
        return {};
    }
    return usage("unknown command or wrong arguments: '" + line + "'");
}

std::vector<std::string> Console::statusLines() const {
    const tau::TauIterations& it = unit_.iterations();
    std::vector<std::string> out;
    out.push_back(format("Local                : heartbeat %llu", ull(localHeartbeat_)));
    if (lastStatus_) {
        const tau::StatusReply& s = *lastStatus_;
        out.push_back(format("TAUNET status        : heartbeat %llu, state %s", ull(s.heartbeat),
                             stateText(s.state).c_str()));
        out.push_back(format("TAUNET Iteration     : %llu", ull(s.iteration)));
        if (!s.error.empty()) out.push_back("TAUNET error         : " + s.error);
        if (s.acquisitionState != 0)
            out.push_back(format("Acquisition          : %s: %s",
                                 s.acquisitionState == 1   ? "recovering"
                                 : s.acquisitionState == 2 ? "FAILED"
                                                           : "finished",
                                 s.acquisitionMessage.c_str()));
    } else {
        out.push_back("TAUNET status        : not connected" +
                      (statusError_.empty() ? std::string() : " (" + statusError_ + ")"));
        out.push_back("TAUNET Iteration     : -");
    }
    out.push_back(format("Config Iteration     : %-16s Target Iteration      : %s",
                         iterationText(it.config, unit_.isConfigFresh()).c_str(),
                         iterationText(it.targets, unit_.isTargetDataFresh()).c_str()));
    out.push_back(format("Left Image Iteration : %-16s Right Image Iteration : %s",
                         iterationText(it.leftImage, unit_.isImageFresh(Side::Left)).c_str(),
                         iterationText(it.rightImage, unit_.isImageFresh(Side::Right)).c_str()));
    return out;
}

fs::path Console::defaultConfigFile() const {
    return outDir_ / format("config_v%u.xml", unit_.iterations().serverConfigVersion);
}

}  // namespace avatar::tui
