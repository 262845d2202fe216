"""A procedural 3-D street for the simulator: textured ground, facades on both sides, far buildings and sky.

World frame = camera 0's frame (x right, y down, z forward); the ground is the plane ``y = camera_height_m``.

* ground: asphalt (fine grain, stains, cracks, painted marks, manholes) with paved sidewalks along both walls;
* side walls ``x = left_wall_x_m`` / ``x = right_wall_x_m``: facade blocks of varying length, height and colour,
  plaster or brick, with windows, doors, ledges and pipes;
* far structure: a row of buildings with a varied skyline on the plane ``z = far_z_m`` (tens of metres ahead);
* sky: a smooth, featureless gradient.

Textures are periodic (they wrap) and come with mip pyramids so the renderer can pick a level per pixel from
its footprint, which keeps distant texture from aliasing (shimmer would wreck feature tracking).
"""

from __future__ import annotations

import functools
import logging
from dataclasses import dataclass
from typing import Any

import cv2
import numpy as np
from numpy.typing import NDArray

__all__ = ["StreetScene", "Texture", "build_street_scene"]

_log = logging.getLogger(__name__)

#: Facade textures: 1 cm texels, 10.24 m high, 20.48 m along the street (the block layout repeats with it).
_FACADE_TEXEL_M = 0.01
_FACADE_SIZE = (1024, 2048)


@dataclass(frozen=True, slots=True)
class Texture:
    """A periodic BGR uint8 texture with its mip pyramid; ``texel_m`` is the size of a level-0 texel."""

    levels: tuple[NDArray[np.uint8], ...]
    texel_m: float

    @property
    def width_m(self) -> float:
        return self.levels[0].shape[1] * self.texel_m

    @property
    def height_m(self) -> float:
        return self.levels[0].shape[0] * self.texel_m


@dataclass(frozen=True, slots=True)
class StreetScene:
    """Geometry and textures of the street (metres, world frame)."""

    camera_height_m: float
    left_wall_x_m: float
    right_wall_x_m: float
    block_edges_z_m: NDArray[np.float64]  # facade blocks along z (mod the last edge): block k spans [e[k], e[k+1])
    left_heights_m: NDArray[np.float64]
    right_heights_m: NDArray[np.float64]
    far_z_m: float
    far_edges_x_m: NDArray[np.float64]
    far_heights_m: NDArray[np.float64]
    ground: Texture
    left_wall: Texture
    right_wall: Texture
    far: Texture
    sky_horizon_bgr: tuple[float, float, float]
    sky_zenith_bgr: tuple[float, float, float]
    back_z_m: float | None = None  # buildings closing the street behind the start (seen after a U-turn)

    def describe(self) -> dict[str, float]:
        """Scene figures for meta.json."""
        return {
            "camera_height_m": self.camera_height_m,
            "left_wall_x_m": round(self.left_wall_x_m, 3),
            "right_wall_x_m": round(self.right_wall_x_m, 3),
            "far_z_m": round(self.far_z_m, 3),
            **({"back_z_m": round(self.back_z_m, 3)} if self.back_z_m is not None else {}),
            "wall_height_min_m": round(float(min(self.left_heights_m.min(), self.right_heights_m.min())), 3),
            "wall_height_max_m": round(float(max(self.left_heights_m.max(), self.right_heights_m.max())), 3),
        }


# ------------------------------------------------------------------------------------------ texture helpers
def _pink_noise(shape: tuple[int, int], rng: np.random.Generator, beta: float, cutoff_px: float = 1.0) -> NDArray:
    """Periodic noise with a 1/f^beta amplitude spectrum (multi-octave in one FFT), zero mean, unit std."""
    h, w = shape
    fy = np.fft.fftfreq(h)[:, None]
    fx = np.fft.rfftfreq(w)[None, :]
    f = np.sqrt(fx * fx + fy * fy)
    f[0, 0] = 1.0
    amp = f ** (-beta) * np.exp(-((f * cutoff_px) ** 2) * 2.0)
    amp[0, 0] = 0.0
    spec = amp * (rng.standard_normal((h, fx.shape[1])) + 1j * rng.standard_normal((h, fx.shape[1])))
    out = np.fft.irfft2(spec, s=(h, w)).astype(np.float32)
    return (out - out.mean()) / (out.std() + 1e-12)


