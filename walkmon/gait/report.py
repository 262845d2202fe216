"""The session report: one self-contained ``report.html`` (figures embedded as base64 PNG, no external files).

Figures follow the paper's Figures 3-8: raw angles with the removed trend, the corrected (detrended) waveforms,
the Hamming-windowed analysis span, the amplitude spectra with the gait peak, and the extremums per cycle.
When an IMU was fused, a section on the absolute (gravity-referenced) pitch and roll: their statistics and a
figure beside the start-relative angles. Then the indicator table in the layout of the paper's Table 3 (with the baseline and the difference beside it
when a baseline is given), the classification and its reasons, the asymmetry figures and the session metadata.

Matplotlib is used through its object API on the Agg canvas (no pyplot, no global backend switch, no display).
"""

from __future__ import annotations

import base64
import contextlib
import html
import io
import logging
import math
from collections.abc import Mapping, Sequence
from datetime import UTC, datetime
from typing import Any

import numpy as np
from numpy.typing import ArrayLike

from walkmon._version import __version__
from walkmon.consts import AXES
from walkmon.errors import InvalidInputError
from walkmon.gait.indicators import (
    DEFAULT_INDICATOR_SETTINGS,
    GaitAnalysis,
    Indicators,
    IndicatorSettings,
    analyze_gait,
)

__all__ = ["TABLE3_ROWS", "render_report", "render_report_html", "timeline_from_angles", "timeline_from_columns"]

_log = logging.getLogger(__name__)

_COLORS = {"pitch": "#1f77b4", "yaw": "#2ca02c", "roll": "#d62728"}

#: Rows of the paper's Table 3: (label, axis, field).
TABLE3_ROWS = (
    ("P&#772;<sub>lmax</sub>", "pitch", "lmax_mean"),
    ("P&#772;<sub>lmin</sub>", "pitch", "lmin_mean"),
    ("Y&#772;<sub>lmax</sub>", "yaw", "lmax_mean"),
    ("Y&#772;<sub>lmin</sub>", "yaw", "lmin_mean"),
    ("R&#772;<sub>lmax</sub>", "roll", "lmax_mean"),
    ("R&#772;<sub>lmin</sub>", "roll", "lmin_mean"),
    ("&phi;&#772;<sub>p</sub> (swing)", "pitch", "swing_mean"),
    ("&phi;&#772;<sub>y</sub> (swing)", "yaw", "swing_mean"),
    ("&phi;&#772;<sub>r</sub> (swing)", "roll", "swing_mean"),
    ("&rho;&#772;<sub>p</sub> (inclination)", "pitch", "inclination_mean"),
    ("&rho;&#772;<sub>y</sub> (inclination)", "yaw", "inclination_mean"),
    ("&rho;&#772;<sub>r</sub> (inclination)", "roll", "inclination_mean"),
)


def _png(fig: Any) -> str:
    from matplotlib.backends.backend_agg import FigureCanvasAgg  # noqa: PLC0415

    FigureCanvasAgg(fig)
    buf = io.BytesIO()
    fig.savefig(buf, format="png", dpi=90)
    return base64.b64encode(buf.getvalue()).decode("ascii")


def _figure(n_rows: int, title: str) -> tuple[Any, list[Any]]:
    from matplotlib.figure import Figure  # noqa: PLC0415

    fig = Figure(figsize=(10, 1.9 * n_rows + 0.6), layout="constrained")
    axs = fig.subplots(n_rows, 1, sharex=True, squeeze=False)[:, 0]
    fig.suptitle(title)
    return fig, list(axs)


def _shade(ax: Any, an: GaitAnalysis) -> None:
    ind = an.indicators
    for span in (ind.standing_start_s, ind.standing_end_s):
        if span is not None:
            ax.axvspan(span[0], span[1], color="0.85", lw=0)
    i0, i1 = an.analysis_span
    if i1 > i0:
        ax.axvline(an.t_s[i0], color="0.4", lw=0.8, ls=":")
        ax.axvline(an.t_s[i1 - 1], color="0.4", lw=0.8, ls=":")


