"""Hard real-world scenarios for the rotation estimator (issue 14), on top of the simulated street walk.

Each scenario is a normal walk (seeded like every simulated session) plus one difficulty:

``street``          none: the plain street, the baseline the others are compared with
``wall``            the street ends in a textured facade the walker stops 3 m in front of (a near plane)
``turns``           fast turns of the torso: +90°, -180°, +90° (peak 135-180 °/s), the camera sweeping across
                    the facades at a few metres
``movers``          pedestrians (1-1.5 m/s, some crossing 2-4 m ahead, some walking towards the camera) and
                    vehicles (2-3 m/s, 3.5-4.5 m long) crossing the view
``dusk``            low light: 15 % of the light, the camera's gain at 4x (noise), 30 ms exposure (blur)
``night``           4 % of the light, 40 ms exposure
``fog``             fog (visibility ~6 m) and half the contrast: little texture left
``occlusion``       a scarf/hand over the lower left of the lens (45 % of the width), fixed to the camera
``rolling_shutter`` the turns with a 30 ms rolling-shutter readout

Truth stays exact: the turns are a rotation about the world's vertical applied on top of the gait model's
orientation (``R = Ry(turn(t)) R_gait(t)``, position unchanged), and truth.csv, the IMU and the rendered views all
come from that one model. Movers, the wall, light, fog and the occluder change the images only.
"""

from __future__ import annotations

import dataclasses
import json
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from walkmon.consts import angles_deg_from_rotation, rot_y
from walkmon.errors import InvalidInputError
from walkmon.simulate.render import DEFAULT_RENDER_SETTINGS
from walkmon.simulate.session import SimulatedSession

__all__ = ["SCENARIOS", "ScenarioSession", "TurningGait", "simulate_scenario"]

SCENARIOS = ("street", "wall", "turns", "movers", "dusk", "night", "fog", "occlusion", "rolling_shutter")

#: Turns of the ``turns`` scenarios: (start as a fraction of the walking time, duration s, angle deg).
_TURNS = ((0.1, 1.0, 90.0), (0.4, 1.5, -180.0), (0.75, 1.0, 90.0))


def _smoothstep(x: NDArray[np.float64]) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """``3x² - 2x³`` on [0, 1] (clamped) and its derivative."""
    c = np.clip(x, 0.0, 1.0)
    inside = (x > 0) & (x < 1)
    return c * c * (3 - 2 * c), np.where(inside, 6 * c * (1 - c), 0.0)


class TurningGait:
    """A :class:`~walkmon.simulate.gait.GaitModel` turned about the world's vertical: ``R = Ry(psi(t)) R(t)``.

    ``turns``: (start s, duration s, angle deg), each a smoothstep. Everything else is the wrapped model's.
    """

    def __init__(self, model: Any, turns: tuple[tuple[float, float, float], ...]) -> None:
        self._m = model
        self.turns = tuple(turns)

    def __getattr__(self, name: str) -> Any:
        return getattr(self._m, name)

    def turn_deg(self, t_s: ArrayLike) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        """Turn angle (deg) and rate (deg/s) at ``t_s``."""
        t = np.atleast_1d(np.asarray(t_s, dtype=float))
        psi, rate = np.zeros_like(t), np.zeros_like(t)
        for start, dur, angle in self.turns:
            s, ds = _smoothstep((t - start) / dur)
            psi += angle * s
            rate += angle * ds / dur
        return psi, rate

    def rotation(self, t_s: ArrayLike) -> NDArray[np.float64]:
        psi, _ = self.turn_deg(t_s)
        return rot_y(np.radians(psi)) @ self._m.rotation(t_s)

    def pose(self, t_s: ArrayLike) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        return self.rotation(t_s), self._m.position_m(t_s)

    def truth_angles_deg(self, t_s: ArrayLike) -> NDArray[np.float64]:
        return angles_deg_from_rotation(self.rotation(t_s))

    def angular_velocity_rps(self, t_s: ArrayLike) -> NDArray[np.float64]:
        """Body rate in the camera frame: the gait's plus the turn's (``R_gait^T e_y psi'``)."""
        _, rate = self.turn_deg(t_s)
        R = self._m.rotation(t_s)
        return self._m.angular_velocity_rps(t_s) + R[:, 1, :] * np.radians(rate)[:, None]

    def meta(self) -> dict[str, Any]:
        return {**self._m.meta(), "turns": [{"start_s": a, "duration_s": d, "angle_deg": g} for a, d, g in self.turns]}


