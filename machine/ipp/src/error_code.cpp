// SPDX-License-Identifier: GPL-3.0-or-later
#include "metron/machine/ipp/error_code.hpp"

#include <array>

namespace metron::machine::ipp {
namespace {

using enum ErrorCode;
using S = Severity;

// I++ DME 1.4, error chapter (numbers, classes and texts as in NIST errorResponses.res).
constexpr std::array k_errors{
    ErrorInfo{BufferFull, S::Info, "Buffer full"},
    ErrorInfo{IllegalTag, S::Error, "Illegal tag"},
    ErrorInfo{NoSpaceAtPos6, S::Error, "No space at pos. 6"},
    ErrorInfo{TransactionAborted, S::Error, "Transaction aborted (Use ClearAllErrors to Continue)"},
    ErrorInfo{IllegalCharacter, S::Stop, "Illegal character"},
    ErrorInfo{ProtocolError, S::Stop, "Protocol error"},
    ErrorInfo{EmergencyStop, S::Stop, "Emergency stop"},
    ErrorInfo{UnsupportedCommand, S::Stop, "Unsupported command"},
    ErrorInfo{IncorrectArguments, S::Stop, "Incorrect arguments"},
    ErrorInfo{ControllerCommunicationsFailure, S::Fatal, "Controller communications failure"},
    ErrorInfo{ArgumentOutOfRange, S::Warning, "Argument out of range"},
    ErrorInfo{ArgumentNotRecognized, S::Stop, "Argument not recognized"},
    ErrorInfo{ArgumentNotSupported, S::Stop, "Argument not supported"},
    ErrorInfo{IllegalCommand, S::Stop, "Illegal command"},
    ErrorInfo{BadContext, S::Stop, "Bad context"},
    ErrorInfo{BadArgument, S::Stop, "Bad argument"},
    ErrorInfo{BadProperty, S::Stop, "Bad property"},
    ErrorInfo{ErrorProcessingMethod, S::Stop, "Error processing method"},
    ErrorInfo{NoDaemonsActive, S::Warning, "No daemons are active"},
    ErrorInfo{DaemonDoesNotExist, S::Error, "Daemon does not exist"},
    ErrorInfo{UseClearAllErrors, S::Error, "Use ClearAllErrors to continue"},
    ErrorInfo{DaemonAlreadyExists, S::Error, "Daemon already exists"},
    ErrorInfo{MachineInErrorState, S::Stop, "Machine in error state"},
    ErrorInfo{IllegalTouch, S::Error, "Illegal touch"},
    ErrorInfo{AxisDoesNotExist, S::Fatal, "Axis does not exist"},
    ErrorInfo{NoTouch, S::Error, "No touch"},
    ErrorInfo{NumberOfAnglesNotSupported, S::Fatal, "Number of angles not supported on current device"},
    ErrorInfo{ErrorDuringHome, S::Stop, "Error during home"},
    ErrorInfo{SurfaceNotFound, S::Error, "Surface not found"},
    ErrorInfo{ThetaOutOfRange, S::Stop, "Theta out of range"},
    ErrorInfo{TargetOutOfVolume, S::Stop, "Target position out of machine volume"},
    ErrorInfo{AirPressureOutOfRange, S::Stop, "Air pressure out of range"},
    ErrorInfo{VectorHasNoNorm, S::Error, "Vector has no norm"},
    ErrorInfo{FailedToReseatHead, S::Stop, "Failed to re-seat head"},
    ErrorInfo{ProbeNotArmed, S::Stop, "Probe not armed"},
    ErrorInfo{ToolNotFound, S::Stop, "Tool not found"},
    ErrorInfo{ToolNotDefined, S::Stop, "Tool not defined"},
    ErrorInfo{ToolNotCalibrated, S::Stop, "Tool not calibrated"},
    ErrorInfo{HeadErrorExcessiveForce, S::Error, "Head error excessive force"},
    ErrorInfo{ProbeTypeDoesNotAllow, S::Stop, "Type of probe does not allow this operation"},
    ErrorInfo{MachineLimitEncountered, S::Stop, "Machine limit encountered [Move Out Of Limits]"},
    ErrorInfo{AxisNotActive, S::Stop, "Axis not active"},
    ErrorInfo{AxisPositionError, S::Stop, "Axis position error"},
    ErrorInfo{ScaleReadHeadFailure, S::Fatal, "Scale read head failure"},
    ErrorInfo{Collision, S::Stop, "Collision"},
    ErrorInfo{AngleOutOfRange, S::Error, "Specified angle out of range"},
    ErrorInfo{PartNotAligned, S::Error, "Part not aligned"},
};

}  // namespace

const ErrorInfo& error_info(ErrorCode code) {
  for (const auto& e : k_errors)
    if (e.code == code) return e;
  return k_errors[5];  // unreachable for a valid enumerator: ProtocolError
}

std::optional<ErrorInfo> find_error(int number) {
  for (const auto& e : k_errors)
    if (static_cast<int>(e.code) == number) return e;
  return std::nullopt;
}

}  // namespace metron::machine::ipp
