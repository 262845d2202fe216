"""Which files make one recording: a video with its IMU file and calibration, or an IMU file alone.

The pairing rule (``walkmon batch``; the README's "Batch analysis" section quotes it):

1. **Inputs.** Each INPUT is a file, a folder or a glob (``data/**/*.mp4``). A folder is searched recursively
   (hidden folders and the output folder skipped) for videos and for IMU files whose name contains ``imu``
   (``*imu*.csv``). A file or glob match is taken whatever its name: ``.csv`` is an IMU file, a known video
   extension (:data:`VIDEO_EXTENSIONS`) a video, anything else becomes a failed row ("not a video or IMU
   file"). An INPUT that does not exist or a glob that matches nothing stops the batch before it starts.
2. **Video + IMU.** A video ``DIR/STEM.EXT`` is paired with the first existing file among the IMU patterns
   (``--imu-pattern``, repeatable; default :data:`DEFAULT_IMU_PATTERNS`), each a path relative to the video's
   folder where ``{stem}`` is the video's name without extension. A pattern without ``{stem}`` (``imu.csv``,
   the layout of ``walkmon simulate``) pairs only when the video is the only video in its folder, since one
   IMU recording belongs to one walk. The paired IMU file need not be among the INPUTS. ``--imu-pattern none``
   turns pairing off (every video analysed camera-only).
3. **Calibration.** ``--calib camera.yaml`` is used for every video. Without it, each video takes the first
   existing file among :data:`CALIB_PATTERNS` next to it (``{stem}.yaml`` ... then ``camera.yaml``, which a
   folder of videos from one camera shares); none found: the default camera of ``walkmon analyze``.
4. **IMU alone.** An IMU file that no video claimed is an IMU-only recording (``walkmon analyze --imu``).
5. **Names.** A recording's outputs go to ``OUT/<name>/``: the video's (or IMU file's) name without extension;
   where two recordings would get the same name, parent folder names are prepended (``s1-video``,
   ``s2-video``) until they differ. Characters other than letters, digits, ``.``, ``_`` and ``-`` become ``_``.

Only file names are looked at here (and folders listed); no file is opened.
"""

from __future__ import annotations

import glob
import os
import re
from collections.abc import Iterable, Sequence
from dataclasses import dataclass
from pathlib import Path

from walkmon.errors import InvalidInputError

__all__ = [
    "CALIB_PATTERNS",
    "DEFAULT_IMU_PATTERNS",
    "IMU_EXTENSIONS",
    "VIDEO_EXTENSIONS",
    "Recording",
    "find_recordings",
]

#: File extensions taken as videos (lower case).
VIDEO_EXTENSIONS = (".mp4", ".m4v", ".mov", ".avi", ".mkv", ".webm", ".mpg", ".mpeg", ".wmv", ".mjpeg", ".mjpg",
                    ".ts", ".mts", ".h264", ".h265", ".hevc", ".3gp")
#: File extensions taken as IMU files (walkmon's imu.csv: t,gx,gy,gz,ax,ay,az).
IMU_EXTENSIONS = (".csv",)
#: IMU files next to a video ``STEM.EXT``, first match wins (``imu.csv`` only for a folder's sole video).
DEFAULT_IMU_PATTERNS = ("{stem}.imu.csv", "{stem}_imu.csv", "{stem}-imu.csv", "imu.csv")
#: Calibration files next to a video, first match wins (``camera.yaml`` serves every video of its folder).
CALIB_PATTERNS = ("{stem}.yaml", "{stem}.camera.yaml", "{stem}_camera.yaml", "{stem}-camera.yaml", "camera.yaml")

_GLOB_CHARS = re.compile(r"[*?\[]")
_UNSAFE = re.compile(r"[^A-Za-z0-9._-]+")


@dataclass(frozen=True, slots=True)
class Recording:
    """One unit of batch work: ``video`` and/or ``imu`` (absolute paths), the calibration, and its name.

    ``problem`` is set (and the recording fails without being analysed) for an input that is neither a video
    nor an IMU file.
    """

    name: str
    video: Path | None
    imu: Path | None
    calib: Path | None = None
    problem: str = ""

    @property
    def source(self) -> Path:
        """The file the recording is named after (the video, else the IMU file)."""
        src = self.video or self.imu
        assert src is not None  # noqa: S101 - every Recording has one of the two
        return src

    @property
    def kind(self) -> str:
        """``video``, ``video+imu``, ``imu`` or ``unknown``."""
        if self.problem:
            return "unknown"
        if self.video is not None:
            return "video+imu" if self.imu is not None else "video"
        return "imu"


