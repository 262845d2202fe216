"""The Jinja2 environment of the views: templates from this package, autoescaping always on."""

from __future__ import annotations

import datetime as _dt
import functools
import math
from importlib import resources
from typing import Any

import jinja2

__all__ = ["LABEL_WORDS", "describe_label", "environment", "fmt", "render", "static_text"]

#: Plain words for the classifier's labels.
LABEL_WORDS = {
    "normal": "upright, normal walk",
    "bend": "bent forward",
    "left_shoulder_down": "left shoulder down",
    "right_foot_drag": "right foot drags (limp)",
    "not_walking": "not walking",
    "unclassified": "not classified (too little evidence)",
}

#: Plain words for the alert kinds.
ALERT_WORDS = {
    "lean_forward": "lean-forward",
    "shoulder_down": "shoulder-down",
    "unsteady_gait": "unsteady-gait",
    "asymmetric_gait": "asymmetric-gait",
}


def describe_label(label: str) -> str:
    return LABEL_WORDS.get(label, label.replace("_", " "))


def fmt(v: Any, digits: int = 1, unit: str = "") -> str:
    """A number for people: fixed digits, a unit, and an en dash when unknown."""
    if v is None or (isinstance(v, float) and not math.isfinite(v)):
        return "\u2013"
    if isinstance(v, int | float):
        s = f"{v:.{digits}f}"
        return f"{s} {unit}".rstrip() if unit else s
    return str(v)


def cell(v: Any, digits: int = 3) -> Any:
    """A table cell as the report always wrote them: 3 decimals, an en dash entity when unknown."""
    from markupsafe import Markup  # noqa: PLC0415

    if v is None or (isinstance(v, float) and not math.isfinite(v)):
        return Markup("&ndash;")
    if isinstance(v, float):
        return f"{v:.{digits}f}"
    return v


def _duration(seconds: Any) -> str:
    if seconds is None or not math.isfinite(float(seconds)):
        return "\u2013"
    s = int(round(float(seconds)))
    if s < 60:
        return f"{s} s"
    if s < 3600:
        return f"{s // 60} min {s % 60:02d} s"
    return f"{s // 3600} h {s % 3600 // 60:02d} min"


def _local(value: Any, pattern: str = "%Y-%m-%d %H:%M") -> str:
    if value is None:
        return "\u2013"
    if isinstance(value, str):
        from walkmon.views.history import local_time  # noqa: PLC0415

        value = local_time(value)
    if isinstance(value, _dt.datetime):
        return value.strftime(pattern)
    return str(value)


@functools.cache
def environment() -> jinja2.Environment:
    env = jinja2.Environment(
        loader=jinja2.PackageLoader("walkmon.views", "templates"),
        autoescape=True,
        undefined=jinja2.StrictUndefined,
        trim_blocks=True,
        lstrip_blocks=True,
    )
    env.filters.update(fmt=fmt, cell=cell, duration=_duration, local=_local, label_words=describe_label,
                       alert_words=lambda k: ALERT_WORDS.get(k, str(k).replace("_", " ")))
    env.globals.update(LABEL_WORDS=LABEL_WORDS, ALERT_WORDS=ALERT_WORDS)
    return env


@functools.cache
def static_text(name: str) -> str:
    """A file of ``static/`` (the stylesheet is inlined into stand-alone files such as history.html)."""
    return resources.files("walkmon.views").joinpath("static", name).read_text(encoding="utf-8")


def render(template: str, **context: Any) -> str:
    context.setdefault("standalone", False)
    context.setdefault("css", static_text("walkmon.css") if context["standalone"] else "")
    return environment().get_template(template).render(**context)
