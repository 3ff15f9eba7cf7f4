"""Flight modes of an ArduCopter-style vehicle: numbers, names and what each one does.

Modes (ArduCopter numbers, :class:`Mode`; the table is :data:`MODE_TABLE`)
--------------------------------------------------------------------------
=========  ==  ==========================================================================
STABILIZE   0  sticks: lean angles (ANGLE_MAX), collective, yaw rate. Without stick input:
               hold the altitude captured on entry, the horizontal position free
               (reference = estimate), i.e. level attitude
ALT_HOLD    2  sticks: lean angles, climb rate (PILOT_SPEED_UP/DN, THR_DZ about mid-stick),
               yaw rate. Without stick input: as STABILIZE
AUTO        3  fly the mission (:mod:`fcu.navigation.mission`); holds the last point once
               complete
GUIDED      4  take-off command, go-to (SET_POSITION_TARGET_LOCAL_NED, DO_REPOSITION)
LOITER      5  hold the stopping point (estimate + v|v| / 2a); sticks: horizontal velocity
               (LOIT_SPEED), climb rate as ALT_HOLD, yaw rate; centred sticks hold
RTL         6  climb to ``rtl_alt_m`` if lower, fly home, hold ``rtl_hold_s``, land
CIRCLE      7  circle a centre ``circle_radius_m`` ahead at ``circle_rate_deg_s``, facing it
               (ArduCopter's CIRCLE_RADIUS, CIRCLE_RATE); DO_ORBIT flies the same circle
               about the centre it gives (:mod:`fcu.navigation.circle`)
LAND        9  descend along a cubic to the ground, then creep down until landed
POSHOLD    16  as LOITER (the sticks fly the same law here)
BRAKE      17  as LOITER without sticks
FOLLOW     23  follow a lead vehicle's reports at an offset (ArduCopter's FOLL_*;
               :mod:`fcu.navigation.follow`); refused while FOLL_ENABLE is 0
=========  ==  ==========================================================================

The stick laws are :mod:`fcu.navigation.pilot_leg`'s (``ModeSpec.pilot``); with sticks, the
pilot modes also take off from the ground when the throttle is raised above the dead zone
and land (detected) when it is held below it. Other ArduCopter modes are refused with a
reason. Position modes (all but STABILIZE, ALT_HOLD, LAND) are refused while the caller
reports the estimator unhealthy.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass
from enum import IntEnum
from types import MappingProxyType
from typing import Literal

from fcu.navigation.pilot_leg import PilotLaw


class Mode(IntEnum):
    """Supported flight modes, numbered as ArduCopter's custom_mode."""

    STABILIZE = 0
    ALT_HOLD = 2
    AUTO = 3
    GUIDED = 4
    LOITER = 5
    RTL = 6
    CIRCLE = 7
    LAND = 9
    POSHOLD = 16
    BRAKE = 17
    FOLLOW = 23


#: All ArduCopter mode numbers and names (pymavlink ``mode_mapping_acm``), for messages.
ARDUCOPTER_MODE_NAMES: dict[int, str] = {
    0: "STABILIZE", 1: "ACRO", 2: "ALT_HOLD", 3: "AUTO", 4: "GUIDED", 5: "LOITER", 6: "RTL",
    7: "CIRCLE", 8: "POSITION", 9: "LAND", 10: "OF_LOITER", 11: "DRIFT", 13: "SPORT",
    14: "FLIP", 15: "AUTOTUNE", 16: "POSHOLD", 17: "BRAKE", 18: "THROW", 19: "AVOID_ADSB",
    20: "GUIDED_NOGPS", 21: "SMART_RTL", 22: "FLOWHOLD", 23: "FOLLOW", 24: "ZIGZAG",
    25: "SYSTEMID", 26: "AUTOROTATE", 27: "AUTO_RTL", 28: "TURTLE", 29: "RATE_ACRO",
}

SUPPORTED_MODE_NUMBERS: frozenset[int] = frozenset(int(m) for m in Mode)
"""The ArduCopter mode numbers this navigator flies."""


def mode_name(number: int) -> str:
    """ArduCopter name of mode ``number`` (``"MODE_<n>"`` when unknown)."""
    return ARDUCOPTER_MODE_NAMES.get(int(number), f"MODE_{int(number)}")


Behaviour = Literal["manual", "mission", "hold", "rtl", "land", "circle", "follow"]
"""What a mode does in flight: hold the altitude with the horizontal position free
(``manual``), fly the mission, hold the stopping point, return to launch, land, circle."""


@dataclass(frozen=True)
class ModeSpec:
    """One row of the mode table.

    Attributes
    ----------
    behaviour : Behaviour
        What the mode starts when entered in flight (or on a forced arm in the air).
    needs_position : bool
        Needs a healthy position estimate: refused while the estimator is unhealthy.
    lands : bool
        Ends on the ground: armed on the ground in it, the vehicle counts as landed
        (auto-disarm after ``landed_disarm_delay_s``).
    pilot : PilotLaw or None
        What stick input flies in this mode (:mod:`fcu.navigation.pilot_leg`); None: the
        mode ignores the sticks.
    """

    behaviour: Behaviour
    needs_position: bool
    lands: bool
    pilot: PilotLaw | None = None


MODE_TABLE: Mapping[Mode, ModeSpec] = MappingProxyType({
    Mode.STABILIZE: ModeSpec("manual", needs_position=False, lands=False, pilot="stabilize"),
    Mode.ALT_HOLD: ModeSpec("manual", needs_position=False, lands=False, pilot="alt_hold"),
    Mode.AUTO: ModeSpec("mission", needs_position=True, lands=False),
    Mode.GUIDED: ModeSpec("hold", needs_position=True, lands=False),
    Mode.LOITER: ModeSpec("hold", needs_position=True, lands=False, pilot="loiter"),
    Mode.RTL: ModeSpec("rtl", needs_position=True, lands=True),
    Mode.CIRCLE: ModeSpec("circle", needs_position=True, lands=False),
    Mode.LAND: ModeSpec("land", needs_position=False, lands=True),
    Mode.POSHOLD: ModeSpec("hold", needs_position=True, lands=False, pilot="loiter"),
    Mode.BRAKE: ModeSpec("hold", needs_position=True, lands=False),
    Mode.FOLLOW: ModeSpec("follow", needs_position=True, lands=False),
})
"""What each supported mode does (module docstring)."""
