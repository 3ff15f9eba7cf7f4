"""The autopilot: one tick from sensor samples to PWM (:mod:`fcu.autopilot`), configured by
:mod:`fcu.config`; its parts in :mod:`fcu.estimation`, :mod:`fcu.control`,
:mod:`fcu.navigation` and :mod:`fcu.monitoring`, its MAVLink endpoint in :mod:`fcu.mavlink`.
Pluggable kinds of part are built by name through registries (:mod:`fcu.registry`)."""
