"""Simulated sessions cached on disk under a key of the simulator version and every parameter.

Benchmarks simulate the same sessions again and again; a cache keyed by a file name alone (``normal_16s_seed1``)
silently serves clips of an older simulator, or of other render settings, after the simulator changed (issue 14).
Here the folder name ends in a hash of ``SIMULATOR_VERSION`` and all arguments of :func:`simulate`, so a changed
simulator or parameter gives a new folder; a folder counts only once its ``cache-key.json`` is written, after
everything else, so an interrupted simulation is redone rather than half-used.
"""

from __future__ import annotations

import hashlib
import json
import os
import re
import shutil
from dataclasses import asdict
from pathlib import Path
from typing import Any

from walkmon.simulate import _version
from walkmon.simulate.gait import STANDING_S
from walkmon.simulate.imu import DEFAULT_IMU_SETTINGS, ImuSettings
from walkmon.simulate.render import DEFAULT_RENDER_SETTINGS, RenderSettings

__all__ = ["KEY_FILE", "cached_simulation", "simulation_key", "simulation_params"]

#: Written last into a cached folder: the parameters and the key (its presence marks the folder complete).
KEY_FILE = "cache-key.json"


def simulation_params(
    walk: str = "normal",
    seconds: float = 16.0,
    seed: int = 0,
    width: int = 640,
    height: int = 480,
    fps: float = 30.0,
    distortion: bool = False,
    *,
    video: bool = True,
    stand_s: float = STANDING_S,
    render_settings: RenderSettings = DEFAULT_RENDER_SETTINGS,
    imu_settings: ImuSettings = DEFAULT_IMU_SETTINGS,
) -> dict[str, Any]:
    """Everything that determines a simulation's output, with the simulator version, as plain JSON values."""
    return {
        "simulator_version": _version.SIMULATOR_VERSION,
        "walk": str(walk),
        "seconds": float(seconds),
        "seed": int(seed),
        "width": int(width),
        "height": int(height),
        "fps": float(fps),
        "distortion": bool(distortion),
        "video": bool(video),
        "stand_s": float(stand_s),
        "render": asdict(render_settings),
        "imu": imu_settings.to_dict(),  # the IMU error model's version and its parameters
    }


def simulation_key(**kwargs: Any) -> str:
    """A 16-hex-digit key of :func:`simulation_params` (same arguments as :func:`walkmon.simulate.simulate`)."""
    blob = json.dumps(simulation_params(**kwargs), sort_keys=True, separators=(",", ":"))
    return hashlib.sha256(blob.encode("utf-8")).hexdigest()[:16]


def cached_simulation(cache_dir: str | Path, **kwargs: Any) -> Path:
    """The folder of a simulation with these arguments under ``cache_dir``, simulating it first if needed.

    Takes :func:`walkmon.simulate.simulate`'s arguments by keyword (except ``out_dir``). The folder is named
    ``<walk>-s<seed>-<W>x<H>-<key>`` (walk shortened to letters, digits and ``_``), readable and unique.
    """
    from walkmon.simulate.session import simulate

    params = simulation_params(**kwargs)
    key = simulation_key(**kwargs)
    slug = re.sub(r"[^a-z0-9_]+", "_", params["walk"].lower()).strip("_")[:40] or "walk"
    root = Path(cache_dir)
    final = root / f"{slug}-s{params['seed']}-{params['width']}x{params['height']}-{key}"
    if (final / KEY_FILE).is_file():
        return final
    root.mkdir(parents=True, exist_ok=True)
    tmp = root / f".{final.name}.tmp{os.getpid()}"
    if tmp.exists():
        shutil.rmtree(tmp)
    simulate(tmp, **kwargs)
    (tmp / KEY_FILE).write_text(json.dumps({"key": key, **params}, indent=2, sort_keys=True) + "\n", encoding="utf-8")
    if final.exists():  # an incomplete folder left by an interrupted run
        shutil.rmtree(final)
    tmp.rename(final)
    return final
