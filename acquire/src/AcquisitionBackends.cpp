#include <avatar/acquire/AcquisitionBackends.h>

#include <avatar/acquire/AcquireSIPFileLoader.h>
#include <avatar/acquire/AcquireSIPFirewire.h>
#include <avatar/acquire/AcquireSIPGenICam.h>
#include <avatar/acquire/AcquireSIPSimulation.h>
#include <avatar/acquire/RawDataAcquire.h>
#include <avatar/common/Error.h>
#include <avatar/config/ConfigXml.h>
#include <avatar/render/Renderer.h>
#include <avatar/render/Scene.h>

#include <functional>

namespace avatar {

namespace {

/// The configuration file the backend needs; throws naming the backend when absent.
Backend withConfigFile(const BackendRequest& r) {
    if (!r.config) throw InvalidArgument("the " + r.name + " backend needs a configuration: --config FILE");
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
        RecordedConfig recorded;
        try {
            recorded = replay->initialConfig();
        } catch (const NotAvailable& e) {
            throw NotAvailable(std::string(e.what()) + "; give one with --config FILE");
        }
        b.config = std::move(recorded.config);
        b.configSource = recorded.source;
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

Backend makeSimulation(const BackendRequest& r) {
    if (!r.scene)
        throw InvalidArgument("the simulation backend needs a scene: --scene FILE (e.g. data/scenes/lab.xml)");
    Backend b = withConfigFile(r);
    render::RenderOptions options;
    options.sensor = render::sensorFormatFrom(b.config.camera);
    options.seed = r.seed;
    // The simulated cameras are calibrated exactly as the configuration says.
    b.acquisition = std::make_unique<AcquireSIPSimulation>(render::readSceneFile(*r.scene), b.config.stereo, options);
    return b;
}

struct Entry {
    BackendEntry info;
    std::function<Backend(const BackendRequest&)> make;
};

std::vector<Entry> entries() {
    return {
        {{"replay", "a recorded session directory (--session DIR; --config FILE overrides the recorded one)"},
         makeReplay},
        {{"files", "8-bit image files (--left-files/--right-files PATTERN, --config FILE)"}, makeFiles},
        {{"firewire", "two IIDC cameras on the FireWire bus (--config FILE names them)"}, makeFirewire},
        {{"genicam", "two GenICam cameras through Aravis (--config FILE names them)"}, makeGenICam},
        {{"simulation", "a rendered scene (--scene FILE, --config FILE)"}, makeSimulation},
    };
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
        if (e.info.name == request.name) return e.make(request);
        names += (names.empty() ? "" : ", ") + e.info.name;
    }
    throw InvalidArgument("unknown backend '" + request.name + "' (one of: " + names + ")");
}

}  // namespace avatar
