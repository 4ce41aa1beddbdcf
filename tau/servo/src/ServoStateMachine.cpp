#include <avatar/servo/ServoStateMachine.h>

#include <avatar/common/Error.h>

#include <optional>
#include <string>

namespace avatar::servo {

std::string_view toString(ServoState state) {
    switch (state) {
        case ServoState::Initialize: return "initialize";
        case ServoState::RequestVision: return "request_vision";
        case ServoState::WaitVision: return "wait_vision";
        case ServoState::ComputeMove: return "compute_move";
        case ServoState::ArmMoving: return "arm_moving";
        case ServoState::ArmSampling: return "arm_sampling";
        case ServoState::Done: return "done";
        case ServoState::Fault: return "fault";
        case ServoState::TimedOut: return "timed_out";
        case ServoState::Aborted: return "aborted";
    }
    return "?";
}

std::string_view toString(ServoEvent event) {
    switch (event) {
        case ServoEvent::VisionRequested: return "vision_requested";
        case ServoEvent::DataValid: return "data_valid";
        case ServoEvent::TargetsMissing: return "targets_missing";
        case ServoEvent::DataErrant: return "data_errant";
        case ServoEvent::MoveCommanded: return "move_commanded";
        case ServoEvent::FinalMoveCommanded: return "final_move_commanded";
        case ServoEvent::MotionComplete: return "motion_complete";
        case ServoEvent::ArmFault: return "arm_fault";
        case ServoEvent::Timeout: return "timeout";
        case ServoEvent::Abort: return "abort";
    }
    return "?";
}

bool isFinal(ServoState state) {
    return state == ServoState::Done || state == ServoState::Fault || state == ServoState::TimedOut ||
           state == ServoState::Aborted;
}

namespace {

/// The transitions particular to one state; std::nullopt when not allowed.
std::optional<ServoState> specific(ServoState s, ServoEvent e) {
    using S = ServoState;
    using E = ServoEvent;
    switch (s) {
        case S::Initialize:
            if (e == E::DataValid) return S::ComputeMove;
            if (e == E::TargetsMissing || e == E::DataErrant) return S::Initialize;
            break;
        case S::RequestVision:
            if (e == E::VisionRequested) return S::WaitVision;
            break;
        case S::WaitVision:
            if (e == E::DataValid) return S::ComputeMove;
            if (e == E::TargetsMissing || e == E::DataErrant) return S::RequestVision;
            break;
        case S::ComputeMove:
            if (e == E::MoveCommanded) return S::ArmMoving;
            if (e == E::FinalMoveCommanded) return S::ArmSampling;
            if (e == E::DataErrant) return S::RequestVision;
            break;
        case S::ArmMoving:
            if (e == E::MotionComplete) return S::RequestVision;
            break;
        case S::ArmSampling:
            if (e == E::MotionComplete) return S::Done;
            break;
        default: break;
    }
    return std::nullopt;
}

}  // namespace

ServoState nextState(ServoState state, ServoEvent event) {
    if (!isFinal(state)) {
        if (const std::optional<ServoState> next = specific(state, event)) {
            return *next;
        }
        if (event == ServoEvent::ArmFault) return ServoState::Fault;
        if (event == ServoEvent::Timeout) return ServoState::TimedOut;
        if (event == ServoEvent::Abort) return ServoState::Aborted;
    }
    throw InvalidState("illegal transition: " + std::string(toString(event)) + " in state " +
                       std::string(toString(state)));
}

ServoState ServoStateMachine::fire(ServoEvent event) {
    const ServoState next = nextState(state_, event);
    history_.emplace_back(state_, event);
    state_ = next;
    return next;
}

}  // namespace avatar::servo
