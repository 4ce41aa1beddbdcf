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

#include <algorithm>
#include <filesystem>
#include <functional>
#include <optional>

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
    FirewireOptions options;
    if (r.frameTimeout) options.dequeueTimeout = *r.frameTimeout;
    if (r.pairTolerance) options.timestampTolerance = *r.pairTolerance;
    b.acquisition = makeFirewireAcquisition(options);
    return b;
}

Backend makeGenICam(const BackendRequest& r) {
    Backend b = withConfigFile(r);
    GenICamOptions options;
    if (r.frameRateHz) {
        options.frameRateHz = r.frameRateHz;
        if (*r.frameRateHz > 0.0)  // half the frame period: free-running cameras are not in phase
            options.pairTolerance = std::chrono::microseconds(static_cast<std::int64_t>(5e5 / *r.frameRateHz));
    }
    if (r.pairTolerance) options.pairTolerance = *r.pairTolerance;
    if (r.frameTimeout) options.frameTimeout = *r.frameTimeout;
    b.acquisition = std::make_unique<AcquireSIPGenICam>(b.config, options);  // opens and starts the cameras
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

// ---------------------------------------------------------------- surveys

BackendSurvey surveyReplay(const BackendRequest& r) {
    if (!r.session) throw InvalidArgument("the replay backend needs a session directory: --session DIR");
    BackendSurvey s;
    s.backend = r.name;
    std::optional<SessionLogReader> reader;
    try {
        reader.emplace(*r.session);
    } catch (const Error& e) {
        s.checks.push_back({"session log", false, e.what()});
        return s;
    }
    const std::vector<SessionRecord> records = reader->records();
    const std::size_t damaged = reader->errors().size();
    BackendCheck log{"session log", !records.empty(), ""};
    log.detail = reader->logPath().string() + ": version " + std::to_string(reader->version()) + ", " +
                 std::to_string(records.size()) + " intact record(s), " + std::to_string(damaged) + " damaged" +
                 (damaged > 0 ? " (the first: " + reader->errors().front() + ")" : std::string()) +
                 (records.empty() ? "; nothing to replay" : "");
    s.checks.push_back(log);
    std::vector<std::string> missing;
    for (const SessionRecord& record : records)
        for (const ImageFileRef* f : {&record.files.left, &record.files.right})
            if (!std::filesystem::exists(reader->directory() / f->name)) missing.push_back(f->name);
    BackendCheck files{"image files", missing.empty(), ""};
    if (missing.empty()) {
        files.detail = "all " + std::to_string(2 * records.size()) + " present";
    } else {
        files.detail = std::to_string(missing.size()) + " of " + std::to_string(2 * records.size()) +
                       " missing in " + reader->directory().string() + ", e.g. " + missing.front();
    }
    s.checks.push_back(files);
    // The recorded camera ids, each once, left ones first.
    for (const Side side : {Side::Left, Side::Right}) {
        std::vector<std::string> seen;
        for (const SessionRecord& record : records) {
            const std::string& id = side == Side::Left ? record.acquisition.left.cameraId
                                                       : record.acquisition.right.cameraId;
            if (std::find(seen.begin(), seen.end(), id) != seen.end()) continue;
            seen.push_back(id);
            std::size_t count = 0;
            for (const SessionRecord& other : records)
                count += (side == Side::Left ? other.acquisition.left.cameraId : other.acquisition.right.cameraId) ==
                         id;
            s.cameras.push_back({id, "recorded", reader->directory().string(), true,
                                 std::string(side == Side::Left ? "left" : "right") + " camera of " +
                                     std::to_string(count) + " record(s)" +
                                     (id.empty() ? "; the recording carries no camera id" : "")});
        }
    }
    return s;
}

BackendSurvey surveyFiles(const BackendRequest& r) {
    if (!r.leftFiles || !r.rightFiles)
        throw InvalidArgument("the files backend needs --left-files PATTERN and --right-files PATTERN");
    BackendSurvey s;
    s.backend = r.name;
    StereoFilePattern pattern;
    pattern.left = *r.leftFiles;
    pattern.right = *r.rightFiles;
    pattern.start = r.firstFile;
    pattern.count = r.fileCount;
    try {
        pattern.validate();
    } catch (const InvalidArgument& e) {
        s.checks.push_back({"file patterns", false, e.what()});
        return s;
    }
    const StereoFilePaths first = pattern.at(pattern.start);
    for (const auto& path : {first.left, first.right}) {
        const bool exists = std::filesystem::exists(path);
        s.checks.push_back({path.string(), exists,
                            exists ? "the first pair's file is there" : "the first pair's file does not exist"});
    }
    // Image files carry no camera ids: no cameras to list.
    return s;
}

BackendSurvey surveySimulation(const BackendRequest& r) {
    if (!r.scene)
        throw InvalidArgument("the simulation backend needs a scene: --scene FILE (e.g. data/scenes/lab.xml)");
    BackendSurvey s;
    s.backend = r.name;
    try {
        const render::Scene scene = render::readSceneFile(*r.scene);
        s.checks.push_back({"scene", true, r.scene->string() + ": scene '" + scene.name + "'"});
        for (const char* id : {"sim-left", "sim-right"})
            s.cameras.push_back({id, "simulated (scene " + scene.name + ")", r.scene->string(), true, "rendered"});
    } catch (const Error& e) {
        s.checks.push_back({"scene", false, e.what()});
    }
    return s;
}

BackendSurvey surveyFirewireBackend(const BackendRequest& /*r*/) { return surveyFirewire(); }

BackendSurvey surveyGenICamBackend(const BackendRequest& /*r*/) { return AcquireSIPGenICam::survey(); }

struct Entry {
    BackendEntry info;
    std::function<Backend(const BackendRequest&)> make;
    std::function<BackendSurvey(const BackendRequest&)> survey;
};

std::vector<Entry> entries() {
    return {
        {{"replay", "a recorded session directory (--session DIR; --config FILE overrides the recorded one)"},
         makeReplay, surveyReplay},
        {{"files", "8-bit image files (--left-files/--right-files PATTERN, --config FILE)"}, makeFiles, surveyFiles},
        {{"firewire", "two IIDC cameras on the FireWire bus (--config FILE names them)"}, makeFirewire,
         surveyFirewireBackend},
        {{"genicam", "two GenICam cameras through Aravis (--config FILE names them)"}, makeGenICam,
         surveyGenICamBackend},
        {{"simulation", "a rendered scene (--scene FILE, --config FILE)"}, makeSimulation, surveySimulation},
    };
}

/// The entry named @p name; InvalidArgument listing the names otherwise.
const Entry& entryNamed(const std::vector<Entry>& all, const std::string& name) {
    std::string names;
    for (const Entry& e : all) {
        if (e.info.name == name) return e;
        names += (names.empty() ? "" : ", ") + e.info.name;
    }
    throw InvalidArgument("unknown backend '" + name + "' (one of: " + names + ")");
}

}  // namespace

std::vector<BackendEntry> backendTable() {
    std::vector<BackendEntry> out;
    for (const Entry& e : entries()) out.push_back(e.info);
    return out;
}

Backend makeBackend(const BackendRequest& request) {
    const std::vector<Entry> all = entries();
    return entryNamed(all, request.name).make(request);
}

BackendSurvey surveyBackend(const BackendRequest& request) {
    const std::vector<Entry> all = entries();
    return entryNamed(all, request.name).survey(request);
}

}  // namespace avatar