def _is_video(p: Path) -> bool:
    return p.suffix.lower() in VIDEO_EXTENSIONS


def _is_imu(p: Path) -> bool:
    return p.suffix.lower() in IMU_EXTENSIONS


def _scan_folder(folder: Path, exclude: Path | None) -> list[Path]:
    """Videos and ``*imu*.csv`` files under ``folder`` (recursive; hidden folders and ``exclude`` skipped)."""
    found: list[Path] = []
    for root, dirs, files in os.walk(folder):
        rp = Path(root)
        dirs[:] = sorted(d for d in dirs if not d.startswith(".") and (exclude is None or (rp / d).resolve() != exclude))
        for f in sorted(files):
            p = rp / f
            if f.startswith("."):
                continue
            if _is_video(p) or (_is_imu(p) and "imu" in f.lower()):
                found.append(p)
    return found


def _expand(inputs: Iterable[str | os.PathLike[str]], exclude: Path | None) -> tuple[list[Path], list[Path]]:
    """(files named or matched explicitly, files found by scanning folders), both absolute, in input order."""
    explicit: list[Path] = []
    scanned: list[Path] = []
    for item in inputs:
        text = os.fspath(item)
        p = Path(text).expanduser()
        if p.is_dir():
            scanned += [q.resolve() for q in _scan_folder(p, exclude)]
        elif p.is_file():
            explicit.append(p.resolve())
        elif _GLOB_CHARS.search(text):
            matches = sorted(glob.glob(os.path.expanduser(text), recursive=True))
            if not matches:
                msg = f"{text}: matches no files"
                raise InvalidInputError(msg)
            for m in matches:
                q = Path(m)
                if q.is_dir():
                    scanned += [r.resolve() for r in _scan_folder(q, exclude)]
                elif q.is_file():
                    explicit.append(q.resolve())
        elif p.exists():
            msg = f"{text}: not a file or folder"
            raise InvalidInputError(msg)
        else:
            msg = f"{text}: no such file or folder"
            raise InvalidInputError(msg)
    return explicit, scanned


def _first_match(video: Path, patterns: Sequence[str], sole_video: bool, *, loose: bool = True,
                 taken: set[Path] | None = None) -> Path | None:
    """The first existing file a pattern names for ``video``; ``loose``: else the one file in the pattern's own
    folder whose name is the pattern's but for case (not one in ``taken``)."""
    for pattern in patterns:
        if "{stem}" not in pattern and not sole_video:
            continue
        try:
            candidate = video.parent / pattern.format(stem=video.stem)
        except (KeyError, IndexError, ValueError):
            msg = f"pattern {pattern!r}: only {{stem}} may appear in braces"
            raise InvalidInputError(msg) from None
        if candidate.is_file():
            return candidate.resolve()
        # a camera's upper-case names (WALK.MP4 beside WALK_IMU.csv): the pattern matched without regard to case,
        # as the IMU files are found (user review: one walk became two recordings, unpaired, without a word); in
        # the pattern's own folder (review: 'imu/{stem}_imu.csv' took the video's folder's file)
        if loose and candidate.parent.is_dir():
            same = [p for p in candidate.parent.iterdir()
                    if p.name.lower() == candidate.name.lower() and p.is_file() and p.resolve() not in (taken or ())]
            if len(same) == 1:
                return same[0].resolve()
    return None


