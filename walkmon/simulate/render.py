"""Per-pixel ray casting of the street scene: images a camera at a known pose would see.

Every pixel's viewing ray is computed once from the camera model (exactly inverting its lens distortion, so the
rendered image *is* distorted the way ``CameraModel.pixels_from_camera_points`` projects), rotated into the world
for each pose and intersected with the scene's planes. Texture comes from the mip level that matches the pixel's
footprint on the surface (trilinear filtering, no shimmer at distance). A video frame averages samples
along each pixel's motion during the exposure (motion blur), then gets a slight defocus, vignetting and shot/read noise.
"""

from __future__ import annotations

import logging
from dataclasses import dataclass
from typing import Any

import cv2
import numpy as np
from numpy.typing import NDArray

from walkmon.camera.model import CameraModel
from walkmon.errors import ConfigError
from walkmon.simulate.scene import StreetScene, Texture

__all__ = ["DEFAULT_RENDER_SETTINGS", "RenderSettings", "Renderer", "SURFACES", "pixel_rays"]

_log = logging.getLogger(__name__)

#: Resolution of the wall-height and skyline lookup tables, metres.
_LUT_STEP_M = 0.01

#: Surface labels of :meth:`Renderer.cast` (index = label; -1 means sky).
SURFACES = ("ground", "left_wall", "right_wall", "far", "wall_ahead", "mover")

#: Brightest gain a camera applies in low light (``RenderSettings.light`` below 1/this leaves the image darker).
_MAX_LOW_LIGHT_GAIN = 4.0


@dataclass(frozen=True, slots=True)
class RenderSettings:
    """Camera effects. Motion blur over ``exposure_s`` centred on the frame time: each pixel is averaged along its
    own image motion with one sample per ``blur_step_px`` of motion (at most ``max_blur_taps``); noise in digital
    numbers (0-255): standard deviation ``sqrt(read_noise_dn² + shot_noise_gain * value)``.

    ``rolling_shutter_s`` > 0 reads the rows out over that time, top to bottom, the middle row at the frame time
    (so truth.csv's pose is the middle row's); the image is rendered in row bands, each at its own pose, with
    bands thin enough that the image moves less than ``rolling_shutter_step_px`` from one band to the next.
    0 (the default) is a global shutter.

    Scenario options (issue 14; the defaults leave every image byte-identical to a plain street):
    ``wall_ahead_z_m`` > 0 closes the street with a textured facade on the plane ``z = wall_ahead_z_m`` (a wall or
    door the walker walks towards). ``movers``: independently moving textured people/vehicles, each a tuple
    ``(x0_m, z0_m, vx_m_s, vz_m_s, width_m, height_m, texture_u_m)``: an upright rectangle facing the camera,
    standing on the ground, centred at ``x0 + vx t`` on the plane ``z = z0 + vz t`` at the frame time ``t``
    (:meth:`Renderer.set_time`; the movers' own motion during exposure and rolling-shutter readout is not
    modelled, the camera's is). ``light`` < 1 scales the scene's radiance (dusk 0.2, night 0.05): noise is
    added at the sensor's level and the camera's gain (at most 4x) then brightens signal and noise together.
    ``contrast`` < 1 flattens the texture towards mid grey (haze, a white corridor); ``fog_distance_m`` small
    for fog. ``occlusion`` > 0 covers that fraction of the image width, from the lower left corner, with a
    dark, blurred, lightly textured blob fixed to the lens (a scarf or a hand)."""

    exposure_s: float = 0.008
    max_blur_taps: int = 8
    blur_step_px: float = 1.0
    defocus_sigma_px: float = 0.55
    vignetting: float = 0.25
    read_noise_dn: float = 1.5
    shot_noise_gain: float = 0.03
    fog_distance_m: float = 250.0
    lod_bias: float = 0.0
    rolling_shutter_s: float = 0.0
    rolling_shutter_step_px: float = 0.5
    wall_ahead_z_m: float = 0.0
    movers: tuple[tuple[float, float, float, float, float, float, float], ...] = ()
    light: float = 1.0
    contrast: float = 1.0
    occlusion: float = 0.0

    def __post_init__(self) -> None:
        if not (self.wall_ahead_z_m >= 0 and 0 < self.light <= 1.0 and 0 < self.contrast <= 1.0
                and 0 <= self.occlusion <= 0.8):
            msg = (f"scenario settings out of range: wall_ahead_z_m >= 0, light and contrast in (0, 1], occlusion "
                   f"in [0, 0.8]; got {self.wall_ahead_z_m}, {self.light}, {self.contrast}, {self.occlusion}")
            raise ConfigError(msg)
        if any(len(m) != 7 or m[4] <= 0 or m[5] <= 0 for m in self.movers):
            msg = "each mover must be (x0_m, z0_m, vx_m_s, vz_m_s, width_m > 0, height_m > 0, texture_u_m)"
            raise ConfigError(msg)
        if not (0.0 <= self.rolling_shutter_s <= 0.1 and self.rolling_shutter_step_px > 0):
            msg = (
                f"rolling shutter readout must be in [0, 0.1] s (got {self.rolling_shutter_s}) "
                f"with a positive band step (got {self.rolling_shutter_step_px} px)"
            )
            raise ConfigError(msg)
        if not (0.0 <= self.exposure_s <= 0.1 and 1 <= self.max_blur_taps <= 32 and self.blur_step_px > 0):
            msg = f"invalid render settings: {self}"
            raise ConfigError(msg)
        if min(self.defocus_sigma_px, self.vignetting, self.read_noise_dn, self.shot_noise_gain) < 0:
            msg = f"render noise/blur settings must be >= 0: {self}"
            raise ConfigError(msg)


