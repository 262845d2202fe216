"""Small inline SVG charts (pure functions returning markup): the session timeline and the history trend.

SVG rather than PNG: it is sharp on screen and paper, costs milliseconds (the history of 100 hours renders in
well under a second), needs no plotting library in the dashboard and carries its own accessible title. Every
text node is escaped; the markup is given to the templates as ``Markup``.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from html import escape
from typing import Any

from markupsafe import Markup

__all__ = ["ACTIVITY_COLORS", "LABEL_COLORS", "legend", "timeline_svg", "trend_svg"]

#: Fill colours of the activity/posture band (colour-blind-safe palette, Okabe-Ito).
LABEL_COLORS = {
    "normal": "#009E73", "bend": "#E69F00", "left_shoulder_down": "#CC79A7", "right_foot_drag": "#D55E00",
    "unclassified": "#999999", "not_walking": "#DDDDDD",
}
ACTIVITY_COLORS = {"standing": "#DDDDDD", "not walking": "#DDDDDD", "turning": "#56B4E9", "unknown": "#BBBBBB"}
_PITCH, _ROLL, _TEXT, _GRID = "#0072B2", "#D55E00", "#222222", "#BBBBBB"
#: The timeline shades the seconds whose upright reference may be off by more than this (deg): about what the
#: video's own orientation error reaches over a long straight walk, below which shading would mark every turn.
UNCERTAIN_SHADE_DEG = 1.0


def legend(tl: dict[str, Any]) -> list[tuple[str, str]]:
    """(name in words, colour) of the states that appear in a timeline's band, each name once."""
    from walkmon.views.render import describe_label  # noqa: PLC0415

    hops = tl["hops"]
    seen = {lab for w, lab in zip(hops["walking"], hops["label"], strict=True) if w and lab}
    seen |= {act for w, lab, act in zip(hops["walking"], hops["label"], hops["activity"], strict=True)
             if not (w and lab)}
    out: dict[str, str] = {}
    for k, c in LABEL_COLORS.items():
        if k in seen:
            out.setdefault(describe_label(k), c)
    for k, c in ACTIVITY_COLORS.items():
        if k in seen:
            out.setdefault(k, c)
    return list(out.items())


def _fmt_t(t: float) -> str:
    if t >= 120:
        return f"{t / 60:.0f} min" if t % 60 == 0 else f"{t / 60:.1f} min"
    return f"{t:.0f} s" if abs(t - round(t)) < 0.05 else f"{t:.1f} s"


def _ticks(lo: float, hi: float, n: int = 6) -> list[float]:
    span = hi - lo
    if not span > 0:
        return [lo]
    raw = span / n
    mag = 10 ** math.floor(math.log10(raw))
    step = next(m * mag for m in (1, 2, 5, 10) if m * mag >= raw)
    first = math.ceil(lo / step) * step
    return [first + i * step for i in range(int((hi - first) / step) + 1)]


def _polyline(xs: Sequence[float], ys: Sequence[float | None], color: str, width: float = 1.4) -> str:
    """Polylines broken at missing values."""
    parts: list[list[str]] = []
    cur: list[str] = []
    for x, y in zip(xs, ys, strict=True):
        if y is None or not math.isfinite(y):
            if len(cur) > 1:
                parts.append(cur)
            cur = []
        else:
            cur.append(f"{x:.1f},{y:.1f}")
    if len(cur) > 1:
        parts.append(cur)
    return "".join(f'<polyline fill="none" stroke="{color}" stroke-width="{width}" points="{" ".join(p)}"/>'
                   for p in parts)


