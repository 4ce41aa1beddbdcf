#include "Backends.h"

#include <avatar/acquire/AcquireSIPFileLoader.h>
#include <avatar/acquire/AcquireSIPFirewire.h>
#include <avatar/acquire/AcquireSIPGenICam.h>
#include <avatar/acquire/RawDataAcquire.h>
#include <avatar/common/Error.h>
#include <avatar/config/ConfigXml.h>

#ifdef AVATAR_TAUNET_SIMULATION
#include <avatar/render/AcquireSIPSimulation.h>
#include <avatar/render/Renderer.h>
#include <avatar/render/Scene.h>
#endif

#include <functional>

namespace avatar::taunet {

namespace fs = std::filesystem;

namespace {

/// The configuration file the backend needs; throws naming the backend when absent.
Backend withConfigFile(const BackendRequest& r) {
    if (!r.config)
        throw InvalidArgument("the " + r.name + " backend needs a configuration: --config FILE");
    Backend b;
    b.config = readConfigFile(*r.config);
    b.configDirectory = r.config->parent_path();
    b.configSource = r.config->string();
    return b;
}

Backend makeReplay(const BackendRequest& r) {
    if (!r.session) throw InvalidArgument("the replay backend needs a session directory: --session DIR");
    auto replay = std::make_unique<RawDataAcquire>(*r.session);
    Backend b;
    if (r.config) {
        b = withConfigFile(r);
    } else {
        // The configuration the session was recorded with (its first record's).
        const auto records = replay->reader().records();
        if (records.empty())
            throw InvalidArgument("session " + r.session->string() + " has no intact record to take the configuration from; "
                                  "give one with --config FILE");
        const auto xml = replay->reader().configXml(records.front().configVersion);
        if (!xml)
            throw InvalidArgument("session " + r.session->string() + " does not hold configuration " +
                                  std::to_string(records.front().configVersion) + "; give one with --config FILE");
        b.configSource = replay->reader().logPath().string() + " (recorded configuration " +
                         std::to_string(records.front().configVersion) + ")";
        b.config = readConfigString(*xml, b.configSource);
        b.configDirectory = *r.session;
    }
    b.acquisition = std::move(replay);
    return b;
}

Backend makeFiles(const BackendRequest& r) {
    if (!r.leftFiles || !r.rightFiles)
        throw InvalidArgument("the files backend needs --left-files PATTERN and --right-files PATTERN");
    Backend b = withConfigFile(r);
    StereoFilePattern pattern;
    pattern.left = *r.leftFiles;
    pattern.right = *r.rightFiles;
    pattern.start = r.firstFile;
    pattern.count = r.fileCount;
    b.acquisition = std::make_unique<AcquireSIPFileLoader>(pattern);
    return b;
}

Backend makeFirewire(const BackendRequest& r) {
    Backend b = withConfigFile(r);
    b.acquisition = makeFirewireAcquisition();
    return b;
}

Backend makeGenICam(const BackendRequest& r) {
    Backend b = withConfigFile(r);
    b.acquisition = std::make_unique<AcquireSIPGenICam>(b.config);  // opens and starts the cameras
    return b;
}

#ifdef AVATAR_TAUNET_SIMULATION
Backend makeSimulation(const BackendRequest& r) {
    if (!r.scene) throw InvalidArgument("the simulation backend needs a scene: --scene FILE (e.g. data/scenes/lab.xml)");
    Backend b = withConfigFile(r);
    render::RenderOptions options;
    options.sensor = render::sensorFormatFrom(b.config.camera);
    options.seed = r.seed;
    // The simulated cameras are calibrated exactly as the configuration says.
    b.acquisition =
        std::make_unique<render::AcquireSIPSimulation>(render::readSceneFile(*r.scene), b.config.stereo, options);
    return b;
}
#endif

struct Entry {
    BackendEntry info;
    std::function<Backend(const BackendRequest&)> make;
};

std::vector<Entry> entries() {
    std::vector<Entry> e;
    e.push_back({{"replay", "a recorded session directory (--session DIR; --config FILE overrides the recorded one)",
                  true, ""},
                 makeReplay});
    e.push_back({{"files", "8-bit image files (--left-files/--right-files PATTERN, --config FILE)", true, ""},
                 makeFiles});
    e.push_back({{"firewire", "two IIDC cameras on the FireWire bus (--config FILE names them)", true, ""},
                 makeFirewire});
    e.push_back({{"genicam", "two GenICam cameras through Aravis (--config FILE names them)", true, ""},
                 makeGenICam});
#ifdef AVATAR_TAUNET_SIMULATION
    e.push_back({{"simulation", "a rendered scene (--scene FILE, --config FILE)", true, ""}, makeSimulation});
#else
    e.push_back({{"simulation", "a rendered scene (--scene FILE, --config FILE)", false,
                  "the simulation backend needs the renderer, built with AVATAR_BUILD_TOOLS=ON"},
                 nullptr});
#endif
    return e;
}

}  // namespace

std::vector<BackendEntry> backendTable() {
    std::vector<BackendEntry> out;
    for (const Entry& e : entries()) out.push_back(e.info);
    return out;
}

Backend makeBackend(const BackendRequest& request) {
    std::string names;
    for (const Entry& e : entries()) {
        if (e.info.name == request.name) {
            if (!e.info.available || !e.make)
                throw InvalidArgument("backend '" + request.name + "' is not available: " + e.info.missing);
            return e.make(request);
        }
        names += (names.empty() ? "" : ", ") + e.info.name;
    }
    throw InvalidArgument("unknown backend '" + request.name + "' (one of: " + names + ")");
}

}  // namespace avatar::taunet
