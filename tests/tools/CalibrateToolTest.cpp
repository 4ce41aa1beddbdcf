// avatar-calibrate as a user runs it, on rendered checkerboard pairs with a
// known calibration: the issue's command line on 8-bit PNG files and on raw
// 16-bit Bayer files, the report's keys, a pair without the board listed and
// left out, the export/import round trips (OpenCV YAML, ROS camera_info), a
// Bouguet text import, and the Appendix A diagnostics.
#include "SampleConfigs.h"
#include "TempDir.h"
#include "ToolRun.h"

#include <avatar/acquire/SessionLog.h>
#include <avatar/common/CameraModel.h>
#include <avatar/common/ImageUtils.h>
#include <avatar/common/StereoImagePairFileIO.h>
#include <avatar/config/ConfigXml.h>
#include <avatar/render/Renderer.h>
#include <avatar/render/SceneSet.h>

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>
#include <opencv2/imgcodecs.hpp>

#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <sstream>
#include <string>
#include <sys/wait.h>
#include <unistd.h>

namespace avatar {
namespace {

namespace fs = std::filesystem;

using test::slurp;
using test::ToolRun;

ToolRun calibrate(const fs::path& dir, const std::string& arguments) {
    return test::runCaptured(std::string(AVATAR_CALIBRATE_EXECUTABLE) + " " + arguments, dir / "stdout.txt",
                             dir / "stderr.txt");
}

StereoSystemConfig truthRig() {
    StereoSystemConfig s = test::scorpionCalibration();
    s.left.kc = {-0.12, 0.08, 0.0008, -0.0005, 0.0};
    s.right.kc = {-0.11, 0.07, -0.0006, 0.0004, 0.0};
    return s;
}

/// 12 rendered pairs of a 10 x 7 square board (9 x 6 inner corners, 25 mm),
/// as 8-bit PNG (png/left_NN.png, png/right_NN.png), raw files (raw/) and a
/// recorded session (session/), plus one pair of the empty seabed (no board),
/// png/left_99 and right_99; the exact corner projections of pair 3 in
/// truth03.txt. Rendered once per ctest run (about 15 s) into
/// AVATAR_TEST_CACHE_DIR (emptied by the suite's setup test) and shared by the
/// tests, each of which ctest runs in a process of its own: made under a
/// temporary name and renamed into place, so concurrent tests never see half
/// of it.
struct Boards {
    fs::path dir;
    std::vector<cv::Point2d> truthLeft3, truthRight3;
    Boards() {
        dir = fs::path(AVATAR_TEST_CACHE_DIR) / "boards";
        if (!fs::exists(dir / "complete")) render(dir);
        std::ifstream truth(dir / "truth03.txt");
        for (double lx, ly, rx, ry; truth >> lx >> ly >> rx >> ry;) {
            truthLeft3.emplace_back(lx, ly);
            truthRight3.emplace_back(rx, ry);
        }
    }

private:
    static void render(const fs::path& final) {
        const fs::path temp = final.string() + ".tmp-" + std::to_string(::getpid());
        fs::remove_all(temp);
        fs::create_directories(temp / "png");
        fs::create_directories(temp / "raw");
        render::CheckerboardSpec spec;
        spec.views = 12;
        spec.seed = 5;
        spec.squaresX = 10;
        spec.squaresY = 7;
        spec.squareMm = 25.0;
        spec.minRangeMm = 500.0;
        spec.maxRangeMm = 1200.0;
        render::RenderOptions options;
        const StereoSystemConfig rig = truthRig();
        const auto scenes = render::makeCheckerboardViews(spec, rig, options.sensor);
        SessionLogWriter session(temp / "session");
        AvatarConfig recorded = test::scorpionSample();
        recorded.stereo.left = rig.left;
        recorded.stereo.right = rig.right;
        for (std::size_t i = 0; i <= scenes.size(); ++i) {
            render::Scene scene;
            if (i < scenes.size()) scene = scenes[i];
            else scene.seabed.distanceMm = 1500.0;  // no board
            options.seed = 40 + i;
            const render::RenderResult r = render::render(scene, rig, options);
            const StereoImagePair bgr = demosaic(r.pair);
            char name[32];
            std::snprintf(name, sizeof name, "%02zu", i < scenes.size() ? i : std::size_t{99});
            for (const Side side : {Side::Left, Side::Right})
                cv::imwrite((temp / "png" / ((side == Side::Left ? "left_" : "right_") + std::string(name) + ".png")).string(),
                            toDisplay8(bgr.image(side), 16));
            if (i == scenes.size()) break;
            render::writeRender(r, options.sensor, temp / "raw", 1, static_cast<std::uint32_t>(i), false);
            StereoImagePair pair = r.pair;
            pair.setId({1, static_cast<std::uint32_t>(i), {"sim-left", 0}, {"sim-right", 0}});
            SessionRecord record;
            record.iteration = i + 1;
            record.acquisition = pair.id();
            record.files = session.writePair(pair, Compression::Png);
            record.configVersion = 1;
            if (i == 0) record.configXml = writeConfigString(recorded);
            session.append(record);
            if (i == 3) {
                std::ofstream truth(temp / "truth03.txt");
                truth.precision(17);
                const render::CheckerboardTruth& t = *r.truth.checkerboard;
                for (std::size_t k = 0; k < t.cornersLeftPx.size(); ++k)
                    truth << t.cornersLeftPx[k].x << " " << t.cornersLeftPx[k].y << " " << t.cornersRightPx[k].x << " "
                          << t.cornersRightPx[k].y << "\n";
            }
        }
        std::ofstream(temp / "complete") << "rendered\n";
        std::error_code ec;
        fs::rename(temp, final, ec);  // another test process may have won: then use its copy
        if (ec) fs::remove_all(temp);
    }
};

const Boards& boards() {
    static const Boards b;
    return b;
}

std::string q(const fs::path& p) { return "'" + p.string() + "'"; }

TEST(AvatarCalibrate, CalibratesFromPngPairsWithTheIssuesCommandLine) {
    const Boards& b = boards();
    test::TempDir work;
    const ToolRun r = calibrate(work.path(), "--board 9x6 --square-mm 25 --left " + q(b.dir / "png" / "left*.png") +
                                                 " --right " + q(b.dir / "png" / "right*.png") + " --out " +
                                                 (work / "avatar.xml").string() + " --report " +
                                                 (work / "report.json").string());
    ASSERT_EQ(r.status, 0) << r.out << r.err;
    const nlohmann::json j = nlohmann::json::parse(slurp(work / "report.json"));
    EXPECT_EQ(j["pairs_used"], 12);
    ASSERT_EQ(j["pairs_skipped"].size(), 1u);
    EXPECT_NE(j["pairs_skipped"][0].get<std::string>().find("left_99.png"), std::string::npos);
    for (const char* key : {"rms_px", "epipolar_rms_px", "om", "T", "om_std", "T_std", "left", "right"})
        EXPECT_TRUE(j.contains(key)) << key;
    EXPECT_LT(j["rms_px"].get<double>(), 0.2);
    EXPECT_LT(j["epipolar_rms_px"].get<double>(), 0.2);
    const StereoSystemConfig truth = truthRig();
    for (const auto& [side, in] : {std::pair<const char*, const CameraIntrinsics&>{"left", truth.left},
                                   {"right", truth.right}}) {
        const nlohmann::json& c = j[side];
        for (const char* key : {"rms_px", "fc", "cc", "alpha_c", "kc", "fc_std", "cc_std", "kc_std"})
            EXPECT_TRUE(c.contains(key)) << side << " " << key;
        ASSERT_EQ(c["kc"].size(), 5u);
        ASSERT_EQ(c["kc_std"].size(), 5u);
        for (std::size_t i = 0; i < 2; ++i) {
            EXPECT_NEAR(c["fc"][i].get<double>(), in.fc[i], 4 * c["fc_std"][i].get<double>() + 0.5) << side;
            EXPECT_NEAR(c["cc"][i].get<double>(), in.cc[i], 4 * c["cc_std"][i].get<double>() + 0.5) << side;
        }
        EXPECT_NEAR(c["kc"][0].get<double>(), in.kc[0], 4 * c["kc_std"][0].get<double>() + 0.002) << side;
    }
    for (std::size_t i = 0; i < 3; ++i) {
        EXPECT_NEAR(j["om"][i].get<double>(), truth.om[i], 4 * j["om_std"][i].get<double>() + 1e-4);
        EXPECT_NEAR(j["T"][i].get<double>(), truth.translationMm[i], 4 * j["T_std"][i].get<double>() + 0.1);
    }
    // The configuration: a new one for 1280x960 8-bit colour images, with the calibration and its errors.
    const AvatarConfig c = readConfigFile(work / "avatar.xml");
    EXPECT_EQ(c.camera.width, 1280);
    EXPECT_EQ(c.camera.bitDepth, 8);
    ASSERT_TRUE(c.stereo.uncertainty);
    EXPECT_EQ(c.stereo.left.fc[0], j["left"]["fc"][0].get<double>());
    EXPECT_EQ(c.stereo.uncertainty->translationMm[2], j["T_std"][2].get<double>());
    EXPECT_TRUE(j["config_created"].get<bool>());
    EXPECT_NE(r.out.find("placeholder"), std::string::npos);
}

TEST(AvatarCalibrate, CalibratesFromRawBayerFilesIntoAnExistingConfiguration) {
    const Boards& b = boards();
    test::TempDir work;
    AvatarConfig existing = test::scorpionSample();  // 1280x960 16-bit Bayer, with a registration
    writeConfigFile(existing, work / "avatar.xml");
    const ToolRun r = calibrate(work.path(), "--board 9x6 --square-mm 25 --left " + q(b.dir / "raw" / "L_*.raw") +
                                                 " --right " + q(b.dir / "raw" / "R_*.raw") + " --out " +
                                                 (work / "avatar.xml").string() + " --report " +
                                                 (work / "report.json").string() + " --strategy refine-all");
    ASSERT_EQ(r.status, 0) << r.out << r.err;
    const AvatarConfig c = readConfigFile(work / "avatar.xml");
    EXPECT_EQ(c.targets, existing.targets);  // only the calibration changed
    EXPECT_EQ(c.stereo.baseTVision, existing.stereo.baseTVision);
    EXPECT_FALSE(c.stereo.left == existing.stereo.left);
    const nlohmann::json j = nlohmann::json::parse(slurp(work / "report.json"));
    EXPECT_EQ(j["strategy"], "refine-all");
    EXPECT_EQ(j["pairs_used"], 12);
    EXPECT_FALSE(j["config_created"].get<bool>());
    // 16-bit raw data gives corners at least as good as the 8-bit renditions.
    EXPECT_LT(j["rms_px"].get<double>(), 0.15);
}

TEST(AvatarCalibrate, CalibratesFromARecordedSession) {
    const Boards& b = boards();
    test::TempDir work;
    writeConfigFile(test::scorpionSample(), work / "avatar.xml");
    const ToolRun r = calibrate(work.path(), "--board 9x6 --square-mm 25 --session " + (b.dir / "session").string() +
                                                 " --out " + (work / "avatar.xml").string() + " --report " +
                                                 (work / "report.json").string());
    ASSERT_EQ(r.status, 0) << r.out << r.err;
    const nlohmann::json j = nlohmann::json::parse(slurp(work / "report.json"));
    EXPECT_EQ(j["pairs_used"], 12);
    EXPECT_LT(j["rms_px"].get<double>(), 0.15);
    const StereoSystemConfig truth = truthRig();
    EXPECT_NEAR(j["left"]["fc"][0].get<double>(), truth.left.fc[0], 4 * j["left"]["fc_std"][0].get<double>());
    EXPECT_NEAR(j["T"][0].get<double>(), truth.translationMm[0], 4 * j["T_std"][0].get<double>() + 0.05);
}

TEST(AvatarCalibrate, ExportsAndImportsRoundTrip) {
    test::TempDir work;
    AvatarConfig config = test::scorpionSample();
    config.stereo.left.kc = {-0.12, 0.08, 0.0008, -0.0005, 0.001};
    CalibrationUncertainty u;
    u.left = {{0.67, 0.68}, {1.13, 1.18}, 0.0, {0.002, 0.01, 0.0001, 0.0001, 0.0}};
    u.right = {{0.67, 0.69}, {1.22, 1.16}, 0.0, {0.002, 0.01, 0.0001, 0.0001, 0.0}};
    u.om = {0.001, 0.001, 0.0004};
    u.translationMm = {0.08, 0.07, 0.29};
    config.stereo.uncertainty = u;
    writeConfigFile(config, work / "avatar.xml");
    ToolRun r = calibrate(work.path(), "--config " + (work / "avatar.xml").string() + " --export-opencv " +
                                           (work / "stereo.yml").string() + " --export-ros " + (work / "ros").string());
    ASSERT_EQ(r.status, 0) << r.err;
    ASSERT_TRUE(fs::exists(work / "ros" / "left.yaml") && fs::exists(work / "ros" / "right.yaml"));

    // OpenCV: exact, standard errors included.
    writeConfigFile(test::scorpionSample(), work / "a.xml");
    r = calibrate(work.path(), "--import " + (work / "stereo.yml").string() + " --out " + (work / "a.xml").string());
    ASSERT_EQ(r.status, 0) << r.err;
    StereoSystemConfig back = readConfigFile(work / "a.xml").stereo;
    EXPECT_EQ(back.left, config.stereo.left);
    EXPECT_EQ(back.right, config.stereo.right);
    EXPECT_EQ(back.uncertainty, config.stereo.uncertainty);
    // R is kept as a matrix, so om comes back through two Rodrigues conversions.
    for (std::size_t i = 0; i < 3; ++i) {
        EXPECT_NEAR(back.om[i], config.stereo.om[i], 1e-13);
        EXPECT_EQ(back.translationMm[i], config.stereo.translationMm[i]);
    }
    // ROS: through the rectification and metres; to rounding.
    writeConfigFile(test::scorpionSample(), work / "b.xml");
    r = calibrate(work.path(), "--import " + (work / "ros").string() + " --out " + (work / "b.xml").string());
    ASSERT_EQ(r.status, 0) << r.err;
    back = readConfigFile(work / "b.xml").stereo;
    EXPECT_EQ(back.left, config.stereo.left);
    EXPECT_EQ(back.right, config.stereo.right);
    for (std::size_t i = 0; i < 3; ++i) {
        EXPECT_NEAR(back.om[i], config.stereo.om[i], 1e-12);
        EXPECT_NEAR(back.translationMm[i], config.stereo.translationMm[i], 1e-9);
    }
}

TEST(AvatarCalibrate, ImportsABouguetExport) {
    test::TempDir work;
    // Calib_Results_stereo.m as the toolbox writes it (Table 6-4), and the
    // printed form with +/- of the GUI.
    std::ofstream(work / "Calib_Results_stereo.m") << R"(% Intrinsic parameters of left camera:
fc_left = [ 1049.13 ; 1050.38 ];
cc_left = [ 712.28 ; 564.45 ];
alpha_c_left = [ 0.00000 ];
kc_left = [ -0.12 ; 0.08 ; 0.0008 ; -0.0005 ; 0.00000 ];
fc_left_error = [ 0.67 ; 0.68 ];
cc_left_error = [ 1.13 ; 1.18 ];
kc_left_error = [ 0.002 ; 0.01 ; 0.0001 ; 0.0001 ; 0.00000 ];
% Intrinsic parameters of right camera:
fc_right = [ 1047.20 ; 1048.66 ];
cc_right = [ 702.74 ; 561.13 ];
kc_right = [ -0.11 ; 0.07 ; -0.0006 ; 0.0004 ; 0.00000 ];
fc_right_error = [ 0.67 ; 0.69 ];
cc_right_error = [ 1.22 ; 1.16 ];
kc_right_error = [ 0.002 ; 0.01 ; 0.0001 ; 0.0001 ; 0.00000 ];
% Extrinsic parameters (position of right camera wrt left camera):
om = [ 0.002 ; 0.003 ; 0.047 ];
T = [ -106.53 ; -2.58 ; 0.82 ];
om_error = [ 0.001 ; 0.001 ; 0.000 ];
T_error = [ 0.08 ; 0.07 ; 0.29 ];
nx = 1280;
ny = 960;
)";
    std::ofstream(work / "printed.txt") << "Stereo calibration parameters after optimization:\n\n"
                                           "Focal Length:          fc_left = [ 1049.13   1050.38 ] \xC2\xB1 [ 0.67   0.68 ]\n"
                                           "Principal point:       cc_left = [ 712.28   564.45 ] \xC2\xB1 [ 1.13   1.18 ]\n"
                                           "Distortion:            kc_left = [ -0.12 0.08 0.0008 -0.0005 0 ] \xC2\xB1 [ 0.002 0.01 0.0001 0.0001 0 ]\n"
                                           "Focal Length:          fc_right = [ 1047.20   1048.66 ] +/- [ 0.67   0.69 ]\n"
                                           "Principal point:       cc_right = [ 702.74   561.13 ] +/- [ 1.22   1.16 ]\n"
                                           "Distortion:            kc_right = [ -0.11 0.07 -0.0006 0.0004 0 ] +/- [ 0.002 0.01 0.0001 0.0001 0 ]\n"
                                           "Rotation vector:             om = [ 0.002 0.003 0.047 ] \xC2\xB1 [ 0.001 0.001 0.000 ]\n"
                                           "Translation vector:           T = [ -106.53 -2.58 0.82 ] \xC2\xB1 [ 0.08 0.07 0.29 ]\n";
    for (const char* file : {"Calib_Results_stereo.m", "printed.txt"}) {
        SCOPED_TRACE(file);
        writeConfigFile(test::scorpionSample(), work / "c.xml");
        const ToolRun r = calibrate(work.path(), "--import " + (work / file).string() + " --out " +
                                                     (work / "c.xml").string() + " --report " + (work / "r.json").string());
        ASSERT_EQ(r.status, 0) << r.err;
        const StereoSystemConfig s = readConfigFile(work / "c.xml").stereo;
        EXPECT_EQ(s.left.fc, (std::array<double, 2>{1049.13, 1050.38}));
        EXPECT_EQ(s.right.cc, (std::array<double, 2>{702.74, 561.13}));
        EXPECT_EQ(s.left.kc[0], -0.12);
        EXPECT_EQ(s.om, (std::array<double, 3>{0.002, 0.003, 0.047}));
        EXPECT_EQ(s.translationMm, (std::array<double, 3>{-106.53, -2.58, 0.82}));
        ASSERT_TRUE(s.uncertainty);
        EXPECT_EQ(s.uncertainty->left.cc, (std::array<double, 2>{1.13, 1.18}));
        EXPECT_EQ(s.uncertainty->translationMm, (std::array<double, 3>{0.08, 0.07, 0.29}));
        EXPECT_EQ(nlohmann::json::parse(slurp(work / "r.json"))["format"], "bouguet");
    }
    std::ofstream(work / "broken.m") << "fc_left = [ 1049.13 ; 1050.38 ];\n";
    const ToolRun r = calibrate(work.path(), "--import " + (work / "broken.m").string() + " --out " + (work / "c.xml").string());
    EXPECT_EQ(r.status, 1);
    EXPECT_NE(r.err.find("no 'cc_left = [ ... ]'"), std::string::npos) << r.err;
}

TEST(AvatarCalibrate, DiagnosesAPairWithItsEssentialAndFundamentalMatrices) {
    const Boards& b = boards();
    test::TempDir work;
    AvatarConfig config = test::scorpionSample();
    config.stereo.left = truthRig().left;
    config.stereo.right = truthRig().right;
    writeConfigFile(config, work / "truth.xml");
    const ToolRun r = calibrate(work.path(), "--config " + (work / "truth.xml").string() + " --diagnose " +
                                                 (b.dir / "png" / "left_03.png").string() + "," +
                                                 (b.dir / "png" / "right_03.png").string() + " --board 9x6 --out " +
                                                 (work / "diag").string());
    ASSERT_EQ(r.status, 0) << r.err;
    for (const char* file : {"epipolar.png", "rectified.png"}) {
        const cv::Mat image = cv::imread((work / "diag" / file).string());
        ASSERT_FALSE(image.empty()) << file;
        EXPECT_EQ(image.cols, 2 * 1280) << file;
    }
    // F of the true calibration puts each true right corner on the epipolar
    // line of its left corner (undistorted pixels), to rounding.
    const nlohmann::json m = nlohmann::json::parse(slurp(work / "diag" / "matrices.json"));
    cv::Matx33d f;
    for (int i = 0; i < 3; ++i)
        for (int j = 0; j < 3; ++j) f(i, j) = m["F"][i][j].get<double>();
    ASSERT_EQ(b.truthLeft3.size(), 54u);
    for (std::size_t k = 0; k < b.truthLeft3.size(); ++k) {
        const cv::Point2d l = normalizedToPixel(config.stereo.left, *normalizePixelExact(config.stereo.left, b.truthLeft3[k]));
        const cv::Point2d rr = normalizedToPixel(config.stereo.right, *normalizePixelExact(config.stereo.right, b.truthRight3[k]));
        const cv::Vec3d line = f * cv::Vec3d(l.x, l.y, 1.0);
        EXPECT_LT(std::abs(cv::Vec3d(rr.x, rr.y, 1.0).dot(line)) / std::hypot(line[0], line[1]), 1e-6) << k;
    }
}

// Real photographs: OpenCV's sample stereo pairs (Debian's opencv-doc, which
// the set-up script installs): 13 pairs of 640x480 JPEG, a 9 x 6 board. Their
// true calibration is not known; what is: every board is found, the
// residuals are those of a good real calibration (OpenCV's own stereo_calib
// sample reports about 0.4 px on them), and the cameras are the ~536 px,
// ~3.3-square-baseline pair OpenCV documents.
TEST(AvatarCalibrate, CalibratesRealPhotographs) {
    const fs::path data = "/usr/share/doc/opencv-doc/examples/data";
    ASSERT_TRUE(fs::exists(data / "left01.jpg")) << "install Debian's opencv-doc (tools/scripts/bootstrap.sh does)";
    test::TempDir work;
    const ToolRun r = calibrate(work.path(), "--board 9x6 --square-mm 25 --left " + q(data / "left[0-9]*.jpg") +
                                                 " --right " + q(data / "right[0-9]*.jpg") + " --out " +
                                                 (work / "real.xml").string() + " --report " + (work / "real.json").string());
    ASSERT_EQ(r.status, 0) << r.out << r.err;
    const nlohmann::json j = nlohmann::json::parse(slurp(work / "real.json"));
    EXPECT_EQ(j["pairs_used"], 13);
    EXPECT_TRUE(j["pairs_skipped"].empty());
    EXPECT_LT(j["rms_px"].get<double>(), 0.6);
    EXPECT_LT(j["epipolar_rms_px"].get<double>(), 0.4);
    for (const char* side : {"left", "right"}) {
        EXPECT_NEAR(j[side]["fc"][0].get<double>(), 537.0, 8.0) << side;
        EXPECT_LT(j[side]["fc_std"][0].get<double>(), 2.0) << side;
        EXPECT_LT(j[side]["cc_std"][0].get<double>(), 2.0) << side;
    }
    EXPECT_NEAR(j["T"][0].get<double>() / 25.0, -3.34, 0.05);  // the baseline in squares
}

TEST(AvatarCalibrate, UsageAndInputErrorsAreNamed) {
    test::TempDir work;
    ToolRun r = calibrate(work.path(), "--board 9 --square-mm 25 --left 'x*' --right 'y*' --out a.xml");
    EXPECT_EQ(r.status, 2);
    EXPECT_NE(r.err.find("--board: expected the inner corners as COLUMNSxROWS"), std::string::npos) << r.err;
    r = calibrate(work.path(), "--board 9x6 --square-mm 25 --left " + q(work / "none*.png") + " --right " +
                                   q(work / "none*.png") + " --out " + (work / "a.xml").string());
    EXPECT_EQ(r.status, 1);
    EXPECT_NE(r.err.find("no file matches"), std::string::npos) << r.err;
    r = calibrate(work.path(), "--out " + (work / "a.xml").string());
    EXPECT_EQ(r.status, 2);
    EXPECT_NE(r.err.find("nothing to do"), std::string::npos) << r.err;
}

}  // namespace
}  // namespace avatar