def _figures(an: GaitAnalysis) -> list[tuple[str, str]]:
    t = an.t_s
    out = []
    # Fig. 3-4: raw angles and the trend removed
    fig, axs = _figure(3, "Angles and the removed trend (grey: standing phases, dotted: analysed span)")
    for k, (axis, ax) in enumerate(zip(AXES, axs, strict=True)):
        _shade(ax, an)
        ax.plot(t, an.raw_deg[:, k], color=_COLORS[axis], lw=0.9, label=f"{axis} (raw)")
        ax.plot(t, an.trend_deg[:, k], color="k", lw=1.2, ls="--", label="trend / reference")
        ax.set_ylabel("deg")
        ax.legend(loc="upper right", fontsize=8)
    axs[-1].set_xlabel("time [s]")
    out.append(("Raw angles and trend (paper Fig. 3-4)", _png(fig)))
    # Fig. 5: corrected
    fig, axs = _figure(3, "Corrected angles (raw - trend)")
    for k, (axis, ax) in enumerate(zip(AXES, axs, strict=True)):
        _shade(ax, an)
        ax.plot(t, an.corrected_deg[:, k], color=_COLORS[axis], lw=0.9, label=axis)
        ax.axhline(0, color="0.5", lw=0.6)
        ax.set_ylabel("deg")
        ax.legend(loc="upper right", fontsize=8)
    axs[-1].set_xlabel("time [s]")
    out.append(("Detrended waveforms (paper Fig. 5)", _png(fig)))
    # Fig. 6: windowed
    fig, axs = _figure(3, "Hamming-windowed analysis span (Eq. 8)")
    for k, (axis, ax) in enumerate(zip(AXES, axs, strict=True)):
        ax.plot(t, an.windowed_deg[:, k], color=_COLORS[axis], lw=0.9, label=axis)
        ax.set_ylabel("deg")
        ax.legend(loc="upper right", fontsize=8)
    axs[-1].set_xlabel("time [s]")
    out.append(("Windowed waveforms (paper Fig. 6)", _png(fig)))
    # Fig. 7: spectra
    if an.spectra:
        fig, axs = _figure(3, "Amplitude spectra and the gait peak")
        for axis, ax in zip(AXES, axs, strict=True):
            f, amp = an.spectra[axis]
            sel = f <= 5.0
            ax.plot(f[sel], amp[sel], color=_COLORS[axis], lw=1.0, label=axis)
            peak = an.peak_hz.get(axis, float("nan"))
            if math.isfinite(peak):
                ax.axvline(peak, color="k", ls="--", lw=1.0, label=f"peak {peak:.3f} Hz")
            ax.set_ylabel("deg")
            ax.legend(loc="upper right", fontsize=8)
        axs[-1].set_xlabel("frequency [Hz]")
        out.append(("Spectra (paper Fig. 7)", _png(fig)))
    # Fig. 8: extremums
    fig, axs = _figure(3, "Extremums per gait cycle (triangles: maxima a_i, minima b_i)")
    for k, (axis, ax) in enumerate(zip(AXES, axs, strict=True)):
        _shade(ax, an)
        y = an.smoothed_deg[:, k]
        ax.plot(t, y, color=_COLORS[axis], lw=0.9, label=axis)
        imax = an.maxima_idx.get(axis, np.zeros(0, int))
        imin = an.minima_idx.get(axis, np.zeros(0, int))
        ax.plot(t[imax], y[imax], "^", color="k", ms=5, label=f"{imax.size} cycles")
        ax.plot(t[imin], y[imin], "v", color="0.45", ms=5)
        ax.set_ylabel("deg")
        ax.legend(loc="upper right", fontsize=8)
    axs[-1].set_xlabel("time [s]")
    out.append(("Extremums (paper Fig. 8)", _png(fig)))
    return out


