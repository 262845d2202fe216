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
import html
import io
import logging
import math
from collections.abc import Mapping
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

__all__ = ["TABLE3_ROWS", "render_report", "render_report_html"]

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


def _absolute_section(t_s: np.ndarray, rel_deg: np.ndarray, abs_deg: np.ndarray | None) -> str:
    """The absolute pitch/roll section ('' without any finite absolute angle, e.g. a camera-only session)."""
    if abs_deg is None or not np.isfinite(abs_deg).any():
        return ""
    have = np.isfinite(abs_deg).all(axis=1)
    stats: dict[str, Any] = {"frames with absolute angles": f"{int(have.sum())} of {have.size}"}
    for k, name in enumerate(("pitch_abs", "roll_abs")):
        v = abs_deg[have, k]
        stats.update({f"{name} mean [deg]": float(v.mean()), f"{name} min [deg]": float(v.min()),
                      f"{name} max [deg]": float(v.max()), f"{name} std [deg]": float(v.std())})
    fig, axs = _figure(2, "Absolute pitch and roll (against gravity) and the start-relative angles")
    for k, (axis, ax) in enumerate(zip(("pitch", "roll"), axs, strict=True)):
        col = AXES.index(axis)
        ax.plot(t_s, abs_deg[:, k], color=_COLORS[axis], lw=0.9, label=f"{axis}_abs (gravity-referenced)")
        ax.plot(t_s, rel_deg[:, col], color="0.5", lw=0.8, ls="--", label=f"{axis} (relative to the start)")
        ax.set_ylabel("deg")
        ax.legend(loc="upper right", fontsize=8)
    axs[-1].set_xlabel("time [s]")
    title = "Absolute pitch and roll (IMU fusion)"
    return (f"<h2>{title}</h2>\n<p class='small'>Pitch and roll against gravity, from the camera-IMU fusion "
            "(0 = upright camera, no drift); blank where a frame was not fused.</p>\n"
            f"{_kv_table(stats)}\n<figure><img alt='{title}' src='data:image/png;base64,{_png(fig)}'>"
            f"<figcaption class='small'>{title}</figcaption></figure>")


def _fmt(v: Any, digits: int = 3) -> str:
    if v is None:
        return "&ndash;"
    if isinstance(v, float):
        return f"{v:.{digits}f}" if math.isfinite(v) else "&ndash;"
    return html.escape(str(v))


def _value(doc: Mapping[str, Any], axis: str, key: str) -> float:
    v = doc.get("axes", {}).get(axis, {}).get(key)
    return float("nan") if v is None else float(v)


def _indicator_table(doc: Mapping[str, Any], base: Mapping[str, Any] | None) -> str:
    head = "<tr><th>indicator [deg]</th><th>this walk</th>"
    if base is not None:
        head += "<th>baseline</th><th>difference</th>"
    rows = [head + "</tr>"]
    for label, axis, key in TABLE3_ROWS:
        v = _value(doc, axis, key)
        row = f"<tr><td>{label}</td><td>{_fmt(v)}</td>"
        if base is not None:
            b = _value(base, axis, key)
            row += f"<td>{_fmt(b)}</td><td>{_fmt(v - b)}</td>"
        rows.append(row + "</tr>")
    extra = [("cadence [steps/min]", "cadence_spm", 1), ("walking analysed [s]", "walking_s", 1)]
    for label, key, digits in extra:
        value = doc.get(key)
        row = f"<tr><td>{label}</td><td>{_fmt(None if value is None else float(value), digits)}</td>"
        if base is not None:
            base_value = base.get(key)
            d = None if (value is None or base_value is None) else float(value) - float(base_value)
            row += (f"<td>{_fmt(None if base_value is None else float(base_value), digits)}</td>"
                    f"<td>{_fmt(d, digits)}</td>")
        rows.append(row + "</tr>")
    cycles = ", ".join(f"{a} {doc['axes'][a].get('n_cycles', 0)}" for a in AXES)
    rows.append(f"<tr><td>cycles used</td><td colspan='3'>{html.escape(cycles)}</td></tr>")
    return "<table>" + "".join(rows) + "</table>"


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
            f"Upright reference: {html.escape(str(ref.get('source', '?')))}. Labelled walking time: "
            f"{html.escape(posture)}. Turns: {html.escape(turns)}. The summary above is the duration-weighted "
            f"aggregate over the posture segments (turns excluded).</p>{f'<ul>{notes}</ul>' if notes else ''}\n"
            f"<h3>Bouts</h3><table>{head}{rows(doc.get('bouts') or [])}</table>\n"
            f"<h3>Posture segments</h3><table>{head}{rows(doc.get('segments') or [])}</table>")


def _kv_table(items: Mapping[str, Any]) -> str:
    rows = "".join(f"<tr><td>{html.escape(str(k))}</td><td>{_fmt(v)}</td></tr>" for k, v in items.items())
    return f"<table>{rows}</table>"


