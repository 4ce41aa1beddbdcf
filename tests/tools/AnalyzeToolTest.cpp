// avatar-analyze --repeat N --timings FILE.json (issue 13): every pair of the
// bundled lab session analysed N times, the medians of each stage's wall and
// CPU time written as JSON with the keys other programs read, and the runs
// checked to agree.
#include "TempDir.h"
#include "ToolRun.h"

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include <fstream>
#include <string>

namespace avatar {
namespace {

test::ToolRun analyze(const test::TempDir& dir, const std::string& arguments) {
    return test::runCaptured(std::string(AVATAR_ANALYZE_EXECUTABLE) + " --session " + AVATAR_DATA_DIR +
                                 "/sessions/lab " + arguments,
                             dir / "stdout.txt", dir / "stderr.txt");
}

TEST(AvatarAnalyzeTimings, RepeatsEveryPairAndWritesTheMediansOfEveryStage) {
    test::TempDir dir("analyze-timings");
    const std::string file = (dir / "timings.json").string();
    const test::ToolRun r = analyze(dir, "--repeat 4 --timings " + file);
    ASSERT_EQ(r.status, 0) << r.err;
    // The targets are printed once per pair, not once per run.
    std::size_t iterations = 0;
    for (std::size_t at = r.out.find("iteration "); at != std::string::npos; at = r.out.find("iteration ", at + 1))
        ++iterations;
    EXPECT_EQ(iterations, 3u) << r.out;

    const nlohmann::json j = nlohmann::json::parse(test::slurp(file));
    EXPECT_EQ(j.at("pairs").get<int>(), 3);
    const auto& total = j.at("total");
    const double wall = total.at("wall_ms_median").get<double>(), cpu = total.at("cpu_ms_median").get<double>();
    EXPECT_GT(wall, 0.0);
    EXPECT_GT(cpu, 0.0);
    const auto& stages = j.at("stages");
    double stagesCpu = 0.0;
    for (const char* stage : {"demosaic", "lighting", "color_filter", "erode_restore", "locate_features", "match",
                              "triangulate", "visibility"}) {
        ASSERT_TRUE(stages.contains(stage)) << stage << " in " << j.dump();
        EXPECT_GE(stages[stage].at("wall_ms_median").get<double>(), 0.0) << stage;
        EXPECT_GE(stages[stage].at("cpu_ms_median").get<double>(), 0.0) << stage;
        stagesCpu += stages[stage].at("cpu_ms_median").get<double>();
    }
    EXPECT_EQ(stages.size(), 8u) << "no \"total\" among the stages";
    EXPECT_GT(stages["demosaic"].at("cpu_ms_median").get<double>(), 0.0);
    // Medians do not add up exactly, but the stages are what the total is made of.
    EXPECT_NEAR(stagesCpu, cpu, 0.5 * cpu);
}

// The bundled session with tracking and coarse-to-fine on: the first frame
// of each pair searched on superpixels, the repeats only around the targets;
// every run must agree with the first (the tool checks) and print what the
// whole-image search prints, for less CPU.
TEST(AvatarAnalyzeTimings, TrackingAndCoarseToFinePrintTheWholeImageTargets) {
    test::TempDir dir("analyze-tracking");
    std::string xml = test::slurp(std::string(AVATAR_DATA_DIR) + "/config/scorpion.xml");
    const std::string options =
        "  <tracking><enabled>true</enabled><fullFrameEvery>30</fullFrameEvery></tracking>\n"
        "    <coarseToFine><enabled>true</enabled></coarseToFine>\n  </analysis>";
    const std::size_t at = xml.find("</analysis>");
    ASSERT_NE(at, std::string::npos);
    xml.replace(at, std::string("</analysis>").size(), options);
    const std::string tracked = (dir / "tracked.xml").string();
    std::ofstream(tracked) << xml;
    const std::string plainFile = (dir / "plain.json").string(), trackedFile = (dir / "tracked.json").string();
    const test::ToolRun plain = analyze(dir, "--config " + std::string(AVATAR_DATA_DIR) +
                                                 "/config/scorpion.xml --repeat 4 --timings " + plainFile);
    ASSERT_EQ(plain.status, 0) << plain.err;
    const test::ToolRun fast = analyze(dir, "--config " + tracked + " --repeat 4 --timings " + trackedFile);
    ASSERT_EQ(fast.status, 0) << fast.err;
    const auto withoutTimings = [](const std::string& out) {
        std::string kept;
        std::size_t from = 0;
        while (from < out.size()) {
            std::size_t end = out.find('\n', from);
            if (end == std::string::npos) end = out.size();
            const std::string line = out.substr(from, end - from);
            if (line.find("timings:") == std::string::npos) kept += line + "\n";
            from = end + 1;
        }
        return kept;
    };
    EXPECT_EQ(withoutTimings(fast.out), withoutTimings(plain.out));
    EXPECT_NE(plain.out.find("stereo,whole"), std::string::npos) << plain.out;
    const double plainCpu = nlohmann::json::parse(test::slurp(plainFile)).at("total").at("cpu_ms_median").get<double>();
    const double fastCpu = nlohmann::json::parse(test::slurp(trackedFile)).at("total").at("cpu_ms_median").get<double>();
    EXPECT_GT(plainCpu, 0.0);
    EXPECT_GT(fastCpu, 0.0);
}

TEST(AvatarAnalyzeTimings, RefusesARepeatBelowOne) {
    test::TempDir dir("analyze-timings");
    const test::ToolRun r = analyze(dir, "--repeat 0");
    EXPECT_EQ(r.status, 2);
    EXPECT_NE(r.err.find("--repeat must be at least 1, got 0"), std::string::npos) << r.err;
    const test::ToolRun unwritable = analyze(dir, "--timings " + (dir / "no" / "such" / "t.json").string());
    EXPECT_EQ(unwritable.status, 1);
    EXPECT_NE(unwritable.err.find("cannot write the timings file"), std::string::npos) << unwritable.err;
}

}  // namespace
}  // namespace avatar
