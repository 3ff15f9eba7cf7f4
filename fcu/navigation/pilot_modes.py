"""The pilot modes' layer of the navigator: sticks in, pilot legs flown.

STABILIZE, ALT_HOLD, LOITER and POSHOLD are flown by the sticks (:mod:`fcu.navigation.sticks`)
while a stick input is in force (:meth:`PilotModes.set_sticks`), through a "pilot" leg
(:mod:`fcu.navigation.pilot_leg`, the law ``ModeSpec.pilot`` names). Without stick input they
fly as they always have (STABILIZE, ALT_HOLD: hold the altitude, level; LOITER, POSHOLD: hold
the stopping point), so a vehicle flown by a ground station alone never meets a stick law.

- In flight in a pilot mode, the first tick with sticks turns the mode's leg into a pilot leg
  starting from the reference flown so far (a mode entered with sticks in force starts its
  usual leg, then this); released sticks (None) give the mode's usual leg back, from where
  the vehicle is.
- Armed on the ground in a pilot mode, a throttle above the dead zone takes off (ArduCopter's
  "raise the throttle"); the leg reports itself a take-off (crash check: no ground-contact
  test) until the vehicle no longer looks on the ground.
- A throttle not raised above the dead zone lets the landing detector run (a vehicle in the
  air does not look on the ground, so it only finds a vehicle brought down); the leg reports
  itself a landing while the vehicle looks on the ground (crash check: no ground-contact
  test). Landed, the vehicle disarms as after any landing unless the throttle is raised
  again.

When sticks time out the endpoint's RC failsafe (:mod:`fcu.mavlink.protocols.manual_input`) releases
them and triggers the failsafe action; the navigator itself never reads a clock for them.
"""

from __future__ import annotations

import numpy as np

from fcu.navigation.events import CommandResult
from fcu.navigation.flight import FlightLegs
from fcu.navigation.legs import Leg
from fcu.navigation.modes import MODE_TABLE, Mode
from fcu.navigation.pilot_leg import Demand, PilotLaw, PilotLeg
from fcu.navigation.sticks import Sticks

__all__ = ["PilotModes"]


class PilotModes(FlightLegs):
    """Stick input and the pilot legs (module docstring); a layer of the navigator."""

    _mode: Mode  # the navigator's flight mode

    def _reset_flight(self) -> None:
        super()._reset_flight()
        self._sticks: Sticks | None = None

    @property
    def sticks(self) -> Sticks | None:
        """The stick input in force (None: none, or released)."""
        return self._sticks

    def set_sticks(self, sticks: Sticks | None) -> CommandResult:
        """The pilot's latest stick input (MANUAL_CONTROL, RC overrides); None releases the
        sticks. Flown from the next step, in the pilot modes only."""
        if sticks is not None and not isinstance(sticks, Sticks):
            return self._refuse("sticks", f"{sticks!r} is not a Sticks record")
        self._sticks = sticks
        return self._ok()

    @property
    def flying_pilot_leg(self) -> bool:
        """The leg flown follows live input (sticks, GUIDED velocity or attitude set-points):
        where it goes is decided as it flies, not planned."""
        return self._leg is not None and self._leg.pilot is not None

    @property
    def stopping_point_ned(self) -> np.ndarray:
        """Where the vehicle would stop if braked now (estimate + v|v| / 2a, m, NED)."""
        return self._stopping_point()

    @property
    def leg_kind(self) -> str:
        """As :attr:`FlightLegs.leg_kind`; a pilot leg is "takeoff" while it lifts off the
        ground, "land" while the throttle asks to descend, else "pilot"."""
        kind = super().leg_kind
        pilot = self._leg.pilot if kind == "pilot" and self._leg is not None else None
        if pilot is None:
            return kind
        if pilot.from_ground:
            return "takeoff"
        return "land" if pilot.grounded and not pilot.climbing else kind

    def _pilot_leg(self, t: float, *, from_ground: bool = False,
                   law: PilotLaw | None = None) -> Leg:
        """A pilot leg flying ``law`` (None: the mode's) from the reference flown so far, or
        from the estimate at rest when ``from_ground``."""
        law = MODE_TABLE[self._mode].pilot if law is None else law
        assert law is not None
        if from_ground:
            pos, vel, yaw = self._est_pos_ned, np.zeros(3), self._est_yaw_rad
        else:
            ref = self._reference(t)
            pos, vel, yaw = ref.pos_ned, ref.vel_ned, ref.yaw_rad
        pilot = PilotLeg(law, self.config.pilot, t, pos, vel, yaw, from_ground=from_ground)
        return Leg("pilot", None, pilot=pilot)

    def _run_flight(self, t: float, max_transitions: int) -> None:
        leg = self._leg
        law = MODE_TABLE[self._mode].pilot
        pilot = leg.pilot if leg is not None else None
        if law is None or (pilot is None and self._sticks is None) or leg is None or \
                leg.kind not in ("manual", "hold", "pilot"):
            super()._run_flight(t, max_transitions)
            return
        sticks = self._sticks
        if sticks is None:  # released: the mode's usual leg, from where the vehicle is
            if law == "loiter":
                self._enter_hold(t)
            else:
                self._enter_manual(t)
            self._landing.reset()
            return
        if pilot is None or pilot.law != law:
            leg = self._leg = self._pilot_leg(t)
            pilot = leg.pilot
            assert pilot is not None
            self._event("mode", f"{self._mode.name}: flown by the sticks")
        self._fly_pilot(t, leg, pilot, Demand.of_sticks(sticks, self.config.pilot))

    def _fly_pilot(self, t: float, leg: Leg, pilot: PilotLeg, demand: Demand) -> None:
        """Advance the pilot leg ``leg`` to ``t`` (s) under ``demand``: its targets, whether
        it still lifts off, and landing detection unless it climbs."""
        pilot.advance(t, demand, self._est_pos_ned, self._est_vel_ned)
        pilot.grounded = self._looks_on_ground()
        if pilot.from_ground and not pilot.grounded:
            pilot.from_ground = False
        if pilot.climbing:
            self._landing.reset()
        else:
            self._detect_landing(t, leg)

    def _pilot_takeoff(self, t: float) -> bool:
        """Armed on the ground at ``t`` (s): a pilot mode with the throttle raised above the
        dead zone takes off (True)."""
        sticks = self._sticks
        if sticks is None or MODE_TABLE[self._mode].pilot is None:
            return False
        if sticks.throttle <= 0.5 + self.config.pilot.throttle_deadzone:
            return False
        self._pilot_lift_off(t, None, Demand.of_sticks(sticks, self.config.pilot),
                             f"take-off by throttle in {self._mode.name}")
        return True

    def _pilot_lift_off(self, t: float, law: PilotLaw | None, demand: Demand, text: str
                        ) -> None:
        """Armed on the ground at ``t`` (s): take off on a pilot leg flying ``law`` (None:
        the mode's) under ``demand``; ``text`` announces it."""
        self._leg = self._pilot_leg(t, from_ground=True, law=law)
        self._flying = True
        self._landed_after_flight = False
        self._ground_since_s = None
        self._landing.reset()
        self._event("takeoff", text)
        assert self._leg.pilot is not None
        self._leg.pilot.advance(t, demand, self._est_pos_ned, self._est_vel_ned)

