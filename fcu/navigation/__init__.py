"""What the vehicle should do: flight modes (:mod:`.modes`), arming (:mod:`.arming`), landing
detection (:mod:`.landing`), missions (:mod:`.mission`), legs in flight (:mod:`.legs`,
:mod:`.flight`), the pilot's sticks (:mod:`.sticks`, :mod:`.pilot_leg`, :mod:`.pilot_modes`),
the geofence (:mod:`.fence`, :mod:`.fence_watch`) and the mode state machine
(:mod:`.navigator`), turned into guidance references (:mod:`.guidance`)."""
