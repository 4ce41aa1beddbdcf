// accuracy_report: the accuracy, precision and detection figures of the
// analysis pipeline on rendered scenes with exact ground truth (see
// docs/accuracy.md). Generates the sets in-process from seeds, renders them
// with avatar::render (Scorpion calibration, 1280x960, 16-bit Bayer BG,
// noise), analyses every pair, associates each reported target with the
// truth and prints markdown tables.
//
//   accuracy_report [--scenes N] [--set lab|wide|dark|seabed|precision|bias|all]
//                   [--seed S] [--repeats R] [--verbose] [--unfused]

#include "../analyze/AccuracyHarness.h"

#include <avatar/analyze/AnalyzeStereoImagePair.h>
#include <avatar/common/Error.h>
#include <avatar/config/ConfigXml.h>
#include <avatar/render/Renderer.h>

#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <map>
#include <string>
#include <vector>

using namespace avatar;
using namespace avatar::accuracy;

namespace {

struct Options {
    int scenes{50};
    std::string set{"all"};
    std::uint64_t seed{1};
    int repeats{30};
    /// --unfused: the stages one by one, the lighting correction after the
    /// demosaic (the order before the fused front end), for comparison.
    bool unfused{false};
};

/// The built-in demosaic behind a stage type the chain does not fuse.
class UnfusedDemosaic final : public ProcessStereoImagePair {
public:
    explicit UnfusedDemosaic(std::unique_ptr<ProcessStereoImagePair> inner) : inner_(std::move(inner)) {}
    std::string_view name() const override { return inner_->name(); }
    bool hasImageWork() const override { return inner_->hasImageWork(); }
    void prepare(AnalysisFrame& f) override { inner_->prepare(f); }
    void processImage(AnalysisFrame& f, Side s) override { inner_->processImage(f, s); }
    void processPair(AnalysisFrame& f) override { inner_->processPair(f); }

private:
    std::unique_ptr<ProcessStereoImagePair> inner_;
};

StageRegistry registryFor(const Options& options) {
    StageRegistry r = StageRegistry::builtin();
    if (options.unfused)
        r.add("demosaic", [](const StageContext& c) {
            return std::make_unique<UnfusedDemosaic>(StageRegistry::builtin().create("demosaic", c));
        });
    return r;
}

/// Every truth target and every reported target of one analysed pair (for --verbose).
void dump(const render::GroundTruth& truth, const VisionTargets& result) {
    for (const auto& t : truth.targets) {
        std::fprintf(stderr, "  truth %s %s %s (%.1f %.1f %.1f)", t.name.c_str(), t.type.c_str(),
                     std::string(render::toString(t.shape)).c_str(), t.centreLeftMm.x, t.centreLeftMm.y, t.centreLeftMm.z);
        for (const auto* v : {&t.left, &t.right})
            if (v->silhouetteCentroidPx)
                std::fprintf(stderr, " [%s %.2f %.2f a=%.0f]", std::string(render::toString(v->visibility)).c_str(),
                             v->silhouetteCentroidPx->x, v->silhouetteCentroidPx->y, v->areaPx);
            else
                std::fprintf(stderr, " [none]");
        std::fprintf(stderr, "\n");
    }
    for (const auto& v : result.targets) {
        std::fprintf(stderr, "  found %s flags %u", v.type.c_str(), v.flags);
        if (v.centroidLeftPx) std::fprintf(stderr, " L %.2f %.2f a=%.0f", v.centroidLeftPx->x, v.centroidLeftPx->y, v.areaLeftPx);
        if (v.centroidRightPx) std::fprintf(stderr, " R %.2f %.2f a=%.0f", v.centroidRightPx->x, v.centroidRightPx->y, v.areaRightPx);
        if (v.positionVisionMm)
            std::fprintf(stderr, " P %.1f %.1f %.1f", v.positionVisionMm->x, v.positionVisionMm->y, v.positionVisionMm->z);
        std::fprintf(stderr, "\n");
    }
}
bool gVerbose = false;

void usage() {
    std::fprintf(stderr,
                 "usage: accuracy_report [--scenes N] [--set lab|wide|dark|seabed|precision|bias|all] "
                 "[--seed S] [--repeats R] [--verbose] [--unfused]\n");
}

std::uint64_t renderSeed(std::uint64_t seed, std::size_t index) { return seed * 1000003ULL + index + 1; }

std::string fmt(double v, int digits = 2) {
    if (std::isnan(v)) return "-";
    char buf[32];
    std::snprintf(buf, sizeof buf, "%.*f", digits, v);
    return buf;
}

void printStatsRow(const std::string& label, const ErrorStats& s) {
    std::printf("| %-34s | %4zu | %6s | %6s | %7s | %6s | %6s | %7s |\n", label.c_str(), s.n, fmt(s.medianMm).c_str(),
                fmt(s.p95Mm).c_str(), fmt(s.maxMm).c_str(), fmt(s.medianPercent, 3).c_str(),
                fmt(s.p95Percent, 3).c_str(), fmt(s.meanRadialPercent, 3).c_str());
}

void printStatsHeader() {
    std::printf("| %-34s | %4s | %6s | %6s | %7s | %6s | %6s | %7s |\n", "targets (fully visible, detected)", "n",
                "median", "p95", "max", "med %", "p95 %", "bias %");
    std::printf("|%s|%s|%s|%s|%s|%s|%s|%s|\n", std::string(36, '-').c_str(), std::string(6, '-').c_str(),
                std::string(8, '-').c_str(), std::string(8, '-').c_str(), std::string(9, '-').c_str(),
                std::string(8, '-').c_str(), std::string(8, '-').c_str(), std::string(9, '-').c_str());
}

/// Outcomes of one configuration over a whole set.
struct Tally {
    std::vector<TargetRecord> targets;
    int stereo{0}, wrong{0}, spurious{0}, duplicates{0};
    void add(const SceneOutcome& o) {
        targets.insert(targets.end(), o.targets.begin(), o.targets.end());
        stereo += o.stereoTargets;
        wrong += o.wrongMatches;
        spurious += o.spurious;
        duplicates += o.duplicates;
    }
    int fullyVisible() const {
        int n = 0;
        for (const auto& t : targets) n += t.fullyVisible && !t.crowded;
        return n;
    }
    int recalled() const {
        int n = 0;
        for (const auto& t : targets) n += t.fullyVisible && !t.crowded && t.detected;
        return n;
    }
    int crowded(bool detected) const {
        int n = 0;
        for (const auto& t : targets) n += t.fullyVisible && t.crowded && t.detected == detected;
        return n;
    }
    std::vector<TargetRecord> select(bool (*keep)(const TargetRecord&)) const {
        std::vector<TargetRecord> out;
        for (const auto& t : targets)
            if (keep(t)) out.push_back(t);
        return out;
    }
};

bool fullDetected(const TargetRecord& t) { return t.fullyVisible && !t.crowded && t.detected; }
bool crowdedDetected(const TargetRecord& t) { return t.fullyVisible && t.crowded && t.detected; }
bool fullSphere(const TargetRecord& t) { return fullDetected(t) && t.shape == render::Shape::Sphere; }
bool fullDisc(const TargetRecord& t) { return fullDetected(t) && t.shape == render::Shape::Disc; }
bool partialDetected(const TargetRecord& t) { return !t.fullyVisible && t.detected; }

/// Shape known: spheres measured by the sphere configuration, everything else by the centroid one.
std::vector<TargetRecord> shapeKnown(const Tally& centroid, const Tally& sphere) {
    std::vector<TargetRecord> out;
    for (std::size_t i = 0; i < centroid.targets.size(); ++i) {
        const TargetRecord& t = centroid.targets[i].shape == render::Shape::Sphere ? sphere.targets[i] : centroid.targets[i];
        if (fullDetected(t)) out.push_back(t);
    }
    return out;
}

void printDetection(const std::string& label, const Tally& t) {
    const int full = t.fullyVisible(), found = t.recalled();
    std::printf("| %-24s | %5zu | %5d | %7s | %9s | %5d | %8d | %10d |\n", label.c_str(), t.targets.size(), full,
                fmt(full ? 100.0 * found / full : NAN, 2).c_str(),
                (std::to_string(t.crowded(true)) + "/" + std::to_string(t.crowded(true) + t.crowded(false))).c_str(),
                t.wrong, t.spurious, t.duplicates);
}

void runSet(const SetDefinition& set, const Options& options, const StereoSystemConfig& stereo,
            const render::SensorFormat& sensor) {
    const auto start = std::chrono::steady_clock::now();
    const SetConfigs configs = makeConfigs(set);
    const auto scenes = makeScenes(set, options.scenes, options.seed, stereo, sensor);
    const StageRegistry registry = registryFor(options);
    AnalyzeStereoImagePair centroid(configs.centroid, {}, registry), sphere(configs.sphere, {}, registry),
        uncorrected(configs.uncorrected, {}, registry);
    Tally tc, ts, tu;
    double renderSeconds = 0.0;
    for (std::size_t k = 0; k < scenes.size(); ++k) {
        render::RenderOptions ro;
        ro.sensor = sensor;
        ro.seed = renderSeed(options.seed, k);
        const auto r0 = std::chrono::steady_clock::now();
        const render::RenderResult rr = render::render(scenes[k], stereo, ro);
        renderSeconds += std::chrono::duration<double>(std::chrono::steady_clock::now() - r0).count();
        const VisionTargets rc = centroid.analyze(rr.pair, k);
        const SceneOutcome oc = judge(rc, rr.truth, &scenes[k], &stereo);
        tc.add(oc);
        if (gVerbose) {
            bool interesting = oc.wrongMatches > 0 || oc.spurious > 0;
            for (const auto& t : oc.targets)
                interesting |= t.fullyVisible && (!t.detected || t.errorMm > 5.0);
            if (interesting) {
                std::fprintf(stderr, "%s:\n", rr.truth.sceneName.c_str());
                dump(rr.truth, rc);
            }
        }
        ts.add(judge(sphere.analyze(rr.pair, k), rr.truth, &scenes[k], &stereo));
        if (configs.hasCorrectionVariant) tu.add(judge(uncorrected.analyze(rr.pair, k), rr.truth, &scenes[k], &stereo));
    }
    const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();

    std::printf("\n## Set `%s`: %zu scenes, %.1f-%.1f m, config %s (seed %llu; %.0f s, %.0f s rendering)\n\n",
                set.name.c_str(), scenes.size(), set.minRangeMm / 1000.0, set.maxRangeMm / 1000.0,
                set.configFile.c_str(), static_cast<unsigned long long>(options.seed), seconds, renderSeconds);
    std::printf("| %-24s | %5s | %5s | %7s | %9s | %5s | %8s | %10s |\n", "detection", "truth", "full", "recall%",
                "crowded", "wrong", "spurious", "duplicates");
    std::printf("|--------------------------|-------|-------|---------|-----------|-------|----------|------------|\n");
    const char* withLabel = configs.hasCorrectionVariant ? "centroid, lighting corr." : "centroid";
    printDetection(withLabel, tc);
    printDetection("sphere-corrected", ts);
    if (configs.hasCorrectionVariant) printDetection("centroid, no lighting", tu);

    std::printf("\n3-D error in mm (median, p95, max), as %% of range, and mean signed error along the line of "
                "sight (bias, %% of range, - = towards the camera):\n\n");
    printStatsHeader();
    printStatsRow("all, shape known", errorStats(shapeKnown(tc, ts)));
    printStatsRow("all, centroid triangulation", errorStats(tc.select(fullDetected)));
    printStatsRow("spheres, centroid", errorStats(tc.select(fullSphere)));
    printStatsRow("spheres, shape-corrected", errorStats(ts.select(fullSphere)));
    printStatsRow("discs, centroid", errorStats(tc.select(fullDisc)));
    printStatsRow("crowded, shape known", errorStats([&] {
        std::vector<TargetRecord> out;
        for (std::size_t i = 0; i < tc.targets.size(); ++i) {
            const auto& t = tc.targets[i].shape == render::Shape::Sphere ? ts.targets[i] : tc.targets[i];
            if (crowdedDetected(t)) out.push_back(t);
        }
        return out;
    }()));
    printStatsRow("partly visible, centroid", errorStats(tc.select(partialDetected)));
    if (configs.hasCorrectionVariant) {
        printStatsRow("all, centroid, no lighting corr", errorStats(tu.select(fullDetected)));
    }
    if (set.maxRangeMm - set.minRangeMm > 900.0) {
        std::printf("\nBy range (shape known, fully visible):\n\n");
        printStatsHeader();
        const auto all = shapeKnown(tc, ts);
        for (double lo = set.minRangeMm; lo < set.maxRangeMm; lo += 500.0) {
            std::vector<TargetRecord> bin;
            for (const auto& t : all)
                if (t.rangeMm >= lo && t.rangeMm < lo + 500.0) bin.push_back(t);
            printStatsRow(fmt(lo / 1000.0, 1) + "-" + fmt((lo + 500.0) / 1000.0, 1) + " m", errorStats(bin));
        }
    }
    // The worst fully visible targets, for diagnosis.
    auto worst = shapeKnown(tc, ts);
    std::sort(worst.begin(), worst.end(), [](const auto& a, const auto& b) { return a.errorMm > b.errorMm; });
    std::printf("\nWorst (shape known): ");
    for (std::size_t i = 0; i < worst.size() && i < 3; ++i)
        std::printf("%s/%s %s %.0f mm %.0f px: %.2f mm;  ", worst[i].scene.c_str(), worst[i].name.c_str(),
                    std::string(render::toString(worst[i].shape)).c_str(), worst[i].rangeMm, worst[i].areaLeftPx,
                    worst[i].errorMm);
    std::printf("\nMissed (fully visible): ");
    for (const auto& t : tc.targets)
        if (t.fullyVisible && !t.crowded && !t.detected)
            std::printf("%s/%s %s %.0f mm %.0f px;  ", t.scene.c_str(), t.name.c_str(),
                        std::string(render::toString(t.shape)).c_str(), t.rangeMm, t.areaLeftPx);
    std::printf("\n");
    std::fflush(stdout);
}

void runPrecision(const Options& options, const StereoSystemConfig& stereo, const render::SensorFormat& sensor) {
    const auto start = std::chrono::steady_clock::now();
    const SetConfigs configs = makeConfigs(standardSets().front());
    AnalyzeStereoImagePair centroid(configs.centroid), sphere(configs.sphere);
    const render::Scene scene = precisionScene();
    std::map<std::string, std::vector<cv::Point3d>> byCentroid, bySphere;
    std::map<std::string, TargetRecord> truth;
    int missed = 0;
    for (int k = 0; k < options.repeats; ++k) {
        render::RenderOptions ro;
        ro.sensor = sensor;
        ro.seed = renderSeed(options.seed + 7777, static_cast<std::size_t>(k));
        const auto rr = render::render(scene, stereo, ro);
        const SceneOutcome c = judge(centroid.analyze(rr.pair, static_cast<std::uint64_t>(k)), rr.truth);
        const SceneOutcome s = judge(sphere.analyze(rr.pair, static_cast<std::uint64_t>(k)), rr.truth);
        for (std::size_t i = 0; i < c.targets.size(); ++i) {
            truth[c.targets[i].name] = c.targets[i];
            if (c.targets[i].detected) byCentroid[c.targets[i].name].push_back(c.targets[i].measuredMm);
            else ++missed;
            if (s.targets[i].detected) bySphere[s.targets[i].name].push_back(s.targets[i].measuredMm);
        }
    }
    const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    std::printf("\n## Precision: one scene, %d noise seeds (%.0f s; %d misses)\n\n", options.repeats, seconds, missed);
    std::printf("| target | shape  | range mm | n  | sx mm | sy mm | sz mm | sigma mm | sigma mm, sphere-corr | mean error mm |\n");
    std::printf("|--------|--------|----------|----|-------|-------|-------|----------|-----------------------|---------------|\n");
    double worst = 0.0;
    for (const auto& [name, points] : byCentroid) {
        const TargetRecord& t = truth[name];
        const Spread sc = spread(points);
        const bool isSphere = t.shape == render::Shape::Sphere;
        const Spread ss = spread(isSphere ? bySphere[name] : points);
        cv::Point3d mean(0, 0, 0);
        const auto& used = isSphere ? bySphere[name] : points;
        for (const auto& p : used) mean += p;
        mean *= 1.0 / static_cast<double>(std::max<std::size_t>(used.size(), 1));
        std::printf("| %-6s | %-6s | %8.0f | %2zu | %5.3f | %5.3f | %5.3f | %8.3f | %21s | %13.3f |\n", name.c_str(),
                    std::string(render::toString(t.shape)).c_str(), t.rangeMm, sc.n, sc.sigmaMm.x, sc.sigmaMm.y,
                    sc.sigmaMm.z, sc.magnitudeMm(), isSphere ? fmt(ss.magnitudeMm(), 3).c_str() : "-",
                    cv::norm(mean - t.truthMm));
        worst = std::max({worst, sc.magnitudeMm(), ss.magnitudeMm()});
    }
    std::printf("\nLargest sigma magnitude: %.3f mm (thesis 6.1.3: 2.6-3.8 mm)\n", worst);
    std::fflush(stdout);
}

void runBias(const Options& options, const StereoSystemConfig& stereo, const render::SensorFormat& sensor) {
    const SetConfigs configs = makeConfigs(standardSets().front());
    AnalyzeStereoImagePair centroid(configs.centroid), sphere(configs.sphere);
    std::printf("\n## Sphere silhouette bias: a sphere ~30 deg off axis, 5 noise seeds each\n\n");
    std::printf("| radius mm | range mm | centroid error mm | radial %% | shape-corrected error mm | radial %% |\n");
    std::printf("|-----------|----------|-------------------|----------|--------------------------|----------|\n");
    const double cases[][2] = {{45, 500}, {45, 750}, {30, 1000}, {30, 1500}, {45, 2000}};
    for (const auto& c : cases) {
        const render::Scene scene = sphereBiasScene(c[1], c[0]);
        std::vector<TargetRecord> rc, rs;
        for (int k = 0; k < 5; ++k) {
            render::RenderOptions ro;
            ro.sensor = sensor;
            ro.seed = renderSeed(options.seed + 99, static_cast<std::size_t>(k));
            const auto rr = render::render(scene, stereo, ro);
            const auto oc = judge(centroid.analyze(rr.pair, 0), rr.truth);
            const auto sr = sphere.analyze(rr.pair, 0);
            const auto os = judge(sr, rr.truth);
            if (gVerbose && k == 0) {
                dump(rr.truth, sr);
                for (const auto& t : rr.truth.targets)
                    std::fprintf(stderr, "  projected L %.2f %.2f R %.2f %.2f\n", t.left.projectedCentrePx->x,
                                 t.left.projectedCentrePx->y, t.right.projectedCentrePx->x, t.right.projectedCentrePx->y);
            }
            if (oc.targets[0].detected) rc.push_back(oc.targets[0]);
            if (os.targets[0].detected) rs.push_back(os.targets[0]);
        }
        const auto sc = errorStats(rc), ss = errorStats(rs);
        std::printf("| %9.0f | %8.0f | %17s | %8s | %24s | %8s |\n", c[0], c[1], fmt(sc.medianMm, 3).c_str(),
                    fmt(sc.meanRadialPercent, 3).c_str(), fmt(ss.medianMm, 3).c_str(),
                    fmt(ss.meanRadialPercent, 3).c_str());
    }
    std::fflush(stdout);
}

}  // namespace

