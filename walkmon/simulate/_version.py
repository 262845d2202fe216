"""The simulator's version: bump it whenever the same arguments give different output (motion, scene, rendering,
IMU samples, truth files). Benchmarks key their cached simulations by it (:mod:`walkmon.simulate.cache`)."""

from __future__ import annotations

#: 1: the simulator up to issue 11 (implicit; never written). 2: session scripts (turns, pauses, gait
#: initiation/termination, posture changes), truth_timeline.csv/truth_steps.csv, unwrapped truth yaw, version in meta.json.
#: 3: unknown activity in session scripts (sit, pickup, camera), session steps are initial contacts (half-integer
#: phases) so a walk type's alternating-step asymmetry shows in the contacts' step times (right_foot_drag).
#: 4: the camera's mount on the trunk (script token ``mount:PITCH[:ROLL]``; unkind sessions draw one), meta.json
#: ``mount_deg``; a session without the token is unchanged.
#: 5: the walker's left/right pitch difference (script token ``lr:X``; unkind sessions draw one, X 0-2), meta.json
#: ``pitch_lr``; a session without the token is unchanged.
SIMULATOR_VERSION = 5
