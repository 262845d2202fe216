"""Random session scripts "as unkind as life" (issue 11): what a real daily check looks like, not a lab walk.

``unkind_script(seed, walk)`` draws a literal session script (see :mod:`walkmon.simulate.gait`) around one walk
type: it starts standing for a random time or already walking, walks 2-4 bouts separated by pauses of 1-6 s,
turns by 180° (U-turns) or by 90° towards a facade and 90° on (at once, after a pause in front of it or after a
few steps towards it), moves without a gait rhythm once in most sessions (sits down on a bench, bends down to
pick something up or handles the camera: the truth's ``unknown``), changes posture in
the middle of a bout (to ``bend`` and back for a normal walker, to ``normal`` and back for the others, each
posture held long enough to measure: >= 6 s) and ends standing or mid-walk. The camera sits on the trunk
tilted as a chest mount holds it (``mount:PITCH:ROLL``: 25 deg down to 5 deg up, +-3 deg askew), and the walker's
trunk pitches differently on the left and right steps (``lr:X``, X 0-2: from none to a pitch that repeats once
per stride, as on the real Mobilise-D lower backs). The same seed gives the same
script; the script itself is the truth's description (``GaitModel`` lays it out and records the timeline).
"""

from __future__ import annotations

import numpy as np

from walkmon.errors import InvalidInputError
from walkmon.simulate.gait import WALK_TYPES

__all__ = ["UNKIND_WALKS", "unkind_script"]

#: Walk types an unkind session can be built around.
UNKIND_WALKS = tuple(w for w in WALK_TYPES if w != "stand")


def _s(x: float) -> str:
    return f"{x:.1f}"


def unkind_script(seed: int, walk: str = "normal") -> str:
    """A random unkind session script around ``walk``, reproducible per ``seed`` (about 30-100 s long)."""
    if walk not in UNKIND_WALKS:
        msg = f"unkind sessions are built around a walk type ({', '.join(UNKIND_WALKS)}), got {walk!r}"
        raise InvalidInputError(msg)
    if not isinstance(seed, int | np.integer) or seed < 0:
        msg = f"seed must be a whole number >= 0, got {seed!r}"
        raise InvalidInputError(msg)
    rng = np.random.default_rng([int(seed), 0x0C1D, UNKIND_WALKS.index(walk)])
    other = "bend" if walk == "normal" else "normal"
    parts: list[str] = []
    slots: list[int] = []  # where a pause between two bouts ends
    if rng.uniform() < 0.6:  # a standing start of any length, else the recording starts mid-walk
        parts.append(f"stand:{_s(rng.uniform(0.5, 5.0))}")
    n_bouts = int(rng.integers(2, 5))
    posture_bout = int(rng.integers(0, n_bouts))  # one bout changes posture in its middle
    for i in range(n_bouts):
        if i == posture_bout:
            parts += [f"{walk}:{_s(rng.uniform(6.0, 9.0))}", f"{other}:{_s(rng.uniform(6.0, 10.0))}"]
            if rng.uniform() < 0.5:
                parts.append(f"{walk}:{_s(rng.uniform(6.0, 8.0))}")
        else:
            parts.append(f"{walk}:{_s(rng.uniform(4.0, 10.0))}")
        last = i == n_bouts - 1
        turn = rng.uniform()
        if turn < 0.4:  # a U-turn while walking, then walk back
            parts += [f"turn:{int(rng.choice([-180, 180]))}", f"{walk}:{_s(rng.uniform(3.0, 8.0))}"]
        elif turn < 0.7:  # a quarter turn towards a facade, a pause or a few steps, another quarter turn
            sign = int(rng.choice([-1, 1]))
            parts.append(f"turn:{90 * sign}")
            between = rng.uniform()
            if between < 1 / 3:  # stop in front of the facade
                parts.append(f"pause:{_s(rng.uniform(1.0, 4.0))}")
            elif between < 2 / 3:  # a few steps towards it
                parts.append(f"{walk}:{_s(rng.uniform(1.0, 2.0))}")
            parts += [f"turn:{90 * sign * int(rng.choice([-1, 1]))}", f"{walk}:{_s(rng.uniform(4.0, 8.0))}"]
        if not last:
            parts.append(f"pause:{_s(rng.uniform(1.0, 6.0))}")
            slots.append(len(parts))
    if rng.uniform() < 0.6:  # a standing end of any length, else the recording stops mid-walk
        parts.append(f"stand:{_s(rng.uniform(0.5, 4.0))}")
    # moving without a gait rhythm (the truth's "unknown"), from a stream of its own so that the rest of the
    # script stays what earlier simulator versions drew: most sessions sit down on a bench, bend down to pick
    # something up or handle the camera once, between two bouts (after their pause) or at the start or end
    u = np.random.default_rng([int(seed), 0x0C1E, UNKIND_WALKS.index(walk)])
    if u.uniform() < 0.75:
        kind = str(u.choice(["sit", "pickup", "camera"]))
        secs = {"sit": (8.0, 15.0), "pickup": (3.0, 5.0), "camera": (3.0, 6.0)}[kind]
        piece = [f"{kind}:{_s(u.uniform(*secs))}", f"pause:{_s(u.uniform(0.8, 2.0))}"]
        where = int(u.integers(0, len(slots) + 2))
        if where == 0:  # at the start: standing a moment, then it, then a pause before walking
            parts[:0] = [f"stand:{_s(u.uniform(0.5, 2.0))}", *piece]
        elif where == len(slots) + 1:  # at the end, after a pause
            parts += [f"pause:{_s(u.uniform(0.8, 2.0))}", *piece]
        else:  # between two bouts, after the pause
            i = slots[where - 1]
            parts[i:i] = piece
    # the camera's mount on the trunk (a stream of its own too): a chest strap or clip rarely holds the camera
    # level; it points a little down at the path (here 0-25 deg, or up to 5 deg up) and sits a few degrees askew
    mnt = np.random.default_rng([int(seed), 0x0C1F, UNKIND_WALKS.index(walk)])
    parts.insert(0, f"mount:{_s(mnt.uniform(-25.0, 5.0))}:{_s(mnt.uniform(-3.0, 3.0))}")
    # the walker's left/right difference in trunk pitch (a stream of its own): real trunks pitch differently on
    # the two steps, enough on the Mobilise-D lower backs for the pitch to repeat once per stride (lr 1-2)
    lrg = np.random.default_rng([int(seed), 0x0C20, UNKIND_WALKS.index(walk)])
    parts.insert(1, f"lr:{_s(lrg.uniform(0.0, 2.0))}")
    return ",".join(parts)
