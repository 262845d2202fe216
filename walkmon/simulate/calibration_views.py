"""Rendered chessboard views for testing camera calibration: a planar board at random poses in front of the
simulated camera, seen through the same projection (lens distortion included) as the street renderer."""

from __future__ import annotations

import logging
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from walkmon.camera.model import CameraModel
from walkmon.consts import rotation_from_angles_deg
from walkmon.errors import InvalidInputError
from walkmon.simulate.render import pixel_rays

__all__ = ["ChessboardView", "render_chessboard_views"]

_log = logging.getLogger(__name__)


@dataclass(frozen=True, slots=True)
class ChessboardView:
    """One rendered view: the grey image, the board pose (board-to-camera rotation, translation in metres) and the
    true pixel positions of the inner corners (row-major, as OpenCV orders a ``cols x rows`` board)."""

    image: NDArray[np.uint8]
    rotation: NDArray[np.float64]
    translation_m: NDArray[np.float64]
    corners_px: NDArray[np.float64]


def _board_value(x: NDArray, y: NDArray, board: tuple[int, int], square_m: float) -> NDArray[np.float32]:
    """Reflectance on the board plane (board coordinates in metres, origin at the first inner corner)."""
    cols, rows = board
    i = np.floor(x / square_m)
    j = np.floor(y / square_m)
    inside = (i >= -1) & (i <= cols - 1) & (j >= -1) & (j <= rows - 1)
    black = ((i + j) % 2 == 0) & inside
    margin = (x >= -2 * square_m) & (x <= (cols + 1) * square_m) & (y >= -2 * square_m) & (y <= (rows + 1) * square_m)
    value = np.where(margin, 225.0, np.nan)
    return np.where(black, 25.0, value).astype(np.float32)


def _shade_board(
    rays: tuple[NDArray, NDArray, NDArray], R: NDArray, t: NDArray, board: tuple[int, int], square_m: float
) -> NDArray[np.float32]:
    """Board reflectance seen along each ray (NaN where the ray misses the board or its white margin)."""
    rx, ry, rz = rays
    n = R[:, 2]
    denom = n[0] * rx + n[1] * ry + n[2] * rz
    with np.errstate(divide="ignore", invalid="ignore"):
        s = float(t @ n) / denom
        hx, hy, hz = rx * s - t[0], ry * s - t[1], rz * s - t[2]
        bx = R[0, 0] * hx + R[1, 0] * hy + R[2, 0] * hz  # R^T (s d - t): board coordinates
        by = R[0, 1] * hx + R[1, 1] * hy + R[2, 1] * hz
        val = _board_value(bx, by, board, square_m)
    val[~(s > 0)] = np.nan
    return val


def render_chessboard_views(
    camera: CameraModel,
    board: tuple[int, int] = (9, 6),
    square_m: float = 0.025,
    n_views: int = 15,
    seed: int = 0,
    *,
    supersample: int = 3,
    noise_dn: float = 2.0,
) -> list[ChessboardView]:
    """``n_views`` grey images of a ``cols x rows`` inner-corner chessboard at random, fully visible poses.

    Poses spread the board over the image (centre and corners, where distortion is strongest), tilted by up to
    25° about each axis. Pixels are supersampled ``supersample``² times (anti-aliased edges) and get Gaussian noise.
    """
    cols, rows = board
    if cols < 2 or rows < 2 or square_m <= 0 or n_views < 1:
        msg = f"need a board of at least 2x2 inner corners, a positive square and views, got {board}, {square_m}"
        raise InvalidInputError(msg)
    rng = np.random.default_rng([seed, 0xCA1B])
    w, h = camera.width_px, camera.height_px
    offs = (np.arange(supersample) + 0.5) / supersample - 0.5
    u, v = np.meshgrid(np.arange(w, dtype=float), np.arange(h, dtype=float))
    sub = np.stack(
        [np.stack([u.ravel() + ox, v.ravel() + oy], axis=1) for oy in offs for ox in offs], axis=0
    ).reshape(-1, 2)
    rays = tuple(np.ascontiguousarray(c, dtype=np.float64) for c in pixel_rays(camera, sub).T)
    obj = np.zeros((cols * rows, 3))
    obj[:, :2] = np.mgrid[0:cols, 0:rows].T.reshape(-1, 2) * square_m
    outline = np.array([[-2, -2, 0], [cols + 1, -2, 0], [-2, rows + 1, 0], [cols + 1, rows + 1, 0]]) * square_m
    centre = np.array([(cols - 1) / 2, (rows - 1) / 2, 0.0]) * square_m
    views: list[ChessboardView] = []
    targets = [(0.5, 0.5)] + [(float(a), float(b)) for a, b in rng.uniform(0.15, 0.85, (4 * n_views, 2))]
    attempts = 0
    while len(views) < n_views:
        attempts += 1
        if attempts > 200 * n_views:
            msg = "could not place the chessboard fully in view; the board is too large for this camera"
            raise InvalidInputError(msg)
        tx, ty = targets[len(views) % len(targets)] if attempts < 50 * n_views else rng.uniform(0.2, 0.8, 2)
        R = rotation_from_angles_deg(rng.uniform(-25, 25), rng.uniform(-25, 25), rng.uniform(-25, 25))
        dist = rng.uniform(0.27, 0.42) * (cols + 1) * square_m / 0.25
        # aim the board centre at the target pixel
        ray = pixel_rays(camera, np.array([[tx * w, ty * h]]))[0]
        t = ray / ray[2] * dist - R @ centre
        pts_cam = np.vstack([obj, outline]) @ R.T + t
        if np.any(pts_cam[:, 2] < 0.05):
            continue
        px = camera.pixels_from_camera_points(pts_cam)
        if np.any(px < 8) or np.any(px[:, 0] > w - 9) or np.any(px[:, 1] > h - 9):
            continue
        img_val = _shade_board(rays, R, t, board, square_m)  # type: ignore[arg-type]  # rays: 3 arrays
        background = 110.0 + 25.0 * np.sin(sub[:, 0] / 37.0) * np.cos(sub[:, 1] / 53.0)
        val = np.where(np.isnan(img_val), background.astype(np.float32), img_val)
        img = val.reshape(supersample * supersample, h, w).mean(axis=0)
        img = img + rng.normal(0.0, noise_dn, img.shape)
        image = np.clip(np.rint(img), 0, 255).astype(np.uint8)
        views.append(ChessboardView(image, R, t, camera.pixels_from_camera_points(obj @ R.T + t)))
    _log.debug("rendered %d chessboard views in %d attempts", len(views), attempts)
    return views
