#include "FeatureSet.h"

#include <avatar/common/Error.h>

#include <algorithm>
#include <cmath>
#include <sstream>
#include <thread>

namespace avatar::featureset {

namespace {

using Clock = std::chrono::steady_clock;

constexpr std::array<Side, 2> kSides{Side::Left, Side::Right};
std::size_t at(Side side) { return side == Side::Left ? 0 : 1; }
const char* sideName(Side side) { return side == Side::Left ? "left" : "right"; }

std::string number(double v) {
    std::ostringstream os;
    os.precision(10);
    os << v;
    return os.str();
}

/// Sets the mode of feature @p name in @p set, and its value when @p value is given.
void setFeature(CameraFeatureSet& set, const std::string& name, bool automatic,
                std::optional<std::pair<double, double>> value = std::nullopt) {
    if (name == "whiteBalance") {
        set.whiteBalance.automatic = automatic;
        if (value) {
            set.whiteBalance.blueU = value->first;
            set.whiteBalance.redV = value->second;
        }
        return;
    }
    CameraFeature* f = name == "exposure"     ? &set.exposure
                       : name == "shutter"    ? &set.shutter
                       : name == "gain"       ? &set.gain
                       : name == "brightness" ? &set.brightness
                                              : &set.gamma;
    f->automatic = automatic;
    if (value) f->value = value->first;
}

/// Whether @p a and @p b differ by more than @p tolerance (relative).
bool changed(double a, double b, double tolerance) {
    return std::fabs(a - b) > tolerance * std::max(std::fabs(a), std::fabs(b)) + 1e-9;
}

std::string describe(const std::string& name, double value, double redV) {
    return name == "whiteBalance" ? number(value) + "/" + number(redV) + " (blue/U / red/V)" : number(value);
}

}  // namespace

void Options::validate() const {
    const auto& all = cameraFeatureNames();
    if (features.empty()) throw InvalidArgument("features: none given");
    for (const std::string& n : features)
        if (std::find(all.begin(), all.end(), n) == all.end())
            throw InvalidArgument("features: '" + n +
                                  "' is not a camera feature (one of exposure, shutter, gain, whiteBalance, "
                                  "brightness, gamma)");
    if (!(tolerance >= 0.0 && tolerance < 1.0))
        throw InvalidArgument("tolerance must be in 0..1 (a fraction), got " + number(tolerance));
    if (stableReads < 1 || stableReads > 1000)
        throw InvalidArgument("stable-reads must be 1..1000, got " + std::to_string(stableReads));
    if (poll.count() < 1 || poll.count() > 60000)
        throw InvalidArgument("poll-ms must be 1..60000, got " + std::to_string(poll.count()));
    if (!(timeout.count() > 0.0 && timeout.count() <= 3600.0))
        throw InvalidArgument("settle-timeout must be in (0, 3600] s, got " + number(timeout.count()));
}

const char* toString(Mode mode) {
    switch (mode) {
        case Mode::Missing: return "missing";
        case Mode::Fixed: return "no automatic mode";
        case Mode::Automatic: return "automatic";
    }
    return "?";
}

double storedValue(const std::vector<double>& readings) {
    if (readings.empty()) return 0.0;
    double sum = 0.0;
    bool integral = true;
    for (const double v : readings) {
        sum += v;
        integral = integral && v == std::floor(v);
    }
    const double mean = sum / static_cast<double>(readings.size());
    return integral ? std::round(mean) : mean;
}

Result run(AcquireStereoImagePair& acquisition, const AvatarConfig& original, const Options& options) {
    options.validate();
    Result result;
    result.config = original;
    const bool colour = original.camera.bayer || original.camera.channels == 3;
    for (const std::string& n : options.features) {
        if (std::any_of(result.features.begin(), result.features.end(),
                        [&](const FeatureResult& f) { return f.name == n; }))
            continue;
        if (n == "whiteBalance" && !colour) {
            result.notApplicable.push_back(
                "whiteBalance: not applicable: the configuration's images are mono (not Bayer, 1 channel)");
            continue;
        }
        FeatureResult f;
        f.name = n;
        result.features.push_back(f);
    }

    // ---- let the cameras adjust the features themselves
    AvatarConfig automatic = original;
    for (const FeatureResult& f : result.features) setFeature(automatic.camera.features, f.name, true);
    acquisition.applyConfig(automatic);  // a camera that lacks a feature (or its automatic mode) skips it
    std::array<CameraFeatureReadback, 2> reading = acquisition.readFeatures();
    result.reads = 1;
    for (const Side side : kSides) result.cameraIds[at(side)] = reading[at(side)].cameraId;
    for (FeatureResult& f : result.features)
        for (const Side side : kSides) {
            const FeatureReading& r = reading[at(side)].feature(f.name);
            f.reading[at(side)] = r;
            f.mode[at(side)] = !r.present ? Mode::Missing : r.automatic ? Mode::Automatic : Mode::Fixed;
            result.settleNeeded = result.settleNeeded || f.mode[at(side)] == Mode::Automatic;
        }
    const auto camera = [&](Side side) {
        const std::string& id = result.cameraIds[at(side)];
        return std::string(sideName(side)) + " camera" + (id.empty() ? "" : " " + id);
    };

    // ---- wait until every automatic value is stable
    if (result.settleNeeded) {
        std::vector<std::array<int, 2>> stable(result.features.size(), {0, 0});
        const auto start = Clock::now();
        for (;;) {
            std::this_thread::sleep_for(options.poll);
            // Keep the pairs flowing while the cameras adjust (a finite source may end: then only read).
            const AcquisitionStatus status = acquisition.status();
            if (status.state == AcquisitionStatus::State::Ok || status.state == AcquisitionStatus::State::Recovering) {
                try {
                    acquisition.acquire();
                    ++result.pairs;
                } catch (const AcquisitionError& e) {
                    result.pairFailures.push_back(e.what());
                }
            }
            reading = acquisition.readFeatures();
            ++result.reads;
            const double elapsed = std::chrono::duration<double>(Clock::now() - start).count();
            int least = options.stableReads;
            std::string moving;
            for (std::size_t i = 0; i < result.features.size(); ++i) {
                FeatureResult& f = result.features[i];
                for (const Side side : kSides) {
                    if (f.mode[at(side)] != Mode::Automatic) continue;
                    const FeatureReading& now = reading[at(side)].feature(f.name);
                    FeatureReading& before = f.reading[at(side)];
                    const bool moved = changed(before.value, now.value, options.tolerance) ||
                                       (f.name == "whiteBalance" && changed(before.redV, now.redV, options.tolerance));
                    int& count = stable[i][at(side)];
                    count = moved ? 0 : count + 1;
                    if (moved) {
                        moving = f.name + " on the " + camera(side) + ": " + describe(f.name, before.value, before.redV) +
                                 " -> " + describe(f.name, now.value, now.redV);
                        f.settledAfterS.reset();
                    }
                    least = std::min(least, count);
                    before = now;
                }
                // Settled when every automatic camera's value is.
                int fewest = options.stableReads;
                for (const Side side : kSides)
                    if (f.mode[at(side)] == Mode::Automatic) fewest = std::min(fewest, stable[i][at(side)]);
                if (fewest >= options.stableReads && !f.settledAfterS &&
                    std::find(f.mode.begin(), f.mode.end(), Mode::Automatic) != f.mode.end())
                    f.settledAfterS = elapsed;
            }
            if (options.progress) options.progress(least, result.reads);
            if (least >= options.stableReads) {
                result.settledS = elapsed;
                break;
            }
            if (elapsed > options.timeout.count()) {
                try {
                    acquisition.applyConfig(original);  // leave the cameras as they were
                } catch (const Error&) {
                }
                throw TimedOut("the automatic features did not settle within " + number(options.timeout.count()) +
                               " s (" + std::to_string(result.reads) + " reads " + std::to_string(options.poll.count()) +
                               " ms apart, tolerance " + number(options.tolerance * 100.0) + " %, " +
                               std::to_string(options.stableReads) + " stable reads wanted); still changing: " +
                               (moving.empty() ? std::string("(changed earlier)") : moving));
            }
        }
    }

    // ---- the values to store: the cameras' mean (rounded when they report integers, as IIDC cameras do)
    for (FeatureResult& f : result.features) {
        std::vector<double> values;
        std::vector<double> reds;
        for (const Side side : kSides) {
            if (f.mode[at(side)] == Mode::Missing) continue;
            values.push_back(f.reading[at(side)].value);
            reds.push_back(f.reading[at(side)].redV);
        }
        if (values.empty()) continue;
        f.stored = true;
        f.value = storedValue(values);
        f.redV = storedValue(reds);
        setFeature(result.config.camera.features, f.name, false, std::pair{f.value, f.redV});
    }

    // ---- switch to manual with those values and check that the cameras keep them
    acquisition.applyConfig(result.config);
    reading = acquisition.readFeatures();
    for (FeatureResult& f : result.features) {
        if (!f.stored) continue;
        for (const Side side : kSides) {
            if (f.mode[at(side)] == Mode::Missing) continue;
            const FeatureReading& r = reading[at(side)].feature(f.name);
            const bool ok = r.present && !r.automatic && !changed(r.value, f.value, options.tolerance) &&
                            (f.name != "whiteBalance" || !changed(r.redV, f.redV, options.tolerance));
            f.verified[at(side)] = ok;
            if (!ok) {
                f.verifyNote[at(side)] = "reports " + describe(f.name, r.value, r.redV) +
                                         (r.automatic ? " in automatic mode" : "") + " after being set to " +
                                         describe(f.name, f.value, f.redV);
                result.mismatches.push_back(f.name + " on the " + camera(side) + " " + f.verifyNote[at(side)]);
            }
        }
    }
    return result;
}

}  // namespace avatar::featureset
