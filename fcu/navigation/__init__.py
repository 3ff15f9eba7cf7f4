"""What the vehicle should do: flight modes (:mod:`.modes`), arming (:mod:`.arming`), landing
detection (:mod:`.landing`), missions (:mod:`.mission`), legs in flight (:mod:`.legs`,
:mod:`.flight`) and the mode state machine (:mod:`.navigator`), turned into guidance
references (:mod:`.guidance`)."""