def _absolute_section(t_s: np.ndarray, rel_deg: np.ndarray, abs_deg: np.ndarray | None) -> dict[str, Any] | None:
    """The absolute pitch/roll section's statistics and figure (None without any finite absolute angle)."""
    if abs_deg is None or not np.isfinite(abs_deg).any():
        return None
    have = np.isfinite(abs_deg).all(axis=1)
    stats: list[tuple[str, Any]] = [("frames with absolute angles", f"{int(have.sum())} of {have.size}")]
    for k, name in enumerate(("pitch_abs", "roll_abs")):
        v = abs_deg[have, k]
        stats += [(f"{name} mean [deg]", float(v.mean())), (f"{name} min [deg]", float(v.min())),
                  (f"{name} max [deg]", float(v.max())), (f"{name} std [deg]", float(v.std()))]
    fig, axs = _figure(2, "Absolute pitch and roll (against gravity) and the start-relative angles")
    for k, (axis, ax) in enumerate(zip(("pitch", "roll"), axs, strict=True)):
        col = AXES.index(axis)
        ax.plot(t_s, abs_deg[:, k], color=_COLORS[axis], lw=0.9, label=f"{axis}_abs (gravity-referenced)")
        ax.plot(t_s, rel_deg[:, col], color="0.5", lw=0.8, ls="--", label=f"{axis} (relative to the start)")
        ax.set_ylabel("deg")
        ax.legend(loc="upper right", fontsize=8)
    axs[-1].set_xlabel("time [s]")
    return {"stats": stats, "png": _png(fig)}


def _posture_withheld(cls: Mapping[str, Any]) -> bool:
    """The analysis withheld every posture (:func:`walkmon.gait.session.without_posture`: a sensor in another
    sensor's axes): its gravity angles are not the trunk's either, and the report shows none (user review: the
    appendix printed pitch_abs mean -88 deg, and 53 deg for angles wrapping past +-180)."""
    from walkmon.gait.session import NO_POSTURE  # noqa: PLC0415

    return any(str(r).startswith(NO_POSTURE) for r in cls.get("reasons") or ())


def _fmt(v: Any, digits: int = 3) -> str:
    if v is None or (isinstance(v, float) and not math.isfinite(v)):
        return "\u2013"
    return f"{v:.{digits}f}" if isinstance(v, float) else str(v)


def _value(doc: Mapping[str, Any], axis: str, key: str) -> float:
    v = doc.get("axes", {}).get(axis, {}).get(key)
    return float("nan") if v is None else float(v)


def _table3(doc: Mapping[str, Any], base: Mapping[str, Any] | None) -> tuple[list[tuple[Any, ...]], list[tuple[Any, ...]]]:
    """Rows of the paper's Table 3 (label markup, this walk[, baseline, difference]) and the extra rows."""
    from markupsafe import Markup  # noqa: PLC0415

    rows = []
    for label, axis, key in TABLE3_ROWS:
        v = _value(doc, axis, key)
        row: tuple[Any, ...] = (Markup(label), v)
        if base is not None:
            b = _value(base, axis, key)
            row += (b, v - b)
        rows.append(row)
    extra = []
    for label, key, digits in (("cadence [steps/min]", "cadence_spm", 1), ("walking analysed [s]", "walking_s", 1)):
        raw = doc.get(key)
        fv = None if raw is None else float(raw)
        row = (label, digits, fv)
        if base is not None:
            raw_base = base.get(key)
            fb = None if raw_base is None else float(raw_base)
            row += (fb, None if (fv is None or fb is None) else fv - fb)
        extra.append(row)
    return rows, extra


def timeline_from_angles(t_s: np.ndarray, angles_deg: np.ndarray, doc: Mapping[str, Any],
                         hop_s: float = 1.0) -> dict[str, Any]:
    """A per-second timeline from the angles alone (when neither hops nor a gait timeline exist): the mean
    pitch and roll of each second relative to the upright reference; activity ``standing`` in the detected
    standing phases, ``walking`` inside the analysed walking interval (labelled with the walk's one label),
    ``unknown`` elsewhere."""
    t = np.asarray(t_s, float)
    a = np.asarray(angles_deg, float)
    ref = doc.get("reference_deg") or {}
    rp, rr = float(ref.get("pitch") or 0.0), float(ref.get("roll") or 0.0)
    label = doc.get("classification", {}).get("label", "")
    walk = doc.get("walking_interval_s") or [None, None]
    stands = [s for s in (doc.get("standing_start_s"), doc.get("standing_end_s")) if s]
    cols: dict[str, list[Any]] = {k: [] for k in ("t_s", "walking", "activity", "label", "pitch", "roll")}
    if t.size == 0:
        return {"hops": cols, "alerts": [], "thresholds": {}, "hop_s": hop_s}
    edges = np.arange(t[0], t[-1] + hop_s, hop_s)
    for lo, hi in zip(edges[:-1], edges[1:], strict=True):
        sel = (t >= lo) & (t < hi)
        if not sel.any():
            continue
        mid = 0.5 * (lo + hi)
        walking = walk[0] is not None and walk[1] is not None and walk[0] <= mid <= walk[1]
        standing = any(s[0] is not None and s[0] <= mid <= s[1] for s in stands)
        cols["t_s"].append(float(hi - t[0]))
        cols["walking"].append(bool(walking))
        cols["activity"].append("walking" if walking else "standing" if standing else "unknown")
        cols["label"].append(label if walking else "")
        cols["pitch"].append(float(np.mean(a[sel, 0])) - rp)
        cols["roll"].append(float(np.mean(a[sel, 2])) - rr)
    return {"hops": cols, "alerts": [], "thresholds": {}, "hop_s": hop_s}