class _Panel:
    """One chart panel: data coordinates -> SVG coordinates, with axes and tick labels."""

    def __init__(self, x0: float, y0: float, w: float, h: float, xlim: tuple[float, float],
                 ylim: tuple[float, float]) -> None:
        self.x0, self.y0, self.w, self.h = x0, y0, w, h
        self.xlim, self.ylim = xlim, ylim

    def x(self, v: float) -> float:
        lo, hi = self.xlim
        return self.x0 + (v - lo) / (hi - lo) * self.w if hi > lo else self.x0

    def y(self, v: float | None) -> float | None:
        if v is None or not math.isfinite(v):
            return None
        lo, hi = self.ylim
        v = min(max(v, lo), hi)
        return self.y0 + self.h - (v - lo) / (hi - lo) * self.h

    def frame(self, ylabel: str, yticks: Sequence[float]) -> str:
        out = [f'<rect x="{self.x0}" y="{self.y0}" width="{self.w}" height="{self.h}" fill="none" '
               f'stroke="{_GRID}"/>']
        for v in yticks:
            yy = self.y(v)
            if yy is None:
                continue
            out.append(f'<line x1="{self.x0}" x2="{self.x0 + self.w}" y1="{yy:.1f}" y2="{yy:.1f}" stroke="#EEEEEE"/>')
            out.append(f'<text x="{self.x0 - 4}" y="{yy + 4:.1f}" text-anchor="end" font-size="11" '
                       f'fill="{_TEXT}">{v:g}</text>')
        out.append(f'<text x="{self.x0 - 40}" y="{self.y0 + self.h / 2:.0f}" font-size="12" fill="{_TEXT}" '
                   f'transform="rotate(-90 {self.x0 - 40} {self.y0 + self.h / 2:.0f})" text-anchor="middle">'
                   f'{escape(ylabel)}</text>')
        return "".join(out)

    def hline(self, v: float, color: str, label: str) -> str:
        yy = self.y(v)
        if yy is None:
            return ""
        return (f'<line x1="{self.x0}" x2="{self.x0 + self.w}" y1="{yy:.1f}" y2="{yy:.1f}" stroke="{color}" '
                f'stroke-dasharray="5 4"/><text x="{self.x0 + self.w - 4}" y="{yy - 3:.1f}" text-anchor="end" '
                f'font-size="10" fill="{_TEXT}">{escape(label)}</text>')


def _finite(vals: Sequence[float | None]) -> list[float]:
    return [float(v) for v in vals if v is not None and math.isfinite(v)]


def _broken_at_gaps(t: Sequence[float], vals: Sequence[Any], hop_s: float) -> tuple[list[float], list[Any]]:
    """``t`` and ``vals`` with a missing value between two rows more than 1.5 hops apart, so that the line breaks
    there: a timeline has no rows inside a gap of the recording (nothing measured), which a line would bridge."""
    tt: list[float] = []
    vv: list[Any] = []
    for i, (ti, v) in enumerate(zip(t, vals, strict=True)):
        if i and ti - t[i - 1] > 1.5 * hop_s:
            tt.append(0.5 * (ti + t[i - 1]))
            vv.append(None)
        tt.append(ti)
        vv.append(v)
    return tt, vv


