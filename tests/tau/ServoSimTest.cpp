// The visual servo in closed loop through the whole system: every look is a
// rendered stereo pair analysed by the real pipeline behind TAUNet and read
// with TAUUnit; the arm is the simulated one with a 2 cm static error, and
// the vision system's registration is wrong by 5 degrees and 2 cm
// (tools/avatar-servo-sim's world). Seeds 201-... were not used for tuning.

#include "TempDir.h"

#include "ServoWorld.h"

#include <avatar/common/Error.h>
#include <avatar/config/ConfigXml.h>
#include <avatar/servo/AutoRegistration.h>

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>
#include <opencv2/core.hpp>

#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <string>
#include <thread>

namespace avatar::servosim {
namespace {

constexpr double kPi = 3.14159265358979323846;

WorldSpec spec(std::uint64_t seed, Scenario scenario = Scenario::Static) {
    WorldSpec s;
    s.config = readConfigFile(std::filesystem::path(AVATAR_DATA_DIR) / "config" / "servo-sim.xml");
    s.seed = seed;
    s.scenario = scenario;
    return s;
}

/// One run of the world's servo from its start, the sample picked as an operator would.
servo::ServoResult runFromTheStart(ServoWorld& world) {
    servo::ServoTask task;
    task.sampleHintBaseMm = world.sampleHintBaseMm();
    servo::VisualServo controller(world.arm(), world.vision(), world.servoConfig());
    return controller.run(task);
}

int countNotes(const servo::ServoResult& r, const std::string& text) {
    int n = 0;
    for (const servo::ServoStep& s : r.steps) n += s.note.find(text) != std::string::npos ? 1 : 0;
    return n;
}

TEST(ServoSim, ConvergesWhereDeadReckoningMissesByCentimetres) {
    for (std::uint64_t seed : {201u, 202u}) {
        SCOPED_TRACE("seed " + std::to_string(seed));
        const TaskOutcome o = runSamplingTask(spec(seed));
        EXPECT_EQ(o.servo.finalState, servo::ServoState::Done) << o.servo.reason;
        EXPECT_LE(o.servo.moves, 20);
        EXPECT_LE(o.servoFinal.errorMm, 5.0);
        EXPECT_GE(o.deadReckoningFinal.errorMm, 20.0);
        EXPECT_EQ(o.deadReckoning.moves, 1);
        EXPECT_EQ(o.deadReckoning.finalState, servo::ServoState::Done);
        // Every look was answered by the vision system through TAUNet, one per step.
        ASSERT_EQ(o.servoLooks.size(), o.servo.steps.size());
        EXPECT_EQ(o.servo.visionRequests, static_cast<int>(o.servo.steps.size()));
        // The moves: at most d_max, the last within d_last.
        for (const servo::ServoStep& s : o.servo.steps) {
            if (!s.commandedMoveMm) continue;
            EXPECT_LE(cv::norm(*s.commandedMoveMm), 50.0 + 1e-9);
            if (s.finalMove) {
                EXPECT_LE(s.distanceMm, 15.0);
            }
        }
        EXPECT_TRUE(o.servo.steps.back().finalMove);
    }
}

TEST(ServoSim, AKalmanFilteredRunConvergesToo) {
    WorldSpec s = spec(203);
    s.config.servo->filter = ServoFilter::Kalman;
    const TaskOutcome o = runSamplingTask(s);
    EXPECT_EQ(o.servo.finalState, servo::ServoState::Done) << o.servo.reason;
    EXPECT_LE(o.servoFinal.errorMm, 5.0);
}

TEST(ServoSim, TrackingKeepsTheSampleNotTheDistractorOfItsColour) {
    const TaskOutcome o = runSamplingTask(spec(204, Scenario::Distractor));
    EXPECT_EQ(o.servo.finalState, servo::ServoState::Done) << o.servo.reason;
    EXPECT_LE(o.servoFinal.errorMm, 5.0);
    // The sample followed never changed: every estimate within a few mm of the first.
    std::optional<cv::Point3d> first;
    for (const servo::ServoStep& step : o.servo.steps) {
        if (!step.visionSampleMm) continue;
        if (!first) first = step.visionSampleMm;
        EXPECT_LT(cv::norm(*step.visionSampleMm - *first), 10.0);
    }
}

TEST(ServoSim, WithoutAHintTwoSamplesOfOneColourAreAmbiguous) {
    ServoWorld world(spec(204, Scenario::Distractor));
    ServoConfig c = world.servoConfig();
    c.lostTimeoutMs = 1;
    servo::VisualServo controller(world.arm(), world.vision(), c);
    const servo::ServoResult r = controller.run({});
    EXPECT_EQ(r.finalState, servo::ServoState::TimedOut);
    EXPECT_EQ(r.moves, 0);
    EXPECT_NE(r.reason.find("2 whole 'sample' targets and no position to track from"), std::string::npos) << r.reason;
}

TEST(ServoSim, ALostSampleStopsTheServoUntilItIsSeenAgain) {
    WorldSpec s = spec(205, Scenario::Lost);
    s.config.servo->mode = ServoMode::Servo;
    s.lostFrom = 2;
    s.lostLooks = 3;
    const TaskOutcome o = runSamplingTask(s);
    EXPECT_EQ(o.servo.finalState, servo::ServoState::Done) << o.servo.reason;
    EXPECT_LE(o.servoFinal.errorMm, 5.0);
    // Looks 3, 4 and 5 saw no sample: no move was made from them.
    ASSERT_GE(o.servo.steps.size(), 6u);
    for (std::size_t i = 2; i < 5; ++i) {
        SCOPED_TRACE("look " + std::to_string(i + 1));
        EXPECT_FALSE(o.servo.steps[i].commandedMoveMm.has_value());
        EXPECT_EQ(o.servo.steps[i].note, "no stereo 'sample' target with a base-frame position");
        EXPECT_EQ(o.servo.steps[i].move, 2);
    }
    EXPECT_TRUE(o.servo.steps[5].commandedMoveMm.has_value());
}

TEST(ServoSim, HybridMovesOnTheLastPositionWhileTheSampleIsHidden) {
    WorldSpec s = spec(205, Scenario::Lost);
    s.config.servo->mode = ServoMode::Hybrid;
    const TaskOutcome o = runSamplingTask(s);
    EXPECT_EQ(o.servo.finalState, servo::ServoState::Done) << o.servo.reason;
    EXPECT_LE(o.servoFinal.errorMm, 5.0);
    EXPECT_GE(countNotes(o.servo, "sample not seen"), 1);
    for (const servo::ServoStep& step : o.servo.steps) {
        if (step.note.find("sample not seen") != std::string::npos) {
            EXPECT_TRUE(step.commandedMoveMm.has_value());
        }
    }
}

TEST(ServoSim, FollowsASlowlyMovingSample) {
    WorldSpec s = spec(206, Scenario::Moving);
    s.sampleSpeedMmPerLook = 2.0;
    const TaskOutcome o = runSamplingTask(s);
    EXPECT_EQ(o.servo.finalState, servo::ServoState::Done) << o.servo.reason;
    EXPECT_LE(o.servoFinal.errorMm, 5.0);
    // It did move: the sample's true position at the end is not where it began.
    EXPECT_GT(cv::norm(o.servoLooks.back().sampleBaseMm - o.servoLooks.front().sampleBaseMm), 5.0);
}

TEST(ServoSim, AnArmFaultEndsTheRunInFault) {
    ServoWorld world(spec(207));
    int moves = 0;
    world.arm().setPoseListener([&](const RigidTransform&) {
        if (++moves == 2) world.arm().injectFault("joint 2 at its limit");
    });
    const servo::ServoResult r = runFromTheStart(world);
    EXPECT_EQ(r.finalState, servo::ServoState::Fault);
    EXPECT_EQ(r.reason, "arm fault: joint 2 at its limit");
    EXPECT_EQ(r.moves, 2);
    EXPECT_EQ(r.transitions.back().second, servo::ServoEvent::ArmFault);
}

TEST(ServoSim, AbortFromAnotherThreadStopsTheArm) {
    WorldSpec s = spec(207);
    s.moveDuration = std::chrono::milliseconds(3000);
    ServoWorld world(s);
    servo::ServoTask task;
    task.sampleHintBaseMm = world.sampleHintBaseMm();
    servo::VisualServo controller(world.arm(), world.vision(), world.servoConfig());
    std::thread operatorThread([&] {
        while (world.arm().moves() == 0) std::this_thread::sleep_for(std::chrono::milliseconds(5));
        std::this_thread::sleep_for(std::chrono::milliseconds(100));
        controller.abort();
    });
    const servo::ServoResult r = controller.run(task);
    operatorThread.join();
    EXPECT_EQ(r.finalState, servo::ServoState::Aborted);
    EXPECT_EQ(r.reason, "aborted by the operator");
    EXPECT_EQ(r.moves, 1);
    EXPECT_FALSE(world.arm().telemetry().moving);  // halted mid-move
    EXPECT_LT(cv::norm(translationVector(world.arm().telemetry().baseTTool) - cv::Vec3d(world.startTelemetryMm().x,
                                                                                          world.startTelemetryMm().y,
                                                                                          world.startTelemetryMm().z)),
              40.0);
}

TEST(ServoSim, ASampleThatNeverReturnsTimesOut) {
    WorldSpec s = spec(208, Scenario::Lost);
    s.config.servo->mode = ServoMode::Servo;
    s.config.servo->lostTimeoutMs = 1500;
    s.lostFrom = 1;
    s.lostLooks = 1000;
    ServoWorld world(s);
    const servo::ServoResult r = runFromTheStart(world);
    EXPECT_EQ(r.finalState, servo::ServoState::TimedOut);
    EXPECT_EQ(r.moves, 1);
    EXPECT_EQ(r.reason.rfind("no usable vision data for ", 0), 0u) << r.reason;
    EXPECT_NE(r.reason.find("(lostTimeoutMs 1500): no stereo 'sample' target"), std::string::npos) << r.reason;
}

TEST(ServoSim, AnArmSeenTooFarFromTelemetryIsNeverMovedOn) {
    WorldSpec s = spec(209);
    s.config.servo->armToleranceMm = 30;  // the 5 degree, 2 cm registration puts it further
    s.config.servo->lostTimeoutMs = 1000;
    ServoWorld world(s);
    const servo::ServoResult r = runFromTheStart(world);
    EXPECT_EQ(r.finalState, servo::ServoState::TimedOut);
    EXPECT_EQ(r.moves, 0);
    EXPECT_EQ(world.arm().moves(), 0);
    EXPECT_NE(r.reason.find("within 30.0 mm of its expected position"), std::string::npos) << r.reason;
}

TEST(ServoSim, TheVisionSystemGoneEndsTheRunWithItsError) {
    WorldSpec s = spec(210);
    s.config.servo->lostTimeoutMs = 300;
    s.config.servo->visionTimeoutMs = 200;
    ServoWorld world(s);
    tau::TauUnitOptions o;
    o.port = 1;  // nothing listens: every request fails to connect
    o.connectTimeout = std::chrono::milliseconds(100);
    tau::TauUnit unit(o);
    servo::TauUnitVision vision(unit);
    servo::VisualServo controller(world.arm(), vision, world.servoConfig());
    const servo::ServoResult r = controller.run({});
    EXPECT_EQ(r.finalState, servo::ServoState::TimedOut);
    EXPECT_EQ(world.arm().moves(), 0);
    EXPECT_NE(r.reason.find("vision: "), std::string::npos) << r.reason;
    EXPECT_NE(r.reason.find("127.0.0.1:1"), std::string::npos) << r.reason;
}

TEST(ServoSim, AutomatedRegistrationRecoversTheArmsFrame) {
    ServoWorld world(spec(211));
    const servo::MotionRegistration reg =
        servo::registerByMotion(world.arm(), world.vision(), world.registrationWaypoints(), world.servoConfig());
    // A waypoint where the marker is hidden (by the sample) or cut is skipped, and says so.
    EXPECT_EQ(reg.visionMm.size() + reg.skipped.size(), 12u);
    EXPECT_GE(reg.visionMm.size(), 10u);
    for (const std::string& why : reg.skipped) {
        EXPECT_EQ(why.rfind("waypoint ", 0), 0u) << why;
    }
    // The registration maps vision onto the arm's telemetry frame: the truth
    // shifted by the arm's static error.
    const cv::Vec3d bias =
        translationVector(world.arm().trueBaseTTool()) - translationVector(world.arm().telemetry().baseTTool);
    const RigidTransform& truth = world.trueRegistration();
    const double rotationDeg =
        rotationAngleBetween(rotationMatrix(truth), rotationMatrix(reg.registration.baseTVision)) * 180.0 / kPi;
    EXPECT_LT(rotationDeg, 0.5);
    EXPECT_LT(cv::norm(translationVector(reg.registration.baseTVision) - (translationVector(truth) - bias)), 5.0);
    EXPECT_LT(reg.registration.rmsMm, 2.0);

    // With it, dead reckoning reaches the sample too.
    world.applyRegistration(reg.registration.baseTVision);
    world.resetArm();
    ServoConfig once = world.servoConfig();
    once.mode = ServoMode::DeadReckoning;
    servo::ServoTask task;
    task.sampleHintBaseMm = world.sampleHintBaseMm();
    servo::VisualServo dr(world.arm(), world.vision(), once);
    EXPECT_EQ(dr.run(task).finalState, servo::ServoState::Done);
    EXPECT_LT(world.truth().errorMm, 5.0);
}

TEST(ServoSim, TheToolWritesItsSummaryCsvAndPlots) {
    const test::TempDir dir;
    const std::string command = std::string(AVATAR_SERVO_SIM_EXECUTABLE) +
                                " --runs 1 --seed 212 --registration-error-deg 5 --registration-error-mm 20"
                                " --arm-bias-mm 20 --out " + dir.path().string() + " > " +
                                (dir.path() / "stdout.txt").string() + " 2>&1";
    ASSERT_EQ(std::system(command.c_str()), 0);
    std::ifstream in(dir.path() / "summary.json");
    const nlohmann::json summary = nlohmann::json::parse(in);
    ASSERT_EQ(summary.size(), 1u);
    ASSERT_EQ(summary.at("runs").size(), 1u);
    const nlohmann::json& run = summary["runs"][0];
    EXPECT_EQ(run.size(), 5u);
    EXPECT_EQ(run.at("seed").get<int>(), 212);
    EXPECT_TRUE(run.at("converged").get<bool>());
    EXPECT_LE(run.at("iterations").get<int>(), 20);
    EXPECT_LE(run.at("final_error_mm").get<double>(), 5.0);
    EXPECT_GE(run.at("dead_reckoning_error_mm").get<double>(), 20.0);
    EXPECT_TRUE(std::filesystem::exists(dir.path() / "run_212.png"));
    std::ifstream csv(dir.path() / "run_212.csv");
    std::string header;
    std::getline(csv, header);
    EXPECT_EQ(header.rfind("step,time_s,state,move,vision_iteration,telemetry_x", 0), 0u);
    EXPECT_NE(header.find(",move_x,move_y,move_z,"), std::string::npos);
    EXPECT_NE(header.find(",true_error_mm,"), std::string::npos);
    int rows = 0;
    for (std::string line; std::getline(csv, line);) ++rows;
    EXPECT_EQ(rows, run.at("iterations").get<int>() + 1);  // a row per look (all used here), and the end
}

TEST(ServoSim, TheToolRefusesBadArguments) {
    const test::TempDir dir;
    const std::string exe = AVATAR_SERVO_SIM_EXECUTABLE;
    const auto status = [&](const std::string& args) {
        const int raw = std::system((exe + " " + args + " > /dev/null 2>&1").c_str());
        return WIFEXITED(raw) ? WEXITSTATUS(raw) : -1;
    };
    EXPECT_EQ(status("--runs 1"), 2);                                             // no --out
    EXPECT_EQ(status("--runs 1 --out " + dir.path().string() + " --scenario x"), 1);
    EXPECT_EQ(status("--runs 1 --out " + dir.path().string() + " --arm-bias-mm -1"), 1);
    EXPECT_EQ(status("--runs x --out " + dir.path().string()), 2);
}

}  // namespace
}  // namespace avatar::servosim