@contextlib.contextmanager
def _below_warning(logger: logging.Logger):  # noqa: ANN202
    """``logger``'s warnings held back (logged at DEBUG instead) for the ``with`` block."""

    class _Demote(logging.Filter):
        def filter(self, record: logging.LogRecord) -> bool:
            if record.levelno == logging.WARNING:
                logger.debug("%s", record.getMessage())
                return False
            return True

    demote = _Demote()
    logger.addFilter(demote)
    try:
        yield
    finally:
        logger.removeFilter(demote)


def vertical_text(ref: Mapping[str, Any]) -> str:
    """' Gravity: ...' for a report or a summary line: where gravity's direction came from and, from the wearer's
    turns, the camera's tilt at the upright pose (its tilt on the chest when that pose is a standing phase); ''
    without it (paper mode, older files)."""
    v = ref.get("vertical") or {}
    if not v.get("source"):
        return ""
    tilt = ""
    if v.get("camera_pitch_deg") is not None and v.get("camera_roll_deg") is not None:
        p, r = float(v["camera_pitch_deg"]), float(v["camera_roll_deg"])
        askew = (f" and {abs(r):.0f} deg {'clockwise' if r > 0 else 'anticlockwise'} (seen from behind)"
                 if abs(r) >= 0.5 else "")
        tilt = f"; the camera {abs(p):.0f} deg {'down' if p < 0 else 'up'}{askew} at the upright pose"
        if v.get("verified") is False:
            tilt += f", not verified (uncertain by {float(v.get('uncertainty_deg') or 0):.0f} deg)"
    return f" Gravity: {v['source']}{tilt}."


def _session_section(doc: Mapping[str, Any]) -> str:
    """Walking bouts, posture segments and turns of a walkmon-mode analysis (schema 2); '' in paper mode."""
    if "segments" not in doc:
        return ""
    summary = doc.get("summary") or {}
    ref = doc.get("upright_reference") or {}
    head = ("<tr><th>start [s]</th><th>end [s]</th><th>steps</th><th>cadence [spm]</th><th>spectral [spm]</th>"
            "<th>pitch &rho; [deg]</th><th>roll &rho; [deg]</th><th>total swing [deg]</th><th>label</th></tr>")

    def rows(items: list[Mapping[str, Any]]) -> str:
        out = []
        for d in items:
            axes = d.get("axes") or {}

            def ax(name: str, key: str, axes=axes) -> Any:  # noqa: ANN001
                a = axes.get(name) or {}
                return a.get(key)

            swings = [ax(a, "swing_mean") for a in ("pitch", "yaw", "roll")]
            total = sum(v for v in swings if v is not None) if any(v is not None for v in swings) else None
            out.append(f"<tr><td>{_fmt(d.get('start_s'), 1)}</td><td>{_fmt(d.get('end_s'), 1)}</td>"
                       f"<td>{d.get('n_steps')}</td><td>{_fmt(d.get('cadence_spm'), 1)}</td>"
                       f"<td>{_fmt(d.get('spectral_cadence_spm'), 1)}</td><td>{_fmt(ax('pitch', 'inclination_mean'), 1)}"
                       f"</td><td>{_fmt(ax('roll', 'inclination_mean'), 1)}</td><td>{_fmt(total, 1)}</td>"
                       f"<td title='{html.escape('; '.join(d.get('reasons') or []))}'>{html.escape(str(d.get('label')))}"
                       "</td></tr>")
        return "".join(out)

    turns = ", ".join(f"{_fmt(u.get('start_s'), 1)}-{_fmt(u.get('end_s'), 1)} s ({_fmt(u.get('angle_deg'), 0)} deg)"
                      for u in doc.get("turns") or []) or "none"
    times = ", ".join(f"{k} {_fmt(v, 1)} s" for k, v in (doc.get("activity_s") or {}).items())
    posture = ", ".join(f"{k} {_fmt(v, 1)} s" for k, v in (summary.get("posture_time_s") or {}).items()) or "none"
    notes = "".join(f"<li>{html.escape(n)}</li>" for n in (doc.get("input") or {}).get("notes") or [])
    return (f"<h2>Activity, walking bouts and posture segments</h2>\n<p class='small'>Activity: {html.escape(times)}. "
            f"Upright reference: {html.escape(str(ref.get('source', '?')))}.{html.escape(vertical_text(ref))} "
            "Labelled walking time: "
            f"{html.escape(posture)}. Turns: {html.escape(turns)}. The summary above is the duration-weighted "
            f"aggregate over the posture segments (turns excluded).</p>{f'<ul>{notes}</ul>' if notes else ''}\n"
            f"<h3>Bouts</h3><table>{head}{rows(doc.get('bouts') or [])}</table>\n"
            f"<h3>Posture segments</h3><table>{head}{rows(doc.get('segments') or [])}</table>")