_CSS = """
body{font-family:system-ui,-apple-system,Segoe UI,sans-serif;margin:24px auto;max-width:1000px;color:#222}
h1{font-size:1.6em;margin-bottom:0}h2{font-size:1.2em;margin-top:1.6em;border-bottom:1px solid #ccc}
table{border-collapse:collapse;margin:8px 0}td,th{border:1px solid #ccc;padding:3px 10px;text-align:right}
td:first-child,th:first-child{text-align:left}th{background:#f0f0f0}
.label{font-size:1.4em;font-weight:bold;padding:8px 14px;display:inline-block;border-radius:6px;background:#e8f0fe}
.label.normal{background:#e6f4ea}.label.unclassified{background:#eee}
figure{margin:12px 0}figure img{width:100%;height:auto;border:1px solid #ddd}
.small{color:#666;font-size:.9em}
"""


def render_report_html(
    analysis: GaitAnalysis,
    indicators: Indicators,
    baseline: Indicators | Mapping[str, Any] | None = None,
    meta: Mapping[str, Any] | None = None,
    *,
    abs_angles_deg: ArrayLike | None = None,
) -> str:
    """The report as one HTML string (see :func:`write_report`); ``abs_angles_deg`` (N, 2) at ``analysis.t_s``."""
    doc = indicators.to_dict()
    base = baseline.to_dict() if isinstance(baseline, Indicators) else baseline
    cls = doc["classification"]
    label = html.escape(cls["label"])
    reasons = "".join(f"<li>{html.escape(r)}</li>" for r in cls["reasons"]) or "<li>(none)</li>"
    figures = "".join(
        f"<figure><img alt='{html.escape(title)}' src='data:image/png;base64,{png}'>"
        f"<figcaption class='small'>{html.escape(title)}</figcaption></figure>"
        for title, png in _figures(analysis)
    )
    session = {
        "generated (UTC)": datetime.now(UTC).strftime("%Y-%m-%d %H:%M:%S"),
        "walkmon version": __version__,
        "processing mode": doc["mode"],
        "status": doc["status"],
        "duration [s]": doc["duration_s"],
        "analysed span [s]": " - ".join(_fmt(v, 2) for v in doc["walking_interval_s"]),
        "standing at start [s]": " - ".join(_fmt(v, 2) for v in (doc["standing_start_s"] or [None, None])),
        "standing at end [s]": " - ".join(_fmt(v, 2) for v in (doc["standing_end_s"] or [None, None])),
        "baseline given": "yes" if base is not None else "no (default absolute thresholds)",
    }
    for k, v in (meta or {}).items():
        session[str(k)] = v if isinstance(v, int | float | str) or v is None else str(v)
    ref = {f"{k} reference (upright) [deg]": v for k, v in doc["reference_deg"].items()}
    ref.update({f"{k} drift removed [deg]": v for k, v in doc["drift_removed_deg"].items()})
    absolute = _absolute_section(analysis.t_s, analysis.raw_deg,
                                 None if abs_angles_deg is None else np.asarray(abs_angles_deg, float).reshape(-1, 2))
    return f"""<!DOCTYPE html>
<html lang="en"><head><meta charset="utf-8"><title>walkmon gait report</title>
<style>{_CSS}</style></head><body>
<h1>walkmon gait report</h1>
<p class="small">Trunk rotation of a chest-worn camera while walking: the indicators of Sec. 4-5 of the
reference paper (swing &phi; = a &minus; b and inclination &rho; = (a + b)/2 per gait cycle, Eq. 9-15).</p>
<h2>Classification</h2>
<p><span class="label {label}">{label}</span> &nbsp; cadence {_fmt(doc['cadence_spm'], 1)} steps/min</p>
<ul>{reasons}</ul>
{_session_section(doc)}
<h2>Indicators (paper Table 3 layout)</h2>
{_indicator_table(doc, base)}
<h2>Left/right asymmetry (alternate steps)</h2>
{_kv_table(doc['asymmetry'])}
<h2>Figures</h2>
{figures}
{absolute}
<h2>Session</h2>
{_kv_table(session)}
{_kv_table(ref) if ref else ''}
</body></html>
"""


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
) -> str:
    """The self-contained report.html of one walk, as a string (the caller writes it: gait does no I/O).

    The figures are recomputed with :func:`walkmon.gait.indicators.analyze_gait` in ``indicators.mode`` (or with
    ``settings``); the tables show ``indicators`` as given. ``abs_angles_deg`` (N, 2): the fused absolute
    pitch and roll at the same ``t_s`` (NaN where a frame was not fused) adds their section; none, or all NaN:
    no section.
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
    analysis = analyze_gait(t_s, angles_deg, settings, reference_deg=reference_deg)
    t_in = np.asarray(t_s, dtype=float)
    if abs_angles_deg is not None and not np.array_equal(analysis.t_s, t_in):
        # irregular time stamps (dropped frames): the analysis resampled the angles onto a uniform grid, and
        # the absolute angles are plotted beside them, so they go onto the same grid
        abs_angles_deg = np.column_stack([np.interp(analysis.t_s, t_in, abs_angles_deg[:, k]) for k in range(2)])
    return render_report_html(analysis, indicators, baseline, meta, abs_angles_deg=abs_angles_deg)
