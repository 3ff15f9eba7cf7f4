"""Why a flight failed, each with the exit code ``ftc-gcs`` returns for it.

=====  ===================  =====================================================
code   error                when
=====  ===================  =====================================================
0      (none)               the mission was flown and the vehicle landed
1      :class:`Crashed`     the vehicle (simulator) reported a crash, or the vehicle
                            disarmed without ever taking off (FlightError)
2      (usage)              bad flags or input files (argparse convention)
3      VehicleNotFound      no HEARTBEAT from an autopilot within the timeout
3      SigningMismatch      the vehicle's MAVLink 2 signing does not match ours
4      CommandRefused       the vehicle refused a command or a parameter
4      VehicleBusy          the vehicle was found armed (flying, or about to)
4      RestartNeeded        the vehicle arms only after a restart (a failure detected in
                            an earlier flight), and the flight was not allowed one
5      MissionRejected      the vehicle rejected the mission upload
6      FlightTimeout        no answer, link lost, or the mission did not finish
130    (interrupted)        Ctrl-C
=====  ===================  =====================================================
"""

from __future__ import annotations

from flightdata.arguments import EXIT_INTERRUPTED, EXIT_USAGE

__all__ = [
    "EXIT_INTERRUPTED",
    "EXIT_OK",
    "EXIT_USAGE",
    "CommandRefused",
    "Crashed",
    "FlightError",
    "FlightTimeout",
    "MissionRejected",
    "RestartNeeded",
    "SigningMismatch",
    "VehicleBusy",
    "VehicleNotFound",
]

EXIT_OK = 0


class FlightError(Exception):
    """A flight that cannot go on; ``str(err)`` is the one-line reason."""

    exit_code = 1
    label = "flight failed"

    def __init__(self, reason: str) -> None:
        super().__init__(reason)
        self.reason = reason

    def one_line(self) -> str:
        """``<label>: <reason>`` on one line."""
        text = " ".join(self.reason.split())
        return f"{self.label}: {text}"


class Crashed(FlightError):
    """The vehicle crashed."""

    exit_code = 1
    label = "crash"


class VehicleNotFound(FlightError):
    """No vehicle answered."""

    exit_code = 3
    label = "vehicle not found"


class SigningMismatch(VehicleNotFound):
    """The vehicle signs with another key, or signs while we do not, or does not sign while
    we do: nothing we send would be obeyed (or nothing it sends verifies)."""

    label = "signing"


class CommandRefused(FlightError):
    """A command or parameter change was refused."""

    exit_code = 4
    label = "command refused"


class VehicleBusy(CommandRefused):
    """The vehicle is armed: someone else is flying it (or it is about to take off)."""

    label = "vehicle busy"


class RestartNeeded(CommandRefused):
    """The vehicle refuses to arm until its autopilot restarts (``--reboot`` allows it)."""

    label = "restart needed"


class MissionRejected(FlightError):
    """The mission upload was rejected; ``result`` is the MAV_MISSION_RESULT (None when not
    from a MISSION_ACK)."""

    exit_code = 5
    label = "mission rejected"

    def __init__(self, reason: str, *, result: int | None = None) -> None:
        super().__init__(reason)
        self.result = result


class FlightTimeout(FlightError):
    """Something did not happen in time (including a lost link)."""

    exit_code = 6
    label = "timeout"