int main(int argc, char** argv) {
    Options options;
    for (int i = 1; i < argc; ++i) {
        const std::string a = argv[i];
        auto value = [&]() -> std::string {
            if (i + 1 >= argc) {
                usage();
                std::exit(2);
            }
            return argv[++i];
        };
        if (a == "--scenes") options.scenes = std::atoi(value().c_str());
        else if (a == "--set") options.set = value();
        else if (a == "--seed") options.seed = std::strtoull(value().c_str(), nullptr, 10);
        else if (a == "--repeats") options.repeats = std::atoi(value().c_str());
        else if (a == "--verbose") gVerbose = true;
        else if (a == "--unfused") options.unfused = true;
        else if (a == "--help" || a == "-h") {
            usage();
            return 0;
        } else {
            usage();
            return 2;
        }
    }
    if (options.scenes < 1 || options.repeats < 2) {
        usage();
        return 2;
    }
    try {
        const AvatarConfig scorpion = readConfigFile(dataDir() / "config/scorpion.xml");
        const render::SensorFormat sensor = render::sensorFormatFrom(scorpion.camera);
        std::printf("# AVATAR accuracy report\n\nScorpion calibration (thesis Table 6-4), %dx%d %d-bit Bayer, "
                    "%d scenes per set, seed %llu.\n",
                    sensor.width, sensor.height, sensor.bitDepth, options.scenes,
                    static_cast<unsigned long long>(options.seed));
        bool any = false;
        for (const auto& set : standardSets())
            if (options.set == "all" || options.set == set.name) {
                runSet(set, options, scorpion.stereo, sensor);
                any = true;
            }
        if (options.set == "all" || options.set == "precision") {
            runPrecision(options, scorpion.stereo, sensor);
            any = true;
        }
        if (options.set == "all" || options.set == "bias") {
            runBias(options, scorpion.stereo, sensor);
            any = true;
        }
        if (!any) {
            std::fprintf(stderr, "unknown set '%s'\n", options.set.c_str());
            usage();
            return 2;
        }
    } catch (const std::exception& e) {
        std::fprintf(stderr, "accuracy_report: %s\n", e.what());
        return 1;
    }
    return 0;
}