def timeline_svg(tl: dict[str, Any], *, width: int = 900, title: str = "Session timeline") -> Markup:
    """Pitch and roll posture per hop against the alert thresholds, the activity/posture band, alert markers.

    ``tl``: :meth:`walkmon.serve.store.Store.timeline`'s dict (or the same shape built from a timeline.csv):
    ``hops`` columns ``t_s``, ``activity``, ``label``, ``walking``, ``pitch``, ``roll``; ``alerts``;
    ``thresholds`` (``lean_forward_deg``, ``shoulder_down_deg``); ``hop_s``.
    """
    hops = tl["hops"]
    t = [float(v) for v in hops["t_s"]]
    th = tl.get("thresholds", {})
    lean, shoulder = float(th.get("lean_forward_deg", 10.0)), float(th.get("shoulder_down_deg", 5.0))
    hop_s = float(tl.get("hop_s", 1.0))
    left, right, top = 60, 16, 30
    pw = width - left - right
    band_h, panel_h, gap = 18, 110, 26
    height = top + band_h + gap + 2 * panel_h + gap + 40
    if not t:
        return Markup(f'<svg role="img" viewBox="0 0 {width} 60" width="100%"><title>{escape(title)}</title>'
                      f'<text x="10" y="30" fill="{_TEXT}">no hops logged</text></svg>')
    # a hop's time is the end of its window; a recording starts at 0 (its first timeline second, centred there,
    # holds half a second)
    xlim = (max(t[0] - hop_s, 0.0) if t[0] >= 0 else t[0] - hop_s, t[-1])
    pitch, roll = hops["pitch"], hops["roll"]
    fp, fr = _finite(pitch), _finite(roll)
    p_lim = (min(-lean - 5, *(fp or [0]), -5.0), max(5.0, *(fp or [0])))
    r_abs = max(shoulder + 3, *(abs(v) for v in fr)) if fr else shoulder + 3
    r_lim = (-r_abs, r_abs)
    band = _Panel(left, top, pw, band_h, xlim, (0, 1))
    pp = _Panel(left, top + band_h + gap, pw, panel_h, xlim, p_lim)
    rp = _Panel(left, top + band_h + gap + panel_h + 10, pw, panel_h, xlim, r_lim)
    out = [f'<svg role="img" aria-labelledby="tl-title" viewBox="0 0 {width} {height}" width="100%" '
           f'xmlns="http://www.w3.org/2000/svg" font-family="system-ui, sans-serif">'
           f'<title id="tl-title">{escape(title)}</title>']
    # activity / posture band: one rectangle per run of equal state
    runs: list[tuple[float, float, str]] = []
    for i, ti in enumerate(t):
        walking = hops["walking"][i]
        label = hops["label"][i] if walking else ""
        state = label or hops["activity"][i] or "unknown"
        t0 = max(ti - hop_s, xlim[0])
        if runs and runs[-1][2] == state and abs(runs[-1][1] - t0) < 1.5 * hop_s:
            runs[-1] = (runs[-1][0], ti, state)
        else:
            runs.append((t0, ti, state))
    for a, b, state in runs:
        color = LABEL_COLORS.get(state) or ACTIVITY_COLORS.get(state, "#BBBBBB")
        out.append(f'<rect x="{band.x(a):.1f}" y="{top}" width="{max(0.5, band.x(b) - band.x(a)):.1f}" '
                   f'height="{band_h}" fill="{color}"><title>{escape(state)}: {_fmt_t(a)} - {_fmt_t(b)}'
                   f'</title></rect>')
    out.append(f'<text x="{left - 4}" y="{top + 13}" text-anchor="end" font-size="11" fill="{_TEXT}">posture</text>')
    # seconds whose upright reference may be off (the gait analysis's ref_uncertainty_deg): shaded across both
    # panels, so that a pitch read after a turn without a standing phase is not taken at face value
    unc = hops.get("uncertainty") or []
    shaded: list[tuple[float, float, float]] = []
    for ti, u in zip(t, unc, strict=False):
        if u is None or not u > UNCERTAIN_SHADE_DEG:
            continue
        if shaded and abs(shaded[-1][1] - (ti - hop_s)) < 0.5 * hop_s:  # the next second: one band
            shaded[-1] = (shaded[-1][0], ti, max(shaded[-1][2], float(u)))
        else:
            shaded.append((max(ti - hop_s, xlim[0]), ti, float(u)))  # from the axis' start at most (review)
    for a, b, u in shaded:
        out.append(f'<rect x="{pp.x(a):.1f}" y="{pp.y0}" width="{max(0.5, pp.x(b) - pp.x(a)):.1f}" '
                   f'height="{rp.y0 + rp.h - pp.y0}" fill="#000000" fill-opacity="0.08"><title>upright reference '
                   f'uncertain by up to {u:.1f} deg, {_fmt_t(a)} - {_fmt_t(b)}: pitch and roll may be off by as much'
                   f'</title></rect>')
    # pitch panel
    out.append(pp.frame("pitch [deg]", _ticks(*p_lim, n=4)))
    out.append(pp.hline(-lean, _PITCH, f"lean-forward alert at {-lean:g} deg"))
    tb, pitch_b = _broken_at_gaps(t, pitch, hop_s)
    out.append(_polyline([pp.x(v) for v in tb], [pp.y(v) for v in pitch_b], _PITCH))
    # roll panel
    out.append(rp.frame("roll [deg]", _ticks(*r_lim, n=4)))
    out.append(rp.hline(shoulder, _ROLL, f"shoulder-down alert at +-{shoulder:g} deg"))
    out.append(rp.hline(-shoulder, _ROLL, ""))
    tb, roll_b = _broken_at_gaps(t, roll, hop_s)
    out.append(_polyline([rp.x(v) for v in tb], [rp.y(v) for v in roll_b], _ROLL))
    # alerts: raised = filled triangle, cleared = hollow
    for ev in tl.get("alerts", []):
        if ev.get("t_s") is None:
            continue
        x = pp.x(float(ev["t_s"]))
        y = top + band_h + 4
        fill = "#B00020" if ev["state"] == "raised" else "none"
        out.append(f'<path d="M{x - 6:.1f},{y} L{x + 6:.1f},{y} L{x:.1f},{y + 10} Z" fill="{fill}" stroke="#B00020">'
                   f'<title>{escape(str(ev["state"]))} at {_fmt_t(float(ev["t_s"]))}: {escape(str(ev["message"]))}'
                   f'</title></path>')
    # x axis
    yb = rp.y0 + rp.h
    for v in _ticks(*xlim, n=8):
        xx = rp.x(v)
        out.append(f'<line x1="{xx:.1f}" x2="{xx:.1f}" y1="{yb}" y2="{yb + 4}" stroke="{_TEXT}"/>'
                   f'<text x="{xx:.1f}" y="{yb + 16}" text-anchor="middle" font-size="11" fill="{_TEXT}">'
                   f'{_fmt_t(v)}</text>')
    out.append(f'<text x="{left + pw / 2}" y="{yb + 32}" text-anchor="middle" font-size="12" fill="{_TEXT}">'
               f'time since the session started</text>')
    if shaded:
        out.append(f'<text x="{left + pw}" y="{yb + 32}" text-anchor="end" font-size="10" fill="{_TEXT}">'
                   f'grey: upright reference uncertain by more than {UNCERTAIN_SHADE_DEG:g} deg</text>')
    out.append("</svg>")
    return Markup("".join(out))