def _markup(text: str) -> Any:
    """``text`` (HTML built with every value escaped) marked safe for the autoescaping template."""
    from markupsafe import Markup  # noqa: PLC0415

    return Markup(text)  # noqa: S704  (values inside were escaped with html.escape)


def _kv_table(items: Mapping[str, Any]) -> str:
    rows = "".join(f"<tr><td>{html.escape(str(k))}</td><td>{_fmt(v)}</td></tr>" for k, v in items.items())
    return f"<table>{rows}</table>"


def timeline_from_columns(cols: Mapping[str, Sequence[Any]], hop_s: float = 1.0) -> dict[str, Any]:
    """The gait analysis's timeline.csv (``t,activity,label,pitch,roll[,ref_uncertainty_deg]`` at 1 s) in the
    timeline shape (the uncertainty as ``hops["uncertainty"]`` when the columns hold it). A row's ``t`` is the
    middle of its second, [t - 0.5, t + 0.5); a hop's time is the end of its window, as the live monitor's are:
    ``t + hop_s / 2`` (the figure drew each second half a second early, the first from -1 s: user review)."""
    activity = [str(v or "") for v in cols["activity"]]
    walking = [act == "walking" for act in activity]

    def num(v: Any) -> float | None:
        try:
            f = float(v)
        except (TypeError, ValueError):
            return None
        return f if math.isfinite(f) else None

    hops = {"t_s": [float(v) + hop_s / 2 for v in cols["t"]], "walking": walking, "activity": activity,
            "label": [str(v or "") for v in cols["label"]], "pitch": [num(v) for v in cols["pitch"]],
            "roll": [num(v) for v in cols["roll"]]}
    if "ref_uncertainty_deg" in cols:
        hops["uncertainty"] = [num(v) for v in cols["ref_uncertainty_deg"]]
    return {"hops": hops, "alerts": [], "thresholds": {}, "hop_s": hop_s}


