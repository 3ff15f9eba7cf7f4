"""The battery monitor and its failsafe, after ArduPilot's ``AP_BattMonitor`` and ArduCopter.

The power module's samples (sensor ``"battery"``: terminal voltage in V, current in A) give
the pack voltage and current; the current integrated over time gives the charge and energy
used since boot, and with the pack's capacity the charge remaining. The failsafe levels, as
``AP_BattMonitor_Backend::update_failsafes`` sets them:

- **low**: the voltage below ``BATT_LOW_VOLT`` for ``BATT_LOW_TIMER`` seconds without a
  break, or the charge remaining below ``BATT_LOW_MAH``;
- **critical**: the same with ``BATT_CRT_VOLT`` and ``BATT_CRT_MAH``.

A threshold of 0 disables its check. The level only rises (ArduPilot latches it until the
autopilot restarts). Each rise is announced ("Battery 1 is low 10.41V used 2101 mAh") and
acts as ``BATT_FS_LOW_ACT`` / ``BATT_FS_CRT_ACT`` say: 0 warn only, 1 LAND, 2 RTL (in flight;
armed on the ground the navigator disarms, and arming is refused while the failsafe lasts).

Defaults are ArduCopter's for a 3S pack (``BATT_LOW_VOLT`` 10.5 V, the rest off) and the
simulated pack's capacity (2500 mAh): by default a low battery is announced and shown in
telemetry, and the pilot decides, as in ArduCopter.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Literal

from flightdata.config import finite, require

__all__ = ["ACTIONS", "BatteryEvent", "BatteryMonitor", "BatteryMonitorConfig", "Level"]

Level = Literal["ok", "low", "critical"]
ACTIONS: dict[int, str | None] = {0: None, 1: "land", 2: "rtl"}
"""BATT_FS_*_ACT values: 0 warn only, 1 LAND, 2 RTL (ArduCopter's numbers)."""
_RANK = {"ok": 0, "low": 1, "critical": 2}


@dataclass(frozen=True, kw_only=True)
class BatteryMonitorConfig:
    """Battery monitor and failsafe settings (ArduPilot parameter in brackets)."""

    capacity_mah: float = 2500.0  # mAh, full pack [BATT_CAPACITY]
    low_volt_v: float = 10.5  # V, low below this for low_timer_s; 0 off [BATT_LOW_VOLT]
    low_mah: float = 0.0  # mAh, low when less remains; 0 off [BATT_LOW_MAH]
    critical_volt_v: float = 0.0  # V, critical voltage; 0 off [BATT_CRT_VOLT]
    critical_mah: float = 0.0  # mAh, critical remaining charge; 0 off [BATT_CRT_MAH]
    low_action: int = 0  # 0 warn, 1 LAND, 2 RTL [BATT_FS_LOW_ACT]
    critical_action: int = 0  # 0 warn, 1 LAND, 2 RTL [BATT_FS_CRT_ACT]
    low_timer_s: float = 10.0  # s, voltage below a threshold this long [BATT_LOW_TIMER]

    def __post_init__(self) -> None:
        require(finite(self.capacity_mah) and self.capacity_mah > 0.0, "capacity_mah",
                self.capacity_mah, "must be a finite capacity > 0 mAh")
        for name in ("low_volt_v", "low_mah", "critical_volt_v", "critical_mah",
                     "low_timer_s"):
            value = getattr(self, name)
            require(finite(value) and value >= 0.0, name, value,
                    "must be a finite number >= 0 (0 = off)")
        for name in ("low_action", "critical_action"):
            value = getattr(self, name)
            require(isinstance(value, int) and not isinstance(value, bool) and value in ACTIONS,
                    name, value, "must be 0 (warn), 1 (LAND) or 2 (RTL)")


@dataclass(frozen=True, slots=True)
class BatteryEvent:
    """The failsafe level rose to ``level``; ``action`` is "land", "rtl" or None (warn)."""

    time_s: float
    level: Level
    action: str | None
    text: str


class BatteryMonitor:
    """Voltage, current, charge used and failsafe level of one pack (module docstring).

    Parameters
    ----------
    config : BatteryMonitorConfig
    """

    def __init__(self, config: BatteryMonitorConfig | None = None) -> None:
        self.config = config if config is not None else BatteryMonitorConfig()
        cfg = self.config
        # each level's thresholds, the higher level first (read every tick)
        self._checks: tuple[tuple[Level, float, float], ...] = (
            ("critical", cfg.critical_volt_v, cfg.critical_mah),
            ("low", cfg.low_volt_v, cfg.low_mah))
        self.reset()

    def reset(self) -> None:
        """No sample yet, nothing used, level ok."""
        self.voltage_v = math.nan  # V, latest reading
        self.current_a = math.nan  # A, latest reading
        self.consumed_mah = 0.0  # mAh since boot
        self.consumed_j = 0.0  # J since boot
        self.level: Level = "ok"
        self._last_s: float | None = None
        self._below_since: dict[Level, float | None] = {"low": None, "critical": None}
        # the level was worked out since the latest reading with no voltage timer running:
        # until the next reading it cannot change (it depends on time only through a timer)
        self._settled = False

    def take_over(self, other: BatteryMonitor) -> None:
        """Continue from ``other``'s readings, charge used and level (the autopilot rebuilt
        for a parameter change keeps counting; the pack did not change)."""
        self.voltage_v, self.current_a = other.voltage_v, other.current_a
        self.consumed_mah, self.consumed_j = other.consumed_mah, other.consumed_j
        self.level = other.level
        self._last_s = other._last_s
        self._below_since = dict(other._below_since)
        self._settled = False

    @property
    def remaining_mah(self) -> float:
        """Charge left, mAh (never below 0)."""
        return max(self.config.capacity_mah - self.consumed_mah, 0.0)

    @property
    def remaining(self) -> float:
        """Charge left as a fraction of the capacity, 0..1."""
        return self.remaining_mah / self.config.capacity_mah

    @property
    def time_remaining_s(self) -> float:
        """Time to empty at the present current, s (NaN when not drawing)."""
        if not (math.isfinite(self.current_a) and self.current_a > 0.01):
            return math.nan
        return self.remaining_mah / 1000.0 / self.current_a * 3600.0

    def step(self, time_s: float, voltage_v: float | None,
             current_a: float | None) -> BatteryEvent | None:
        """A tick at ``time_s`` (s) with the power module's reading, if one came (V, A).

        Returns the event when the failsafe level rose, else None.
        """
        if voltage_v is not None and current_a is not None and \
                math.isfinite(voltage_v) and math.isfinite(current_a):
            if self._last_s is not None and time_s > self._last_s:
                dt = time_s - self._last_s
                # trapezoid between the previous reading and this one
                mean_a = 0.5 * (self.current_a + current_a)
                self.consumed_mah += mean_a * dt / 3.6
                self.consumed_j += 0.5 * (self.current_a * self.voltage_v
                                          + current_a * voltage_v) * dt
            self._last_s = time_s
            self.voltage_v, self.current_a = float(voltage_v), float(current_a)
            self._settled = False
        elif self._settled:
            return None  # no reading since a time-independent evaluation: the same level
        if self.level == "critical":
            return None  # the level only rises, and this is the top (its timers no longer
            # matter)
        level = self._level(time_s)
        below = self._below_since
        self._settled = below["low"] is None and below["critical"] is None
        if _RANK[level] <= _RANK[self.level]:
            return None
        self.level = level
        cfg = self.config
        action = ACTIONS[cfg.low_action if level == "low" else cfg.critical_action]
        text = (f"Battery 1 is {level} {self.voltage_v:.2f}V used "
                f"{self.consumed_mah:.0f} mAh")
        return BatteryEvent(time_s, level, action, text)

    def _level(self, time_s: float) -> Level:
        for level, volt, mah in self._checks:
            if self._voltage_below(level, volt, time_s):
                return level
            if mah > 0.0 and self.remaining_mah < mah:
                return level
        return "ok"

    def _voltage_below(self, level: Level, threshold_v: float, time_s: float) -> bool:
        """The voltage has stayed below ``threshold_v`` for ``low_timer_s`` (timer per
        level; a reading at or above the threshold restarts it)."""
        if threshold_v <= 0.0 or not math.isfinite(self.voltage_v):
            self._below_since[level] = None
            return False
        if self.voltage_v >= threshold_v:
            self._below_since[level] = None
            return False
        since = self._below_since[level]
        if since is None:
            self._below_since[level] = since = time_s
        return time_s - since >= self.config.low_timer_s - 1e-9