DEFAULT_RENDER_SETTINGS = RenderSettings()


def pixel_rays(camera: CameraModel, points_px: NDArray[np.float64] | None = None) -> NDArray[np.float64]:
    """Unit viewing rays (N, 3) in the camera frame through pixel positions (N, 2); default: every pixel
    centre, row-major (N = H*W).

    The lens distortion is inverted to convergence (OpenCV's default undistortion stops after 5 iterations,
    which is not exact for strong distortion), so projecting the rays back gives the pixel positions.
    """
    if points_px is None:
        u, v = np.meshgrid(np.arange(camera.width_px, dtype=np.float64), np.arange(camera.height_px, dtype=np.float64))
        points_px = np.stack([u.ravel(), v.ravel()], axis=1)
    px = np.asarray(points_px, np.float64).reshape(-1, 1, 2)
    if camera.has_distortion:
        crit = (cv2.TERM_CRITERIA_COUNT | cv2.TERM_CRITERIA_EPS, 100, 1e-12)
        if camera.distortion_model == "equidistant":
            xy = cv2.fisheye.undistortPoints(px, camera.camera_matrix, camera.distortion_coefficients, criteria=crit)
        else:
            xy = cv2.undistortPointsIter(px, camera.camera_matrix, camera.distortion_coefficients, None, None, crit)
        xy = xy.reshape(-1, 2)
    else:
        K = camera.camera_matrix
        xy = np.stack([(px[:, 0, 0] - K[0, 2]) / K[0, 0], (px[:, 0, 1] - K[1, 2]) / K[1, 1]], axis=1)
    rays = np.concatenate([xy, np.ones((xy.shape[0], 1))], axis=1)
    return rays / np.linalg.norm(rays, axis=1, keepdims=True)


_PAD = 2