def trend_svg(days: Sequence[Any], *, width: int = 900, title: str = "Trend per day") -> Markup:
    """Walking minutes (bars), % upright and alerts per hour (all kinds) per day: three stacked panels."""
    if not days:
        return Markup(f'<svg role="img" viewBox="0 0 {width} 60" width="100%"><title>{escape(title)}</title>'
                      f'<text x="10" y="30" fill="{_TEXT}">no sessions in this period</text></svg>')
    left, right, top, ph, gap = 60, 16, 20, 90, 22
    pw = width - left - right
    height = top + 3 * ph + 2 * gap + 40
    n = len(days)
    xlim = (-0.5, n - 0.5)
    walk = [d.walking_min for d in days]
    upright = [d.upright_pct for d in days]
    per_hour = [sum(v for v in d.alerts_per_hour.values() if math.isfinite(v)) for d in days]
    panels = [
        ("walking [min]", walk, (0.0, max(1.0, *walk) * 1.1), "#0072B2", "bar"),
        ("upright [%]", upright, (0.0, 100.0), "#009E73", "line"),
        ("alerts / hour", per_hour, (0.0, max(1.0, *per_hour) * 1.1), "#B00020", "line"),
    ]
    out = [f'<svg role="img" aria-labelledby="trend-title" viewBox="0 0 {width} {height}" width="100%" '
           f'xmlns="http://www.w3.org/2000/svg" font-family="system-ui, sans-serif">'
           f'<title id="trend-title">{escape(title)}</title>']
    for k, (label, vals, ylim, color, kind) in enumerate(panels):
        p = _Panel(left, top + k * (ph + gap), pw, ph, xlim, ylim)
        out.append(p.frame(label, _ticks(*ylim, n=3)))
        xs = [p.x(i) for i in range(n)]
        if kind == "bar":
            bw = min(40.0, max(1.0, 0.7 * pw / n))
            for i, v in enumerate(vals):
                y = p.y(v)
                if y is not None:
                    out.append(f'<rect x="{xs[i] - bw / 2:.1f}" y="{y:.1f}" width="{bw:.1f}" '
                               f'height="{p.y0 + p.h - y:.1f}" fill="{color}"><title>{days[i].day}: '
                               f'{v:.1f} min walking</title></rect>')
        else:
            out.append(_polyline(xs, [p.y(v) for v in vals], color, 1.8))
            for i, v in enumerate(vals):
                y = p.y(v)
                if y is not None:
                    out.append(f'<circle cx="{xs[i]:.1f}" cy="{y:.1f}" r="3" fill="{color}"><title>{days[i].day}: '
                               f'{v:.1f} {escape(label)}</title></circle>')
    yb = top + 3 * ph + 2 * gap
    step = max(1, math.ceil(n / 10))
    for i in range(0, n, step):
        xx = left + (i + 0.5) / n * pw
        out.append(f'<text x="{xx:.1f}" y="{yb + 14}" text-anchor="middle" font-size="11" fill="{_TEXT}">'
                   f'{days[i].day.strftime("%d %b")}</text>')
    out.append("</svg>")
    return Markup("".join(out))
