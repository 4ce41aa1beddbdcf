#pragma once
/// @file ServoStateMachine.h
/// The states of the visual-servo controller (thesis Figure 4-7) and the one
/// table of its legal transitions. An event the table does not allow in a
/// state is a programming error: fire() throws avatar::InvalidState naming
/// both, so the controller can never drift into an unplanned state.
///
///   state          event               next
///   Initialize     DataValid           ComputeMove   (both targets seen and consistent)
///   Initialize     TargetsMissing      Initialize    (ask again)
///   Initialize     DataErrant          Initialize
///   RequestVision  VisionRequested     WaitVision
///   WaitVision     DataValid           ComputeMove
///   WaitVision     TargetsMissing      RequestVision
///   WaitVision     DataErrant          RequestVision
///   ComputeMove    MoveCommanded       ArmMoving
///   ComputeMove    FinalMoveCommanded  ArmSampling   (within d_last, or dead reckoning)
///   ComputeMove    DataErrant          RequestVision (vision disagrees with telemetry)
///   ArmMoving      MotionComplete      RequestVision
///   ArmSampling    MotionComplete      Done
///   any but Done, Fault, TimedOut, Aborted:
///                  ArmFault            Fault
///                  Timeout             TimedOut
///                  Abort               Aborted
/// Done, Fault, TimedOut and Aborted are final: no event leaves them.

#include <string_view>
#include <utility>
#include <vector>

namespace avatar::servo {

enum class ServoState {
    Initialize,     ///< waiting for a data set with both the sample and the arm marker
    RequestVision,  ///< about to ask the vision system for data
    WaitVision,     ///< waiting for the vision system's answer
    ComputeMove,    ///< the visual-servo step of Figure 3-19
    ArmMoving,      ///< a move towards the sample is under way
    ArmSampling,    ///< the last move (onto the sample) is under way
    Done,           ///< the tool reached the sample
    Fault,          ///< the arm reported a fault
    TimedOut,       ///< a time or iteration limit ran out
    Aborted         ///< the operator stopped the run
};

enum class ServoEvent {
    VisionRequested,
    DataValid,
    TargetsMissing,
    DataErrant,
    MoveCommanded,
    FinalMoveCommanded,
    MotionComplete,
    ArmFault,
    Timeout,
    Abort
};

std::string_view toString(ServoState state);
std::string_view toString(ServoEvent event);

/// True for Done, Fault, TimedOut and Aborted.
bool isFinal(ServoState state);

/// The table above. Throws avatar::InvalidState ("illegal transition:
/// <event> in state <state>") for an event it does not allow.
ServoState nextState(ServoState state, ServoEvent event);

/// A state and the transitions taken so far.
class ServoStateMachine {
public:
    ServoState state() const { return state_; }
    /// Takes the transition (nextState()) and records it; throws as nextState().
    ServoState fire(ServoEvent event);
    /// Every transition taken: (state before, event).
    const std::vector<std::pair<ServoState, ServoEvent>>& history() const { return history_; }

private:
    ServoState state_{ServoState::Initialize};
    std::vector<std::pair<ServoState, ServoEvent>> history_;
};

}  // namespace avatar::servo