def render_report_html(
    analysis: GaitAnalysis,
    indicators: Indicators,
    baseline: Indicators | Mapping[str, Any] | None = None,
    meta: Mapping[str, Any] | None = None,
    *,
    abs_angles_deg: ArrayLike | None = None,
    timeline: Mapping[str, Any] | None = None,
    timeline_source: str = "",
    stats: Any = None,
    person: str = "",
) -> str:
    """The report as one HTML string (see :func:`render_report`); ``abs_angles_deg`` (N, 2) at ``analysis.t_s``.

    First page in plain words: the summary sentence, the timeline figure (``timeline``: hops and alerts of a
    logged session, or the gait analysis's timeline; without one, :func:`timeline_from_angles`), the time in
    each posture and the alerts; then the appendix: the paper's Table 3, asymmetry, Figures 3-8, the absolute
    angles and the session details. ``stats``: the session's :class:`walkmon.views.history.SessionStats`.
    """
    from walkmon.views import svg, words  # noqa: PLC0415
    from walkmon.views.render import describe_label, render  # noqa: PLC0415

    doc = indicators.to_dict()
    base = baseline.to_dict() if isinstance(baseline, Indicators) else baseline
    cls = doc["classification"]
    if timeline is None:
        timeline = timeline_from_angles(analysis.t_s, analysis.raw_deg, doc)
        timeline_source = timeline_source or ("Per second, from the angles alone: one label for the analysed walk "
                                              "(no per-second classification was logged for this recording).")
    tl = dict(timeline)
    tl.setdefault("thresholds", {})
    cadence = doc.get("cadence_spm")
    summary = _summary(tl, stats, doc, base, words)
    session: list[tuple[str, Any]] = [
        ("generated (local time)", datetime.now(UTC).astimezone().strftime("%Y-%m-%d %H:%M:%S %Z")),
        ("walkmon version", __version__), ("processing mode", doc["mode"]), ("status", doc["status"]),
        ("duration [s]", doc["duration_s"]),
        ("analysed span [s]", " - ".join(_fmt(v, 2) for v in doc["walking_interval_s"])),
        ("standing at start [s]", " - ".join(_fmt(v, 2) for v in (doc["standing_start_s"] or [None, None]))),
        ("standing at end [s]", " - ".join(_fmt(v, 2) for v in (doc["standing_end_s"] or [None, None]))),
        ("baseline given", "yes" if base is not None else "no (default absolute thresholds)"),
    ]
    for k, v in (meta or {}).items():
        session.append((str(k), v if isinstance(v, int | float | str) or v is None else str(v)))
    reference = [(f"{k} reference (upright) [deg]", v) for k, v in doc["reference_deg"].items()]
    reference += [(f"{k} drift removed [deg]", v) for k, v in doc["drift_removed_deg"].items()]
    table3, extra_rows = _table3(doc, base)
    legend = svg.legend(tl)
    when = ""
    started = (meta or {}).get("started_utc")
    if isinstance(started, str):
        from walkmon.views.history import local_time  # noqa: PLC0415

        with contextlib.suppress(ValueError):
            when = "Recorded " + local_time(started).strftime("%A %d %B %Y, %H:%M %Z")
    text = render(
        "report.html", standalone=True, person=person or (stats.person if stats is not None else ""), when=when,
        source=str((meta or {}).get("source") or ""), summary=summary, label=cls["label"],
        label_words=describe_label(cls["label"]), cadence=cadence, reasons=list(cls["reasons"]),
        timeline_svg=svg.timeline_svg(tl, title="Posture per second"), legend=legend,
        timeline_source=timeline_source, postures=words.posture_times(tl),
        alerts=tl["alerts"] if stats is not None or tl["alerts"] else None,
        has_baseline=base is not None, table3=table3, extra_rows=extra_rows,
        cycles=", ".join(f"{a} {doc['axes'][a].get('n_cycles', 0)}" for a in AXES),
        asymmetry=list(doc["asymmetry"].items()), figures=_figures(analysis),
        absolute=None if _posture_withheld(cls) else _absolute_section(
            analysis.t_s, analysis.raw_deg,
            None if abs_angles_deg is None else np.asarray(abs_angles_deg, float).reshape(-1, 2)),
        session=session, reference=reference, session_section=_markup(_session_section(doc)))
    return text.lstrip()