@dataclass(frozen=True, slots=True)
class _MipAtlas:
    """All mip levels of a texture in one image, each padded with a wrapped border, so a trilinear lookup is two
    ``cv2.remap`` calls (floor level and the next) whatever level each pixel needs."""

    image: NDArray[np.uint8]
    offset_x: NDArray[np.float32]  # per level: atlas column of the level's texel (0, 0)
    offset_y: NDArray[np.float32]
    width: NDArray[np.float32]
    height: NDArray[np.float32]
    n_levels: int
    scale: NDArray[np.float32]

    @classmethod
    def from_texture(cls, tex: Texture, gain: float = 1.0) -> _MipAtlas:
        h0, w0 = tex.levels[0].shape[:2]
        if any(lv.shape[:2] != (h0 >> k, w0 >> k) for k, lv in enumerate(tex.levels)):
            msg = "texture sizes must be powers of two so that every mip level halves exactly"
            raise ValueError(msg)
        levels = [np.pad(lv, ((_PAD, _PAD), (_PAD, _PAD), (0, 0)), mode="wrap") for lv in tex.levels]
        if gain != 1.0:
            levels = [np.clip(np.rint(lv * gain), 0, 255).astype(np.uint8) for lv in levels]
        h0, w0 = levels[0].shape[:2]
        rest_h = sum(lv.shape[0] for lv in levels[1:])
        rest_w = max((lv.shape[1] for lv in levels[1:]), default=0)
        atlas = np.zeros((max(h0, rest_h), w0 + rest_w, 3), np.uint8)
        atlas[:h0, :w0] = levels[0]
        ox, oy = [0], [0]
        y = 0
        for lv in levels[1:]:
            atlas[y : y + lv.shape[0], w0 : w0 + lv.shape[1]] = lv
            ox.append(w0)
            oy.append(y)
            y += lv.shape[0]
        f32 = np.float32
        width = np.array([lv.shape[1] for lv in tex.levels], f32)
        height = np.array([lv.shape[0] for lv in tex.levels], f32)
        n = len(tex.levels)
        return cls(
            atlas,
            np.array(ox, f32) + _PAD,
            np.array(oy, f32) + _PAD,
            width,
            height,
            n,
            np.array([0.5**k for k in range(n)], f32),
        )

    def sample(self, u: NDArray[np.float32], v: NDArray[np.float32], level: NDArray[np.float32]) -> NDArray:
        """Trilinear lookup at level-0 texel coordinates (u right, v down), wrapping; (n, 3) float32.

        Level-0 texel i has its centre at coordinate i. ``cv2.pyrDown`` centres level-l texel j on level-0
        coordinate ``j * 2^l`` (not ``(j + 0.5) * 2^l - 0.5`` as box averaging would), so the level-l coordinate
        is simply ``u / 2^l``; any other mapping shifts the texture by up to half a pixel as the level changes
        with distance, which a tracker would see as motion the geometry does not have.
        """
        level = np.clip(level, np.float32(0.0), np.float32(self.n_levels - 1.0001))
        l0 = level.astype(np.int32)
        frac = (level - l0)[:, None]
        # wrap once at level 0: the levels halve exactly (power-of-two sizes), so a wrapped level-0 coordinate
        # scaled by 2^-l is wrapped at level l too (np.mod is several times slower than x - floor(x/w)*w)
        w0, h0 = self.width[0], self.height[0]
        up = u - np.floor(u * (np.float32(1.0) / w0)) * w0
        vp = v - np.floor(v * (np.float32(1.0) / h0)) * h0
        acc = None
        for lk in (l0, l0 + 1):
            scale = self.scale[lk]
            mu = up * scale
            mu += self.offset_x[lk]
            mv = vp * scale
            mv += self.offset_y[lk]
            vals = _remap_points(self.image, mu, mv)
            acc = vals if acc is None else acc + (vals - acc) * frac
        return acc  # type: ignore[return-value]


