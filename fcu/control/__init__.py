"""Control laws: position (eq. 5.3/5.4), attitude (eq. 5.6, 5.10), disturbance observers
(eq. 6.27-6.30) and control allocation (inverse of eq. 3.2)."""