def _unique_names(paths: Sequence[Path]) -> list[str]:
    """Shortest ``parent-...-stem`` names that tell the paths apart (case-insensitively)."""
    def name(p: Path, depth: int) -> str:
        parts = [*p.parent.parts[len(p.parent.parts) - depth:], p.stem] if depth else [p.stem]
        if depth >= len(p.parent.parts):
            parts = [*(q for q in p.parent.parts if q not in ("/", "\\")), p.name]  # last resort: the whole path
        return _UNSAFE.sub("_", "-".join(parts)).strip("._") or "recording"

    depth = [0] * len(paths)
    while True:
        names = [name(p, d) for p, d in zip(paths, depth, strict=True)]
        seen: dict[str, list[int]] = {}
        for i, n in enumerate(names):
            seen.setdefault(n.casefold(), []).append(i)
        clashes = [idx for idx in seen.values() if len(idx) > 1]
        if not clashes:
            return names
        progressed = False
        for idx in clashes:
            for i in idx:
                if depth[i] < len(paths[i].parent.parts):
                    depth[i] += 1
                    progressed = True
        if not progressed:  # identical paths cannot happen (inputs are de-duplicated); be safe anyway
            return [f"{n}-{i}" for i, n in enumerate(names)]


def find_recordings(
    inputs: Iterable[str | os.PathLike[str]],
    *,
    imu_patterns: Sequence[str] | None = None,
    calib: str | os.PathLike[str] | None = None,
    exclude: str | os.PathLike[str] | None = None,
) -> list[Recording]:
    """The recordings of ``inputs`` by the pairing rule of this module, sorted by name.

    ``imu_patterns``: None for :data:`DEFAULT_IMU_PATTERNS`, an empty sequence (or ``["none"]``) for no
    pairing. ``calib``: one calibration for every video. ``exclude``: a folder not to scan (the output folder).
    Raises :class:`InvalidInputError` for a missing INPUT, a glob matching nothing or no recordings at all.
    """
    patterns = DEFAULT_IMU_PATTERNS if imu_patterns is None else tuple(imu_patterns)
    if any(p.strip().lower() == "none" for p in patterns):
        patterns = ()
    for pattern in patterns:
        if Path(pattern).is_absolute():
            msg = f"--imu-pattern {pattern!r}: must be relative to the video's folder"
            raise InvalidInputError(msg)
    calib_path = Path(calib).expanduser().resolve() if calib is not None else None
    if calib_path is not None and not calib_path.is_file():
        msg = f"{calib}: no such calibration file"
        raise InvalidInputError(msg)
    excl = Path(exclude).expanduser().resolve() if exclude is not None else None
    explicit, scanned = _expand(inputs, excl)
    files = list(dict.fromkeys([*explicit, *scanned]))  # de-duplicated, input order
    explicit_set = set(explicit)
    videos = [f for f in files if _is_video(f)]
    videos_per_folder: dict[Path, int] = {}
    for v in videos:
        videos_per_folder[v.parent] = videos_per_folder.get(v.parent, 0) + 1

    recs: list[tuple[Path, Path | None, Path | None, Path | None, str]] = []  # source, video, imu, calib, problem
    claimed: set[Path] = set()
    # pattern by pattern over every video: first each exact name, then without regard to case, never a file taken
    # (review: walk.mp4 and WALK.MP4 in one folder both took WALK_IMU.csv; matching every exact name first broke
    # the patterns' order, WALK.MP4 taking imu.csv; reserving every file another video named exactly left one
    # unpaired)
    imus: dict[Path, Path | None] = dict.fromkeys(videos)
    for pattern in patterns or ():
        for loose in (False, True):
            for v in videos:
                if imus[v] is not None:
                    continue
                found = _first_match(v, (pattern,), videos_per_folder[v.parent] == 1, loose=loose, taken=claimed)
                if found is not None and found not in claimed:  # one video per file (walk.mp4, walk.avi)
                    imus[v] = found
                    claimed.add(found)
    for v in videos:
        imu = imus[v]
        cal = calib_path or _first_match(v, CALIB_PATTERNS, True)
        recs.append((v, v, imu, cal, ""))
    for f in files:
        if _is_video(f) or f in claimed:
            continue
        if _is_imu(f):
            recs.append((f, None, f, None, ""))
        elif f in explicit_set:
            recs.append((f, f, None, None, (f"{f}: not a video ({', '.join(VIDEO_EXTENSIONS[:6])}, ...) "
                                            f"or an IMU file (.csv)")))
    if not recs:
        msg = "no recordings found (videos, or IMU files *imu*.csv in folders; see 'walkmon batch --help')"
        raise InvalidInputError(msg)
    names = _unique_names([r[0] for r in recs])
    out = [Recording(n, video, imu, cal, problem) for n, (_, video, imu, cal, problem) in zip(names, recs, strict=True)]
    return sorted(out, key=lambda r: r.name)