def _remap_points(img: NDArray[np.uint8], mu: NDArray[np.float32], mv: NDArray[np.float32]) -> NDArray[np.float32]:
    """Bilinear samples of ``img`` at n points, (n, 3) float32 (cv2.remap over a (rows, 512) map)."""
    n = mu.shape[0]
    cols = 512
    rows = -(-n // cols)
    pad = rows * cols - n
    if pad:
        mu = np.concatenate([mu, np.zeros(pad, np.float32)])
        mv = np.concatenate([mv, np.zeros(pad, np.float32)])
    res = cv2.remap(
        img, mu.reshape(rows, cols), mv.reshape(rows, cols), cv2.INTER_LINEAR, borderMode=cv2.BORDER_REPLICATE
    )
    return res.reshape(-1, 3)[:n].astype(np.float32)


class Renderer:
    """Renders ``scene`` through ``camera`` at given poses (orientation relative to frame 0 = world, position m).

    ``cast(R, p)`` gives per-pixel hit distance, surface label and world hit points (for geometry tests);
    ``render_ideal`` a noise-free float image; ``render_frame`` a video frame with blur and noise.
    """

    def __init__(self, camera: CameraModel, scene: StreetScene, settings: RenderSettings = DEFAULT_RENDER_SETTINGS):
        self.camera = camera
        self.scene = scene
        self.settings = settings
        rays = pixel_rays(camera)
        # surface brightness (the sun-side wall brighter, the shaded one darker) is baked into the atlases
        self._atlases = [
            _MipAtlas.from_texture(t, gain)
            for t, gain in ((scene.ground, 1.0), (scene.left_wall, 0.82), (scene.right_wall, 1.08), (scene.far, 0.95))
        ]
        self._rays_planar = tuple(np.ascontiguousarray(rays[:, i], dtype=np.float32) for i in range(3))
        # wall heights along z and the far skyline along x as lookup tables (faster than searchsorted)
        zq = (np.arange(int(np.ceil(scene.block_edges_z_m[-1] / _LUT_STEP_M))) + 0.5) * _LUT_STEP_M
        blk = np.clip(np.searchsorted(scene.block_edges_z_m, zq, side="right") - 1, 0, scene.left_heights_m.size - 1)
        self._left_lut = scene.left_heights_m[blk].astype(np.float32)
        self._right_lut = scene.right_heights_m[blk].astype(np.float32)
        x0 = scene.far_edges_x_m[0]
        xq = x0 + (np.arange(int(np.ceil((scene.far_edges_x_m[-1] - x0) / _LUT_STEP_M))) + 0.5) * _LUT_STEP_M
        blk = np.clip(np.searchsorted(scene.far_edges_x_m, xq, side="right") - 1, 0, scene.far_heights_m.size - 1)
        self._far_lut = scene.far_heights_m[blk].astype(np.float32)
        h, w = camera.height_px, camera.width_px
        r3 = rays.reshape(h, w, 3)
        # angular size of each pixel (rad) from neighbouring rays, for the mip level
        dx = np.linalg.norm(np.diff(r3, axis=1), axis=2)
        dy = np.linalg.norm(np.diff(r3, axis=0), axis=2)
        dx = np.concatenate([dx, dx[:, -1:]], axis=1)
        dy = np.concatenate([dy, dy[-1:, :]], axis=0)
        self._lod = (np.log2(np.sqrt(dx * dy)) + settings.lod_bias).ravel().astype(np.float32)
        # vignetting from the ray angle (cos^4-like falloff, scaled)
        cos_t = rays[:, 2].reshape(h, w)
        vignette = (1.0 - settings.vignetting * (1.0 - cos_t**4) / max(1e-6, 1.0 - float(cos_t.min()) ** 4))
        self._vignette = vignette.astype(np.float32)[..., None]
        gx, gy = np.meshgrid(np.arange(w, dtype=np.float32), np.arange(h, dtype=np.float32))
        self._grid = (gx, gy)
        self._noise_bank: list[NDArray[np.float32]] | None = None
        self.time_s = 0.0
        self._occluder: tuple[NDArray[np.float32], NDArray[np.float32]] | None = None

    def set_time(self, t_s: float) -> None:
        """The frame time: where the movers (``RenderSettings.movers``) stand in the next renders."""
        self.time_s = float(t_s)

    # ------------------------------------------------------------------------------------------ geometry
    def _world_rays(self, rotation: NDArray[np.float64], pixels: slice) -> tuple[NDArray[np.float32], ...]:
        """World directions of the pixel rays, as three contiguous float32 arrays (x, y, z)."""
        R = np.asarray(rotation, np.float64)
        rx, ry, rz = (r[pixels] for r in self._rays_planar)
        return tuple(
            (np.float32(R[i, 0]) * rx + np.float32(R[i, 1]) * ry + np.float32(R[i, 2]) * rz) for i in range(3)
        )

    def cast(
        self, rotation: NDArray[np.float64], position_m: NDArray[np.float64], rows: tuple[int, int] | None = None
    ) -> tuple[NDArray[np.float32], NDArray[np.int8], tuple[NDArray[np.float32], ...]]:
        """Ray-cast one pose: distance_m (N,), label (N,) int8 (index into SURFACES, -1 = sky), world rays.

        ``rows = (first, stop)`` casts only those image rows (N = their pixels); default all.
        """
        sc = self.scene
        dxs, dys, dzs = self._world_rays(rotation, self._pixels(rows))
        px, py, pz = (float(v) for v in position_m)
        H = sc.camera_height_m
        n = dxs.size
        dist = np.full(n, np.inf, np.float32)
        label = np.full(n, -1, np.int8)
        # ground: y = H
        np.divide(np.float32(H - py), dys, out=dist, where=dys > 1e-5)
        label[np.isfinite(dist)] = 0
        # side walls, up to each block's height (the block layout repeats along z)
        period = float(sc.block_edges_z_m[-1])
        pz_mod = np.float32(pz % period)
        for lab, xw, dirmask, lut in (
            (1, sc.left_wall_x_m, dxs < -1e-5, self._left_lut),
            (2, sc.right_wall_x_m, dxs > 1e-5, self._right_lut),
        ):
            s = np.full(n, np.inf, np.float32)
            np.divide(np.float32(xw - px), dxs, out=s, where=dirmask)
            cand = np.nonzero(s < dist)[0]
            s_c = s[cand]
            zc = pz_mod + s_c * dzs[cand]
            height = np.float32(H - py) - s_c * dys[cand]
            blk = (np.mod(zc, np.float32(period)) * np.float32(1.0 / _LUT_STEP_M)).astype(np.int32)
            ok = (height >= 0) & (height <= lut[np.clip(blk, 0, lut.size - 1)])
            dist[cand[ok]] = s_c[ok]
            label[cand[ok]] = lab
        # far buildings: z = far_z, skyline from far_heights
        s = np.full(n, np.inf, np.float32)
        np.divide(np.float32(sc.far_z_m - pz), dzs, out=s, where=dzs > 1e-5)
        cand = np.nonzero(s < dist)[0]
        s_c = s[cand]
        xc = np.float32(px - sc.far_edges_x_m[0]) + s_c * dxs[cand]
        height = np.float32(H - py) - s_c * dys[cand]
        blk = np.clip((xc * np.float32(1.0 / _LUT_STEP_M)).astype(np.int32), 0, self._far_lut.size - 1)
        ok = (height >= 0) & (height <= self._far_lut[blk])
        dist[cand[ok]] = s_c[ok]
        label[cand[ok]] = 3
        if sc.back_z_m is not None:  # buildings closing the street behind (same texture as the far ones)
            s = np.full(n, np.inf, np.float32)
            np.divide(np.float32(sc.back_z_m - pz), dzs, out=s, where=dzs < -1e-5)
            cand = np.nonzero(s < dist)[0]
            s_c = s[cand]
            xc = np.float32(px - sc.far_edges_x_m[0]) + s_c * dxs[cand]
            height = np.float32(H - py) - s_c * dys[cand]
            blk = np.clip((xc * np.float32(1.0 / _LUT_STEP_M)).astype(np.int32), 0, self._far_lut.size - 1)
            ok = (height >= 0) & (height <= self._far_lut[blk])
            dist[cand[ok]] = s_c[ok]
            label[cand[ok]] = 3
        if self.settings.wall_ahead_z_m > 0 or self.settings.movers:
            self._cast_scenario(dist, label, (dxs, dys, dzs), (px, py, pz))
        return dist, label, (dxs, dys, dzs)

    def mover_positions(self, t_s: float | None = None) -> list[tuple[float, float, float, float, float]]:
        """``(centre x, plane z, width, height, texture u)`` of every mover at ``t_s`` (default: the set time)."""
        t = self.time_s if t_s is None else float(t_s)
        return [(x0 + vx * t, z0 + vz * t, w, h, u0) for x0, z0, vx, vz, w, h, u0 in self.settings.movers]

    def _cast_scenario(self, dist, label, rays, origin) -> None:  # noqa: ANN001
        """The wall ahead (label 4) and the movers (label 5; which one in ``self._mover_hit``), in place."""
        dxs, dys, dzs = rays
        px, py, pz = origin
        H = self.scene.camera_height_m
        z_wall = self.settings.wall_ahead_z_m
        if z_wall > 0:
            s = np.full(dist.size, np.inf, np.float32)
            np.divide(np.float32(z_wall - pz), dzs, out=s, where=dzs > 1e-5)
            hit = np.nonzero(s < dist)[0]
            hit = hit[(np.float32(H - py) - s[hit] * dys[hit]) >= 0]  # above the ground (no sky over it: tall)
            dist[hit] = s[hit]
            label[hit] = 4
        self._mover_hit = np.full(dist.size, -1, np.int16)
        for k, (xc, zc, w, h, _u0) in enumerate(self.mover_positions()):
            s = np.full(dist.size, np.inf, np.float32)
            np.divide(np.float32(zc - pz), dzs, out=s, where=dzs > 1e-5)
            cand = np.nonzero(s < dist)[0]
            sc = s[cand]
            x = np.float32(px - xc) + sc * dxs[cand]
            up = np.float32(H - py) - sc * dys[cand]
            ok = (np.abs(x) <= np.float32(w / 2)) & (up >= 0) & (up <= np.float32(h))
            dist[cand[ok]] = sc[ok]
            label[cand[ok]] = 5
            self._mover_hit[cand[ok]] = k

    def _pixels(self, rows: tuple[int, int] | None) -> slice:
        if rows is None:
            return slice(None)
        w = self.camera.width_px
        return slice(rows[0] * w, rows[1] * w)

    def hit_points(self, rotation: NDArray[np.float64], position_m: NDArray[np.float64]) -> NDArray[np.float64]:
        """World points (H, W, 3) seen by each pixel (inf for sky)."""
        dist, _, D = self.cast(rotation, position_m)
        d = dist.astype(np.float64)
        pts = np.stack([float(position_m[i]) + d * D[i].astype(np.float64) for i in range(3)], axis=1)
        pts[~np.isfinite(d)] = np.inf
        return pts.reshape(self.camera.height_px, self.camera.width_px, 3)

    # --------------------------------------------------------------------------------------------- shading
    def render_ideal(self, rotation: NDArray[np.float64], position_m: NDArray[np.float64]) -> NDArray[np.float32]:
        """Noise-free, blur-free BGR float32 image (H, W, 3), values 0-255."""
        return self._shade(rotation, position_m)[0]

    def render_blurred(
        self,
        rotations: NDArray[np.float64],
        positions_m: NDArray[np.float64],
        n_taps: int,
        *,
        band_rotations: NDArray[np.float64] | None = None,
        band_positions_m: NDArray[np.float64] | None = None,
    ) -> NDArray[np.float32]:
        """Motion-blurred noise-free image over an exposure from pose 0 (start) to pose 2 (end), centre pose 1.

        The image is rendered once at the centre pose (or, for a rolling shutter, in equal row bands at
        ``band_rotations``/``band_positions_m``, top to bottom); every pixel's 3-D point is projected into the
        start and end poses, and the image is averaged along that per-pixel motion (``n_taps`` samples): the
        same as averaging sub-exposures, to first order, at a fraction of the cost.
        """
        R, P = np.asarray(rotations, float), np.asarray(positions_m, float)
        if band_rotations is None or len(band_rotations) <= 1:
            if band_rotations is not None:
                R, P = R.copy(), P.copy()
                R[1], P[1] = band_rotations[0], np.asarray(band_positions_m, float)[0]
            img, dist, D = self._shade(R[1], P[1])
            origin: tuple[Any, ...] = (np.float32(0.0),) * 3
        else:
            img, dist, D, origin = self._shade_bands(band_rotations, band_positions_m, P[1])  # type: ignore[arg-type]
        if n_taps <= 1:
            return img
        d = np.where(np.isfinite(dist), dist, np.float32(1e4))
        pix = []
        for k in (0, 2):
            rel = (P[1] - P[k]).astype(np.float32)
            xw = [rel[i] + origin[i] + d * D[i] for i in range(3)]
            Rt = R[k].T.astype(np.float32)
            xc, yc, zc = ((Rt[i, 0] * xw[0] + Rt[i, 1] * xw[1] + Rt[i, 2] * xw[2]) for i in range(3))
            zc = np.maximum(zc, np.float32(1e-3))
            pix.append((xc / zc, yc / zc))
        K = self.camera.camera_matrix
        h, w = self.camera.height_px, self.camera.width_px
        flow_x = (np.float32(K[0, 0]) * (pix[1][0] - pix[0][0])).reshape(h, w)
        flow_y = (np.float32(K[1, 1]) * (pix[1][1] - pix[0][1])).reshape(h, w)
        gx, gy = self._grid
        acc = np.zeros_like(img)
        for a in np.linspace(-0.5, 0.5, n_taps, dtype=np.float32):
            acc += cv2.remap(img, gx - a * flow_x, gy - a * flow_y, cv2.INTER_LINEAR, borderMode=cv2.BORDER_REPLICATE)
        acc *= np.float32(1.0 / n_taps)
        return acc

    def band_rows(self, n_bands: int) -> NDArray[np.int64]:
        """Row edges (n_bands + 1) of equal horizontal bands, top to bottom."""
        return np.round(np.linspace(0, self.camera.height_px, n_bands + 1)).astype(np.int64)

    def _shade_bands(
        self, rotations: NDArray[np.float64], positions_m: NDArray[np.float64], origin_m: NDArray[np.float64]
    ) -> tuple[NDArray[np.float32], NDArray[np.float32], tuple[NDArray[np.float32], ...], tuple[NDArray, ...]]:
        """Render row bands at their own poses; also each pixel's camera position relative to ``origin_m``."""
        h, w = self.camera.height_px, self.camera.width_px
        edges = self.band_rows(len(rotations))
        img = np.empty((h, w, 3), np.float32)
        dist = np.empty(h * w, np.float32)
        D = tuple(np.empty(h * w, np.float32) for _ in range(3))
        origin = tuple(np.empty(h * w, np.float32) for _ in range(3))
        positions = np.asarray(positions_m, float)
        for b in range(len(rotations)):
            r0, r1 = int(edges[b]), int(edges[b + 1])
            if r1 <= r0:
                continue
            sl = slice(r0 * w, r1 * w)
            img[r0:r1], dist[sl], Db = self._shade(rotations[b], positions[b], (r0, r1))
            for i in range(3):
                D[i][sl] = Db[i]
                origin[i][sl] = positions[b][i] - origin_m[i]
        return img, dist, D, origin

    def _shade(
        self, rotation: NDArray[np.float64], position_m: NDArray[np.float64], rows: tuple[int, int] | None = None
    ) -> tuple[NDArray[np.float32], NDArray[np.float32], tuple[NDArray[np.float32], ...]]:
        sc, st = self.scene, self.settings
        dist, label, (dxs, dys, dzs) = self.cast(rotation, position_m, rows)
        lod = self._lod[self._pixels(rows)]
        px, py, pz = (float(v) for v in position_m)
        H = sc.camera_height_m
        n = dist.size
        img = np.empty((n, 3), np.float32)
        # sky: smooth gradient with elevation
        sky = np.nonzero(label < 0)[0]
        if sky.size:
            elev = np.clip(-dys[sky] * np.float32(1 / 0.6), 0.0, 1.0)[:, None]
            hor, zen = np.array(sc.sky_horizon_bgr, np.float32), np.array(sc.sky_zenith_bgr, np.float32)
            img[sky] = hor + (zen - hor) * elev
        fog_c = np.array(sc.sky_horizon_bgr, np.float32)
        period = float(sc.block_edges_z_m[-1])
        for lab, tex in enumerate((sc.ground, sc.left_wall, sc.right_wall, sc.far)):
            idx = np.nonzero(label == lab)[0]
            if idx.size == 0:
                continue
            s = dist[idx]
            inv = np.float32(1.0 / tex.texel_m)
            tex_rows = np.float32(tex.levels[0].shape[0])
            if lab == 0:
                cols_m = tex.levels[0].shape[1] * tex.texel_m
                u = (np.float32((px - sc.left_wall_x_m) % cols_m) + s * dxs[idx]) * inv
                v = (np.float32(pz % tex.height_m) + s * dzs[idx]) * inv
                cos_i = np.abs(dys[idx])
            elif lab in (1, 2):
                u = (np.float32(pz % period) + s * dzs[idx]) * inv
                v = tex_rows - (np.float32(H - py) - s * dys[idx]) * inv
                cos_i = np.abs(dxs[idx])
            else:
                u = (np.float32(px - sc.far_edges_x_m[0]) + s * dxs[idx]) * inv
                v = tex_rows - (np.float32(H - py) - s * dys[idx]) * inv
                cos_i = np.abs(dzs[idx])
            # footprint: distance / pixel size, stretched by the incidence: log2(s / sqrt(cos)) = 0.5 log2(s² / cos)
            level = lod[idx] + np.float32(0.5) * np.log2((s * inv) ** 2 / np.maximum(cos_i, np.float32(0.02)))
            col = self._atlases[lab].sample(u, v, level)
            fog = 1.0 - np.exp(-s * np.float32(1.0 / st.fog_distance_m))
            img[idx] = col + (fog_c - col) * fog[:, None]
        if st.wall_ahead_z_m > 0 or st.movers:
            self._shade_scenario(img, dist, label, (dxs, dys, dzs), (px, py, pz), lod, fog_c)
        return img.reshape(-1, self.camera.width_px, 3), dist, (dxs, dys, dzs)

    def _shade_scenario(self, img, dist, label, rays, origin, lod, fog_c) -> None:  # noqa: ANN001
        """Texture for the wall ahead (the left facade's texture, u along x) and the movers (the right facade's
        texture, darker, each from its own ``texture_u_m``), in place."""
        dxs, dys, dzs = rays
        px, py, _pz = origin
        H = self.scene.camera_height_m
        tex = self.scene.left_wall
        inv = np.float32(1.0 / tex.texel_m)
        rows = np.float32(tex.levels[0].shape[0])
        movers = self.mover_positions()
        for lab in (4, 5):
            idx = np.nonzero(label == lab)[0]
            if idx.size == 0:
                continue
            s = dist[idx]
            if lab == 4:
                u = (np.float32(px) + s * dxs[idx]) * inv
                atlas = self._atlases[1]
            else:
                k = self._mover_hit[idx]
                xc = np.array([m[0] - m[2] / 2 - m[4] for m in movers], np.float32)[k]
                u = (np.float32(px) - xc + s * dxs[idx]) * inv
                atlas = self._atlases[2]
            v = rows - (np.float32(H - py) - s * dys[idx]) * inv
            cos_i = np.abs(dzs[idx])
            level = lod[idx] + np.float32(0.5) * np.log2((s * inv) ** 2 / np.maximum(cos_i, np.float32(0.02)))
            col = atlas.sample(u, v, level)
            if lab == 5:
                col *= np.float32(0.7)
            fog = 1.0 - np.exp(-s * np.float32(1.0 / self.settings.fog_distance_m))
            img[idx] = col + (fog_c - col) * fog[:, None]

    def blur_taps(self, blur_px: float) -> int:
        """Samples to average along a pixel's motion of ``blur_px`` during the exposure (1 = no blur)."""
        if blur_px < 0.5:
            return 1
        return int(np.clip(np.ceil(blur_px / self.settings.blur_step_px) + 1, 2, self.settings.max_blur_taps))

    def finish(self, img: NDArray[np.float32], rng: np.random.Generator) -> NDArray[np.uint8]:
        """Defocus, vignetting, shot and read noise, 8-bit quantisation."""
        st = self.settings
        if st.defocus_sigma_px > 0:
            img = cv2.GaussianBlur(img, (0, 0), st.defocus_sigma_px)
        if st.contrast < 1.0:
            img = np.float32(128.0) + (img - np.float32(128.0)) * np.float32(st.contrast)
        if st.occlusion > 0:
            alpha, cover = self._occlusion_layer()
            img = img * (np.float32(1.0) - alpha) + cover * alpha
        img = img * self._vignette  # type: ignore[assignment]  # float32 * float32
        if st.light < 1.0:
            img = img * np.float32(st.light)  # the sensor sees less light; noise is added at this level
        if st.read_noise_dn > 0 or st.shot_noise_gain > 0:
            sigma = np.sqrt(np.float32(st.read_noise_dn**2) + np.float32(st.shot_noise_gain) * np.maximum(img, 0.0))
            img += self._noise(rng) * sigma
        if st.light < 1.0:
            img = img * np.float32(min(1.0 / st.light, _MAX_LOW_LIGHT_GAIN))  # the camera's gain
        return np.clip(img + np.float32(0.5), 0, 255).astype(np.uint8)

    def _occlusion_layer(self) -> tuple[NDArray[np.float32], NDArray[np.float32]]:
        """A soft-edged blob fixed to the lens over the lower left (alpha (H,W,1)) and its dark fabric (H,W,3)."""
        if self._occluder is None:
            h, w = self.camera.height_px, self.camera.width_px
            r = self.settings.occlusion * w
            yy, xx = np.mgrid[0:h, 0:w].astype(np.float32)
            d = np.hypot(xx / 1.0, (yy - h) * 1.3)  # an ellipse from the lower left corner
            alpha = np.clip((np.float32(r) - d) / np.float32(0.08 * w + 1.0), 0.0, 1.0)
            alpha = cv2.GaussianBlur(alpha, (0, 0), 0.02 * w + 1.0)[..., None]
            rng = np.random.default_rng(0x5CA7F)
            weave = cv2.GaussianBlur(rng.standard_normal((h, w)).astype(np.float32), (0, 0), 2.0)
            cover = (np.float32(40.0) + np.float32(25.0) * weave)[..., None] * np.array([0.9, 0.8, 1.0], np.float32)
            self._occluder = (alpha.astype(np.float32), cover.astype(np.float32))
        return self._occluder

    def _noise(self, rng: np.random.Generator) -> NDArray[np.float32]:
        """Unit white noise (H, W, 3): a random crop of a random one of a few pre-drawn fields, randomly flipped
        (drawing 1M normals per frame would cost more than rendering it); different every frame."""
        h, w = self.camera.height_px, self.camera.width_px
        if self._noise_bank is None:
            bank_rng = np.random.default_rng(0x401_5E)
            self._noise_bank = [bank_rng.standard_normal((h + 64, w + 64, 3), dtype=np.float32) for _ in range(4)]
        field_ = self._noise_bank[int(rng.integers(len(self._noise_bank)))]
        oy, ox = int(rng.integers(64)), int(rng.integers(64))
        crop = field_[oy : oy + h, ox : ox + w]
        if rng.integers(2):
            crop = crop[::-1]
        if rng.integers(2):
            crop = crop[:, ::-1]
        return crop
