// The visual servo's parts on their own: the state machine's whole transition
// table, target selection and the Kalman filter on reported data sets, and the
// simulated arm's kinematics and errors.

#include <avatar/common/Error.h>
#include <avatar/servo/ServoStateMachine.h>
#include <avatar/servo/SimulatedArm.h>
#include <avatar/servo/Tracking.h>

#include <gtest/gtest.h>
#include <opencv2/core.hpp>

#include <chrono>
#include <cmath>
#include <map>
#include <thread>
#include <utility>
#include <vector>

namespace avatar::servo {
namespace {

using S = ServoState;
using E = ServoEvent;

const std::vector<S> kStates = {S::Initialize, S::RequestVision, S::WaitVision, S::ComputeMove, S::ArmMoving,
                                S::ArmSampling, S::Done,          S::Fault,      S::TimedOut,    S::Aborted};
const std::vector<E> kEvents = {E::VisionRequested, E::DataValid,     E::TargetsMissing, E::DataErrant,
                                E::MoveCommanded,   E::FinalMoveCommanded, E::MotionComplete, E::ArmFault,
                                E::Timeout,         E::Abort};

// Figure 4-7 as a table: every legal (state, event) and where it leads. Any
// pair not listed must be refused.
const std::map<std::pair<S, E>, S> kLegal = {
    {{S::Initialize, E::DataValid}, S::ComputeMove},
    {{S::Initialize, E::TargetsMissing}, S::Initialize},
    {{S::Initialize, E::DataErrant}, S::Initialize},
    {{S::RequestVision, E::VisionRequested}, S::WaitVision},
    {{S::WaitVision, E::DataValid}, S::ComputeMove},
    {{S::WaitVision, E::TargetsMissing}, S::RequestVision},
    {{S::WaitVision, E::DataErrant}, S::RequestVision},
    {{S::ComputeMove, E::MoveCommanded}, S::ArmMoving},
    {{S::ComputeMove, E::FinalMoveCommanded}, S::ArmSampling},
    {{S::ComputeMove, E::DataErrant}, S::RequestVision},
    {{S::ArmMoving, E::MotionComplete}, S::RequestVision},
    {{S::ArmSampling, E::MotionComplete}, S::Done},
};

TEST(ServoStateMachine, EveryTransitionOfTheTable) {
    int legal = 0;
    int refused = 0;
    for (S s : kStates) {
        for (E e : kEvents) {
            SCOPED_TRACE(std::string(toString(s)) + " + " + std::string(toString(e)));
            std::optional<S> expected;
            if (const auto it = kLegal.find({s, e}); it != kLegal.end()) {
                expected = it->second;
            } else if (!isFinal(s) && e == E::ArmFault) {
                expected = S::Fault;
            } else if (!isFinal(s) && e == E::Timeout) {
                expected = S::TimedOut;
            } else if (!isFinal(s) && e == E::Abort) {
                expected = S::Aborted;
            }
            if (expected) {
                EXPECT_EQ(nextState(s, e), *expected);
                ++legal;
            } else {
                try {
                    nextState(s, e);
                    ADD_FAILURE() << "accepted";
                } catch (const InvalidState& error) {
                    EXPECT_EQ(std::string(error.what()), "illegal transition: " + std::string(toString(e)) +
                                                             " in state " + std::string(toString(s)));
                }
                ++refused;
            }
        }
    }
    EXPECT_EQ(legal, 12 + 6 * 3);  // the table, and fault/timeout/abort from the six working states
    EXPECT_EQ(refused, 100 - legal);
}

TEST(ServoStateMachine, FinalStatesAreTheFourEnds) {
    for (S s : kStates) {
        const bool end = s == S::Done || s == S::Fault || s == S::TimedOut || s == S::Aborted;
        EXPECT_EQ(isFinal(s), end) << toString(s);
    }
}

TEST(ServoStateMachine, RecordsItsHistoryAndRefusesWithoutChanging) {
    ServoStateMachine m;
    EXPECT_EQ(m.state(), S::Initialize);
    m.fire(E::TargetsMissing);
    m.fire(E::DataValid);
    m.fire(E::MoveCommanded);
    EXPECT_THROW(m.fire(E::DataValid), InvalidState);  // no vision data while the arm moves
    EXPECT_EQ(m.state(), S::ArmMoving);
    m.fire(E::MotionComplete);
    m.fire(E::VisionRequested);
    m.fire(E::DataValid);
    m.fire(E::FinalMoveCommanded);
    m.fire(E::MotionComplete);
    EXPECT_EQ(m.state(), S::Done);
    EXPECT_THROW(m.fire(E::Abort), InvalidState);
    const std::vector<std::pair<S, E>> expected = {
        {S::Initialize, E::TargetsMissing}, {S::Initialize, E::DataValid},    {S::ComputeMove, E::MoveCommanded},
        {S::ArmMoving, E::MotionComplete},  {S::RequestVision, E::VisionRequested}, {S::WaitVision, E::DataValid},
        {S::ComputeMove, E::FinalMoveCommanded}, {S::ArmSampling, E::MotionComplete}};
    EXPECT_EQ(m.history(), expected);
}

// ---- target selection --------------------------------------------------

VisionTarget target(const std::string& type, cv::Point3d base, std::uint32_t flags = kTargetStereo | kTargetWhole) {
    VisionTarget t;
    t.type = type;
    t.flags = flags;
    t.positionVisionMm = base;
    t.positionBaseMm = base;
    return t;
}

TEST(TargetSelection, TheOnlyWholeTargetWithoutAnExpectedPosition) {
    VisionTargets data;
    data.targets = {target("arm", {0, 0, 0}), target("sample", {100, 0, 0})};
    const TargetSighting s = selectTarget(data, "sample", {});
    ASSERT_EQ(s.status, Sighting::Found);
    EXPECT_EQ(s.target->positionBaseMm, cv::Point3d(100, 0, 0));
}

TEST(TargetSelection, SeveralWholeTargetsWithoutAPositionAreAmbiguous) {
    VisionTargets data;
    data.targets = {target("sample", {100, 0, 0}), target("sample", {200, 0, 0})};
    const TargetSighting s = selectTarget(data, "sample", {});
    EXPECT_EQ(s.status, Sighting::Ambiguous);
    EXPECT_EQ(s.why, "2 whole 'sample' targets and no position to track from");
}

TEST(TargetSelection, TheNearestToTheExpectedPosition) {
    VisionTargets data;
    data.targets = {target("sample", {100, 0, 0}), target("sample", {180, 0, 0}), target("sample", {130, 4, 0})};
    SelectionRule rule;
    rule.expectedBaseMm = cv::Point3d(125, 0, 0);
    const TargetSighting s = selectTarget(data, "sample", rule);
    ASSERT_EQ(s.status, Sighting::Found);
    EXPECT_EQ(s.target->positionBaseMm, cv::Point3d(130, 4, 0));
    EXPECT_NEAR(s.distanceMm, std::hypot(5.0, 4.0), 1e-12);
}

TEST(TargetSelection, AJumpIsErrantAndAFarTargetIsAnotherObject) {
    VisionTargets data;
    data.targets = {target("sample", {130, 0, 0})};
    SelectionRule rule;
    rule.expectedBaseMm = cv::Point3d(100, 0, 0);
    rule.maxJumpMm = 20;
    rule.trackingRadiusMm = 60;
    TargetSighting s = selectTarget(data, "sample", rule);
    EXPECT_EQ(s.status, Sighting::Jumped);
    EXPECT_EQ(s.why, "the 'sample' target moved 30.0 mm from its expected position (at most 20.0 mm)");
    rule.trackingRadiusMm = 25;
    s = selectTarget(data, "sample", rule);
    EXPECT_EQ(s.status, Sighting::Missing);
    EXPECT_EQ(s.why, "no 'sample' target within 25.0 mm of its expected position (nearest 30.0 mm)");
}

TEST(TargetSelection, AFlaggedTargetIsNotUsed) {
    VisionTargets data;
    data.targets = {target("sample", {100, 0, 0}, kTargetStereo | kTargetOccludedLeft)};
    SelectionRule rule;
    rule.expectedBaseMm = cv::Point3d(100, 0, 0);
    TargetSighting s = selectTarget(data, "sample", rule);
    EXPECT_EQ(s.status, Sighting::Flagged);
    EXPECT_EQ(s.why, "the 'sample' target is not whole (stereo,occluded-left)");
    s = selectTarget(data, "sample", {});
    EXPECT_EQ(s.status, Sighting::Flagged);
}

TEST(TargetSelection, NoBaseFramePositionIsMissing) {
    VisionTargets data;
    VisionTarget left;
    left.type = "sample";
    left.flags = kTargetLeftOnly;
    data.targets = {left};
    const TargetSighting s = selectTarget(data, "sample", {});
    EXPECT_EQ(s.status, Sighting::Missing);
    EXPECT_EQ(s.why, "no stereo 'sample' target with a base-frame position");
}

// ---- the Kalman filter ---------------------------------------------------

TEST(PositionFilter, TwoMeasurementsGiveTheirInverseVarianceMean) {
    PositionFilter f;
    EXPECT_FALSE(f.initialised());
    f.update({0, 0, 0}, cv::Matx33d::diag({1, 4, 9}));
    EXPECT_TRUE(f.initialised());
    const Estimate& e = f.update({10, 10, 10}, cv::Matx33d::diag({1, 1, 1}));
    // per axis: (x1/v1 + x2/v2) / (1/v1 + 1/v2), variance 1 / (1/v1 + 1/v2)
    EXPECT_NEAR(e.positionMm.x, 5.0, 1e-12);
    EXPECT_NEAR(e.positionMm.y, 8.0, 1e-12);
    EXPECT_NEAR(e.positionMm.z, 9.0, 1e-12);
    EXPECT_NEAR(e.covarianceMm2(0, 0), 0.5, 1e-12);
    EXPECT_NEAR(e.covarianceMm2(1, 1), 0.8, 1e-12);
    EXPECT_NEAR(e.covarianceMm2(2, 2), 0.9, 1e-12);
}

TEST(PositionFilter, ProcessNoiseLetsNewMeasurementsCountMore) {
    PositionFilter still, drifting;
    for (PositionFilter* f : {&still, &drifting}) {
        f->update({0, 0, 0}, cv::Matx33d::eye());
    }
    drifting.predict(3.0);  // variance 1 + 9
    still.predict(0.0);
    const double a = still.update({10, 0, 0}, cv::Matx33d::eye()).positionMm.x;
    const double b = drifting.update({10, 0, 0}, cv::Matx33d::eye()).positionMm.x;
    EXPECT_NEAR(a, 5.0, 1e-12);
    EXPECT_NEAR(b, 10.0 * 10.0 / 11.0, 1e-12);
}

TEST(PositionFilter, RefusesACovarianceThatIsNotPositiveDefinite) {
    PositionFilter f;
    EXPECT_THROW(f.update({0, 0, 0}, cv::Matx33d::diag({1, 0, 1})), InvalidArgument);
    EXPECT_FALSE(f.initialised());
}

// ---- the simulated arm ---------------------------------------------------

SimulatedArmOptions armAt(cv::Vec3d tip) {
    SimulatedArmOptions o;
    o.startBaseTTool = makeRigidTransform(cv::Matx33d::eye(), tip);
    return o;
}

TEST(SimulatedArm, TelemetryIsTheCommandAndTheToolMissesItByTheBias) {
    SimulatedArmOptions o = armAt({500, 0, -100});
    o.staticBiasMm = {12, -16, 0};  // 20 mm
    o.repeatabilityMm = 0;
    SimulatedArm arm(o);
    arm.moveTo({550, 10, -90});
    EXPECT_TRUE(arm.motionComplete());
    EXPECT_EQ(translationVector(arm.telemetry().baseTTool), cv::Vec3d(550, 10, -90));
    EXPECT_EQ(translationVector(arm.trueBaseTTool()), cv::Vec3d(562, -6, -90));
    EXPECT_EQ(arm.moves(), 1);
}

TEST(SimulatedArm, RepeatabilityNoiseHasItsStandardDeviation) {
    SimulatedArmOptions o = armAt({0, 0, 0});
    o.repeatabilityMm = 0.5;
    o.seed = 3;
    SimulatedArm arm(o);
    double sum = 0, sq = 0;
    const int n = 4000;
    for (int i = 0; i < n; ++i) {
        arm.moveTo({static_cast<double>(i % 2), 0, 0});
        ASSERT_TRUE(arm.motionComplete());
        const double dx = translationVector(arm.trueBaseTTool())[1];  // y: commanded 0
        sum += dx;
        sq += dx * dx;
    }
    EXPECT_NEAR(sum / n, 0.0, 0.05);
    EXPECT_NEAR(std::sqrt(sq / n), 0.5, 0.03);
}

TEST(SimulatedArm, MovesTakeTheirTimeAndRefuseToOverlap) {
    SimulatedArmOptions o = armAt({0, 0, 0});
    o.moveDuration = std::chrono::milliseconds(150);
    o.repeatabilityMm = 0;
    SimulatedArm arm(o);
    int poses = 0;
    arm.setPoseListener([&](const RigidTransform&) { ++poses; });
    arm.moveTo({100, 0, 0});
    EXPECT_FALSE(arm.motionComplete());
    EXPECT_TRUE(arm.telemetry().moving);
    EXPECT_THROW(arm.moveTo({0, 0, 0}), InvalidState);
    std::this_thread::sleep_for(std::chrono::milliseconds(60));
    const double halfway = translationVector(arm.telemetry().baseTTool)[0];
    EXPECT_GT(halfway, 0.0);
    EXPECT_LT(halfway, 100.0);
    std::this_thread::sleep_for(std::chrono::milliseconds(120));
    EXPECT_TRUE(arm.motionComplete());
    EXPECT_EQ(poses, 1);
    EXPECT_EQ(translationVector(arm.telemetry().baseTTool), cv::Vec3d(100, 0, 0));
}

TEST(SimulatedArm, HaltStopsWhereItIs) {
    SimulatedArmOptions o = armAt({0, 0, 0});
    o.moveDuration = std::chrono::milliseconds(200);
    o.repeatabilityMm = 0;
    SimulatedArm arm(o);
    arm.moveTo({100, 0, 0});
    std::this_thread::sleep_for(std::chrono::milliseconds(50));
    arm.halt();
    EXPECT_TRUE(arm.motionComplete());
    const double x = translationVector(arm.telemetry().baseTTool)[0];
    EXPECT_GT(x, 0.0);
    EXPECT_LT(x, 100.0);
}

TEST(SimulatedArm, OutOfReachAndInjectedFaults) {
    SimulatedArmOptions o = armAt({500, 0, 0});
    o.reachMm = 1000;
    SimulatedArm arm(o);
    EXPECT_FALSE(arm.fault().has_value());
    EXPECT_THROW(arm.moveTo({1200, 0, 0}), InvalidState);
    ASSERT_TRUE(arm.fault().has_value());
    EXPECT_NE(arm.fault()->find("out of reach"), std::string::npos);
    SimulatedArm other(armAt({0, 0, 0}));
    other.injectFault("joint 3 over temperature");
    EXPECT_EQ(other.fault(), std::optional<std::string>("joint 3 over temperature"));
    EXPECT_THROW(other.moveTo({1, 0, 0}), InvalidState);
}

TEST(SimulatedArm, RefusesBadOptions) {
    SimulatedArmOptions o;
    o.repeatabilityMm = -1;
    EXPECT_THROW(SimulatedArm{o}, InvalidArgument);
    o.repeatabilityMm = 0;
    o.moveDuration = std::chrono::milliseconds(-1);
    EXPECT_THROW(SimulatedArm{o}, InvalidArgument);
}

}  // namespace
}  // namespace avatar::servo
