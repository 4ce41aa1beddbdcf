// avatar-register as a user runs it: the exact command line of issue 11, the
// report's keys and values, the configuration it writes, and its errors.
#include "RegistrationScenes.h"
#include "SampleConfigs.h"
#include "TempDir.h"
#include "ToolRun.h"

#include <avatar/common/Registration.h>
#include <avatar/config/ConfigXml.h>

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include <cstdlib>
#include <fstream>
#include <sstream>
#include <string>
#include <sys/wait.h>

namespace avatar {
namespace {

using test::slurp;
using test::ToolRun;

ToolRun run(const test::TempDir& dir, const std::string& arguments) {
    return test::runCaptured(std::string(AVATAR_REGISTER_EXECUTABLE) + " " + arguments, dir / "stdout.txt",
                             dir / "stderr.txt");
}

void writeCsv(const std::filesystem::path& path, const test::PointSet& set) {
    std::ofstream csv(path);
    csv.precision(17);
    csv << "vx,vy,vz,bx,by,bz\n";
    for (std::size_t i = 0; i < set.vision.size(); ++i)
        csv << set.vision[i].x << "," << set.vision[i].y << "," << set.vision[i].z << "," << set.base[i].x << ","
            << set.base[i].y << "," << set.base[i].z << "\n";
}

TEST(AvatarRegister, WritesTheRegistrationAndItsReport) {
    test::TempDir dir;
    test::PointSetSpec spec;
    spec.points = 12;
    spec.noiseMm = 0.0;
    spec.rotationRad = 2.0;
    spec.outlierFraction = 1.0 / 12.0;  // point pair 1 is off by 50..200 mm
    const test::PointSet set = test::drawPointSet(spec, 5);
    writeCsv(dir / "points.csv", set);
    writeConfigFile(test::scorpionSample(), dir / "avatar.xml");

    const ToolRun r = run(dir, "--points " + (dir / "points.csv").string() + " --out " + (dir / "avatar.xml").string() +
                               " --report " + (dir / "report.json").string());
    ASSERT_EQ(r.status, 0) << r.err;
    EXPECT_NE(r.out.find("outlier: point pair 1 (" + (dir / "points.csv").string() + ":2)"), std::string::npos) << r.out;

    const nlohmann::json report = nlohmann::json::parse(slurp(dir / "report.json"));
    const cv::Matx33d truth = rotationMatrix(set.baseTVision);
    for (int i = 0; i < 3; ++i) {
        for (int j = 0; j < 3; ++j) EXPECT_NEAR(report["R"][i][j].get<double>(), truth(i, j), 1e-9);
        EXPECT_NEAR(report["t"][i].get<double>(), set.baseTVision.translationMm[static_cast<std::size_t>(i)], 1e-6);
        EXPECT_NEAR(report["euler_zyx_rad"][i].get<double>(), eulerZyx(truth)[static_cast<std::size_t>(i)], 1e-9);
    }
    EXPECT_LT(report["rms_mm"].get<double>(), 1e-6);
    ASSERT_EQ(report["residuals_mm"].size(), 12u);
    ASSERT_EQ(report["inliers"].size(), 12u);
    EXPECT_FALSE(report["inliers"][0].get<bool>());
    EXPECT_GT(report["residuals_mm"][0].get<double>(), 49.0);
    for (std::size_t i = 1; i < 12; ++i) EXPECT_TRUE(report["inliers"][i].get<bool>()) << i;

    // The configuration now carries exactly that registration, and nothing else changed.
    const AvatarConfig written = readConfigFile(dir / "avatar.xml");
    ASSERT_TRUE(written.stereo.baseTVision);
    for (std::size_t k = 0; k < 9; ++k) EXPECT_NEAR(written.stereo.baseTVision->rotation[k], truth.val[k], 1e-9);
    AvatarConfig expected = test::scorpionSample();
    expected.stereo.baseTVision = written.stereo.baseTVision;
    EXPECT_EQ(written, expected);

    // The thesis's iterative algorithm finds the same registration here.
    const ToolRun iterative = run(dir, "--points " + (dir / "points.csv").string() + " --out " +
                                       (dir / "avatar.xml").string() + " --report " +
                                       (dir / "iterative.json").string() + " --method iterative");
    ASSERT_EQ(iterative.status, 0) << iterative.err;
    const nlohmann::json it = nlohmann::json::parse(slurp(dir / "iterative.json"));
    EXPECT_EQ(it["method"], "iterative");
    for (int i = 0; i < 3; ++i) EXPECT_NEAR(it["t"][i].get<double>(), report["t"][i].get<double>(), 1e-6);
}

TEST(AvatarRegister, BadInputIsAClearErrorAndChangesNothing) {
    test::TempDir dir;
    writeConfigFile(test::scorpionSample(), dir / "avatar.xml");
    const std::string before = slurp(dir / "avatar.xml");
    const auto tool = [&](const std::string& csv, const std::string& extra = "") {
        std::ofstream(dir / "points.csv") << csv;
        return run(dir, "--points " + (dir / "points.csv").string() + " --out " + (dir / "avatar.xml").string() +
                            " --report " + (dir / "report.json").string() + extra);
    };
    ToolRun r = tool("x,y,z,a,b,c\n1,2,3,4,5,6\n");
    EXPECT_EQ(r.status, 1);
    EXPECT_NE(r.err.find((dir / "points.csv").string() + ":1: expected the header 'vx,vy,vz,bx,by,bz'"),
              std::string::npos)
        << r.err;
    r = tool("vx,vy,vz,bx,by,bz\n1,2,3,4,5\n");
    EXPECT_EQ(r.status, 1);
    EXPECT_NE(r.err.find(":2: expected 6 numbers"), std::string::npos) << r.err;
    r = tool("vx,vy,vz,bx,by,bz\n0,0,800,1,0,0\n100,0,800,101,0,0\n200,0,800,201,0,0\n300,0,800,301,0,0\n");
    EXPECT_EQ(r.status, 1);
    EXPECT_NE(r.err.find("lie on one line"), std::string::npos) << r.err;
    r = tool("vx,vy,vz,bx,by,bz\n0,0,800,1,0,0\n", " --method gradient");
    EXPECT_EQ(r.status, 2);
    EXPECT_EQ(slurp(dir / "avatar.xml"), before);
    // A configuration that does not exist is not invented.
    r = run(dir, "--points " + (dir / "points.csv").string() + " --out " + (dir / "missing.xml").string() +
                     " --report " + (dir / "report.json").string());
    EXPECT_EQ(r.status, 1);
    EXPECT_NE(r.err.find("missing.xml"), std::string::npos) << r.err;
    EXPECT_FALSE(std::filesystem::exists(dir / "missing.xml"));
}

}  // namespace
}  // namespace avatar
