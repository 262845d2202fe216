"""walkmon's Python API: the front door that ``walkmon analyze``, ``walkmon indicators`` and ``walkmon report``
use too, so a script gets exactly what the commands write.

    import walkmon, pandas
    result = walkmon.analyze("walk.mp4", calib="camera.yaml")
    df = pandas.DataFrame(result.angles)          # the angles.csv columns
    result.indicators["classification"]["label"]  # the indicators.json document
    result.write("out/")                          # angles.csv, indicators.json, report.html (+ imu.json)

* :func:`analyze` -- a video (and/or an imu.csv) to an :class:`Analysis`;
* :func:`analyze_angles` -- angles you already have (``t``, pitch, yaw, roll) to an :class:`Analysis`;
* :func:`open_video` -- the frames of a video file, ``(t_s, frame_bgr)``;
* :func:`load_session` -- a session of the session log (``walkmon live``, ``walkmon analyze --save``).

This module reads and writes files (it is the front door); the packages it calls (rotation, imu, gait) do not.
"""

from __future__ import annotations

import dataclasses
import logging
import math
import os
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from walkmon.errors import ConfigError, InvalidInputError
from walkmon.gait.indicators import Indicators, IndicatorSettings, compute_indicators, indicators_from_dict
from walkmon.sampling import gaps, sampling_rate_hz

if TYPE_CHECKING:
    from walkmon.drivers.video_file import VideoFile
    from walkmon.imu.fusion import FusionSettings
    from walkmon.rotation.types import RotationEstimate

__all__ = [
    "Analysis",
    "Session",
    "analyze",
    "analyze_angles",
    "angle_columns",
    "estimate_rotations",
    "load_session",
    "measured_rows",
    "open_video",
    "status_summary",
]

_log = logging.getLogger(__name__)

#: Extra columns of a video's angles.csv after t,pitch,yaw,roll.
EXTRA_COLUMNS = ("n_inliers", "n_tracks", "residual_px", "model", "status", "keyframe")

#: Decimals per angles.csv column of a video analysis (others: 6).
_PRECISION = {"t": 4, "pitch": 4, "yaw": 4, "roll": 4, "residual_px": 3, "n_inliers": 0, "n_tracks": 0, "keyframe": 0,
              "visual_used": 0}

#: (frames done, frames in the file's header; 0 when unknown), after every frame.
ProgressCallback = Callable[[int, int], object]


# --------------------------------------------------------------------------------------------- results
def _structured(columns: Mapping[str, Any]) -> NDArray[Any]:
    """A read-only numpy structured array of ``{name: column}`` (numbers as float64/int64, text as unicode)."""
    arrays = {name: np.asarray(col) for name, col in columns.items()}
    n = {len(a) for a in arrays.values()}
    if len(n) > 1:
        msg = f"columns differ in length: { {k: len(a) for k, a in arrays.items()} }"
        raise ValueError(msg)
    dtype: list[tuple[str, Any]] = []
    for name, a in arrays.items():
        if a.dtype.kind in "iub":
            dtype.append((name, np.int64))
        elif a.dtype.kind == "f":
            dtype.append((name, np.float64))
        else:
            width = max((len(str(v)) for v in a), default=1)
            dtype.append((name, f"<U{max(width, 1)}"))
    out = np.empty(n.pop() if n else 0, dtype=dtype)
    for name, a in arrays.items():
        out[name] = a if a.dtype.kind in "iubf" else [str(v) for v in a]
    out.flags.writeable = False
    return out


#: The files :meth:`Analysis.write` may write (for the warning about an earlier run's left beside them).
_OUTPUT_NAMES = ("angles.csv", "imu.json", "indicators.json", "timeline.csv", "report.html")