def _movers(model: Any, seed: int) -> tuple[tuple[float, float, float, float, float, float, float], ...]:
    """Pedestrians and vehicles timed to cross the walker's view while walking (seeded)."""
    rng = np.random.default_rng([seed, 0x30BE])
    (a, b), = [(a, b) for a, b in _walking_span(model)]
    out = []
    for k in range(8):
        tc = a + (b - a) * (k + rng.uniform(0.2, 0.8)) / 8  # crossing time
        zc = float(model.position_m([tc])[0, 2])
        if k % 4 == 3:  # a vehicle crossing further ahead
            v = rng.uniform(2.0, 3.0) * rng.choice([-1.0, 1.0])
            d, w, h = rng.uniform(6.0, 10.0), rng.uniform(3.5, 4.5), rng.uniform(1.4, 1.8)
            out.append((-v * tc, zc + d, v, 0.0, w, h, rng.uniform(0, 20)))
        elif k % 4 == 1:  # a pedestrian walking towards the camera, slightly to one side
            v = rng.uniform(1.0, 1.5)
            d = rng.uniform(3.0, 5.0)
            x = rng.choice([-1.0, 1.0]) * rng.uniform(0.6, 1.2)
            out.append((x, zc + d + v * tc, 0.0, -v, 0.5, rng.uniform(1.6, 1.85), rng.uniform(0, 20)))
        else:  # a pedestrian crossing close
            v = rng.uniform(1.0, 1.5) * rng.choice([-1.0, 1.0])
            d = rng.uniform(2.0, 4.0)
            out.append((-v * tc, zc + d, v, 0.0, 0.5, rng.uniform(1.6, 1.85), rng.uniform(0, 20)))
    return tuple((float(m[0]), float(m[1]), float(m[2]), float(m[3]), float(m[4]), float(m[5]), float(m[6]))
                 for m in out)


def _walking_span(model: Any) -> list[tuple[float, float]]:
    """The first to the last walking time (between the standing intervals at the start and the end)."""
    t = np.linspace(0.0, model.duration_s, 400)
    walking = t[~model.is_standing(t)]
    if walking.size == 0:
        return [(0.0, model.duration_s)]
    return [(float(walking[0]), float(walking[-1]))]


class ScenarioSession(SimulatedSession):
    """A :class:`SimulatedSession` with one of :data:`SCENARIOS` (same walk, truth and IMU conventions)."""

    def __init__(self, scenario: str, seconds: float = 8.0, seed: int = 0, width: int = 640, height: int = 480,
                 fps: float = 30.0) -> None:
        if scenario not in SCENARIOS:
            msg = f"unknown scenario {scenario!r}; expected one of {', '.join(SCENARIOS)}"
            raise InvalidInputError(msg)
        super().__init__("normal", seconds, seed, width, height, fps)
        self.scenario = scenario
        rs = DEFAULT_RENDER_SETTINGS
        (a, b), = _walking_span(self.model)
        if scenario in ("turns", "rolling_shutter"):
            turns = tuple((a + f * (b - a), d, g) for f, d, g in _TURNS)
            self.model = TurningGait(self.model, turns)  # type: ignore[assignment]  # a GaitModel in all but type
        if scenario == "wall":
            z_end = float(self.model.position_m(np.linspace(0, self.model.duration_s, 200))[:, 2].max())
            rs = dataclasses.replace(rs, wall_ahead_z_m=z_end + 3.0)
        elif scenario == "movers":
            rs = dataclasses.replace(rs, movers=_movers(self.model, self.seed))
        elif scenario == "dusk":
            rs = dataclasses.replace(rs, light=0.15, exposure_s=0.03, max_blur_taps=16)
        elif scenario == "night":
            rs = dataclasses.replace(rs, light=0.04, exposure_s=0.04, max_blur_taps=16, read_noise_dn=2.0)
        elif scenario == "fog":
            rs = dataclasses.replace(rs, fog_distance_m=6.0, contrast=0.5)
        elif scenario == "occlusion":
            rs = dataclasses.replace(rs, occlusion=0.45)
        elif scenario == "rolling_shutter":
            rs = dataclasses.replace(rs, rolling_shutter_s=0.03)
        self.render_settings = rs

    def render(self, t_s: float, rng: np.random.Generator) -> NDArray[np.uint8]:
        self.renderer.set_time(t_s)
        return super().render(t_s, rng)

    def meta(self) -> dict[str, Any]:
        meta = super().meta()
        rs = self.render_settings
        meta["scenario"] = {"name": self.scenario, "wall_ahead_z_m": rs.wall_ahead_z_m, "movers": [list(m) for m in rs.movers],
                            "light": rs.light, "contrast": rs.contrast, "fog_distance_m": rs.fog_distance_m,
                            "occlusion": rs.occlusion, "exposure_s": rs.exposure_s,
                            "rolling_shutter_s": rs.rolling_shutter_s}
        return meta


def simulate_scenario(out_dir: str | Path, scenario: str, seed: int = 0, seconds: float = 8.0, width: int = 640,
                      height: int = 480, fps: float = 30.0) -> Path:
    """Write video.mp4, truth.csv, camera.yaml and meta.json of a scenario clip into ``out_dir``."""
    from walkmon.camera.model import write_camera_yaml  # noqa: PLC0415
    from walkmon.simulate.session import _write_video  # noqa: PLC0415
    from walkmon.tables import write_table  # noqa: PLC0415

    session = ScenarioSession(scenario, seconds, seed, width, height, fps)
    out = Path(out_dir)
    from walkmon.safe_io import prepare_dir  # noqa: PLC0415

    prepare_dir(out)
    write_table(out / "truth.csv", {k: np.round(v, 6) + 0.0 for k, v in session.truth().items()}, default_precision=6)
    write_camera_yaml(dataclasses.replace(session.camera, readout_s=session.render_settings.rolling_shutter_s),
                      out / "camera.yaml")  # the readout in the calibration, as a user's camera.yaml carries it
    _write_video(session, out / "video.mp4")
    (out / "meta.json").write_text(json.dumps(session.meta(), indent=2) + "\n", encoding="utf-8")
    return out