def _summary(tl: Mapping[str, Any], stats: Any, doc: Mapping[str, Any], base: Mapping[str, Any] | None,
             words: Any) -> str:
    """The first page's sentence: from the session's statistics, else from the timeline and the indicators."""
    from walkmon.views.history import SessionStats  # noqa: PLC0415

    if stats is None:
        hops = tl["hops"]
        hop_s = float(tl.get("hop_s", 1.0))
        th = tl.get("thresholds") or {}
        lean, shoulder = float(th.get("lean_forward_deg", 10.0)), float(th.get("shoulder_down_deg", 5.0))
        known = [(p, r) for w, p, r in zip(hops["walking"], hops["pitch"], hops["roll"], strict=True)
                 if w and p is not None and r is not None]
        upright = sum(1 for p, r in known if -p <= lean and abs(r) <= shoulder)
        walking_s = sum(hops["walking"]) * hop_s  # straight walking, as the history counts it
        alerts: dict[str, int] = {}
        for ev in tl.get("alerts", []):
            if ev["state"] == "raised":
                alerts[ev["kind"]] = alerts.get(ev["kind"], 0) + 1
        pitch = [p for p, _ in known]
        stats = SessionStats(
            id=0, kind="analysis", person="", started_utc="1970-01-01T00:00:00+00:00", ended_utc=None,
            end_reason=None, camera="", hop_s=hop_s, recorded_s=len(hops["t_s"]) * hop_s, walking_s=walking_s,
            upright_s=upright * hop_s, posture_known_s=len(known) * hop_s,
            cadence_spm=float(doc.get("cadence_spm") or math.nan),
            pitch_deg=float(np.mean(pitch)) if pitch else math.nan, roll_deg=math.nan, asymmetry=math.nan,
            alerts=alerts)
    bouts = doc.get("walking_s")  # an analysis's time in walking bouts (schema 2), shown beside it
    text = words.session_summary(stats, in_bouts_s=float(bouts) if isinstance(bouts, int | float) else None)
    if base is not None:
        base_cadence = float(base.get("cadence_spm") or math.nan)
        base_pitch = _value(base, "pitch", "inclination_mean")

        class _Base:
            upright_pct = math.nan
            cadence_spm = base_cadence
            pitch_deg = base_pitch

        text += " " + words.compare(math.nan, float(doc.get("cadence_spm") or math.nan),
                                    _value(doc, "pitch", "inclination_mean"), _Base(), "your baseline")
    return text


def render_report(
    t_s: ArrayLike,
    angles_deg: ArrayLike,
    indicators: Indicators,
    baseline: Indicators | Mapping[str, Any] | None = None,
    meta: Mapping[str, Any] | None = None,
    *,
    settings: IndicatorSettings | None = None,
    reference_deg: ArrayLike | None = None,
    abs_angles_deg: ArrayLike | None = None,
    timeline: Mapping[str, Any] | None = None,
    timeline_source: str = "",
    stats: Any = None,
    person: str = "",
) -> str:
    """The self-contained report.html of one walk, as a string (the caller writes it: gait does no I/O).

    The figures are recomputed with :func:`walkmon.gait.indicators.analyze_gait` in ``indicators.mode`` (or with
    ``settings``); the tables show ``indicators`` as given. ``abs_angles_deg`` (N, 2): the fused absolute
    pitch and roll at the same ``t_s`` (NaN where a frame was not fused) adds their section; none, or all NaN:
    no section. ``timeline`` (hops and alerts of a logged session, or the gait analysis's timeline.csv via
    :func:`timeline_from_columns`) drives the first page's timeline figure; ``stats`` its summary sentence.
    """
    if abs_angles_deg is not None:
        abs_angles_deg = np.asarray(abs_angles_deg, dtype=float)
        if abs_angles_deg.shape != (np.shape(t_s)[0], 2):
            msg = f"abs_angles_deg must have shape ({np.shape(t_s)[0]}, 2) like t_s, got {abs_angles_deg.shape}"
            raise InvalidInputError(msg)
    if settings is None:
        settings = (
            DEFAULT_INDICATOR_SETTINGS
            if indicators.mode == DEFAULT_INDICATOR_SETTINGS.mode
            else IndicatorSettings(mode=indicators.mode)
        )
    # the figures' own pass over the recording: the analysis that produced ``indicators`` has already said what
    # it had to (its stance warnings, e.g. an end stance that a tilted camera's U-turn moved, would repeat here)
    with _below_warning(logging.getLogger("walkmon.gait.indicators")):
        analysis = analyze_gait(t_s, angles_deg, settings, reference_deg=reference_deg)
    t_in = np.asarray(t_s, dtype=float)
    if abs_angles_deg is not None and not np.array_equal(analysis.t_s, t_in):
        # irregular time stamps (dropped frames): the analysis resampled the angles onto a uniform grid, and
        # the absolute angles are plotted beside them, so they go onto the same grid
        abs_angles_deg = np.column_stack([np.interp(analysis.t_s, t_in, abs_angles_deg[:, k]) for k in range(2)])
    return render_report_html(analysis, indicators, baseline, meta, abs_angles_deg=abs_angles_deg,
                              timeline=timeline, timeline_source=timeline_source, stats=stats, person=person)