@dataclass(frozen=True, eq=False)
class Analysis:
    """The result of :func:`analyze` / :func:`analyze_angles` (frozen).

    ``angles``: numpy structured array with the angles.csv columns (``pandas.DataFrame(result.angles)`` works);
    ``indicators``: the indicators.json document (a fresh dict on every access); ``gait``: the same as
    :class:`~walkmon.gait.indicators.Indicators`; ``estimates``: the rotation estimate of every frame (empty
    without a video); ``imu_info``: what imu.json holds (None without an IMU). :meth:`write` writes the files of
    ``walkmon analyze``.
    """

    angles: NDArray[Any]
    gait: Indicators
    estimates: tuple[RotationEstimate, ...] = ()
    imu_info: Mapping[str, Any] | None = None
    source: str = ""
    method: str = ""
    meta: Mapping[str, Any] = field(default_factory=dict)
    settings: IndicatorSettings = field(default_factory=IndicatorSettings)
    baseline: Indicators | None = None
    reference_deg: NDArray[np.float64] | None = None
    precision: Mapping[str, int] = field(default_factory=dict)
    #: timeline.csv rows ``(t, activity, label, pitch, roll, ref_uncertainty_deg)`` at 1 s (walkmon mode; empty in
    #: paper mode)
    timeline: tuple[tuple[float, str, str, float, float, float], ...] = ()
    #: the raw IMU samples the steps and the activity came from (:class:`walkmon.gait.session.ImuInput`, on the
    #: angles' time base; None without an IMU): :meth:`save` stores them, so ``walkmon report ID`` finds the same
    #: steps
    imu_input: Any = None

    @property
    def indicators(self) -> dict[str, Any]:
        """The indicators.json document."""
        return self.gait.to_dict()

    @property
    def t_s(self) -> NDArray[np.float64]:
        return np.asarray(self.angles["t"], dtype=float)

    @property
    def angles_deg(self) -> NDArray[np.float64]:
        """(N, 3) pitch, yaw, roll in degrees (relative to the first frame)."""
        return np.column_stack([self.angles[c] for c in ("pitch", "yaw", "roll")]).astype(float)

    @property
    def abs_angles_deg(self) -> NDArray[np.float64] | None:
        """(N, 2) gravity-referenced pitch and roll (NaN where not fused) when an IMU was used, else None."""
        names = self.angles.dtype.names or ()
        if "pitch_abs" not in names or "roll_abs" not in names:
            return None
        return np.column_stack([self.angles["pitch_abs"], self.angles["roll_abs"]]).astype(float)

    def status_summary(self) -> str:
        """One line on the frames' estimation status (see :func:`status_summary`); '' without a video."""
        return status_summary(self.estimates) if self.estimates else ""

    def _timeline_columns(self) -> dict[str, Any]:
        """timeline.csv's columns (:data:`walkmon.tables.TIMELINE_COLUMNS`) from :attr:`timeline`'s rows: the
        activity and label as text, the rest as floats."""
        from walkmon.tables import TIMELINE_COLUMNS  # noqa: PLC0415

        cols = zip(TIMELINE_COLUMNS, zip(*self.timeline, strict=True), strict=True)
        return {k: list(v) if k in ("activity", "label") else np.array(v, dtype=float) for k, v in cols}

    def report_html(self, **timeline: Any) -> str:
        """report.html as a string. Its timeline is the gait analysis's per-second timeline (walkmon mode) unless
        ``timeline=`` (and ``timeline_source=``, ``stats=``, ``person=``: see :func:`walkmon.gait.report.render_report`)
        give another one, e.g. the hops and alerts a live session logged."""
        from walkmon.gait.report import render_report, timeline_from_columns  # noqa: PLC0415  (matplotlib: when asked)

        meta = dict(self.meta)
        angles = self.angles_deg
        if angles.size and np.isnan(angles[:, 1]).all():  # accelerometer only: no yaw, drawn as flat
            angles[:, 1] = 0.0
        if "timeline" not in timeline and self.timeline:
            timeline = {"timeline": timeline_from_columns(self._timeline_columns()),
                        "timeline_source": "Per second, from the gait analysis (activity, posture segments)."}
        return render_report(self.t_s, angles, self.gait, self.baseline, meta, settings=self.settings,
                             reference_deg=self.reference_deg, abs_angles_deg=self.abs_angles_deg, **timeline)

    def write(self, out_dir: str | Path, *, angles: bool = True, report: bool = True) -> dict[str, Path]:
        """Write the files of ``walkmon analyze`` into ``out_dir`` (created): angles.csv (``angles=False``: not),
        imu.json when an IMU was used, indicators.json, timeline.csv (walkmon mode), report.html (``report=False``:
        not). Returns ``{file name: path}``."""
        from walkmon.safe_io import json_text, prepare_dir, write_text  # noqa: PLC0415
        from walkmon.tables import write_indicators, write_table  # noqa: PLC0415

        # 0700; a symlinked folder is refused (every file: walkmon.safe_io); '~' expanded as save() and the readers
        # do (review: write('~/out') made a folder named '~' in the current one)
        out = prepare_dir(Path(out_dir).expanduser())
        written: dict[str, Path] = {}
        if angles:
            written["angles.csv"] = out / "angles.csv"
            write_table(written["angles.csv"], {name: self.angles[name] for name in self.angles.dtype.names or ()},
                        precision=self.precision)
            if self.imu_info is not None:
                written["imu.json"] = out / "imu.json"
                write_text(written["imu.json"], json_text(dict(self.imu_info)))  # NaN -> null: valid JSON
        written["indicators.json"] = out / "indicators.json"
        write_indicators(written["indicators.json"], self.gait)
        if self.timeline:
            written["timeline.csv"] = out / "timeline.csv"
            write_table(written["timeline.csv"], self._timeline_columns(),
                        precision={"t": 1, "pitch": 2, "roll": 2, "ref_uncertainty_deg": 1})
        if report:
            written["report.html"] = out / "report.html"
            text = self.report_html()
            write_text(written["report.html"], text)
            _log.info("wrote %s (%d kB)", written["report.html"], len(text) // 1024)
        # an earlier run's outputs left beside these (user review: a video-only run into the folder of an IMU run
        # kept its imu.json, which no longer matched) are said, not deleted (they may be all a user has of that
        # run); only what this call writes in its configuration: with angles=False (indicators, report ID)
        # angles.csv and imu.json may be the command's own input (review), with report=False the caller writes
        # report.html
        mine = [n for n in _OUTPUT_NAMES if (angles or n not in ("angles.csv", "imu.json"))
                and (report or n != "report.html")]
        stale = sorted(n for n in mine if n not in written and (out / n).exists())
        if stale:
            _log.warning("%s: %s from an earlier run left there, not from this one", out, ", ".join(stale))
        return written

    def save(self, data_dir: str | Path | None = None, *, meta: Mapping[str, object] | None = None) -> int:
        """Record this analysis as a session of kind ``analyze`` in the session log (``walkmon analyze --save``);
        returns its id. ``data_dir``: the database folder (default ~/.local/share/walkmon); ``meta``: stored with
        the session."""
        from walkmon.live.session_log import (  # noqa: PLC0415
            check_database_usable,
            default_data_dir,
            record_offline_session,
        )

        if meta is not None and not isinstance(meta, Mapping):
            msg = f"meta must be a mapping (a dict), got {type(meta).__name__}"
            raise InvalidInputError(msg)
        folder = Path(data_dir).expanduser() if data_dir is not None else default_data_dir()
        check_database_usable(folder)  # a file, a foreign database: one line (review: NotADirectoryError)
        absolute = self.abs_angles_deg
        video = bool(self.estimates)
        # with an IMU, the frames' pitch_abs/roll_abs as 'walkmon live' stores them, so 'walkmon report ID'
        # shows their section; fused (1: the IMU covered the frame, 0: camera only) only when a video was fused
        fused = None if absolute is None or not video else np.all(np.isfinite(absolute), axis=1).tolist()
        # the raw IMU, so that 'walkmon report ID' takes its steps from it as this analysis did (without it, the
        # report analysed the angles alone: a Mobilise-D course saved at 98.9 steps/min reported 71.6; an
        # accelerometer alone, no report at all); and the per-second timeline as hops, so that the history and the
        # dashboard count this session's time (without hops: 0 min recorded, 0 min walked)
        imu = self.imu_input
        samples = None if imu is None else (imu.t_s, imu.gyro_rad_s, imu.acc_m_s2)
        return record_offline_session(
            folder, self.t_s, self.angles_deg, source=self.source,
            imu=str((self.imu_info or {}).get("imu", "")),
            config={"method": self.method},
            # the axes warning too: 'walkmon report ID' re-analyses the saved IMU and must withhold its posture as
            # this analysis did (review: it read '9 % upright' and a pitch of 172 deg where analyze had none)
            meta={**dict(meta or {}), **({"axes_warning": warn} if (warn := (self.imu_info or {}).get("axes_warning"))
                                         else {}),
                  # the accelerometer in the angles' axes (an IMU or an accelerometer alone): the report measures the
                  # upright stance from it as this analysis did (review: it went back to the filter's lagging
                  # gravity, -3.0 deg where analyze had -0.4)
                  **({} if imu is None or imu.acc_camera_m_s2 is None else {"acc_camera": {
                      "calibration": None if imu.accelerometer_calibration is None
                      else imu.accelerometer_calibration.to_dict()}})},
            extra=[(e.n_inliers, e.model, e.status.value) for e in self.estimates] or None,  # none: IMU-only
            abs_angles_deg=absolute, fused=fused, imu_samples=samples, timeline=self._timeline_hops(),
        )

    def _timeline_hops(self) -> list[tuple[float, str, str, float, float, float]]:
        """:attr:`timeline` as ``(t, activity, label, pitch, roll, cadence_spm)``: each walking second with the
        cadence of the posture segment it lies in, else of its bout (review: a bout's, across a normal and a bent
        stretch of 113.4 and 105.8 steps/min, gave every second 109.8); NaN outside them or without a cadence."""
        doc = self.indicators
        spans = [(float(x["start_s"]), float(x["end_s"]), x.get("cadence_spm"))
                 for key in ("segments", "bouts") for x in (doc.get(key) or [])
                 if x.get("start_s") is not None and x.get("cadence_spm") is not None]
        out = []
        for t, activity, label, pitch, roll, _doubt in self.timeline:
            cadence = next((float(c) for a, b, c in spans if a <= t <= b), math.nan)
            out.append((float(t), str(activity), str(label), float(pitch), float(roll), cadence))
        return out


def _baseline(baseline: Any) -> tuple[Indicators | None, str | None]:
    """(Indicators, the path it came from) of any accepted ``baseline=`` value."""
    from walkmon.tables import read_indicators  # noqa: PLC0415

    if baseline is None:
        return None, None
    if isinstance(baseline, Analysis):
        return baseline.gait, None
    if isinstance(baseline, Indicators):
        return baseline, None
    if isinstance(baseline, Mapping):
        return indicators_from_dict(baseline, "baseline"), None
    if isinstance(baseline, str | Path):
        return read_indicators(baseline), str(baseline)
    msg = f"baseline must be an indicators.json path, its dict, Indicators or an Analysis, not {type(baseline).__name__}"
    raise InvalidInputError(msg)


#: The longest median interval between angle samples (s) an analysis takes: one a second, slower than any video a
#: step rhythm could be seen in, but far from t in milliseconds (frames 33 s apart at 30 fps); 0.2 s refused a 4 fps
#: walk 'analyze' itself had analysed (review).
MAX_ANGLE_INTERVAL_S = 1.0


def analyze_angles(
    t_s: ArrayLike,
    angles_deg: ArrayLike,
    *,
    baseline: Any = None,
    mode: str = "walkmon",
    abs_angles_deg: ArrayLike | None = None,
    reference_deg: ArrayLike | None = None,
    meta: Mapping[str, Any] | None = None,
) -> Analysis:
    """Gait indicators, classification and report of angles you already have.

    ``t_s`` (N,) seconds, ``angles_deg`` (N, 3) pitch, yaw, roll relative to the start (conventions of
    :mod:`walkmon.consts`); ``abs_angles_deg`` (N, 2) gravity-referenced pitch and roll (NaN where unknown) add
    the report's absolute-angle section; ``reference_deg`` the upright stance (pitch, yaw, roll) when the
    recording has no standing phase at its start; ``baseline`` the same person's normal walk (see :func:`analyze`).
    """
    t = np.asarray(t_s, dtype=float).reshape(-1)
    a = np.asarray(angles_deg, dtype=float)
    if a.shape != (len(t), 3):
        msg = f"angles_deg must have shape ({len(t)}, 3) like t_s, got {a.shape}"
        raise InvalidInputError(msg)
    # the other arguments checked too (review: a reference of 2 numbers, or a list as meta, raised a bare
    # ValueError / TypeError from deep inside)
    if reference_deg is not None:
        given: Any = reference_deg
        if isinstance(given, Mapping):  # as indicators.json stores it: {pitch, yaw, roll}
            given = [given.get(k) for k in ("pitch", "yaw", "roll")]
        try:
            ref = np.asarray(given, dtype=float).reshape(-1)
        except (TypeError, ValueError):
            ref = np.full(0, np.nan)  # refused below (review: a bare ValueError / TypeError)
        if ref.shape != (3,) or not np.isfinite(ref).all():
            msg = f"reference_deg must be 3 finite numbers (pitch, yaw, roll in degrees), got {reference_deg!r}"
            raise InvalidInputError(msg)
        reference_deg = ref
    if meta is not None and not isinstance(meta, Mapping):
        msg = f"meta must be a mapping (a dict), got {type(meta).__name__}"
        raise InvalidInputError(msg)
    if len(t) >= 2 and np.isfinite(t).all() and float(np.median(np.diff(t))) > MAX_ANGLE_INTERVAL_S:
        # t in milliseconds read as seconds: 30 fps became frames 33 s apart, 'no walking bout' and a standing
        # phase of hours, exit 0 (user review; the IMU's reader refuses the same, walkmon.imu.units)
        dt = float(np.median(np.diff(t)))
        msg = (f"angles {dt:g} apart on median ({1.0 / dt:.3g} per unit of t): t must be in seconds and the angles "
               f"at least {1.0 / MAX_ANGLE_INTERVAL_S:g} a second (is t in milliseconds?)")
        raise InvalidInputError(msg)
    columns: dict[str, Any] = {"t": t, "pitch": a[:, 0], "yaw": a[:, 1], "roll": a[:, 2]}
    if abs_angles_deg is not None:
        ab = np.asarray(abs_angles_deg, dtype=float)
        if ab.shape != (len(t), 2):
            msg = f"abs_angles_deg must have shape ({len(t)}, 2) like t_s, got {ab.shape}"
            raise InvalidInputError(msg)
        columns.update(pitch_abs=ab[:, 0], roll_abs=ab[:, 1])
    return _gait_stage(columns, baseline=baseline, mode=mode, reference_deg=reference_deg, meta=meta)


def measured_rows(model: ArrayLike | Sequence[str] | None, fused: ArrayLike | None = None) -> NDArray[np.bool_] | None:
    """The rows of a video's angles that measure something (None: no ``model`` column, or no held row: every row
    does): not the frames the estimator held (``model`` ``hold``: the last orientation repeated over a lens cap, a
    repeated, featureless or lost frame; ``coast``: such a frame in a turn, carried on at the last rate), unless an
    IMU carried them: ``fused`` per row (1: the fusion gave the row, as the session log's and ``sessions
    export``'s ``fused`` column says; 0 or NaN: the camera's alone).
    The session analysis leaves the held rows out, so a held stretch of a second or more is a gap of the
    recording (unknown, no steps, no bout across it, no timeline row): held through a 4 s lens cap mid-walk, the
    flat angles read as 4 s of standing. Fewer than 10 rows left: InvalidInputError (nothing measured to
    analyse). An offline fused analysis (``analyze VIDEO --imu``) passes no ``model``: the fusion carries every
    row (a frame held during an IMU dropout is then held, not left out: not handled)."""
    if model is None:
        return None
    from walkmon.rotation.types import UNMEASURED_MODELS  # noqa: PLC0415

    held = np.asarray([str(m) in UNMEASURED_MODELS for m in np.asarray(model).reshape(-1)], dtype=bool)
    if fused is not None:
        f = np.asarray(fused, dtype=float).reshape(-1)
        if f.shape == held.shape:
            held &= ~(f > 0.5)
    if not held.any():
        return None
    if int((~held).sum()) < 10:
        msg = (f"only {int((~held).sum())} of {held.size} frames were measured: the rotation estimator held the "
               "others (a covered lens, featureless, repeated or lost frames); nothing to analyse")
        raise InvalidInputError(msg)
    return ~held


def _gait_stage(columns: Mapping[str, Any], **kwargs: Any) -> Analysis:
    """:func:`_gait_stage_of` with its refusals naming the input (user review: an image given as a video said only
    'need at least 10 samples, got 1', a CSV with a repeated time 'times must be ... increasing', no file)."""
    try:
        return _gait_stage_of(columns, **kwargs)
    except InvalidInputError as exc:
        meta = kwargs.get("meta") or {}
        name = kwargs.get("source") or meta.get("input") or meta.get("video")
        if not name or str(name) in str(exc):
            raise
        msg = f"{name}: {exc}"
        raise InvalidInputError(msg) from None


def _gait_stage_of(
    columns: Mapping[str, Any],
    *,
    baseline: Any,
    mode: str,
    reference_deg: ArrayLike | None = None,
    meta: Mapping[str, Any] | None = None,
    imu_input: Any = None,
    no_yaw: bool = False,
    no_posture: str | None = None,
    **fields: Any,
) -> Analysis:
    """The later stages shared by every entry point: in walkmon mode the session analysis (activity, bouts,
    posture segments, summary, timeline; :mod:`walkmon.gait.session`), in paper mode the paper's whole-recording
    indicators; ``imu_input``: the raw IMU (:class:`walkmon.gait.session.ImuInput`) for steps and activity;
    ``no_posture``: why no posture may be reported (an IMU in another sensor's axes; else imu_info's
    axes_warning), :func:`walkmon.gait.session.without_posture`."""
    base, base_path = _baseline(baseline)
    settings = IndicatorSettings(mode=mode)
    t = np.asarray(columns["t"], dtype=float)
    a = np.column_stack([np.asarray(columns[c], dtype=float) for c in ("pitch", "yaw", "roll")])
    if no_yaw:
        a[:, 1] = 0.0  # accelerometer only: no yaw (angles.csv keeps it empty); indicators report it as null
    ref = None if reference_deg is None else np.asarray(reference_deg, dtype=float)
    timeline: tuple = ()
    if mode == "paper":
        indicators = compute_indicators(t, a, settings, base, reference_deg=ref)
    else:
        from walkmon.gait.session import analyze_session  # noqa: PLC0415

        absolute = (np.column_stack([np.asarray(columns["pitch_abs"], float), np.asarray(columns["roll_abs"], float)])
                    if "pitch_abs" in columns and "roll_abs" in columns else None)
        # a fused analysis (visual_used column): the IMU carried every row
        keep = measured_rows(None if "visual_used" in columns else columns.get("model"))
        if keep is not None:
            t, a, absolute = t[keep], a[keep], None if absolute is None else absolute[keep]
        session = analyze_session(t, a, imu=imu_input, abs_angles_deg=absolute, baseline=base, settings=settings,
                                  no_yaw=no_yaw, reference_deg=ref)
        indicators, timeline = session.indicators, session.timeline
        no_posture = no_posture or (fields.get("imu_info") or {}).get("axes_warning")
        if no_posture:  # another sensor's axes: its pitch and roll are not the trunk's, in no output
            from walkmon.gait.session import without_posture  # noqa: PLC0415

            indicators, timeline = without_posture(indicators, timeline, no_posture)
    meta = dict(meta or {})
    if base_path:
        meta.setdefault("baseline", base_path)
    return Analysis(angles=_structured(columns), gait=indicators, meta=meta, settings=settings, baseline=base,
                    reference_deg=ref, timeline=timeline, imu_input=imu_input, **fields)


# --------------------------------------------------------------------------------------------- analyze
def estimate_rotations(
    frames: Any, estimator: Any, on_frame: Callable[[], object] | None = None
) -> list[RotationEstimate]:
    """Push every ``(t_s, frame)`` through ``estimator``; returns the list of RotationEstimate."""
    out = []
    for t_s, frame in frames:
        out.append(estimator.push(frame, t_s))
        if on_frame is not None:
            on_frame()
    return out


def angle_columns(estimates: Sequence[RotationEstimate]) -> dict[str, Any]:
    """The angles.csv columns of a list of RotationEstimate (t from the first frame)."""
    if not estimates:
        msg = "no frames to write"
        raise InvalidInputError(msg)
    t = np.array([e.t_s for e in estimates]) - estimates[0].t_s
    a = np.array([e.angles_deg for e in estimates]).reshape(-1, 3)
    return {
        "t": t,
        "pitch": a[:, 0],
        "yaw": a[:, 1],
        "roll": a[:, 2],
        "n_inliers": np.array([e.n_inliers for e in estimates], dtype=int),
        "n_tracks": np.array([e.n_tracks for e in estimates], dtype=int),
        "residual_px": np.array([e.residual_px for e in estimates]),
        "model": [e.model for e in estimates],
        "status": [e.status.value for e in estimates],
        "keyframe": np.array([int(e.keyframe) for e in estimates], dtype=int),
    }


def status_summary(estimates: Sequence[RotationEstimate]) -> str:
    """``"480 frames: 470 ok, 8 low_quality (5 fast_rotation, 3 planar_ambiguity), 2 held (too_few_features)"``.

    ok counts the measured frames (``ok`` and the ``first_frame``); a frame whose status is not ok is either
    still estimated (``low_quality``) and counted under its status with its reasons
    (:data:`walkmon.rotation.FLAG_REASONS`; "rotation-only" when an estimate gives none), or held (model
    ``hold``: the last orientation repeated) and counted under "held" with its statuses, or carried on through a
    turn (model ``coast``) and counted under "coasted". Zero counts are left out.
    """
    from collections import Counter  # noqa: PLC0415

    from walkmon.rotation.types import UNMEASURED_MODELS  # noqa: PLC0415

    n_ok = sum(e.status.is_measured for e in estimates)
    flagged = [e for e in estimates if not e.status.is_measured]
    estimated = [e for e in flagged if e.model not in UNMEASURED_MODELS]
    parts = [f"{n_ok} ok"] if n_ok else []
    for status, n in sorted(Counter(e.status.value for e in estimated).items()):
        given = Counter(e.reason for e in estimated if e.status.value == status)
        if set(given) == {""}:  # no reason given (the paper method): the fast method's old label
            parts.append(f"{n} {status}{' (rotation-only)' if status == 'low_quality' else ''}")
        else:
            reasons = ", ".join(f"{k} {r or 'unstated'}" for r, k in given.most_common())
            parts.append(f"{n} {status} ({reasons})")
    for name, model in (("held", "hold"), ("coasted", "coast")):
        group = Counter(e.status.value for e in flagged if e.model == model)
        if group:
            why = ", ".join(status if len(group) == 1 else f"{n} {status}" for status, n in sorted(group.items()))
            parts.append(f"{sum(group.values())} {name} ({why})")
    return f"{len(estimates)} frames: {', '.join(parts) or 'none'}"


def open_video(path: str | Path, *, decode_threads: int = 0) -> VideoFile:
    """Open a video file: iterate it for ``(t_s, frame_bgr)`` (``t_s``: the frame's presentation time from the
    first's); it has ``fps``, ``width_px``, ``height_px``, ``frame_count`` and ``rotation_deg`` (the display
    rotation OpenCV applied); use it as a context manager. A missing file raises InvalidInputError, one
    OpenCV cannot decode SourceError."""
    from walkmon.drivers.video_file import VideoFile  # noqa: PLC0415

    return VideoFile(path, decode_threads=decode_threads)


def _video_rotations(
    video: str | Path, calib: str | Path | None, method: str, progress: ProgressCallback | None,
    readout_s: float | None = None,
) -> list[RotationEstimate]:
    """The rotation of every frame of ``video`` (the camera model from ``calib``, scaled to the video's size;
    ``readout_s``, when given, replaces its rolling-shutter readout)."""
    from walkmon.camera.lens_profile import read_camera_file  # noqa: PLC0415  (a YAML, or a Gyroflow .json)
    from walkmon.camera.model import camera_for_frames, default_camera  # noqa: PLC0415
    from walkmon.rotation import RotationEstimator, RotationSettings  # noqa: PLC0415

    camera = read_camera_file(calib) if calib is not None else None
    with open_video(video) as frames:
        if camera is None:
            camera = default_camera(frames.width_px, frames.height_px)
        if readout_s is not None:
            camera = dataclasses.replace(camera, readout_s=readout_s)
        rotation = float(getattr(frames, "rotation_deg", 0.0))
        fitted = camera_for_frames(camera, frames.width_px, frames.height_px, rotation)  # or one line, exit 2
        if fitted is not camera:
            turned = (fitted.width_px > fitted.height_px) != (camera.width_px > camera.height_px)
            _log.warning(
                "calibration is for %dx%d, video is %dx%d%s: intrinsics %s",
                camera.width_px, camera.height_px, frames.width_px, frames.height_px,
                f" (shown turned {rotation:g} deg)" if rotation else "", "turned to the frames" if turned else "scaled",
            )
        camera = fitted
        estimator = RotationEstimator(camera, RotationSettings(method=method))
        done = [0]

        def on_frame() -> None:
            done[0] += 1
            if progress is not None:
                progress(done[0], frames.frame_count)

        return estimate_rotations(frames, estimator, on_frame)


#: ``--imu telemetry:FILE``: the IMU an action camera stored in FILE (walkmon.drivers.telemetry_imu).
TELEMETRY_PREFIX = "telemetry:"


def _read_imu(imu_path: str | Path) -> tuple[Any, dict[str, Any]]:
    """The IMU recording ``imu`` names: an imu.csv, or ``telemetry:FILE`` (a camera's embedded gyroscope and
    accelerometer in camera axes, :mod:`walkmon.drivers.telemetry_imu`); plus what imu.json says of its source."""
    spec = str(imu_path)
    if spec.lower().startswith(TELEMETRY_PREFIX):
        from walkmon.drivers.telemetry_imu import read_telemetry_imu  # noqa: PLC0415

        path = spec[len(TELEMETRY_PREFIX):]
        if not path:
            msg = "--imu telemetry: needs a file, e.g. --imu telemetry:clip.mp4"
            raise InvalidInputError(msg)
        found = read_telemetry_imu(path)  # in the axes of the frames as shown (turned with a portrait video's)
        return found.recording, {"telemetry": found.to_dict()}
    from walkmon.tables import read_imu_csv  # noqa: PLC0415

    units: list[str] = []
    rec = read_imu_csv(imu_path, units_out=units)
    gyro, acc = rec.gyroscope_rad_s, rec.accelerometer_m_s2
    if np.all(np.ptp(gyro, axis=0) == 0.0) and float(np.std(np.linalg.norm(acc, axis=1))) > _MOVING_ACC_SD_M_S2:
        # every row the same rate while the accelerometer moves: no gyroscope there (a logger writing zeros for a
        # missing or dead one). Analysed, it read no turn and labelled a real course left_shoulder_down, where its
        # own gyroscope, or its accelerometer alone, gave no label (user review)
        msg = (f"{imu_path}: the gyroscope reads {gyro[0, 0]:g}, {gyro[0, 1]:g}, {gyro[0, 2]:g} rad/s on every row "
               "while the accelerometer moves: a dead or missing gyroscope; give the file without its gx,gy,gz "
               "columns (t,ax,ay,az) to analyse the accelerometer alone")
        raise InvalidInputError(msg)
    return rec, ({"units": units} if units else {})


#: An accelerometer whose magnitude varies by more than this (SD, m/s²) moves: a still sensor's noise is 0.01-0.05,
#: a walk's 1-3 (a still recording with a gyroscope that reads exactly zero at rest is no dead gyroscope; review).
_MOVING_ACC_SD_M_S2 = 0.2


def _imu_settings(imu_filter: str, offset_s: float, calib: str | Path | None) -> FusionSettings:
    """The fusion settings of an analysis: the IMU attitude core, the time offset, the accelerometer calibration."""
    from walkmon.imu.attitude import ImuFilterSettings  # noqa: PLC0415
    from walkmon.imu.fusion import FusionSettings  # noqa: PLC0415
    from walkmon.tables import read_accelerometer_calibration  # noqa: PLC0415

    accel = None if calib is None else read_accelerometer_calibration(calib)
    return FusionSettings(time_offset_s=float(offset_s), imu_filter=ImuFilterSettings(filter=imu_filter),
                          accelerometer_calibration=accel)


def _acc_only_columns(imu_path: str | Path, offset_s: float, imu_filter: str = "vqf",
                      calib: str | Path | None = None) -> tuple[dict[str, Any], dict[str, Any]]:
    """Accelerometer-only analysis (``t,ax,ay,az``, issue 11): gravity pitch/roll (the accelerometer low-passed at
    0.25 Hz, its axes taken as the camera's; corrected by ``calib``, the accelerometer calibration, when given), no
    yaw (an empty column); steps and bouts come from the raw samples. ``imu_filter`` is checked (no attitude
    filter runs here): a bad name or calibration file was silently ignored (review)."""
    from walkmon.consts import gravity_angles_deg_from_gravity  # noqa: PLC0415
    from walkmon.gait.activity import gravity_direction  # noqa: PLC0415
    from walkmon.gait.session import ImuInput  # noqa: PLC0415
    from walkmon.tables import read_acc_csv  # noqa: PLC0415

    cal = _imu_settings(imu_filter, offset_s, calib).accelerometer_calibration  # refuses a bad name or file
    units: list[str] = []
    t_raw, acc = read_acc_csv(imu_path, units_out=units)
    t_raw = t_raw + float(offset_s)
    rate = sampling_rate_hz(t_raw)
    step = max(1, int(np.ceil(rate / 100.0 - 1e-9)))
    acc_cal = acc if cal is None else cal.correct(acc)
    absolute = gravity_angles_deg_from_gravity(-gravity_direction(acc_cal, rate))[::step]
    t = t_raw[::step] - t_raw[0]
    rel = absolute - absolute[0]
    cols: dict[str, Any] = {"t": t, "pitch": rel[:, 0], "yaw": np.full(t.size, np.nan), "roll": rel[:, 1],
                            "pitch_abs": absolute[:, 0], "roll_abs": absolute[:, 1],
                            "_imu_input": ImuInput(t_raw - t_raw[0], acc, None, acc_camera_m_s2=acc_cal,
                                                   accelerometer_calibration=cal)}
    axes = _axes_note(acc, str(imu_path))
    info = {"mode": "accelerometer_only", "imu": str(imu_path), **({"axes_warning": axes} if axes else {}),
            "samples": len(t_raw), "rate_hz": round(rate, 3),
            **_gap_doc(t_raw), "rows": len(t), "axes": "accelerometer's own axes (no camera extrinsics)",
            "accelerometer_calibration": None if calib is None else str(calib),
            "note": "no gyroscope: pitch/roll from gravity (low-passed accelerometer), no yaw, no turns"}
    if units:
        info["units"] = units
    return cols, info


#: Gravity further than this (deg) from the camera's up (-y: the specific force of an upright camera) on median
#: is another sensor's own axes (a chest camera pitched 25-45 deg down, as the simulator's steep mounts, stays
#: well inside; Mobilise-D's lower-back IMU reads 88, a phone in a pouch 172).
_AXES_OFF_DEG = 60.0


def _axes_note(acc: NDArray[np.float64], name: str) -> str | None:
    """A warning (logged, and for imu.json) when the recording's gravity lies far from the camera axes' up: the
    file is in another sensor's own axes (Mobilise-D's lower-back IMU: x up), where the posture angles (pitch,
    roll; Euler angles near their 90 deg singularity) mean nothing, while the steps, bouts, cadence and turns do
    not depend on the axes (user review: HA/002's course read standing seconds at 87-159 deg of pitch, silently)."""
    a = np.asarray(acc, dtype=float)
    norm = np.linalg.norm(a, axis=1)
    ok = norm > 0
    if not ok.any():
        return None
    up = np.median(a[ok] / norm[ok, None], axis=0)
    off = float(np.degrees(np.arccos(np.clip(-up[1] / max(float(np.linalg.norm(up)), 1e-9), -1.0, 1.0))))
    if off <= _AXES_OFF_DEG:
        return None
    msg = (f"gravity lies {off:.0f} deg from the camera axes' up (-y) on median: the file is in another sensor's own "
           "axes, so its pitch and roll (and posture labels) are not the trunk's; steps, bouts, cadence and turns "
           "are; turn the samples into camera axes (x right, y down, z forward) for posture")
    _log.warning("%s: %s", name, msg)
    return msg


def _gap_doc(t_s: NDArray[np.float64], listed: int = 20) -> dict[str, Any]:
    """imu.json's ``gaps`` (none: nothing): the intervals without samples (walkmon.sampling.gaps: over 10 x the
    usual interval), their count, total and longest length, and the first ``listed`` of them as ``[last sample
    before, first sample after]`` in seconds from the IMU's first sample."""
    found = gaps(t_s)
    if not found:
        return {}
    t0 = float(t_s[0])
    lengths = [b - a for a, b in found]
    return {"gaps": {"n": len(found), "total_s": round(sum(lengths), 3), "longest_s": round(max(lengths), 3),
                     "first": [[round(a - t0, 3), round(b - t0, 3)] for a, b in found[:listed]]}}


def _imu_only_columns(
    imu_path: str | Path, imu_filter: str, offset_s: float | None, calib: str | Path | None = None
) -> tuple[dict[str, Any], dict[str, Any]]:
    """IMU-only analysis: the angles.csv columns and imu.json of an imu.csv (or a camera's telemetry)."""
    from walkmon.imu.recordings import imu_only_columns  # noqa: PLC0415

    imu, source = _read_imu(imu_path)
    settings = _imu_settings(imu_filter, offset_s or 0.0, calib)
    cols: dict[str, Any] = dict(imu_only_columns(imu, settings))
    from walkmon.gait.session import ImuInput  # noqa: PLC0415

    cal = settings.accelerometer_calibration  # the filter's accelerometer, in the axes it took for the camera's
    acc_camera = imu.accelerometer_m_s2 if cal is None else cal.correct(imu.accelerometer_m_s2)
    cols["_imu_input"] = ImuInput(imu.t_s - imu.t_s[0], imu.accelerometer_m_s2, imu.gyroscope_rad_s,
                                  acc_camera_m_s2=acc_camera, accelerometer_calibration=cal)
    axes = _axes_note(imu.accelerometer_m_s2, str(imu_path)) if "telemetry" not in source else None
    info = {"mode": "imu_only", "imu": str(imu_path), "imu_filter": imu_filter, **({"axes_warning": axes} if axes else {}),
            "accelerometer_calibration": None if calib is None else str(calib), "samples": len(imu.t_s),
            "rate_hz": round(imu.rate_hz, 3), **_gap_doc(imu.t_s), "rows": len(cols["t"]),
            "axes": "camera axes (telemetry mapping)" if "telemetry" in source else "IMU's own axes (no camera extrinsics)",
            **source}
    return dict(cols), info


#: Largest clock offset an IMU may be given (s; an IMU timed in UNIX seconds needs about 1.7e9).
MAX_IMU_OFFSET_S = 1e10

#: Least share of the video's time span the IMU must cover to be fused (below: an error, not zero angles).
MIN_IMU_COVERAGE = 0.5


def _imu_coverage(imu_t_s: NDArray[np.float64], offset_s: float, frame_t_s: NDArray[np.float64], name: str) -> float:
    """The share of the video's time span the IMU covers (IMU times + ``offset_s`` on the video clock).

    Under :data:`MIN_IMU_COVERAGE` (a wrong ``--imu-offset-s``, another recording's IMU, a too-short file) the
    fusion would give angles that are not measurements (all zero with no overlap): InvalidInputError naming both
    spans. Under 95 %: a warning.
    """
    v0, v1 = float(frame_t_s[0]), float(frame_t_s[-1])
    i0, i1 = float(imu_t_s[0]) + offset_s, float(imu_t_s[-1]) + offset_s
    coverage = max(0.0, min(v1, i1) - max(v0, i0)) / max(v1 - v0, 1e-9)
    if not coverage >= MIN_IMU_COVERAGE:
        msg = (f"{name}: the IMU covers {coverage:.0%} of the video (video {v0:.2f}..{v1:.2f} s, IMU "
               f"{i0:.6g}..{i1:.6g} s on the video clock with --imu-offset-s {offset_s:g}); need at least "
               f"{MIN_IMU_COVERAGE:.0%}: check --imu-offset-s and that the IMU file belongs to this video")
        raise InvalidInputError(msg)
    if coverage < 0.95:
        _log.warning("%s: the IMU covers only %.0f%% of the video; frames outside it are not fused", name,
                     100 * coverage)
    return round(coverage, 4)


#: An IMU whose rotation rates match the video's this poorly (correlation of their magnitudes at the best clock
#: offset within 0.5 s of the one in use) while the video turns this fast (RMS over 0.5 s steps, deg/s, where the
#: IMU covers it) is not this video's IMU.
MIN_RATE_CORRELATION = 0.4
MIN_VIDEO_RATE_DEG_S = 1.5
#: Rates this far apart (deg/s RMS) after the best IMU-to-camera rotation, with a correlation under 0.9: another
#: recording's IMU (own IMUs here: 0.4-0.8).
MAX_OWN_RESIDUAL_DEG_S = 8.0


def _video_turn_rate_deg_s(ft: NDArray[np.float64], visual: NDArray[np.float64], ok: NDArray[np.bool_],
                           span: tuple[float, float]) -> float:
    """RMS of the video's rotation rate over steps of about 0.5 s inside ``span`` (ok frames at both ends). Over
    0.5 s a still camera's frame-to-frame jitter averages out (0.05 deg a frame read 3.7 deg/s frame to frame:
    review) while a walk's sway of a few degrees at about 1 Hz stays."""
    from walkmon.consts import rotation_from_angles_deg  # noqa: PLC0415

    if len(ft) < 3:
        return 0.0
    k = max(1, round(0.5 / max(float(np.median(np.diff(ft))), 1e-6)))
    R = rotation_from_angles_deg(visual[:, 0], visual[:, 1], visual[:, 2])
    i = np.arange(len(ft) - k)
    use = ok[i] & ok[i + k] & (ft[i] >= span[0]) & (ft[i + k] <= span[1])
    if not use.any():
        return 0.0
    i = i[use]
    rel = np.einsum("nji,njk->nik", R[i], R[i + k])
    ang = np.degrees(np.arccos(np.clip((np.trace(rel, axis1=1, axis2=2) - 1.0) / 2.0, -1.0, 1.0)))
    return float(np.sqrt(np.mean((ang / (ft[i + k] - ft[i])) ** 2)))


def _same_recording(imu: Any, ft: NDArray[np.float64], visual: NDArray[np.float64], ok: NDArray[np.bool_],
                    ext: Any, offset_s: float | None, name: str) -> None:
    """Refuse an IMU that plainly belongs to another recording (user review: a drone's GoPro telemetry was fused
    into a simulated walk, exit 0, the walk read as no walking at all). A video's own IMU follows its rotation
    rates (simulated walks, the GoPro clip: correlation 0.99); that telemetry on 7-20 s walks: 0.10-0.13, the
    videos turning at 2.6-6.1 deg/s over 0.5 s steps. A video that hardly turns has nothing to compare and passes
    (its own IMU correlates at about 0.1 there too; a still camera's jitter of 0.15 deg a frame reads 0.7 deg/s). With ``offset_s`` given the rates are compared about that
    offset."""
    from walkmon.imu.recordings import extrinsics_from_angles  # noqa: PLC0415

    ext0 = ext  # about no offset
    if offset_s:
        try:
            ext = extrinsics_from_angles(imu, ft - offset_s, visual, ok)
        except InvalidInputError:
            return
    if ext is None or ext.n_intervals < 30:
        return
    span = (float(imu.t_s[0]) + (offset_s or 0.0), float(imu.t_s[-1]) + (offset_s or 0.0))
    # a walk's rates follow any other walk's at a like cadence (correlation 0.53-0.72 between two simulated walks,
    # and a real person's IMU on one: review) but not after the best rotation between them: those left 14-22 deg/s
    # where a video's own IMU leaves 0.4-0.8 (simulated walks, the GoPro clip)
    mismatched = ext.correlation < MIN_RATE_CORRELATION or (
        ext.correlation < 0.9 and ext.residual_deg_s > MAX_OWN_RESIDUAL_DEG_S)
    if not mismatched:
        # The video's own IMU at a wrong offset: a walk's rhythm lines up again a few steps off (user review:
        # --imu-offset-s -1.5 and 1 read correlation 0.6-0.8, 5-7 deg/s apart, and were fused, every frame 'ok'
        # with up to 5 deg of error), while without the offset the rates agreed (0.995, 0.6 deg/s apart)
        if (offset_s and ext0 is not None and ext0.n_intervals >= 30 and ext0.correlation >= 0.9
                and abs(ext0.time_offset_s - offset_s) > 0.5
                and ext.residual_deg_s > max(2.0 * ext0.residual_deg_s, ext0.residual_deg_s + 2.0)
                and _video_turn_rate_deg_s(ft, visual, ok, span) > MIN_VIDEO_RATE_DEG_S):
            msg = (f"{name}: the IMU's rotation follows the video's at a clock offset of {ext0.time_offset_s:+.2f} s "
                   f"(rate correlation {ext0.correlation:.2f}, {ext0.residual_deg_s:.1f} deg/s apart), not at "
                   f"--imu-offset-s {offset_s:g} ({ext.correlation:.2f}, {ext.residual_deg_s:.1f} deg/s apart): "
                   "check the offset")
            raise InvalidInputError(msg)
        return
    rate = _video_turn_rate_deg_s(ft, visual, ok, span)
    if rate > MIN_VIDEO_RATE_DEG_S:
        msg = (f"{name}: the IMU's rotation does not follow the video's (the video turns at {rate:.0f} deg/s RMS; "
               f"correlation of the rates {ext.correlation:.2f}, {ext.residual_deg_s:.0f} deg/s apart, at the best "
               f"clock offset within 0.5 s of {offset_s or 0:g} s): is it this video's IMU? (--imu-offset-s sets "
               f"the clock offset)")
        raise InvalidInputError(msg)


def _fused_columns(
    columns: dict[str, Any], estimates: Sequence[RotationEstimate], imu_path: str | Path, offset_s: float | None,
    extrinsics: str, imu_filter: str = "vqf", calib: str | Path | None = None,
) -> tuple[dict[str, Any], dict[str, Any]]:
    """The video's angles.csv columns with pitch/yaw/roll replaced by the angles fused with the IMU, plus
    pitch_abs, roll_abs, visual_used and the video-only angles as pitch_video, ...; and imu.json (mode,
    extrinsics estimate and residual, increments used)."""
    from walkmon.imu.recordings import extrinsics_from_angles, fused_columns  # noqa: PLC0415

    imu, source = _read_imu(imu_path)
    t = np.asarray(columns["t"], dtype=float)
    ft = t + estimates[0].t_s
    visual = np.column_stack([np.asarray(columns[k], dtype=float) for k in ("pitch", "yaw", "roll")])
    ok = np.array([e.status.is_measured for e in estimates], dtype=bool)
    settings = _imu_settings(imu_filter, offset_s or 0.0, calib)
    info: dict[str, Any] = {"mode": "fused", "imu": str(imu_path), "imu_filter": imu_filter,
                            "accelerometer_calibration": None if calib is None else str(calib),
                            "samples": len(imu.t_s), "rate_hz": round(imu.rate_hz, 3), **_gap_doc(imu.t_s), **source}
    try:
        ext = extrinsics_from_angles(imu, ft, visual, ok)
        info["extrinsics_estimate"] = ext.to_dict()
    except InvalidInputError as exc:
        ext = None
        info["extrinsics_estimate"] = f"not estimated: {exc}"
        if extrinsics == "estimate":
            raise
    _same_recording(imu, ft, visual, ok, ext, offset_s, str(imu_path))
    if extrinsics == "estimate" and ext is not None and not ext.well_conditioned:
        msg = (f"cannot estimate the IMU-camera rotation from this recording (it rotated about one axis only: "
               f"excitation {ext.axis_excitation:.3f}, correlation {ext.correlation:.2f}); walk longer or give none")
        raise InvalidInputError(msg)
    if extrinsics == "estimate" and ext is not None:
        settings = dataclasses.replace(settings, camera_from_imu=tuple(ext.camera_from_imu.ravel()),
                                       time_offset_s=ext.time_offset_s)
        _log.info("using the estimated extrinsics (residual %.2f deg/s)", ext.residual_deg_s)
    elif "telemetry" in source and offset_s is None:
        # a camera's embedded IMU: axes known (mapped), clock not frame-exact: the offset estimated from the gyro
        # vs visual rate magnitudes (independent of the axes) when they agree, else none
        if ext is not None and ext.correlation >= 0.5:
            settings = dataclasses.replace(settings, time_offset_s=ext.time_offset_s)
            info["time_offset"] = "estimated from gyro vs visual rates"
        else:
            info["time_offset"] = "not estimated (gyro and visual rates do not agree): 0"
            _log.warning("%s: could not estimate the IMU clock offset; using 0 (give --imu-offset-s)", imu_path)
    if offset_s is not None and extrinsics != "estimate":
        info["time_offset"] = "given (--imu-offset-s)"
        if ext is not None and ext.correlation >= 0.9 and abs(ext.time_offset_s - offset_s) > 0.1:
            # user review: -0.5 s given where the rates agreed at +0.037 s (correlation 0.99), without a word
            _log.warning("%s: --imu-offset-s %g s, but the gyro and video rates agree best at %+.3f s "
                         "(correlation %.2f): check the offset", imu_path, offset_s, ext.time_offset_s,
                         ext.correlation)
            info["time_offset"] += f"; the rates agree best at {ext.time_offset_s:+.3f} s"
    info["extrinsics_used"] = {"camera_from_imu": settings.camera_from_imu_matrix.round(6).tolist(),
                               "time_offset_s": settings.time_offset_s}
    info["imu_coverage"] = _imu_coverage(imu.t_s, settings.time_offset_s, ft, str(imu_path))
    # an IMU in another sensor's axes gives the fused gravity angles (and the posture from them) of those axes:
    # said, and posture withheld, as for an IMU alone (review: 'analyze VIDEO --imu' of an x-up file read 67 %
    # upright with an upright reference of -94 deg, no warning)
    axes = _axes_note(imu.accelerometer_m_s2 @ settings.camera_from_imu_matrix.T, str(imu_path))
    if axes:
        info["axes_warning"] = axes
    cols, track = fused_columns(imu, ft, visual, ok, settings)
    out: dict[str, Any] = {"t": t}
    out.update({k: cols[k] for k in ("pitch", "yaw", "roll", "pitch_abs", "roll_abs")})
    out["visual_used"] = np.asarray(cols["visual_used"], dtype=int)  # 0/1
    out.update({"pitch_video": visual[:, 0], "yaw_video": visual[:, 1], "roll_video": visual[:, 2]})
    out.update({k: v for k, v in columns.items() if k not in ("t", "pitch", "yaw", "roll")})
    info["visual_increments_used"] = int(track.visual_used.sum())
    info["visual_increments_rejected"] = int(track.frames_rejected)
    info["gravity_resets"] = int(track.gravity_resets)
    info["frames_without_imu"] = int(track.frames_without_imu)  # carried by the vision alone (an IMU dropout)
    return out, info


def analyze(
    video: str | Path | None = None,
    *,
    imu: str | Path | None = None,
    calib: str | Path | None = None,
    method: str = "fast",
    baseline: Any = None,
    mode: str = "walkmon",
    imu_filter: str = "vqf",
    imu_offset_s: float | None = None,
    imu_extrinsics: str = "identity",
    imu_calib: str | Path | None = None,
    progress: ProgressCallback | None = None,
    readout_s: float | None = None,
) -> Analysis:
    """Analyse a walk recorded by a chest-worn camera (and/or an IMU): what ``walkmon analyze`` computes.

    ``video``: a video file (any format OpenCV/FFmpeg reads); ``imu``: an imu.csv (``t,gx,gy,gz,ax,ay,az``; s,
    rad/s, m/s2) or ``"telemetry:FILE"`` (the gyroscope and accelerometer an action camera stored in FILE, read
    with telemetry-parser and mapped to camera axes), fused with the video, or analysed alone when ``video`` is
    None; ``calib``: a ROS camera_info
    YAML (default: 70 deg HFOV pinhole, scaled to the video); ``method``: ``"fast"`` or ``"paper"``;
    ``baseline``: the same person's normal walk (indicators.json path, its dict, Indicators or an Analysis):
    classify relative to it; ``mode``: ``"walkmon"`` or ``"paper"`` indicator processing; ``imu_filter``:
    the IMU attitude core, for IMU-only analysis and under the fusion (``vqf``, default; ``eskf``,
    ``eskf-handheld``); ``imu_offset_s``: added to IMU times to put them on the video clock (None: 0 for an imu.csv, estimated from gyro vs
    visual rates for telemetry); ``imu_extrinsics``:
    ``"identity"`` or ``"estimate"`` (from this recording); ``imu_calib``: an accelerometer calibration file of
    ``walkmon calibrate-imu``; ``readout_s``: the camera's rolling-shutter readout time, top row to bottom (s;
    replaces the calibration file's ``readout_s``; 0: a global shutter; None: the file's, else 0);
    ``progress(done, total)``: called after every frame. Bad input raises a :class:`~walkmon.errors.WalkmonError`
    with a one-line message.
    """
    if method not in ("fast", "paper"):
        msg = f"unknown rotation method {method!r}; expected fast or paper"
        raise ConfigError(msg)
    if imu_extrinsics not in ("identity", "estimate"):
        msg = f"unknown imu_extrinsics {imu_extrinsics!r}; expected identity or estimate"
        raise ConfigError(msg)
    # the API's own arguments checked as the CLI's are (review: plain TypeError / ValueError tracebacks)
    for name, value in (("video", video), ("imu", imu), ("calib", calib), ("imu_calib", imu_calib)):
        if value is not None and not isinstance(value, str | os.PathLike):
            msg = f"{name} must be a path (str or os.PathLike), got {type(value).__name__}"
            raise InvalidInputError(msg)
    if progress is not None and not callable(progress):
        msg = f"progress must be a callable progress(done, total) or None, got {type(progress).__name__}"
        raise InvalidInputError(msg)
    if imu_offset_s is not None:
        try:
            imu_offset_s = float(imu_offset_s)
        except (TypeError, ValueError):
            msg = f"imu_offset_s must be a finite number of seconds, got {imu_offset_s!r}"
            raise ConfigError(msg) from None
    if imu_offset_s is not None and not math.isfinite(float(imu_offset_s)):
        msg = f"imu_offset_s must be a finite number of seconds, got {imu_offset_s!r}"
        raise ConfigError(msg)
    if imu_offset_s is not None and abs(float(imu_offset_s)) > MAX_IMU_OFFSET_S:
        # 1e308 made every IMU time 1e308: 'IMU rate must be positive, got 0.0' (user review); an epoch-timed IMU
        # against a video timed from 0 needs about -1.7e9
        msg = f"imu_offset_s must be within +-{MAX_IMU_OFFSET_S:g} s, got {imu_offset_s!r}"
        raise ConfigError(msg)
    from walkmon.safe_io import pipes_read_again  # noqa: PLC0415

    with pipes_read_again():  # an IMU file given as a pipe is read twice (its columns, then its rows)
        return _analyze(video, imu, calib, method, baseline, mode, imu_filter, imu_offset_s, imu_extrinsics,
                        imu_calib, progress, readout_s)


def _analyze(
    video: str | Path | None, imu: str | Path | None, calib: str | Path | None, method: str, baseline: Any, mode: str,
    imu_filter: str, imu_offset_s: float | None, imu_extrinsics: str, imu_calib: str | Path | None,
    progress: ProgressCallback | None, readout_s: float | None,
) -> Analysis:
    """:func:`analyze`, its arguments checked."""
    estimates: list[RotationEstimate] = []
    imu_info: dict[str, Any] | None = None
    if video is None:  # IMU-only analysis: the IMU's attitude, then the same gait stages
        if imu is None:
            msg = "give a VIDEO, or --imu IMU_CSV for IMU-only analysis"
            raise InvalidInputError(msg)
        if imu_extrinsics == "estimate":
            msg = "--imu-extrinsics estimate needs a VIDEO (the camera's rotation is what the IMU is aligned to)"
            raise ConfigError(msg)
        from walkmon.tables import imu_file_kind  # noqa: PLC0415

        telemetry = str(imu).lower().startswith(TELEMETRY_PREFIX)
        if not telemetry and imu_file_kind(imu) == "acc":  # t,ax,ay,az: steps, bouts, gravity pitch/roll, no yaw
            columns, imu_info = _acc_only_columns(imu, imu_offset_s or 0.0, imu_filter, imu_calib)
        else:
            columns, imu_info = _imu_only_columns(imu, imu_filter, imu_offset_s, imu_calib)
        imu_input = columns.pop("_imu_input")
        precision = dict.fromkeys(columns, 4)
        source = f"IMU only: {imu}"
    else:
        estimates = _video_rotations(video, calib, method, progress, readout_s)
        columns = angle_columns(estimates)
        imu_input = None
        if imu is not None:  # camera-IMU fusion: fused pitch/yaw/roll, + pitch_abs/roll_abs, *_video kept
            columns, imu_info = _fused_columns(columns, estimates, imu, imu_offset_s, imu_extrinsics, imu_filter, imu_calib)
            from walkmon.gait.session import ImuInput  # noqa: PLC0415
            rec, _ = _read_imu(imu)  # the raw samples for steps and activity, on the frames' time base
            used = (imu_info.get("extrinsics_used") or {}).get("time_offset_s")  # given, or estimated (telemetry)
            offset = float(used if used is not None else imu_offset_s or 0.0)
            imu_input = ImuInput(rec.t_s + offset - estimates[0].t_s, rec.accelerometer_m_s2, rec.gyroscope_rad_s)
        precision = dict(_PRECISION)
        source = str(video)
    no_yaw = bool(imu_info is not None and imu_info.get("mode") == "accelerometer_only")
    return _gait_stage(columns, baseline=baseline, mode=mode, meta={"video": source, "rotation method": method},
                       estimates=tuple(estimates), imu_info=imu_info, source=source, method=method,
                       precision=precision, imu_input=imu_input, no_yaw=no_yaw)


# --------------------------------------------------------------------------------------------- sessions
def _column(values: Sequence[object], text: bool) -> NDArray[Any]:
    if text:
        return np.asarray(["" if v is None else str(v) for v in values], dtype=str)
    return np.asarray([math.nan if v is None else v for v in values], dtype=float)


_SESSION_TEXT = {"model", "status", "label", "json", "kind", "state", "message", "reason", "activity"}


@dataclass(frozen=True, eq=False)
class Session:
    """A logged session (:func:`load_session`): its ``record`` (the sessions row: kind, camera, imu,
    started_utc, ended_utc, end_reason, config, versions, meta, ...) and its tables as numpy structured arrays
    (NULL as NaN, or '' in text columns): ``frames``, ``imu``, ``hops`` (with each hop's ``activity``: standing,
    walking, turning or unknown, '' where it has none), ``alerts``, ``calibrations``."""

    id: int
    record: Mapping[str, Any]
    frames: NDArray[Any]
    imu: NDArray[Any]
    hops: NDArray[Any]
    alerts: NDArray[Any]
    calibrations: NDArray[Any]

    def analyze(self, *, baseline: Any = None) -> Analysis:
        """The offline analysis of the session's frames (what ``walkmon report ID`` writes): indicators relative
        to the session's own standing phases as ``walkmon analyze`` finds them (the live monitor's calibration
        where it has none), and the fused absolute angles when an IMU was fused."""
        t = np.asarray(self.frames["t_s"], dtype=float)
        t0 = float(t[0]) if t.size else 0.0  # the session's start, held frames or not
        a = (np.column_stack([self.frames[c] for c in ("pitch", "yaw", "roll")]).astype(float) if t.size
             else np.empty((0, 3)))
        # an accelerometer alone measures no yaw (every frame's is NULL): pitch and roll are what it has
        no_yaw = bool(t.size) and not np.isfinite(a[:, 1]).any()
        ok = np.all(np.isfinite(a[:, [0, 2]] if no_yaw else a), axis=1) if t.size else np.zeros(0, bool)
        measured = measured_rows(self.frames["model"], self.frames["fused"]) if t.size else None
        if measured is not None:
            ok &= measured
        t, a = t[ok], a[ok]
        # schema 2: the fused gravity-referenced angles (NULL where not fused, or in a camera-only session)
        absolute = np.column_stack([self.frames["pitch_abs"], self.frames["roll_abs"]])[ok] if ok.size else None
        if absolute is not None and not np.isfinite(absolute).any():
            absolute = None
        if t.size < 16:
            msg = f"session {self.id} has {t.size} frames with angles: too few for a report"
            raise InvalidInputError(msg)
        imu_input = self._imu_input(t0)
        if no_yaw and imu_input is None:
            # an accelerometer's analysis saved without its samples (before 2026-11-28): its angles are gravity's
            # low-passed pitch and roll, which hold no steps (review: read as 'no walking bout', confidently)
            msg = (f"session {self.id}: the angles of an accelerometer alone, saved without its samples: they hold "
                   "no steps; analyse the accelerometer's file again with 'walkmon analyze --imu FILE --save'")
            raise InvalidInputError(msg)
        r = self.record
        meta = {"session": self.id, "kind": r["kind"], "source": r["camera"], "started_utc": r["started_utc"],
                "ended_utc": r["ended_utc"], "end_reason": r["end_reason"], "frames": int(t.size)}
        columns: dict[str, Any] = {"t": t - t0, "pitch": a[:, 0], "yaw": a[:, 1], "roll": a[:, 2]}
        if absolute is not None:
            columns.update(pitch_abs=absolute[:, 0], roll_abs=absolute[:, 1])
        saved = r.get("meta") if isinstance(r.get("meta"), Mapping) else {}
        axes = saved.get("axes_warning") if isinstance(saved, Mapping) else None  # a saved analysis's (see save)
        kw: dict[str, Any] = {"baseline": baseline, "mode": "walkmon", "meta": meta, "imu_input": imu_input,
                              "no_yaw": no_yaw, "no_posture": str(axes) if axes else None}
        # The session's own standing phases and pauses first, as 'walkmon analyze' finds them (and re-references
        # after turns from); the live monitor's calibration only where the recording has none and the analysis
        # would assume the first stride upright. Until 2026-11-28 the first calibration logged was the reference
        # of the whole session, even one the monitor itself rejected later (user review: taken while seated, every
        # normal walk read 'bend'; one taken after a turn left the rest 'uncertain across the turn').
        analysis = _gait_stage(columns, reference_deg=None, **kw)
        reference = self._live_reference()
        source = str((analysis.indicators.get("upright_reference") or {}).get("source", ""))
        if reference is not None and "assumed upright" in source:
            analysis = _gait_stage(columns, reference_deg=reference, **kw)
        return analysis

    def _live_reference(self) -> NDArray[np.float64] | None:
        """The live monitor's upright reference to fall back on: the last one it took other than a 'pause'
        re-reference (a drifted video's pose after a turn, no upright stance for the whole session), the reference it
        ended with: a 'posture' retake after a rejected stance, or a wearer's 'request' (review: only 'posture'
        counted, and a request's retake went back to the rejected seated start); None without any."""
        cal = self.calibrations
        if not len(cal):
            return None
        reasons = [str(v) for v in cal["reason"]]
        kept = [k for k, why in enumerate(reasons) if why != "pause"]
        if not kept:
            return None
        i = kept[-1]
        return np.array([cal["pitch"][i], cal["yaw"][i], cal["roll"][i]], dtype=float)

    def _imu_input(self, t0: float) -> Any:
        """The raw IMU samples an offline analysis stored (:meth:`Analysis.save`), on the frames' time base less
        ``t0``, for the steps and the activity (as ``walkmon analyze`` took them); None without them. Not a live
        session's: its IMU rows are the samples as they came, which the live monitor did not take steps from."""
        imu = self.imu
        if self.record.get("kind") != "analyze" or len(imu) < 2:
            return None
        from walkmon.gait.session import ImuInput  # noqa: PLC0415

        t = np.asarray(imu["t_s"], dtype=float) - t0
        acc = np.column_stack([imu[c] for c in ("ax", "ay", "az")]).astype(float)
        gyro = np.column_stack([imu[c] for c in ("gx", "gy", "gz")]).astype(float)
        saved = self.record.get("meta") if isinstance(self.record.get("meta"), Mapping) else {}
        spec = saved.get("acc_camera") if isinstance(saved, Mapping) else None
        acc_camera, cal = None, None
        if isinstance(spec, Mapping):  # the accelerometer was in the angles' axes (see Analysis.save)
            from walkmon.imu.calibration import AccelerometerCalibration  # noqa: PLC0415

            raw_cal = spec.get("calibration")
            cal = AccelerometerCalibration.from_dict(dict(raw_cal)) if isinstance(raw_cal, Mapping) else None
            acc_camera = acc if cal is None else cal.correct(acc)
        return ImuInput(t, acc, None if not np.isfinite(gyro).any() else gyro, acc_camera_m_s2=acc_camera,
                        accelerometer_calibration=cal)


def load_session(session_id: int, data_dir: str | Path | None = None) -> Session:
    """A session of the session log in ``data_dir`` (default ~/.local/share/walkmon); see :class:`Session`.
    An unknown id or a missing database raises InvalidInputError."""
    from walkmon.live.session_log import (  # noqa: PLC0415
        TABLE_COLUMNS,
        default_data_dir,
        hop_activity,
        open_database,
        read_session_table,
        session_record,
    )

    if isinstance(session_id, bool) or not isinstance(session_id, int | np.integer):
        # review: 'abc' raised ValueError, None TypeError, and 1.7 loaded session 1
        msg = f"session_id must be a whole number (see 'walkmon sessions list'), got {session_id!r}"
        raise InvalidInputError(msg)
    folder = Path(data_dir).expanduser() if data_dir is not None else default_data_dir()
    conn = open_database(folder, read_only=True)  # reading never writes (a read-only file works too)
    try:
        record = session_record(conn, int(session_id))
        tables = {}
        for name in TABLE_COLUMNS:
            cols = read_session_table(conn, int(session_id), name)
            if name == "hops":  # each hop's activity, from its JSON (as 'walkmon sessions export' gives it: review)
                cols = {**cols, "activity": [hop_activity(j) for j in cols.get("json", [])]}
            tables[name] = _structured({c: _column(v, c in _SESSION_TEXT) for c, v in cols.items()})
    finally:
        conn.close()
    return Session(id=int(session_id), record=record, **tables)
