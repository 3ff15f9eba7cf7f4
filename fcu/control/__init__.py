"""Control laws: position (eq. 5.3/5.4, :mod:`.position`), attitude (:mod:`.attitude`: PD
eq. 5.6 in :mod:`.attitude_pd`, LQR eq. 5.7-5.10 in :mod:`.attitude_lqr`, the reference filter
in :mod:`.attitude_reference`, the motor-lag lead in :mod:`.motor_lead`), disturbance
observers (eq. 6.27-6.30, :mod:`.dob`) and control allocation (inverse of eq. 3.2,
:mod:`.allocation`); the pluggable kinds are built by name through :mod:`.registry`. In
flight the autopilot steps them together through :mod:`.chain`, one compiled call per tick
(each part's arithmetic is a numba kernel of its own module; :mod:`.scalar` holds the shared
scalar helpers)."""