def _band_noise(shape: tuple[int, int], rng: np.random.Generator, scale_px: float) -> NDArray[np.float32]:
    """Periodic smooth noise with features of about ``scale_px``, unit std."""
    h, w = shape
    fy = np.fft.fftfreq(h)[:, None]
    fx = np.fft.rfftfreq(w)[None, :]
    f = np.sqrt(fx * fx + fy * fy)
    amp = np.exp(-((f * scale_px) ** 2))
    amp[0, 0] = 0.0
    spec = amp * (rng.standard_normal((h, fx.shape[1])) + 1j * rng.standard_normal((h, fx.shape[1])))
    out = np.fft.irfft2(spec, s=(h, w)).astype(np.float32)
    return (out - out.mean()) / (out.std() + 1e-12)


def _wrapped(draw, img: NDArray, center: tuple[float, float]) -> None:  # noqa: ANN001
    """Call ``draw(img, dx, dy)`` for the shape and its wrapped copies, so shapes at an edge tile seamlessly."""
    h, w = img.shape[:2]
    for dy in (-h, 0, h):
        for dx in (-w, 0, w):
            cx, cy = center[0] + dx, center[1] + dy
            if -w * 0.5 < cx < w * 1.5 and -h * 0.5 < cy < h * 1.5:
                draw(img, dx, dy)


def _blobs(img: NDArray, rng: np.random.Generator, n: int, radius_px: tuple[float, float], strength: float) -> None:
    """Soft ellipses of random brightness (stains, patches), added to a float image in place."""
    h, w = img.shape[:2]
    layer = np.zeros((h, w), np.float32)
    for _ in range(n):
        c = (float(rng.uniform(0, w)), float(rng.uniform(0, h)))
        axes = (int(rng.uniform(*radius_px)), int(rng.uniform(*radius_px)))
        ang = float(rng.uniform(0, 180))
        val = float(rng.normal(0, strength))

        def draw(im, dx, dy, c=c, axes=axes, ang=ang, val=val):  # noqa: ANN001, ANN202
            cv2.ellipse(im, (int(c[0] + dx), int(c[1] + dy)), axes, ang, 0, 360, val, -1, cv2.LINE_AA)

        _wrapped(draw, layer, c)
    layer = _blur_wrapped(layer, max(radius_px[0] * 0.3, 1.0))
    img += layer[..., None] if img.ndim == 3 else layer


def _cracks(img: NDArray, rng: np.random.Generator, n: int, length_px: float, value: float) -> None:
    h, w = img.shape[:2]
    for _ in range(n):
        p = np.array([rng.uniform(0, w), rng.uniform(0, h)])
        ang = rng.uniform(0, 2 * np.pi)
        pts = [p.copy()]
        for _ in range(int(rng.integers(4, 12))):
            ang += rng.normal(0, 0.6)
            p = p + length_px / 8 * np.array([np.cos(ang), np.sin(ang)])
            pts.append(p.copy())
        arr = np.array(pts)
        thick = int(rng.integers(1, 3))

        def draw(im, dx, dy, arr=arr, thick=thick):  # noqa: ANN001, ANN202
            pts = [np.round(arr + [dx, dy]).astype(np.int32)]
            cv2.polylines(im, pts, False, (value, value, value), thick, cv2.LINE_AA)

        _wrapped(draw, img, (float(arr[0, 0]), float(arr[0, 1])))


def _blur_wrapped(img: NDArray[np.float32], sigma: float) -> NDArray[np.float32]:
    """Gaussian blur of a periodic image (OpenCV's filters do not wrap, so pad periodically and crop)."""
    pad = int(3 * sigma) + 1
    padded = np.pad(img, ((pad, pad), (pad, pad)) + ((0, 0),) * (img.ndim - 2), mode="wrap")
    return cv2.GaussianBlur(padded, (0, 0), sigma)[pad:-pad, pad:-pad]


