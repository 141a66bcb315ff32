// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once
#include <optional>
#include <string_view>

namespace metron::machine::ipp {

/// The error numbers of the I++ DME interface specification 1.4 (the list in its error chapter,
/// as the NIST test suite's errorResponses.res spells them).
enum class ErrorCode : int {
  BufferFull = 0,
  IllegalTag = 1,
  NoSpaceAtPos6 = 2,
  TransactionAborted = 6,
  IllegalCharacter = 7,
  ProtocolError = 8,
  EmergencyStop = 500,
  UnsupportedCommand = 501,
  IncorrectArguments = 502,
  ControllerCommunicationsFailure = 503,
  ArgumentOutOfRange = 504,
  ArgumentNotRecognized = 505,
  ArgumentNotSupported = 506,
  IllegalCommand = 507,
  BadContext = 508,
  BadArgument = 509,
  BadProperty = 510,
  ErrorProcessingMethod = 511,
  NoDaemonsActive = 512,
  DaemonDoesNotExist = 513,
  UseClearAllErrors = 514,
  DaemonAlreadyExists = 515,
  MachineInErrorState = 1000,
  IllegalTouch = 1001,
  AxisDoesNotExist = 1002,
  NoTouch = 1003,
  NumberOfAnglesNotSupported = 1004,
  ErrorDuringHome = 1005,
  SurfaceNotFound = 1006,
  ThetaOutOfRange = 1007,
  TargetOutOfVolume = 1008,
  AirPressureOutOfRange = 1009,
  VectorHasNoNorm = 1010,
  FailedToReseatHead = 1500,
  ProbeNotArmed = 1501,
  ToolNotFound = 1502,
  ToolNotDefined = 1503,
  ToolNotCalibrated = 2000,
  HeadErrorExcessiveForce = 2001,
  ProbeTypeDoesNotAllow = 2002,
  MachineLimitEncountered = 2500,
  AxisNotActive = 2501,
  AxisPositionError = 2502,
  ScaleReadHeadFailure = 2503,
  Collision = 2504,
  AngleOutOfRange = 2505,
  PartNotAligned = 2506,
};

/// Severity classes of the specification: what the server does after the error.
enum class Severity : int {
  Info = 0,     ///< a message only; the command goes on
  Warning = 1,  ///< the command goes on
  Error = 2,    ///< the command is not (fully) executed; the session goes on
  Stop = 3,     ///< the server stops: later commands are refused until ClearAllErrors
  Fatal = 9,    ///< the machine is unusable until the controller is reset
};

/// The specification's class and text of an error number.
struct ErrorInfo {
  ErrorCode code = ErrorCode::ProtocolError;
  Severity severity = Severity::Stop;
  std::string_view text;  ///< the specification's wording, e.g. "Illegal command"
};

/// The table entry of `code` (every enumerator has one).
const ErrorInfo& error_info(ErrorCode code);
/// The table entry of a numeric error code, when the specification defines it.
std::optional<ErrorInfo> find_error(int number);

}  // namespace metron::machine::ipp
