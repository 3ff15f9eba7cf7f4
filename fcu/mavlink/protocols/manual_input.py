"""Pilot sticks over MAVLink: MANUAL_CONTROL and RC_CHANNELS_OVERRIDE, and the RC failsafe.

Both messages become RC channel values, as in ArduCopter (``GCS_MAVLINK::manual_override``,
``handle_rc_channels_override``), then one normalised :class:`~fcu.navigation.sticks.Sticks`
record for the navigator. Channels are ArduCopter's RCMAP defaults: 1 roll, 2 pitch,
3 throttle, 4 yaw, PWM 1000..2000 us with 1500 at centre.

MANUAL_CONTROL (``x`` pitch, ``y`` roll, ``z`` throttle, ``r`` yaw; -1000..1000, ``z``
0..1000 as MAVSDK and QGroundControl send it for ArduPilot)::

    roll  = 1500 + y / 2     pitch = 1500 - x / 2   (x forward = nose down = low PWM)
    thr   = 1000 + z         yaw   = 1500 + r / 2

an axis at INT16_MAX (32767, "not used") releases its channel. RC_CHANNELS_OVERRIDE: a
channel at 0 is released, at UINT16_MAX (65535) left as it was. A released channel reads
centre (throttle mid-stick): there is no receiver behind the overrides. Every channel
released at once releases the sticks altogether (the navigator's pilot modes then fly as
without sticks).

RC failsafe (ArduCopter's radio failsafe, FS_THR_ENABLE)
-------------------------------------------------------
Sticks are *in use* once an input arrives while the vehicle is in a pilot mode (STABILIZE,
ALT_HOLD, LOITER, POSHOLD: ``ModeSpec.pilot``), until the mode is another one or the sticks
are released: a vehicle flown by a ground station without sticks never meets this failsafe
(ArduPilot has it only once an RC input has been seen). When no input has arrived for
RC_FS_TIMEOUT seconds of **wall-clock** time (a joystick sends in wall time: a simulation
speed-up must not fire it, as for the GCS failsafe of :mod:`fcu.mavlink.protocols.failsafe`):

- the sticks are released in the navigator whatever the mode (stale sticks never fly:
  ArduPilot's overrides expire after RC_OVERRIDE_TIME);
- if they were in use, the vehicle is flying (armed, not on the ground) and FS_THR_ENABLE
  is not 0, the failsafe fires once: 1 RTL, 2 RTL (continue a mission in AUTO: never met,
  AUTO is no pilot mode), 3 LAND (the default here; ArduCopter's default is 1); announced
  with a STATUSTEXT. On the ground nothing more happens (ArduCopter disarms; here the
  released sticks leave the vehicle to the idle auto-disarm, DISARM_DELAY, so that a
  ground station that sent one input, armed and switched to GUIDED a second later is not
  disarmed under its take-off). An input clears it (announced; the mode stays), as does
  disarming.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass
from enum import IntEnum

from fcu.mavlink.enums import Severity
from fcu.mavlink.port import VehiclePort
from fcu.mavlink.port_records import LandedState, ParamSpec
from fcu.mavlink.protocols.params import ParamEntry
from fcu.mavlink.transport.codec import MAVLinkMessage
from fcu.navigation.modes import MODE_TABLE
from fcu.navigation.sticks import Sticks

__all__ = ["ManualInput", "RcChannels", "RcFailsafe", "RcFailsafeAction", "RcFailsafeConfig",
           "manual_control_pwm"]

INT16_MAX = 32767  # MANUAL_CONTROL: axis not used
UINT16_MAX = 65535  # RC_CHANNELS_OVERRIDE: channel ignored (left as it was)
PWM_MIN_US, PWM_TRIM_US, PWM_MAX_US = 1000, 1500, 2000  # RCn_MIN, RCn_TRIM, RCn_MAX
ROLL, PITCH, THROTTLE, YAW = range(4)  # RCMAP_ROLL..RCMAP_YAW - 1

PILOT_MODES = frozenset(int(m) for m, spec in MODE_TABLE.items() if spec.pilot is not None)
"""Mode numbers flown by the sticks."""


class RcFailsafeAction(IntEnum):
    """FS_THR_ENABLE values (ArduCopter numbering; 4-7 need SmartRTL, DO_LAND_START)."""

    DISABLED = 0
    RTL = 1
    RTL_OR_CONTINUE_MISSION = 2
    LAND = 3


@dataclass(frozen=True, slots=True)
class RcFailsafeConfig:
    """FS_THR_ENABLE and RC_FS_TIMEOUT as read from the parameter table."""

    action: RcFailsafeAction = RcFailsafeAction.LAND
    timeout_s: float = 1.0  # s of wall-clock time


def manual_control_pwm(x: int, y: int, z: int, r: int) -> tuple[int | None, ...]:
    """MANUAL_CONTROL's axes as channel 1-4 PWM (us; None: released), ArduCopter's mapping."""

    def axis(value: int, offset: int, scale: float, reverse: bool = False) -> int | None:
        if value == INT16_MAX:
            return None
        value = -value if reverse else value
        pwm = PWM_MIN_US + (PWM_MAX_US - PWM_MIN_US) * (value + offset) / scale
        return int(min(max(round(pwm), PWM_MIN_US), PWM_MAX_US))

    return (axis(y, 1000, 2000.0), axis(x, 1000, 2000.0, reverse=True),
            axis(z, 0, 1000.0), axis(r, 1000, 2000.0))


class RcChannels:
    """Channels 1-4 as the overrides left them (None: released)."""

    def __init__(self) -> None:
        self.pwm: list[int | None] = [None] * 4

    def reset(self) -> None:
        """Every channel released."""
        self.pwm = [None] * 4

    def set(self, values: tuple[int | None, ...], *, keep: int | None = None) -> None:
        """Channels 1-4 from ``values`` (None or 0 releases; ``keep`` leaves it as it was)."""
        for i, value in enumerate(values[:4]):
            if keep is not None and value == keep:
                continue
            self.pwm[i] = None if value is None or value == 0 else \
                int(min(max(value, PWM_MIN_US), PWM_MAX_US))

    @property
    def released(self) -> bool:
        """No channel is overridden."""
        return all(v is None for v in self.pwm)

    def sticks(self, time_s: float) -> Sticks | None:
        """The normalised sticks (:class:`Sticks`), None when every channel is released."""
        if self.released:
            return None

        def centred(i: int) -> float:
            pwm = self.pwm[i]
            value = 0.0 if pwm is None else (pwm - PWM_TRIM_US) / (PWM_MAX_US - PWM_TRIM_US)
            return min(max(value, -1.0), 1.0)

        pwm = self.pwm[THROTTLE]
        throttle = 0.5 if pwm is None else (pwm - PWM_MIN_US) / (PWM_MAX_US - PWM_MIN_US)
        return Sticks(roll=centred(ROLL), pitch=centred(PITCH),
                      throttle=min(max(throttle, 0.0), 1.0), yaw=centred(YAW), time_s=time_s)


class RcFailsafe:
    """When stick input counts as lost (module docstring); times are wall-clock s."""

    def __init__(self) -> None:
        self.reset()

    def reset(self) -> None:
        """Nothing seen (boot, reboot)."""
        self._last_input_s = -math.inf
        self._in_use = False
        self._active = False
        self._forwarded = False  # the navigator holds sticks from an input

    @property
    def active(self) -> bool:
        """The failsafe has fired and no input has come back since."""
        return self._active

    @property
    def in_use(self) -> bool:
        """Sticks are flying a pilot mode (the failsafe is armed)."""
        return self._in_use

    def on_input(self, wall_time_s: float, mode: int, released: bool) -> bool:
        """An input arrived at ``wall_time_s`` with the vehicle in ``mode``; ``released``:
        it released every channel. Returns True when it cleared an active failsafe."""
        self._last_input_s = max(self._last_input_s, wall_time_s)
        self._in_use = not released and mode in PILOT_MODES
        self._forwarded = not released
        cleared = self._active and not released
        if cleared:
            self._active = False
        return cleared

    def stale(self, wall_time_s: float, config: RcFailsafeConfig) -> bool:
        """The navigator holds sticks older than ``timeout_s`` (they must be released)."""
        return self._forwarded and wall_time_s - self._last_input_s >= config.timeout_s

    def check(self, flying: bool, mode: int, wall_time_s: float, config: RcFailsafeConfig
              ) -> RcFailsafeAction | None:
        """Called when :meth:`stale`: releases the sticks, and returns the action to take
        now (once per loss) or None. ``flying``: armed and in the air."""
        self._forwarded = False
        in_use = self._in_use and mode in PILOT_MODES
        self._in_use = False
        if not flying or not in_use or self._active or \
                config.action == RcFailsafeAction.DISABLED:
            return None
        self._active = True
        return config.action

    def disarmed(self) -> bool:
        """The vehicle is disarmed: an active failsafe is over (True when it was active)."""
        was, self._active = self._active, False
        return was


class ManualInput:
    """Stick messages in, sticks and the RC failsafe out, for the endpoint.

    Parameters
    ----------
    port : VehiclePort
        The vehicle (sticks, failsafe, snapshot for the mode and arming).
    status : callable
        Sends a STATUSTEXT (severity, text).
    get_param : callable
        Reads a parameter of the endpoint's table (FS_THR_ENABLE, RC_FS_TIMEOUT).
    """

    def __init__(self, port: VehiclePort, status: Callable[[int, str], None],
                 get_param: Callable[[str], float]) -> None:
        self._port = port
        self._status = status
        self._get = get_param
        self.channels = RcChannels()
        self.failsafe = RcFailsafe()

    @staticmethod
    def param_entries(action: int = int(RcFailsafeAction.LAND), timeout_s: float = 1.0
                      ) -> list[ParamEntry]:
        """FS_THR_ENABLE and RC_FS_TIMEOUT (module docstring)."""
        return [
            ParamEntry(ParamSpec(
                name="FS_THR_ENABLE", value=action, min_value=0, max_value=3,
                allowed=tuple(float(a) for a in RcFailsafeAction), integer=True,
                description="RC failsafe (sticks lost in a pilot mode): 0 off, 1 RTL, "
                            "2 RTL/continue AUTO, 3 LAND")),
            ParamEntry(ParamSpec(
                name="RC_FS_TIMEOUT", value=timeout_s, min_value=0.5, max_value=10.0,
                description="Stick input loss before the RC failsafe, s (wall)")),
        ]

    def config(self) -> RcFailsafeConfig:
        """The FS_THR_ENABLE / RC_FS_TIMEOUT settings in force."""
        return RcFailsafeConfig(action=RcFailsafeAction(int(self._get("FS_THR_ENABLE"))),
                                timeout_s=self._get("RC_FS_TIMEOUT"))

    def reset(self) -> None:
        """Reboot: channels released, failsafe forgotten."""
        self.channels.reset()
        self.failsafe.reset()

    def manual_control(self, msg: MAVLinkMessage, wall_time_s: float) -> None:
        """MANUAL_CONTROL addressed to ``own_sysid`` (checked by the caller)."""
        self.channels.set(manual_control_pwm(int(msg.x), int(msg.y), int(msg.z), int(msg.r)))
        self._input(wall_time_s)

    def rc_override(self, msg: MAVLinkMessage, wall_time_s: float) -> None:
        """RC_CHANNELS_OVERRIDE (channels 1-4 used)."""
        self.channels.set((int(msg.chan1_raw), int(msg.chan2_raw), int(msg.chan3_raw),
                           int(msg.chan4_raw)), keep=UINT16_MAX)
        self._input(wall_time_s)

    def _input(self, wall_time_s: float) -> None:
        sticks = self.channels.sticks(wall_time_s)
        mode = self._port.snapshot().custom_mode
        if self.failsafe.on_input(wall_time_s, mode, sticks is None):
            self._port.clear_failsafe("radio")
            self._status(Severity.NOTICE, "Radio failsafe cleared: sticks back")
        self._port.set_sticks(sticks)

    def tick(self, time_s: float, wall_time_s: float) -> None:
        """Release stale sticks and run the failsafe (module docstring)."""
        fs = self.failsafe
        if fs.active and not self._port.snapshot().armed:
            if fs.disarmed():
                self._port.clear_failsafe("radio")
                self._status(Severity.NOTICE, "Radio failsafe cleared: vehicle disarmed")
            return
        config = self.config()
        if not fs.stale(wall_time_s, config):
            return  # the common tick
        snap = self._port.snapshot()
        flying = snap.armed and snap.landed_state != LandedState.ON_GROUND
        action = fs.check(flying, snap.custom_mode, wall_time_s, config)
        self._port.set_sticks(None)
        self.channels.reset()
        if action is None:
            return
        kind = "land" if action == RcFailsafeAction.LAND else "rtl"
        lost = f"Radio failsafe: no sticks for {config.timeout_s:g} s"
        result = self._port.trigger_failsafe("radio", kind)
        if result.accepted:
            self._status(Severity.CRITICAL, f"{lost}, {kind.upper()}")
        else:
            self._status(Severity.EMERGENCY, f"{lost}, {kind.upper()} refused: "
                         f"{result.reason}")