def _pyrdown_wrapped(img: NDArray[np.float32]) -> NDArray[np.float32]:
    """``cv2.pyrDown`` of a periodic image (even size), wrapping at the borders."""
    pad = 4
    padded = np.pad(img, ((pad, pad), (pad, pad)) + ((0, 0),) * (img.ndim - 2), mode="wrap")
    return cv2.pyrDown(padded)[pad // 2 : -pad // 2, pad // 2 : -pad // 2]


def _pyramid(img: NDArray[np.float32], min_size: int = 4) -> tuple[NDArray[np.float32], ...]:
    levels = [np.ascontiguousarray(img, dtype=np.float32)]
    while min(levels[-1].shape[:2]) >= 2 * min_size:
        levels.append(_pyrdown_wrapped(levels[-1]))
    return tuple(levels)


def _finish(img: NDArray[np.float32], texel_m: float) -> Texture:
    levels = tuple(np.round(lv).astype(np.uint8) for lv in _pyramid(np.clip(img, 0.0, 255.0).astype(np.float32)))
    for lv in levels:
        lv.setflags(write=False)
    return Texture(levels, texel_m)


# -------------------------------------------------------------------------------------------- textures
def _ground_texture(rng: np.random.Generator, left_x: float, right_x: float, size: tuple[int, int]) -> Texture:
    """Asphalt road with paved sidewalks along both walls; u = x, v = z (texel 5 mm)."""
    texel = 0.005
    h, w = size  # rows along z, columns along x (x measured from left_x)
    base = np.array([95.0, 98.0, 102.0], np.float32)
    img = np.empty((h, w, 3), np.float32)
    img[:] = base
    grain = _pink_noise((h, w), rng, beta=0.6)
    img += 14.0 * grain[..., None]
    img += 10.0 * _band_noise((h, w), rng, 60.0)[..., None]
    img += 8.0 * _band_noise((h, w), rng, 300.0)[..., None]
    # aggregate: small bright/dark stones
    n_st = h * w // 900
    ys, xs = rng.integers(0, h, n_st), rng.integers(0, w, n_st)
    img[ys, xs] += rng.normal(0, 45, (n_st, 1)).astype(np.float32)
    _blobs(img, rng, 60, (20, 160), 12.0)
    _cracks(img, rng, 40, 220.0, 55.0)
    # manholes / drains
    for _ in range(3):
        c = (int(rng.uniform(0, w)), int(rng.uniform(0, h)))
        r = int(rng.uniform(60, 90))
        cv2.circle(img, c, r, (70.0, 72.0, 75.0), -1, cv2.LINE_AA)
        cv2.circle(img, c, r, (45.0, 45.0, 48.0), 4, cv2.LINE_AA)
        for k in range(-r, r, 18):
            cv2.line(img, (c[0] - r, c[1] + k), (c[0] + r, c[1] + k), (55.0, 56.0, 58.0), 3, cv2.LINE_AA)
    # sidewalks: slabs near both walls
    street_w_m = right_x - left_x
    sw_m = min(1.2, street_w_m * 0.2)
    for x0_m, x1_m in ((0.0, sw_m), (street_w_m - sw_m, street_w_m)):
        x0, x1 = int(x0_m / texel), min(int(x1_m / texel), w)
        region = img[:, x0:x1]
        region[:] = region * 0.6 + np.array([150.0, 155.0, 160.0], np.float32) * 0.4
        slab = int(rng.uniform(0.3, 0.5) / texel)
        shade = rng.normal(0, 8, (h // slab + 2, (x1 - x0) // slab + 2))
        rows = (np.arange(h) // slab)[:, None]
        cols = (np.arange(x1 - x0) // slab)[None, :]
        region += shade[rows, cols][..., None].astype(np.float32)
        region[(np.arange(h) % slab) < 3] *= 0.65
        region[:, (np.arange(x1 - x0) % slab) < 3] *= 0.65
        # kerb
        kx = x1 if x0 == 0 else x0
        img[:, max(kx - 6, 0) : kx + 6] = img[:, max(kx - 6, 0) : kx + 6] * 0.5 + 90.0
    # painted marks: a dashed line off centre and a few arrows/patches
    cx = int((street_w_m * rng.uniform(0.4, 0.6)) / texel)
    dash, gap = int(1.5 / texel), int(1.5 / texel)
    for z0 in range(int(rng.integers(0, gap)), h, dash + gap):
        cv2.rectangle(img, (cx - 12, z0), (cx + 12, min(z0 + dash, h - 1)), (215.0, 220.0, 225.0), -1, cv2.LINE_AA)
    for _ in range(4):
        x, y = int(rng.uniform(0.3, 0.7) * w), int(rng.uniform(0, h))
        pts = np.array([[x, y], [x + 60, y + 120], [x + 20, y + 120], [x + 20, y + 300], [x - 20, y + 300],
                        [x - 20, y + 120], [x - 60, y + 120]], np.int32)
        cv2.fillPoly(img, [pts], (200.0, 210.0, 215.0), cv2.LINE_AA)
    img *= (1.0 + 0.04 * _band_noise((h, w), rng, 40.0))[..., None]
    return _finish(img, texel)


def _facade_texture(rng: np.random.Generator, edges_m: NDArray, heights_m: NDArray, size: tuple[int, int]) -> Texture:
    """Facade blocks along z; u = z (wrapping), v = height above ground counted up from the bottom row."""
    texel = _FACADE_TEXEL_M
    h, w = size
    img = np.empty((h, w, 3), np.float32)
    grain = _pink_noise((h, w), rng, beta=0.7)
    mid = _band_noise((h, w), rng, 25.0)
    large = _band_noise((h, w), rng, 200.0)
    palette = np.array([[170, 190, 205], [120, 140, 170], [200, 205, 210], [90, 110, 150], [150, 165, 170],
                        [110, 120, 125], [180, 170, 150], [140, 160, 190]], np.float32)
    period_m = w * texel
    for k in range(len(edges_m) - 1):
        a_m, b_m = edges_m[k], edges_m[k + 1]
        if a_m >= period_m:
            break
        a, b = int(max(a_m, 0) / texel), int(min(b_m, period_m) / texel)
        if b <= a:
            continue
        colour = palette[rng.integers(len(palette))] * rng.uniform(0.85, 1.1)
        block = img[:, a:b]
        block[:] = colour
        brick = rng.uniform() < 0.4
        bw = b - a
        if brick:
            course, length = 7, 24  # 7 cm courses, 24 cm bricks
            rows = np.arange(h)[:, None] // course
            cols = (np.arange(bw)[None, :] + (rows % 2) * (length // 2)) // length
            shade = rng.normal(0, 14, (rows.max() + 2, bw // length + 3)).astype(np.float32)
            block += shade[rows, cols][..., None]
            block[(np.arange(h) % course) == 0] = block[(np.arange(h) % course) == 0] * 0.55 + 70
            mortar_v = ((np.arange(bw)[None, :] + (rows % 2) * (length // 2)) % length) == 0
            block[np.broadcast_to(mortar_v, (h, bw))] = block[np.broadcast_to(mortar_v, (h, bw))] * 0.55 + 70
        block += (9.0 * grain[:, a:b] + 6.0 * mid[:, a:b] + 10.0 * large[:, a:b])[..., None]
        # storeys: windows on each floor above the ground floor, doors and shop windows at the ground
        height_px = int(heights_m[k] / texel)
        floor_m = rng.uniform(2.8, 3.4)
        win_w, win_h = rng.uniform(0.8, 1.4), rng.uniform(1.2, 1.7)
        spacing = win_w + rng.uniform(0.8, 1.6)
        frame_c = np.clip(colour * rng.uniform(0.5, 1.3), 0, 255)
        n_floors = int(heights_m[k] / floor_m)
        for fl in range(1, n_floors):
            sill_m = fl * floor_m + 0.9
            if sill_m + win_h > heights_m[k] - 0.3:
                break
            y1 = h - int(sill_m / texel)
            y0 = y1 - int(win_h / texel)
            zpos = rng.uniform(0.3, spacing)
            while zpos + win_w < (b - a) * texel - 0.3:
                x0, x1 = a + int(zpos / texel), a + int((zpos + win_w) / texel)
                glass = np.array([60, 55, 50], np.float32) * rng.uniform(0.6, 1.6)
                sheen = 20 * np.linspace(1, -1, y1 - y0)[:, None, None]
                img[y0:y1, x0:x1] = glass + 25.0 * mid[y0:y1, x0:x1, None] + sheen
                cv2.rectangle(img, (x0, y0), (x1, y1), frame_c.tolist(), 5)
                cv2.line(img, ((x0 + x1) // 2, y0), ((x0 + x1) // 2, y1), frame_c.tolist(), 3)
                cv2.rectangle(img, (x0 - 8, y1), (x1 + 8, y1 + 10), (frame_c * 0.8).tolist(), -1)
                zpos += spacing
            # ledge between floors
            yl = h - int(fl * floor_m / texel)
            img[yl - 6 : yl + 6, a:b] = img[yl - 6 : yl + 6, a:b] * 0.7 + 50
        # ground floor: doors and shop windows
        zpos = rng.uniform(0.3, 2.0)
        while zpos < (b - a) * texel - 1.5:
            if rng.uniform() < 0.5:
                dw, dh = rng.uniform(0.9, 1.3), rng.uniform(2.0, 2.3)
                c = np.array([40, 50, 80], np.float32) * rng.uniform(0.7, 1.8)
            else:
                dw, dh = rng.uniform(1.5, 3.0), rng.uniform(1.6, 2.2)
                c = np.array([70, 65, 55], np.float32) * rng.uniform(0.7, 1.4)
            x0, x1 = a + int(zpos / texel), a + int(min(zpos + dw, (b - a) * texel - 0.2) / texel)
            y1 = h - int(0.05 / texel)
            y0 = h - int(dh / texel)
            if x1 > x0:
                img[y0:y1, x0:x1] = c + 18.0 * mid[y0:y1, x0:x1, None]
                cv2.rectangle(img, (x0, y0), (x1, y1), (frame_c * 0.6).tolist(), 6)
            zpos += dw + rng.uniform(1.0, 3.0)
        # drainpipe at the block edge, plinth at the bottom
        xp = a + int(rng.uniform(0.1, 0.3) / texel)
        img[h - height_px :, xp : xp + 9] = np.array([80, 85, 90], np.float32)
        img[h - int(0.35 / texel) :, a:b] = img[h - int(0.35 / texel) :, a:b] * 0.6 + 30
        # roof edge / cornice
        yc = h - height_px
        if 0 <= yc < h:
            img[max(yc, 0) : yc + 15, a:b] = img[max(yc, 0) : yc + 15, a:b] * 0.5 + 40
    _blobs(img, rng, 80, (10, 120), 10.0)  # weathering
    return _finish(img, texel)


def _far_texture(rng: np.random.Generator, size: tuple[int, int]) -> Texture:
    """Distant buildings, coarse (texel 5 cm): plain facades with rows of windows."""
    texel = 0.05
    h, w = size
    img = np.empty((h, w, 3), np.float32)
    img[:] = np.array([150, 150, 155], np.float32)
    img += 12.0 * _band_noise((h, w), rng, 80.0)[..., None] + 6.0 * _pink_noise((h, w), rng, 0.7)[..., None]
    x = 0
    while x < w:
        bw = int(rng.uniform(6, 16) / texel)
        colour = np.array([rng.uniform(110, 200), rng.uniform(110, 190), rng.uniform(110, 180)], np.float32)
        img[:, x : x + bw] = img[:, x : x + bw] * 0.4 + colour * 0.6
        cols = np.arange(x + 10, min(x + bw - 10, w), int(rng.uniform(1.8, 3.0) / texel))
        for r in range(h - 30, 0, -int(3.0 / texel)):
            for c in cols:
                img[r - 20 : r, c : c + 18] = np.array([70, 65, 60], np.float32) * rng.uniform(0.6, 1.4)
        x += bw
    return _finish(img, texel)


def build_street_scene(
    seed: int,
    *,
    camera_height_m: float = 1.3,
    z_max_m: float = 40.0,
    walls_x_m: tuple[float, float] | None = None,
    z_min_m: float | None = None,
) -> StreetScene:
    """A seeded street whose far buildings stand 40-60 m beyond ``z_max_m`` (the walk's farthest point).

    ``walls_x_m = (left, right)`` places the facades there instead of the seed's own positions (session scripts
    fit the street around the walker's path); ``z_min_m`` (the walk's rearmost point) closes the street behind
    with buildings 40-60 m beyond it (the seed's default street is open behind: straight walks never look back).

    The street (walls, facade blocks, textures) depends only on ``seed`` and is cached for the last few seeds,
    since generating its textures takes a few seconds.
    """
    street = dict(_street(int(seed)))
    rng = np.random.default_rng([seed, 0xFA2])
    far_z = float(z_max_m + rng.uniform(40.0, 60.0))
    back_z = None if z_min_m is None else float(z_min_m - rng.uniform(40.0, 60.0))
    if walls_x_m is not None:
        left, right = (float(v) for v in walls_x_m)
        if not (np.isfinite(left) and np.isfinite(right) and left < right):
            msg = f"street walls must be finite with left < right, got {walls_x_m}"
            raise ValueError(msg)
        street["left_wall_x_m"], street["right_wall_x_m"] = left, right
    return StreetScene(
        camera_height_m=float(camera_height_m),
        far_z_m=far_z,
        sky_horizon_bgr=(235.0, 222.0, 205.0),
        sky_zenith_bgr=(205.0, 150.0, 100.0),
        back_z_m=back_z,
        **street,
    )


@functools.lru_cache(maxsize=2)
def _street(seed: int) -> dict[str, Any]:
    rng = np.random.default_rng([seed, 0x5CE7E])
    left = -rng.uniform(2.4, 3.2)
    right = rng.uniform(2.6, 3.6)
    # facade blocks along z repeat with the facade texture's period, so geometry and texture always agree
    period_m = _FACADE_SIZE[1] * _FACADE_TEXEL_M
    edges = [0.0]
    while period_m - edges[-1] > 14.0:
        edges.append(edges[-1] + rng.uniform(5.0, 11.0))
    edges.append(period_m)
    edges_arr = np.array(edges)
    n_blocks = len(edges) - 1
    left_h = rng.uniform(5.0, 10.0, n_blocks)
    right_h = rng.uniform(5.0, 10.0, n_blocks)
    far_edges = [-60.0]
    while far_edges[-1] < 60.0:
        far_edges.append(far_edges[-1] + rng.uniform(6.0, 16.0))
    far_edges_arr = np.array(far_edges)
    far_h = rng.uniform(8.0, 24.0, len(far_edges) - 1)
    for arr in (edges_arr, left_h, right_h, far_edges_arr, far_h):
        arr.setflags(write=False)
    return {
        "left_wall_x_m": float(left),
        "right_wall_x_m": float(right),
        "block_edges_z_m": edges_arr,
        "left_heights_m": left_h,
        "right_heights_m": right_h,
        "far_edges_x_m": far_edges_arr,
        "far_heights_m": far_h,
        "ground": _ground_texture(rng, left, right, (2048, 2048)),
        "left_wall": _facade_texture(rng, edges_arr, left_h, _FACADE_SIZE),
        "right_wall": _facade_texture(rng, edges_arr, right_h, _FACADE_SIZE),
        "far": _far_texture(rng, (512, 2048)),
    }
