"""The ``fast`` rotation method: KLT tracks against a keyframe, GRIC between rotation-only and essential models.

Per frame: build the LK pyramid of the (downscaled) grey frame, track the previous frame's points, convert
tracked positions to normalised coordinates (undistorted), fit the rotation-only model and the essential model
(Gauss-Newton started from the rotation-only fit) against the keyframe's positions of the same tracks, choose
with GRIC, flag the frame when the essential rotation strays from the rotation-only one further than the
parallax explains, drop outlier tracks, and start a new keyframe (re-detecting corners in the gaps) when tracks
thin out, the rotation since the keyframe grows or the keyframe gets old. A frame the images cannot support is
flagged with its reason (types.FLAG_REASONS): models that disagree, a plane's ambiguous rotation, a translation
past a near facade that fits as well as a rotation, a jump from the frame-to-frame tracking, a turn faster than
``max_ok_rate_deg_s``. The orientation is the keyframe's
orientation times the relative rotation, so error only accumulates once per keyframe, not once per frame.
"""

from __future__ import annotations

import dataclasses
import logging
import math
from collections import deque
from dataclasses import dataclass

import cv2
import numpy as np
from numpy.typing import NDArray

from walkmon.camera.model import CameraModel
from walkmon.consts import angle_between_deg
from walkmon.rotation import geometry as geo
from walkmon.rotation import shutter
from walkmon.rotation.heading import HeadingReference
from walkmon.rotation.types import (
    EstimateStatus,
    RotationEstimate,
    RotationSettings,
    make_estimate,
)
from walkmon.rotation.vertical import VerticalReference

__all__ = ["FastEngine"]

_log = logging.getLogger(__name__)

#: A frame whose grey-level standard deviation is below this is treated as featureless (lens cap, black).
_UNIFORM_STD = 2.0
#: The essential and rotation-only fits disagree (frame LOW_QUALITY, rotation-only used) when their rotations
#: differ by more than this many degrees and more than this multiple of the parallax angle; see _models_disagree.
_DISAGREE_MIN_DEG = 0.5
_DISAGREE_PARALLAX_RATIO = 2.0
#: The tracks are taken to lie near one plane when the homography's median transfer error is below this multiple
#: of the essential model's median Sampson error; the plane's two rotations then must agree within
#: _PLANAR_AMBIGUITY_DEG or the frame is flagged. See FastEngine._homography_choice.
_PLANAR_RESIDUAL_RATIO = 5.0
_PLANAR_AMBIGUITY_DEG = 1.0
_PLANAR_AMBIGUITY_TRACK_PX = 4.0
#: The ground's plane solution: its normal (signed, towards the plane) within this of the vertical, in deg, and
#: every other solution's at least ``_OTHER_NORMAL_DEG`` from it, when the vertical lines measured the vertical
#: (known to a few degrees; see ``FastEngine._ground_solution``). Set a priori, not tuned.
_GROUND_NORMAL_DEG = 30.0
_OTHER_NORMAL_DEG = 50.0
#: When the vertical is assumed (no vertical lines seen: the first frame's y axis, then the camera's own, see
#: _CAMERA_Y_OTHER_NORMAL_DEG) and that rule finds no ground: a
#: chest camera may start 45 deg below level (tilted down on a stooping walker), so the ground's normal is taken
#: up to 60 deg from it, when the other solution's lies 90 deg or more from it and the two normals at least
#: ``_ASSUMED_NORMALS_APART_DEG`` apart: the other's is the walk's direction, which lies in the ground (90 deg;
#: the trunk's bob tilts it by well under 20). Without that last test noisy plane fits of a level camera in fog
#: passed the wide cone (normals 32-59 deg off the vertical, a median 59-73 deg apart) and vouched for a fit
#: that jumped (fog seed 4: an ok frame 0.84 deg off the previous). Set from that geometry, then measured.
_ASSUMED_GROUND_NORMAL_DEG = 60.0
_ASSUMED_OTHER_NORMAL_DEG = 90.0
_ASSUMED_NORMALS_APART_DEG = 70.0
#: When neither finds the ground, the same rules are tried against the camera's own y axis (a turn swings the
#: first frame's y axis, wrong by the camera's start tilt, about the vertical: FastEngine._ground_solution), for a
#: camera tilted down only: every other solution's normal at least this far (deg) from that axis. The other one is
#: the walk's direction, 90 deg plus the camera's downward tilt from it; a facade beside a walker going down a ramp
#: passed the rules with it 90.3-96 deg away (review). Set from that geometry, not tuned.
_CAMERA_Y_OTHER_NORMAL_DEG = 100.0
#: A second essential refinement, started across the view, is tried when the camera looks more than this (deg)
#: away from the walker's heading (the optical axis low-passed over _HEADING_TAU_S); it replaces the first when
#: its robust cost is below _ALT_COST_RATIO times the first's. See FastEngine._essential_fit.
_ALT_START_MIN_DEG = 30.0
_ALT_COST_RATIO = 0.8
_HEADING_TAU_S = 2.0
#: The essential model with the baseline along the walker's heading (see FastEngine._heading_fit) is considered
#: only when the parallax since the keyframe (the rotation-only fit's median residual) is below this multiple of
#: the tracks' noise: above it the free essential fit's baseline is well determined (street and wall: 20-40x;
#: night and fog: 3-8x, where it is biased towards the tracks' centroid and takes the rotation with it).
_HEADING_MAX_SNR = 10.0
#: A fit further than this (deg) from the previous frame's estimate moved on by the rotation-only fit's
#: frame-to-frame change is flagged LOW_QUALITY ("step_inconsistent") and the rotation-only fit against the
#: keyframe used instead; a fit the ground's plane solution vouches for is kept, flagged "ground_step".
_STEP_JUMP_DEG = 1.0
#: A ground frame in doubt is held (its own rotation lost for good) only while the frame-to-frame rotation-only
#: change is below this (review: nothing bounded what holds lose in a turn). The held frames of the 25 deg-down
#: bend walks (bench_rotation --mounts) changed by 0.6-1.6 deg, a frame's rotation plus the near ground's parallax;
#: a turn at 90 deg/s, 3 deg a frame, keeps the rotation-only fit, whose bias is about a frame's parallax.
_HOLD_MAX_STEP_DEG = 2.0
#: Tracks start Lucas-Kanade where the last frame's rotation would carry them when it exceeded this (deg).
_PREDICT_MIN_STEP_DEG = 1.0
#: A frame that cannot be measured (held: implausible step, few inliers, lost tracks, the ground in doubt) in a
#: steady turn (the last two accepted frames, ok or still estimated, with no unmeasured frame between or since,
#: each turned at _COAST_MIN_RATE_DEG_S or more over at most _COAST_MAX_S, at rates that differ by at most
#: _COAST_STEADY of the last) is carried on at the last rate (model "coast"), when the last accepted frame is at
#: most _COAST_MAX_S before it: a hold stopped the turn for a frame and lost its whole rotation for good (a
#: walker's U-turn at 274 deg/s: 9.1 deg). The rate floor is 1 deg a frame at 30 fps (_PREDICT_MIN_STEP_DEG there)
#: as a rate, so that a slower video does not coast a walker's sway. See FastEngine._coast.
_COAST_MIN_RATE_DEG_S = 30.0
_COAST_MAX_S = 0.1
_COAST_STEADY = 0.3
_COAST_DT_TOLERANCE_S = 1e-6  # frame times i / fps: 10 fps must not fall either side of _COAST_MAX_S by rounding


def _no_gap(dt_s: float) -> bool:
    """A frame interval a rate may be measured over or carried across (0 < dt <= _COAST_MAX_S)."""
    return 0.0 < dt_s <= _COAST_MAX_S + _COAST_DT_TOLERANCE_S


#: A frame-to-frame rotation differing by more than this (deg) from the one the last accepted step's rate predicts
#: over this frame's interval (FastEngine._expected_step) is held as implausible.
_MAX_STEP_CHANGE_DEG = 4.0
#: A rolling-shutter camera's tracks are moved to the frame's time when the image's skew from the top row to the
#: bottom one (rate x readout x focal) exceeds this (px): a fifth of the tracking noise (feature_noise_px).
_SHUTTER_MIN_SKEW_PX = 0.1
#: At most this many refits of a frame with the rate its own fit measured (FastEngine._shutter_refit): one took
#: rolling_shutter seeds 1-5 to a raw error (as an angle) of 0.8-2.8 deg (two: 0.9-5.5, the second chasing a turn's misfits)
#: at a fifth of the frame rate when the camera walks (two refits: a third).
_SHUTTER_ITERATIONS = 1
#: After a frame faster than max_ok_rate_deg_s, frames stay flagged until the rate falls below this fraction of it.
_TURN_EXIT_FRACTION = 0.5
#: A new keyframe whose refinement (window, vertical lines) moves the orientation by more than this (deg) at once
#: flags its frame ("keyframe_correction"): the frame-to-frame change reported there is not the camera's. The
#: bound two estimates of one rotation may differ by unflagged (_DISAGREE_MIN_DEG), not fitted to the clips.
_CORRECTION_FLAG_DEG = _DISAGREE_MIN_DEG
#: How far (deg) a frame of a fast turn, or a held one, may move the odometry's tilt, for the vertical lines'
#: filter (VerticalReference.add_doubt). About the RMS frame-to-frame error of the fast_rotation frames of the
#: scenario tuning clips (seed 1, 640x480: 0.20 deg) and of the unkind sessions' flagged frames (320x240: 0.30).
#: Only turns and holds count: the few plane-ambiguous frames of a straight walk drift little, and the keyframes
#: their doubt would bring on (VerticalReference.due) changed the odometry's course (turns seed 1: yaw 0.6 -> 4.8).
_FLAGGED_DOUBT_DEG = 0.3
#: Tilting fast (sitting down, bending to pick something up, handling the camera): where the camera's down direction
#: moved by more than _FAST_TILT_DEG within _FAST_TILT_WINDOW_S, each frame adds _FAST_TILT_DOUBT x its own tilt to
#: the vertical lines' doubt (VerticalReference.add_doubt), so that the lines are looked at between keyframes as
#: after a turn. The frames stay ok: they were as ok before, this only changes when the lines are looked at. The
#: odometry reads such a tilt short while the chest drops and pitches at once (a sit-down facing a facade, 4.6 deg
#: of 22 in the unkind sessions: sitting still then read as standing), and keyframes come rarely once the wearer
#: sits still. A walking trunk stays below 15 deg in 0.5 s: the Mobilise-D lower backs' straight walks 8 deg at
#: most, the simulator's chest 14 deg at its 99th percentile (posture changes, gait initiation); the simulated
#: sit-downs, pick-ups and camera handling exceed it in 19 % of their frames. _FAST_TILT_DOUBT: the largest
#: tilt error the odometry reached in such a stretch per degree of its fast tilt (seeds 1-5: 0.026-0.058).
_FAST_TILT_WINDOW_S = 0.5
_FAST_TILT_DEG = 15.0
_FAST_TILT_DOUBT = 0.05
#: ``min_feature_distance_px`` is given for a view this wide and scaled with the frame width.
_REFERENCE_WIDTH_PX = 640.0
#: Haze (fog, mist): a frame is veiled when its darkest 1 % of pixels are at least this fraction of its brightest
#: 1 % (the airlight brightens everything, nothing is dark: the dark channel prior of He et al. 2009, CVPR, on a
#: grey image). In a veiled frame Lucas-Kanade's tracks are refined, at the finest level, on both images less
#: their local mean (a _HIGHPASS_BOX_PX box on a tracking image _FILTER_WIDTH_PX wide, times _HIGHPASS_GAIN):
#: a patch's fog fraction changes along the depth it spans as the walker approaches, which breaks brightness
#: constancy; fog seed 5's tracks crept a median 0.4 px upwards in 10 frames (against the renderer's depth), a
#: pitch drift of 1 deg in 8 s. Used on every frame, the refinement moved the clips of fast turns and crossing
#: movers (rolling shutter met* 4/5 -> 2/5): it is used only where that bias exists. The bound lies in the middle
#: of the gap between the clear frames and the fog frames, every frame of the clips at hand measured on the
#: tracking image: the scenario clips' clear scenes at most 0.36, the robustness sweep's clips 0.34, a camera 25 deg
#: down on a stooping walker (the mounts table: its view all ground) 0.43, the unkind sessions 0.49 (a pick-up,
#: a steep camera; two frames of one pick-up, bend seed 8, read 0.68 and are veiled all the same); the fog clips
#: (seeds 1-10) at least 0.59. The real GoPro drone clip's hazy coast reads 0.30-0.40. The first bound, 0.4, came
#: from the scenario clips alone: it veiled 15 frames of that steep camera's ground (its pitch error 2.61 -> 2.98
#: deg; found when the mounts table was re-run) and up to a tenth of an unkind session's frames. Set from that gap,
#: not tuned.
_VEIL_RATIO = 0.54
#: Low light: a tracking image whose noise (Immerkaer's estimate, 1996, CVIU 64(2) 300-302: the Laplacian
#: difference mask, robust to the image's own structure) is above _NOISY_ON of its grey-level standard
#: deviation (the signal; an SNR under 4) is smoothed by a Gaussian of _DENOISE_SIGMA_PX at a 320 px wide
#: tracking image before anything is done with it (corners, Lucas-Kanade, vertical lines): the image's gradients
#: are then the scene's, not the noise's. Night (SNR ~2.5) drifted 0.4-0.8 deg of pitch in 8 s without it. It
#: stays on until the ratio falls below _NOISY_OFF (no flicker between smoothed and raw pairs at the edge).
#: Smoothing every frame cost the clear scenes dearly (walls: worst raw pitch 0.9 -> 1.4 deg; fast turns,
#: movers), so it is used only where the noise dominates. The ratio is the tracking image's: a 640 px input is
#: averaged down to it, a 320 px one is not and reads noisier (dusk 0.07-0.12 at 640, 0.09-0.21 at 320; review).
#: The bounds lie in the gap between every clear scenario frame at either size (<= 0.21) and night (>= 0.31 at
#: 640, 0.49 at 320); set from that gap, not tuned.
_NOISY_ON = 0.25
_NOISY_OFF = 0.20
_DENOISE_SIGMA_PX = 1.0
_NOISE_MASK = np.array([[1, -2, 1], [-2, 4, -2], [1, -2, 1]], np.float32)
_HIGHPASS_BOX_PX = 21
_HIGHPASS_GAIN = 2.0
#: The tracking-image width that _HIGHPASS_BOX_PX and _DENOISE_SIGMA_PX are given for; both scale with it.
_FILTER_WIDTH_PX = 320.0


def _pick_ground(
    hom: geo.HomographyFit, down: NDArray[np.float64], *, measured: bool, other_min_deg: float = 0.0,
) -> int | None:
    """The index of the plane solution that is the ground seen with ``down`` (unit, current camera frame) taken for
    the vertical, by the rules of :meth:`FastEngine._ground_solution`, every other solution's normal at least
    ``other_min_deg`` from ``down`` as well; or None."""
    angles = [angle_between_deg(n, down) for _, n in hom.solutions]

    def pick(cone: float, other: float) -> int | None:
        near = [i for i, a in enumerate(angles) if a <= cone]
        if len(near) != 1 or any(a < max(other, other_min_deg) for i, a in enumerate(angles) if i != near[0]):
            return None
        return near[0]

    k = pick(_GROUND_NORMAL_DEG, _OTHER_NORMAL_DEG)
    if k is None and not measured:
        k = pick(_ASSUMED_GROUND_NORMAL_DEG, _ASSUMED_OTHER_NORMAL_DEG)
        if k is not None:
            # the angles between the planes (their normals as lines, signs left out)
            apart = [angle_between_deg(n, hom.solutions[k][1]) for i, (_, n) in enumerate(hom.solutions) if i != k]
            if any(min(a, 180.0 - a) < _ASSUMED_NORMALS_APART_DEG for a in apart):
                k = None
    return k


class FastEngine:
    """State of the fast method for one camera size; see the module docstring."""

    def __init__(self, camera: CameraModel, settings: RotationSettings) -> None:
        self.camera = camera
        self.s = settings
        # Never track below min_tracking_width_px: at 320x240 half-resolution tracking (160x120) left so few
        # pixels per corner that the rotation wandered (raw roll RMSE 0.31 deg vs 0.10 at full resolution).
        scale = min(1.0, max(settings.tracking_scale, settings.min_tracking_width_px / camera.width_px))
        self._track_size = (max(16, round(camera.width_px * scale)), max(16, round(camera.height_px * scale)))
        self._sx = camera.width_px / self._track_size[0]
        self._sy = camera.height_px / self._track_size[1]
        self._focal = 0.5 * (camera.fx + camera.fy)
        # below a few tracking pixels the plane's two solutions are within the tracking noise (160x120 tracking
        # flagged 6 % of a foot-drag walk's frames, all within 1 deg of the truth, with a fixed 1 deg)
        self._planar_threshold_deg = max(_PLANAR_AMBIGUITY_DEG,
                                         math.degrees(_PLANAR_AMBIGUITY_TRACK_PX * self._sx / self._focal))
        # Corner spacing is a fraction of the view, not a pixel count: at 320x240 a 16 px spacing halved the
        # corners a 640x480 view gets and left roll at 0.14 deg detrended RMSE (0.06 with the scaled spacing).
        self._feature_spacing_px = settings.min_feature_distance_px * camera.width_px / _REFERENCE_WIDTH_PX
        self._win = (settings.klt_window_px, settings.klt_levels)
        self._criteria = (cv2.TERM_CRITERIA_EPS | cv2.TERM_CRITERIA_COUNT, 20, 0.03)
        self._orientation = np.eye(3)
        self._prev_small: NDArray[np.uint8] | None = None
        # (frame, its high-passed image) of the last veiled frame tracked, reused as the next one's previous frame
        self._hp_cache: tuple[NDArray[np.uint8], NDArray[np.uint8]] | None = None
        self._hp_box = max(3, round(_HIGHPASS_BOX_PX * self._track_size[0] / _FILTER_WIDTH_PX) | 1)
        self._noisy = False  # low light: the tracking images are smoothed (see _NOISY_ON)
        self._denoise_sigma = _DENOISE_SIGMA_PX * self._track_size[0] / _FILTER_WIDTH_PX
        self._pts = np.zeros((0, 1, 2), np.float32)  # current track positions, tracking resolution
        self._kf_q = np.zeros((0, 3))  # the tracks' normalised homogeneous coordinates in the keyframe
        self._ids = np.zeros(0, np.int64)  # a number per track, to find the same track in older keyframes
        self._next_id = 0
        self._rejected = np.zeros((0, 2), np.float32)  # positions of the tracks the last frame rejected
        self._parallax_deg = 0.0
        self._ground_step = False  # this frame's fit is the ground's and jumped from the chain (see _fit)
        # recent keyframes: (orientation, sorted track ids, their normalised coordinates there)
        self._window: deque[tuple[NDArray[np.float64], NDArray[np.int64], NDArray[np.float64]]] = deque(
            maxlen=max(1, settings.keyframe_window)
        )
        self._R_kf = np.eye(3)
        self._R_rel = np.eye(3)
        self._q_prev = np.zeros((0, 3))  # the tracks' normalised coordinates in the previous frame
        self._q_cur = np.zeros((0, 3))
        self._kf_tracks = 0
        self._frames_since_kf = 0
        self._correction_deg = 0.0  # how far the last new keyframe's refinement moved the orientation
        # the walker's heading (unit, first frame's axes), the second start of the essential refinement (see
        # _essential_fit); None until a frame was accepted
        self._travel: NDArray[np.float64] | None = None
        self._t_prev: float | None = None
        self._last_step: NDArray[np.float64] | None = None  # the last accepted frame-to-frame rotation
        self._last_dt = 0.0  # its interval (s); its rate is self._rate
        # the rate of the accepted step before it, for _coast: None across an unmeasured frame or a gap
        self._rate_before: NDArray[np.float64] | None = None
        self._unmeasured = False  # a frame was held or carried on since the last accepted one (see _coast)
        # the angular rate of the last accepted step (rad/s, camera axes: a rolling shutter's correction, the
        # tracks' guess, _coast) and the rate this frame's tracks are moved to the frame's time with (rolling
        # shutter only, camera.readout_s > 0; None: not moved); see shutter.py
        self._readout_s = camera.readout_s
        self._rate: NDArray[np.float64] | None = None
        self._frame_rate: NDArray[np.float64] | None = None
        self._in_turn = False  # a frame turned faster than max_ok_rate_deg_s and the rate has not halved since
        # (time, orientation) of the frames accepted over the last _FAST_TILT_WINDOW_S (see _tilt_doubt)
        self._tilt_history: deque[tuple[float, NDArray[np.float64]]] = deque()
        self._t_s = 0.0
        # pitch/roll drift corrected at keyframes from vertical lines (see walkmon.rotation.vertical)
        self._vertical = (
            VerticalReference(drift_deg_per_s=settings.vertical_drift_deg_s,
                              heading=HeadingReference() if settings.heading_reference else None)
            if settings.vertical_reference else None
        )
        # the walker's direction of travel in the first frame's axes (see _heading_fit): the optical axis at the
        # start, then low-passed from the baselines of the free essential fits accepted; None after a flagged
        # turn or jump (the orientation it is kept in may be off) until the next free essential fit
        self._heading: NDArray[np.float64] | None = np.array([0.0, 0.0, 1.0])
        self._centre: NDArray[np.float64] | None = None  # this frame's free essential baseline (keyframe axes)
        self.started = False

    # ----------------------------------------------------------------------------------------------------------
    def _normalized(self, pts_small: NDArray[np.float32]) -> NDArray[np.float64]:
        px = pts_small.reshape(-1, 2).astype(np.float64)
        px[:, 0] = (px[:, 0] + 0.5) * self._sx - 0.5
        px[:, 1] = (px[:, 1] + 0.5) * self._sy - 0.5
        if self.camera.has_distortion:
            xy = self.camera.normalized_from_pixels(px)
        else:
            xy = np.empty_like(px)
            xy[:, 0] = (px[:, 0] - self.camera.cx) / self.camera.fx
            xy[:, 1] = (px[:, 1] - self.camera.cy) / self.camera.fy
        q = geo.homogeneous_from_normalized(xy)
        if self._frame_rate is not None:  # a rolling shutter in a turn: each row seen at its own time
            dt = shutter.row_offsets_s(px[:, 1], self.camera.height_px, self._readout_s)
            q = shutter.to_frame_time(q, dt, self._frame_rate)
        return q

    def _detect(self, small: NDArray[np.uint8], existing: NDArray[np.float32]) -> NDArray[np.float32]:
        want = self.s.max_features - existing.shape[0]
        if want <= 0:
            return np.zeros((0, 1, 2), np.float32)
        dist = max(2.0, self._feature_spacing_px / self._sx)
        mask = None
        if existing.shape[0] or self._rejected.shape[0]:
            mask = np.full(small.shape, 255, np.uint8)
            for x, y in existing.reshape(-1, 2):
                cv2.circle(mask, (int(x), int(y)), int(dist), 0, -1)
            # no new corners where the last frame's outlier tracks were: independently moving people and
            # vehicles (their tracks fail the camera's motion), which new corners would otherwise pick up again
            for x, y in self._rejected:
                cv2.circle(mask, (int(x), int(y)), int(2 * dist), 0, -1)
        found = cv2.goodFeaturesToTrack(small, want, 0.01, dist, mask=mask, blockSize=5)
        if found is None:
            return np.zeros((0, 1, 2), np.float32)
        return found.astype(np.float32).reshape(-1, 1, 2)

    def _lose_tracks(self) -> None:
        """Tracking broke (cap, blur, too few inliers): forget tracks and keyframes, keep the orientation."""
        self._pts = np.zeros((0, 1, 2), np.float32)
        self._ids = np.zeros(0, np.int64)
        self._kf_q = np.zeros((0, 3))
        self._q_prev = np.zeros((0, 3))
        self._rejected = np.zeros((0, 2), np.float32)
        self._window.clear()

    def _keep(self, mask: NDArray[np.bool_]) -> None:
        self._pts, self._kf_q, self._ids = self._pts[mask], self._kf_q[mask], self._ids[mask]
        self._q_prev = self._q_prev[mask]

    def _refined_keyframe_orientation(self) -> NDArray[np.float64]:
        """Sliding-window refinement: the current orientation averaged with the ones older keyframes imply.

        Tracks that survived since an older keyframe give a direct, longer-baseline measurement of the rotation
        from it, which skips the chain of links in between; the chordal mean of these (weighted by inliers)
        replaces the chained orientation, so per-link errors average out instead of piling up.
        """
        s = self.s
        chained = self._orientation
        if len(self._window) < 2 or self._pts.shape[0] == 0:
            return chained
        q_cur = self._normalized(self._pts)
        order = np.argsort(self._ids)
        ids_cur, q_cur = self._ids[order], q_cur[order]
        total = self._pts.shape[0] * chained
        weight = float(self._pts.shape[0])
        for R_j, ids_j, q_j in list(self._window)[:-1]:
            _, ia, ib = np.intersect1d(ids_j, ids_cur, assume_unique=True, return_indices=True)
            if ia.size < 2 * s.min_inliers:
                continue
            a, b = q_j[ia], q_cur[ib]
            init = R_j.T @ chained
            rot = geo.rotation_only_fit(a, b, self._focal, rotation_init=init, scale_px=2 * s.feature_noise_px)
            pose = geo.refine_relative_pose(a, b, self._focal, init, scale_px=2 * s.feature_noise_px, iterations=6)
            mask = rot.inliers | pose.inliers
            use_pose = geo.gric(pose.residuals_px[mask], s.feature_noise_px, 3, 5) < geo.gric(
                rot.residuals_px[mask], s.feature_noise_px, 2, 3
            )
            R_rel, inl = (pose.rotation, pose.inliers) if use_pose else (rot.rotation, rot.inliers)
            candidate = R_j @ R_rel
            n_inl = int(np.count_nonzero(inl))
            if n_inl < 2 * s.min_inliers or geo.rotation_angle_deg(chained.T @ candidate) > 1.0:
                continue
            total = total + n_inl * candidate
            weight += n_inl
        if weight == self._pts.shape[0]:
            return chained
        U, _, Vt = np.linalg.svd(total / weight)
        return U @ np.diag([1.0, 1.0, float(np.sign(np.linalg.det(U @ Vt)))]) @ Vt

    def _new_keyframe(self, small: NDArray[np.uint8]) -> None:
        """Make the current frame the keyframe (orientation refined over the window); top up the corners."""
        chained = self._orientation
        if self.s.keyframe_window > 1:
            self._orientation = self._refined_keyframe_orientation()
        if self._vertical is not None:
            self._orientation = self._vertical.correct(small, self._orientation, self._t_s, self._normalized, self._sx)
        self._correction_deg = 0.0 if self._orientation is chained else geo.rotation_angle_deg(
            chained.T @ self._orientation)
        new = self._detect(small, self._pts)
        new_ids = np.arange(self._next_id, self._next_id + new.shape[0], dtype=np.int64)
        self._next_id += new.shape[0]
        self._pts = np.concatenate([self._pts, new]) if self._pts.shape[0] else new
        self._ids = np.concatenate([self._ids, new_ids])
        self._kf_q = self._normalized(self._pts) if self._pts.shape[0] else np.zeros((0, 3))
        self._q_prev = self._kf_q.copy()
        order = np.argsort(self._ids)
        self._window.append((self._orientation.copy(), self._ids[order], self._kf_q[order]))
        self._R_kf = self._orientation.copy()
        self._R_rel = np.eye(3)
        self._kf_tracks = self._pts.shape[0]
        self._frames_since_kf = 0

    def _essential_fit(
        self, q_kf: NDArray[np.float64], q_cur: NDArray[np.float64], R_rot: NDArray[np.float64]
    ) -> tuple[geo.PoseFit, str]:
        """The essential model against the keyframe, refined afresh from the rotation-only fit every frame.

        Not warm-started from the previous frame's (R, baseline): at short baselines the essential cost has a
        long, flat valley in which a lateral baseline error trades against a pitch/yaw rotation error. Carried
        from frame to frame, the previous baseline stays in the wrong part of that valley while the true
        baseline direction swings with the walker's sway, and Gauss-Newton pays for it with rotation: the
        estimate slid 3.2 deg in pitch and 2.9 in yaw within one keyframe (0.4 s) on right_foot_drag seed 2 at
        320x240, with a plausible residual and status ok. The rotation-only fit is biased by parallax but
        close, and the baseline that fits it best (closed form) starts each refinement where the data put it.

        That start fails when the camera looks sideways to the direction of travel (a torso turned towards a
        facade 1-3 m away): the lateral translation's flow looks like a yaw, the rotation-only fit takes it as
        one, the closed-form baseline is then along the optical axis, and Gauss-Newton stays in that local
        minimum (turns seed 1, 640x480: 0.7 deg of yaw error per frame, status ok, its robust cost 2-20x the
        true pose's). So when the camera looks more than _ALT_START_MIN_DEG away from the walker's heading (the
        optical axis low-passed over _HEADING_TAU_S, kept in the first frame's axes: a walker looks ahead on
        average; a torso turned to a facade for a second leaves it behind), a second refinement starts with the
        baseline across the view, towards the heading. Walking or standing while looking ahead skips it (no cost
        on the common path). It replaces the first only when its robust cost is clearly lower (below
        _ALT_COST_RATIO times), never on a noise-level difference along the flat valley. The heading is not
        taken from the essential fits' baselines: fits in the wrong minimum dragged it along with the camera.
        Returns the fit and ``"heading"`` when the baseline was fixed along the walker's heading (see
        _heading_fit; tried first), ``"sideways"`` when the second start gave it, ``"ambiguous"`` when neither start's
        cost is clearly lower and their rotations differ by more than _PLANAR_AMBIGUITY_DEG (the frame is then
        flagged: "translation_ambiguity"), else ``""``.
        """
        sigma = self.s.feature_noise_px
        pose = geo.refine_relative_pose(
            q_kf, q_cur, self._focal, R_rot, None, scale_px=sigma * 2, inlier_px=self.s.inlier_px, iterations=4,
        )
        # the tracks' noise: the free fit's robust spread over all tracks (the median ignores a minority of movers)
        noise = max(1.4826 * float(np.median(np.abs(pose.residuals_px))), 1e-3)
        if math.radians(self._parallax_deg) * self._focal >= _HEADING_MAX_SNR * noise:
            self._centre = pose.centre  # a baseline the tracks determine: the walker's heading learns from it
        else:
            on_heading = self._heading_fit(q_kf, q_cur, pose, noise)
            if on_heading is not None:
                return on_heading, "heading"
        if self._travel is None:
            return pose, ""
        travel = self._R_kf.T @ self._travel
        if travel[2] >= math.cos(math.radians(_ALT_START_MIN_DEG)):
            return pose, ""  # the camera looks along the walker's heading (or stands looking ahead)
        # started across the view (the heading's component normal to the optical axis), at the far end of the
        # valley from the first start: the heading itself lags a turn and, as a start, can fall in either basin
        c_alt = np.array([travel[0], travel[1], 0.0])
        if float(c_alt @ c_alt) < 1e-6:
            return pose, ""
        alt = geo.refine_relative_pose(
            q_kf, q_cur, self._focal, R_rot, c_alt, scale_px=sigma * 2, inlier_px=self.s.inlier_px, iterations=6,
        )
        cost_alt, cost = _robust_cost(alt.residuals_px, 2 * sigma), _robust_cost(pose.residuals_px, 2 * sigma)
        if cost_alt < _ALT_COST_RATIO * cost:
            return alt, "sideways"
        gap = geo.rotation_angle_deg(pose.rotation.T @ alt.rotation)
        if cost_alt * _ALT_COST_RATIO <= cost and gap > _PLANAR_AMBIGUITY_DEG:
            return pose, "ambiguous"
        return pose, ""

    def _heading_fit(
        self, q_kf: NDArray[np.float64], q_cur: NDArray[np.float64], pose: geo.PoseFit, noise: float,
    ) -> geo.PoseFit | None:
        """The essential model with the baseline fixed along the walker's heading, when the tracks cannot tell it
        from the free essential fit ``pose``; None to keep ``pose``.

        In the dark (night: tracks 10x noisier than in daylight) and in fog (only the ground and facades within
        ~6 m, all below or beside the view's centre), the parallax since the keyframe is only 3-8x the tracks'
        noise. The free fit's Sampson cost is then nearly flat along the valley in which a baseline error trades
        against a rotation error, and its minimum is biased: the estimated baseline leans towards the tracks'
        centroid (downwards onto the ground) and the rotation pays for it, by a consistent ~0.05 deg in pitch a
        frame (fog seed 2: 3 deg in 4 s of walking; with the true baseline direction fixed, 0.01). A walker moves
        along a heading; his chest strays from it by a few cm a step, an error that does not accumulate (the
        chain of keyframes telescopes it) where the free fit's bias does. So when the parallax is below
        _HEADING_MAX_SNR times the noise (1.4826 x the free fit's median absolute Sampson error), the camera looks
        within _ALT_START_MIN_DEG of the heading and it is not turning, the essential model refined with the
        baseline fixed along the heading (3 parameters) competes with the free one (5) by GRIC at that noise:
        kept unless the tracks reject the heading. Open streets and walls (parallax 20-40x the noise) never use
        it, so their estimates are unchanged. The heading is the optical axis at the start (a walker looks ahead
        on average; the free fits correct it), low-passed over _HEADING_TAU_S from the free fits' baselines.
        """
        if self._heading is None:
            return None
        prior = self._R_kf.T @ self._heading
        turning = self._last_step is not None and geo.rotation_angle_deg(self._last_step) >= _PREDICT_MIN_STEP_DEG
        if turning or prior[2] < math.cos(math.radians(_ALT_START_MIN_DEG)):
            return None
        held = geo.refine_relative_pose(
            q_kf, q_cur, self._focal, pose.rotation, prior, scale_px=2 * self.s.feature_noise_px,
            inlier_px=self.s.inlier_px, iterations=3, fix_centre=True,
        )
        use = pose.inliers | held.inliers
        if np.count_nonzero(use) < 8:
            return None
        if geo.gric(held.residuals_px[use], noise, 3, 3) <= geo.gric(pose.residuals_px[use], noise, 3, 5):
            return held
        return None

    def _models_disagree(self, rot: geo.RotationFit, pose: geo.PoseFit) -> bool:
        """True when the essential rotation is further from the rotation-only one than the parallax allows.

        Parallax (the rotation-only fit's median residual, as an angle) bounds how far the rotation-only fit
        can be pulled off the true rotation; the essential fit should land within about that distance of it.
        On the simulated walks (every type, 160x120 to 640x480) the distance stayed below 1.4x the parallax
        angle; the warm-started refinement that slid by degrees went past 3x. Flag beyond 2x (and 0.5 deg).
        """
        gap_deg = geo.rotation_angle_deg(rot.rotation.T @ pose.rotation)
        if gap_deg <= _DISAGREE_MIN_DEG:
            return False
        parallax_deg = math.degrees(float(np.median(rot.residuals_px)) / self._focal)
        return gap_deg > _DISAGREE_PARALLAX_RATIO * parallax_deg

    def _plane_ambiguous(
        self, q_kf: NDArray[np.float64], q_cur: NDArray[np.float64], pose: geo.PoseFit, mask: NDArray[np.bool_],
    ) -> tuple[bool, NDArray[np.float64] | None]:
        """The third model: a plane-induced homography, fitted when the essential model beat the rotation-only
        one (there is parallax). ``(flag, ground)``: flag True to flag the frame ("planar_ambiguity"), False when
        the essential model stands; ground the rotation of the plane's solution recognised as the ground
        (:meth:`_ground_solution`), else None.

        When the homography explains the tracks nearly as well as the essential model (median transfer error
        below ``_PLANAR_RESIDUAL_RATIO`` times the essential's median Sampson error: the tracks lie near one
        plane, a wall or door ahead, a facade beside the walker after a turn), the essential rotation is not
        determined: a plane admits two (rotation, baseline) solutions, about baseline/distance apart, that fit
        it equally (the homography's decomposition shows both). The frame is then flagged (LOW_QUALITY, the
        rotation-only fit used, as when the essential and rotation-only fits disagree) when the two
        solutions, or the essential and homography rotations, are more than ``_PLANAR_AMBIGUITY_DEG`` apart.

        Measured on seed 1 of the scenario clips at 320x240 (tuned there; seeds 2-5 and 640x480 are held out in
        benchmarks/results/scenarios.md): a street walk got no flags; of the essential fits more than 0.5 deg
        off the truth, the wall's were all flagged (26/26) and the turns' 35 of 52 (the other ambiguous frames
        of the turns stay ok: a known weakness). The GRIC score of the homography (``model_dim=2``,
        ``n_params=8``, returned as ``g_hom``) did not separate the cases: at a keyframe's short baselines
        every model fits and GRIC prefers the homography's lower dimension even in an open street.
        """
        hom = geo.homography_fit(q_kf, q_cur, self._focal, pose.rotation, inlier_px=self.s.inlier_px, method="dlt",
                                 use=mask)
        if hom is None:
            return False, None
        e_res = float(np.median(np.abs(pose.residuals_px[mask])))
        if float(np.median(hom.residuals_px[mask])) >= _PLANAR_RESIDUAL_RATIO * max(e_res, 1e-6):
            return False, None
        gap = geo.rotation_angle_deg(pose.rotation.T @ hom.rotation)
        ground = self._ground_solution(hom, pose) if self.s.ground_plane else None
        if ground is not None:
            # the ground walked along: of the plane's two solutions the one whose normal is the vertical is the
            # true one, so the plane leaves no ambiguity; the essential fit stands when it agrees with it
            return geo.rotation_angle_deg(pose.rotation.T @ ground) > self._planar_threshold_deg, ground
        # two visible plane solutions (the images cannot tell), or the (degenerate) essential fit strayed from
        # the plane's rotation: flagged. Reporting the homography's own rotation instead was tried: its
        # single-frame DLT is too noisy (night: 2.4 deg frame-to-frame jumps, raw yaw 2.2 -> 6.9 deg).
        return max(gap, hom.ambiguity_deg) > self._planar_threshold_deg, None

    def _ground_refit(
        self, q_kf: NDArray[np.float64], q_cur: NDArray[np.float64], ground: NDArray[np.float64],
    ) -> geo.PoseFit | None:
        """The essential model refined from the ground's plane solution, when the tracks lie on the ground (one
        plane solution with a vertical normal, :meth:`_ground_solution`) and the free essential fit strayed from
        it (the plane leaves the essential cost a flat valley; its start, the rotation-only fit, is biased by the
        walker's translation over the near ground): returned when it lands within the planar threshold of the
        ground's rotation, else None (the frame is flagged). Without it a walker bent forward with the camera
        tilted down (45 deg below level) was flagged frame after frame, the rotation-only fallback drifted the
        pitch and the drifted orientation then no longer recognised the ground: 100 deg of error."""
        sigma = self.s.feature_noise_px
        refit = geo.refine_relative_pose(q_kf, q_cur, self._focal, ground, None, scale_px=sigma * 2,
                                         inlier_px=self.s.inlier_px, iterations=4)
        return refit if geo.rotation_angle_deg(refit.rotation.T @ ground) <= self._planar_threshold_deg else None

    def _ground_solution(self, hom: geo.HomographyFit, pose: geo.PoseFit) -> NDArray[np.float64] | None:
        """The rotation of the plane solution that is the ground, when exactly one visible solution has its
        normal within ``_GROUND_NORMAL_DEG`` of the vertical and every other is at least ``_OTHER_NORMAL_DEG``
        from it, or, when the vertical is assumed (not measured) and that finds none, by the ``_ASSUMED_*`` rule;
        else None (a wall or door ahead, a facade beside: their normals are horizontal; but a facade beside a
        walker going down a ramp, seen by a camera tilted up, passed the assumed rule in 6 of 20 synthetic frames,
        5 deg off: review, not fixed).

        A camera tilted down on the chest sees mostly the ground: a plane, so the essential fit is ill-posed and
        was flagged (``planar_ambiguity``) and replaced by the rotation-only fit, whose bias by the walker's
        translation then drifted the pitch (a 20 s walk with the camera 25 deg down: 444 of 600 frames flagged,
        raw pitch error 3.0 deg against 0.05 level). The plane's two solutions differ in their normals: the
        true one is the ground's, the vertical; the other lies near the direction of travel. The vertical in
        the camera: the vertical lines' world vertical when measured (:mod:`walkmon.rotation.vertical`), else the
        first frame's y axis through the current orientation, and when that finds no ground, the camera's own y
        axis for a camera tilted down (``_CAMERA_Y_OTHER_NORMAL_DEG``). The first is wrong by the camera's start
        tilt, and a turn swings that error about the vertical: after a U-turn a camera 45 deg below level had it on
        the optical axis, the ground's normal and the direction of travel equally far from it (45 deg), neither was
        taken, and every frame's rotation-only fallback drifted the walk off (a 25 deg-down camera on a bent walker
        with a U-turn and a 90 deg turn, 320x240 seeds 1-3: 10.8-13.7 deg RMS with the vertical lines' up-tilt
        bound alone, 5.3-5.7 now). The camera's own y axis is fixed on the trunk, which turns about the vertical:
        its error is the camera's tilt on the wearer (mount and stoop) whatever the turns, on the side of the
        image's down for a camera tilted down. It comes second because the trunk's sway moves it by a few degrees
        each step, which the first follows: alone, it changed the fog and night clips' picks (night seed 3 raw
        0.21 -> 0.27 deg). The normals are compared with their signs (each points to its plane,
        :func:`geometry.homography_fit`): the ground's lies on the side of the image's down, the other solution's,
        the direction of travel, about 90 deg from it. Compared without them (as at first),
        both were equally far from a vertical 45 deg off: a camera 25 deg down whose wearer bends forward 20 deg
        had neither taken, every frame flagged and the rotation-only fallback drifting (bench_rotation --mounts:
        61 deg of pitch; 0.6 deg now). Learning the vertical from the recognised ground normals was tried: it
        brought those walks from 40-60 to 12-26 deg of error but accepted noisy ground fits in the night and fog
        clips (met* 2 -> 1 and 1 -> 0 of 5). So was the wider cone whatever the vertical's source (with the lines'
        vertical known it took noisy fits for the ground: wall met 2 -> 0 of 5, rolling shutter raw yaw 2.8 ->
        3.2 deg), and the wide cone alone in place of the narrow one with an assumed vertical (fog seed 4: an ok
        frame 0.84 deg off the previous; with the normals-apart test but without the narrow rule first, fog raw
        pitch 1.08 -> 1.35 deg)."""
        if len(hom.solutions) < 2:
            return None
        measured_world = None if self._vertical is None else self._vertical.world_vertical
        measured = measured_world is not None
        y_axis = np.array([0.0, 1.0, 0.0])  # the first frame's, then the camera's own
        down = (self._R_kf @ pose.rotation).T @ (measured_world if measured_world is not None else y_axis)
        k = _pick_ground(hom, down / float(np.linalg.norm(down)), measured=measured)
        if k is None and not measured:
            k = _pick_ground(hom, y_axis, measured=False, other_min_deg=_CAMERA_Y_OTHER_NORMAL_DEG)
        return None if k is None else hom.solutions[k][0]

    def _hold(self, t_s: float, status: EstimateStatus, reason: str, n_tracks: int = 0, *,
              coast: bool = False) -> RotationEstimate:
        if self._vertical is not None and reason != "repeated_frame":  # the camera may move on while held
            self._vertical.add_doubt(_FLAGGED_DOUBT_DEG, t_s)
        self._unmeasured = True  # no frame after it is carried on until one is measured again
        return make_estimate(t_s, self._orientation, n_inliers=0, model="coast" if coast else "hold", status=status,
                             n_tracks=n_tracks, reason=reason)

    def _expected_step(self, t_s: float) -> NDArray[np.float64] | None:
        """This frame's step if the camera turns on at the last accepted step's rate over this frame's interval,
        for the test of a change of turning rate and the tracks' starting guess; None before any step.

        Scaled to this frame's interval, not the last step itself: a step that spanned dropped frames (4.7 deg over
        4 frames) made every normal step after it a change of rate (held, and judged against it every later frame
        of a turn that had slowed was held to the clip's end: 32 frames; review). Across a gap (this frame's
        interval above _COAST_MAX_S) the last step as it was, as before: extrapolated, a sway at 1 Hz over 0.4 s
        started the tracks so far off that the frame was lost (review). After a held frame the rate from before it
        stands: accepting a turn that stopped as well let fits that read no rotation through in a fast turn (180
        deg/s: 116 deg lost; review)."""
        if self._last_step is None or self._t_prev is None:
            return None
        dt = t_s - self._t_prev
        if self._rate is None or self._last_dt <= 0 or not _no_gap(dt):
            return self._last_step
        return geo.rotation_from_rotvec(self._rate * dt)

    def _coast(self, t_s: float) -> bool:
        """Carry the orientation on to ``t_s`` at the last accepted frame's rate when a frame that cannot be
        measured comes in a steady turn (see _COAST_STEADY); True when it did. Called before the frame's hold.

        A torso does not stop turning from one frame to the next: held, the frame's whole rotation was lost for
        good (a walker's U-turn, 180 deg in 1.2 s: a frame at 274 deg/s with too few inliers, 9.1 deg off held,
        0.3 carried on; in the scenario clips' turns at 640x480, frames at 95 and 81 deg/s 3.16 and 2.70 deg off
        held, 0.48 and 0.54 carried on). Only in a steady turn: carried on at the last step's rate where that step
        was the odd one or the turn was ending, a frame was worse than held (a steep camera's bent walk turning at
        24 deg/s after an odd 2-3 deg step: 2.2 deg off, held 0.8; a frame at 19 deg/s after one at 60: 1.1 deg,
        held 0.6). Only right after an accepted frame, at most _COAST_MAX_S before: after a held or carried frame,
        a gap or a lens cap the last rate is a guess (the next unmeasured frames are held). Still flagged, and like
        a held frame it measures nothing (the gait analysis leaves both out: walkmon.rotation.UNMEASURED_MODELS)."""
        rate, before = self._rate, self._rate_before
        if (self._unmeasured or rate is None or before is None or self._t_prev is None
                or not _no_gap(self._last_dt)):
            return False
        dt = t_s - self._t_prev
        floor = math.radians(_COAST_MIN_RATE_DEG_S)
        slowest = min(float(np.linalg.norm(rate)), float(np.linalg.norm(before)))
        if not _no_gap(dt) or slowest < floor:
            return False
        if float(np.linalg.norm(rate - before)) > _COAST_STEADY * float(np.linalg.norm(rate)):
            return False  # not a steady turn: the last step may itself be the odd one, or the turn ending
        self._orientation = self._orientation @ geo.rotation_from_rotvec(rate * dt)
        return True

    # ----------------------------------------------------------------------------------------------------------
    def push(self, grey: NDArray[np.uint8], t_s: float) -> RotationEstimate:
        """The orientation at ``t_s`` from one grey frame: screen the frame, track, fit, accept or hold."""
        self._t_s = t_s
        small = self._tracking_image(grey)
        held = self._screen(small, t_s)
        if held is not None:
            return held
        if self._prev_small is None:
            return self._start(small, t_s)
        self._frame_rate = self._shutter_rate()
        n = self._track(small)
        if n < self.s.min_inliers:
            # Lost track (cap removed onto a new view, sudden blur): restart from here, holding orientation.
            coast = self._coast(t_s)
            self._restart_held(small, t_s)
            return self._hold(t_s, EstimateStatus.TOO_FEW_FEATURES, "tracking_lost", n, coast=coast)
        fit = self._fit(t_s, n)
        if self._readout_s > 0:
            fit = self._shutter_refit(fit, t_s, n)
        n_inliers = int(np.count_nonzero(fit.inliers))
        orientation = self._R_kf @ fit.rotation
        step = self._orientation.T @ orientation
        step_deg = geo.rotation_angle_deg(step)
        # a change of turning rate beyond _MAX_STEP_CHANGE_DEG in one frame is no torso's: tracks that latched
        # onto a repeated pattern (facade windows) from a wrong start moved coherently (turns seed 4: 11 deg)
        expected = self._expected_step(t_s)
        jerk = expected is not None and geo.rotation_angle_deg(expected.T @ step) > _MAX_STEP_CHANGE_DEG
        if n_inliers < self.s.min_inliers or step_deg > self.s.max_frame_rotation_deg or jerk or fit.hold:
            coast = self._coast(t_s)
            self._restart_held(small, t_s)
            why = ("few_inliers" if n_inliers < self.s.min_inliers else
                   "implausible_step" if step_deg > self.s.max_frame_rotation_deg or jerk else fit.reason)
            return self._hold(t_s, EstimateStatus.LOW_QUALITY, why, n, coast=coast)
        dt = t_s - self._t_prev if self._t_prev is not None else 0.0
        turn = self._turn_state(step_deg, dt, trusted=fit.status is EstimateStatus.OK and not self._ground_step)
        if turn == "fast" and fit.status is EstimateStatus.OK:
            # tracking, motion blur and rolling shutter all degrade in a fast turn: the fit stands, flagged
            fit = dataclasses.replace(fit, status=EstimateStatus.LOW_QUALITY, reason="fast_rotation")
        if fit.status is not EstimateStatus.OK and fit.reason != "planar_ambiguity":
            self._heading = None  # the orientation it is kept in may be off by degrees: learn it afresh
        if turn == "fast" and self._vertical is not None:
            self._vertical.add_doubt(_FLAGGED_DOUBT_DEG, t_s)
        self._tilt_doubt(orientation, t_s)
        new_kf = self._accept(small, orientation, fit, t_s)
        if self._orientation is not orientation and self._tilt_history:
            # a keyframe's refinement or the lines moved this frame's orientation: the window's orientations move
            # with it, or the correction itself would read as a tilt for the next 0.5 s (review)
            world = self._orientation @ orientation.T
            self._tilt_history = deque((t, world @ R) for t, R in self._tilt_history)
        status, reason = fit.status, fit.reason
        if status is EstimateStatus.OK and self._correction_deg > _CORRECTION_FLAG_DEG:
            # The refinement moved this frame's orientation by more than the frame-to-frame accuracy claimed for
            # an ok frame, in one frame: flagged (wall seeds 2, 4: 0.57 and 0.52 deg while standing still, the
            # clips' largest frame-to-frame errors). Taking the correction up over several frames instead was
            # tried (3 deg/s): it reports the uncorrected fit where the correction fixes the frame's own fit
            # (turns seed 1: a frame at 92 deg/s, 0.63 deg off instead of 0.44)
            status, reason = EstimateStatus.LOW_QUALITY, "keyframe_correction"
        if self._ground_step and status is EstimateStatus.OK:
            # estimated as an ok frame (keyframes, refinement), claimed as not: its change from the last frame
            # is not measured to an ok frame's accuracy (see _fit)
            status, reason = EstimateStatus.LOW_QUALITY, "ground_step"
        if turn == "tail" and status is EstimateStatus.OK:
            # the end of a fast turn: reported as not ok, but estimated as an ok frame (same keyframe logic), so
            # the flag changes what is claimed, never the orientation
            status, reason = EstimateStatus.LOW_QUALITY, "fast_rotation"
        return make_estimate(
            t_s, self._orientation, n_inliers=n_inliers, model=fit.model, status=status, n_tracks=n,
            residual_px=float(np.median(fit.residuals_px)), keyframe=new_kf, reason=reason,
        )

    # -- the steps of push -------------------------------------------------------------------------------------
    def _tracking_image(self, grey: NDArray[np.uint8]) -> NDArray[np.uint8]:
        """The grey frame at tracking resolution, smoothed where the noise dominates it (see _NOISY_ON)."""
        small: NDArray[np.uint8] = grey
        if self._track_size != (grey.shape[1], grey.shape[0]):
            small = cv2.resize(grey, self._track_size, interpolation=cv2.INTER_AREA)
        sd = float(cv2.meanStdDev(small)[1][0, 0])
        if sd >= _UNIFORM_STD:  # a featureless frame is held as it is (see _screen)
            ratio = _noise_sd(small) / sd
            self._noisy = ratio > (_NOISY_OFF if self._noisy else _NOISY_ON)
        if self._noisy:
            smooth: NDArray[np.uint8] = cv2.GaussianBlur(small, (0, 0), self._denoise_sigma)
            return smooth
        return small

    def _screen(self, small: NDArray[np.uint8], t_s: float) -> RotationEstimate | None:
        """A held estimate for a featureless or repeated frame; None for a frame worth tracking."""
        if float(cv2.meanStdDev(small)[1][0, 0]) < _UNIFORM_STD:
            # Lens cap / black frame: hold, and keep the last good frame as the one to track from.
            self.started = True
            return self._hold(t_s, EstimateStatus.TOO_FEW_FEATURES, "featureless")
        if self._prev_small is not None and np.array_equal(small, self._prev_small):
            return self._hold(t_s, EstimateStatus.REPEATED_FRAME, "repeated_frame", self._pts.shape[0])
        return None

    def _start(self, small: NDArray[np.uint8], t_s: float) -> RotationEstimate:
        """The first frame (or the first after featureless ones): a keyframe, orientation unchanged."""
        first = not self.started
        self.started = True
        self._restart(small)
        if self._pts.shape[0] < self.s.min_inliers:
            return self._hold(t_s, EstimateStatus.TOO_FEW_FEATURES, "few_features", self._pts.shape[0])
        self._prev_small = small
        status = EstimateStatus.FIRST_FRAME if first else EstimateStatus.OK
        return make_estimate(
            t_s, self._orientation, n_inliers=self._pts.shape[0], model="identity" if first else "hold",
            status=status, n_tracks=self._pts.shape[0], keyframe=True,
        )

    def _restart(self, small: NDArray[np.uint8]) -> None:
        """Drop every track and start a new keyframe on ``small``."""
        self._lose_tracks()
        self._new_keyframe(small)

    def _restart_held(self, small: NDArray[np.uint8], t_s: float) -> None:
        """Restart the tracks on a frame whose orientation is held (tracking lost, few inliers, implausible step, a
        ground frame in doubt).

        The next frame is fitted against this one, so its change spans one frame and its rate (which decides
        fast_rotation, and the rolling-shutter correction's) is measured from this frame's time. From the last
        accepted frame's time it read half the rate: a 93 deg/s turn passed as ok just after a held frame, 0.9
        deg off in that frame (turns seed 4).

        The frames after it are judged as a fast turn's tail (:meth:`_turn_state`): the turning rate is unknown
        until an ok fit has measured it, and a rolling-shutter frame right after a hold is corrected with the rate
        from before it (rolling_shutter seed 3: a frame at 71 deg/s after a held one was reported ok 0.64 deg off
        in one frame). At walking rates (below half ``max_ok_rate_deg_s``) the next ok frame ends it. Frames held by
        :meth:`_screen` (featureless, repeated) keep their tracks and do not start a tail.

        A rolling shutter's new keyframe corners are moved to the frame's time at the last accepted frame's rate
        (:meth:`_shutter_rate`), not at the rejected fit's, which _shutter_refit had left set: at 70 deg/s with a
        30 ms readout a keyframe built at the rejected fit's 308 deg/s left the rest of the clip 2.0 deg off
        (0.96 as without the fault; review)."""
        self._frame_rate = self._shutter_rate()
        self._restart(small)
        if self._t_prev is not None:
            self._t_prev = t_s
        self._in_turn = True

    def _track(self, small: NDArray[np.uint8]) -> int:
        """KLT-track the previous frame's points into ``small``, keep those tracked inside the image; their count."""
        s = self.s
        if self._pts.shape[0]:
            guess, flags = self._predicted_positions(), 0
            if guess is not None:
                flags = cv2.OPTFLOW_USE_INITIAL_FLOW
            # OpenCV's Python binding cannot take prebuilt pyramids (opencv#4777), so LK builds both each frame.
            nxt, st, _err = cv2.calcOpticalFlowPyrLK(
                self._prev_small, small, self._pts, guess, winSize=(s.klt_window_px, s.klt_window_px),
                maxLevel=s.klt_levels, criteria=self._criteria, flags=flags,
            )
            ok = st.ravel().astype(bool)
            if _veiled(small):
                nxt, ok = self._refine_in_haze(small, nxt, ok)
            w, h = self._track_size
            p = nxt.reshape(-1, 2)
            ok &= (p[:, 0] >= 0) & (p[:, 1] >= 0) & (p[:, 0] <= w - 1) & (p[:, 1] <= h - 1)
            self._pts = nxt
            self._keep(ok)
        self._prev_small = small
        return int(self._pts.shape[0])

    def _highpass(self, img: NDArray[np.uint8]) -> NDArray[np.uint8]:
        """``img`` less its local mean (box ``_hp_box``), times _HIGHPASS_GAIN, about mid-grey."""
        out: NDArray[np.uint8] = cv2.addWeighted(img, _HIGHPASS_GAIN, cv2.blur(img, (self._hp_box, self._hp_box)),
                                                 -_HIGHPASS_GAIN, 128.0)
        return out

    def _refine_in_haze(
        self, small: NDArray[np.uint8], nxt: NDArray[np.float32], ok: NDArray[np.bool_],
    ) -> tuple[NDArray[np.float32], NDArray[np.bool_]]:
        """The tracks ``nxt`` refined at full tracking resolution on both frames less their local means (see
        _VEIL_RATIO); a track the refinement loses is lost."""
        assert self._prev_small is not None
        cache = self._hp_cache
        prev_hp = cache[1] if cache is not None and cache[0] is self._prev_small else self._highpass(self._prev_small)
        cur_hp = self._highpass(small)
        s = self.s
        ref, st, _err = cv2.calcOpticalFlowPyrLK(
            prev_hp, cur_hp, self._pts, nxt.copy(), winSize=(s.klt_window_px, s.klt_window_px), maxLevel=0,
            criteria=self._criteria, flags=cv2.OPTFLOW_USE_INITIAL_FLOW,
        )
        self._hp_cache = (small, cur_hp)
        return ref, ok & st.ravel().astype(bool)

    def _predicted_positions(self) -> NDArray[np.float32] | None:
        """Where the tracks land if the camera keeps turning at the last accepted step's rate over this frame's
        interval (:meth:`_expected_step`; tracking pixels), as the starting guess of Lucas-Kanade; None below
        _PREDICT_MIN_STEP_DEG (the common path: no change).

        In a turn at 180 deg/s a corner moves ~24 tracking pixels a frame, more than a 9 px window over two
        pyramid levels recovers from a zero guess: tracks went wrong, inliers fell to none and the orientation
        was held while the camera turned on (turns seed 1: 6 deg a frame for 12 frames)."""
        step = self._expected_step(self._t_s)
        if step is None or geo.rotation_angle_deg(step) < _PREDICT_MIN_STEP_DEG or self._q_prev.shape[0] == 0:
            return None
        if self._q_prev.shape[0] != self._pts.shape[0]:
            return None
        q = self._q_prev @ step  # q_next ~ step.T q (each row), the last frame's change once more
        if np.any(q[:, 2] <= 1e-6):
            return None
        px = self.camera.pixels_from_camera_points(q)
        if self._frame_rate is not None:  # where the rolling shutter shows them: each on its row's time
            dt = shutter.row_offsets_s(px[:, 1], self.camera.height_px, self._readout_s)
            px = self.camera.pixels_from_camera_points(shutter.from_frame_time(q / q[:, 2:3], dt, self._frame_rate))
        guess = np.empty((px.shape[0], 1, 2), np.float32)
        guess[:, 0, 0] = (px[:, 0] + 0.5) / self._sx - 0.5
        guess[:, 0, 1] = (px[:, 1] + 0.5) / self._sy - 0.5
        return guess

    def _tilt_doubt(self, orientation: NDArray[np.float64], t_s: float) -> None:
        """Doubt for the vertical lines' filter while the camera tilts fast (see _FAST_TILT_DEG): the tilt is the
        turn of the world's down direction seen from the camera, so a turn about the vertical adds none, whatever
        the camera's tilt on the chest. Nothing before the lines have measured the vertical (the filter would
        ignore the doubt; the camera's y axis standing in for it would read a tilted camera's turns as tilt)."""
        if self._vertical is None:
            return
        down = self._vertical.world_vertical
        history = self._tilt_history
        if down is None:
            history.clear()
            return
        if history and t_s < history[-1][0]:  # time went back (a caller's clock): the window starts afresh
            history.clear()
        history.append((t_s, orientation))
        while t_s - history[0][0] > _FAST_TILT_WINDOW_S + 1e-3:  # a frame 0.5 s back stays, float error or not
            history.popleft()
        seen = orientation.T @ down
        if angle_between_deg(history[0][1].T @ down, seen) > _FAST_TILT_DEG:
            tilt = angle_between_deg(self._orientation.T @ down, seen)
            if tilt > 0.0:
                self._vertical.add_doubt(_FAST_TILT_DOUBT * tilt, t_s)

    def _turn_state(self, step_deg: float, dt: float, *, trusted: bool = True) -> str:
        """``"fast"`` above ``max_ok_rate_deg_s``; ``"tail"`` after a fast frame until the rate falls below
        _TURN_EXIT_FRACTION of it (a Schmitt trigger), as measured by a fit that is not itself in doubt
        (``trusted``); else ``""``.

        A turn's last frames, at 50-100 deg/s, were read 20-25 deg/s off (0.6-0.9 deg in one frame) and, just under
        the threshold, reported ok (turns seeds 2 and 4, rolling_shutter seeds 2-5): the rate that decides the
        flag is itself measured by the fit in doubt, so a frame near the threshold cannot be trusted to be below
        it. The flag is raised at the threshold and lowered only once the rate has halved, and only by a frame
        whose own fit is ok (not a ground_step one either: its fit jumped from the chained change by more than
        _STEP_JUMP_DEG): a planar_ambiguity frame at a turn's end read 42 deg/s where the camera turned at 81,
        ended the tail, and the next two frames, at 73 and 61 deg/s, were reported ok 0.8 deg off in one frame
        (rolling_shutter seed 1). While the tail lasts the vertical lines are not looked at between keyframes
        (:meth:`_accept`), so the flag can move a later correction, not only what a frame claims."""
        if dt <= 0:  # no rate (the first frame after a hold before any accepted one): as the state stands
            return "tail" if self._in_turn else ""
        rate = step_deg / dt
        limit = self.s.max_ok_rate_deg_s
        if rate > limit:
            self._in_turn = True
            return "fast"
        if trusted:
            self._in_turn = self._in_turn and rate > _TURN_EXIT_FRACTION * limit
        return "tail" if self._in_turn else ""

    def _shutter_rate(self) -> NDArray[np.float64] | None:
        """The angular rate to move this frame's tracks to its time with: the last accepted step's (the turn goes
        on as it went), or None for a global shutter or while the skew stays below _SHUTTER_MIN_SKEW_PX (the
        common path: no change)."""
        if self._readout_s <= 0 or self._rate is None:
            return None
        if shutter.skew_px(self._rate, self._readout_s, self._focal) < _SHUTTER_MIN_SKEW_PX:
            return None
        return self._rate

    def _shutter_refit(self, fit: _Fit, t_s: float, n: int) -> _Fit:
        """A rolling-shutter camera's fit again, its tracks moved to the frame's time with the rate the fit itself
        measured (previous frame -> this one), when that rate differs from the one used by more skew than the
        tracking noise (``feature_noise_px``; at most _SHUTTER_ITERATIONS times). The last frame's rate alone lagged the
        start and the end of a turn by a frame and fed its error back: a frame misread by 50 deg/s skewed the
        next one's tracks by 1.2 px and the estimate rang for several frames (rolling_shutter seed 5)."""
        dt = t_s - self._t_prev if self._t_prev is not None else 0.0
        if dt <= 0:
            return fit
        used = self._frame_rate if self._frame_rate is not None else np.zeros(3)
        for _ in range(_SHUTTER_ITERATIONS):
            rate = shutter.rate_from_step(self._orientation.T @ self._R_kf @ fit.rotation, dt)
            if shutter.skew_px(rate - used, self._readout_s, self._focal) < self.s.feature_noise_px:
                break
            self._frame_rate = used = rate
            fit = self._fit(t_s, n)
        return fit

    def _fit(self, t_s: float, n: int) -> _Fit:
        """The rotation relative to the keyframe: rotation-only, or essential when GRIC prefers it and it agrees."""
        s = self.s
        q_cur = self._normalized(self._pts)
        q_kf = self._kf_q
        sigma = s.feature_noise_px
        rot = geo.rotation_only_fit(
            q_kf, q_cur, self._focal, rotation_init=self._R_rel, scale_px=sigma * 2, inlier_px=s.inlier_px,
            iterations=3,
        )
        # the previous frame's estimate moved on by the rotation-only change between the two frames: every fit
        # is checked against it (a jump from it is a fit that changed minimum, not a rotation the tracks saw)
        frame_step = self._frame_step(q_cur, rot.inliers)
        chain = self._R_rel @ frame_step
        # a ground frame in doubt is held only when that loses little (_HOLD_MAX_STEP_DEG)
        hold_ok = geo.rotation_angle_deg(frame_step) <= _HOLD_MAX_STEP_DEG
        fit = _Fit("rotation", rot.rotation, rot.residuals_px, rot.inliers, EstimateStatus.OK)
        self._centre = None
        start = ""
        on_ground_fit = False
        # the rotation-only fit's median residual as an angle: the parallax since the keyframe (for _accept)
        self._parallax_deg = math.degrees(float(np.median(rot.residuals_px)) / self._focal)
        if float(np.median(rot.residuals_px)) > 0.5 * sigma and n >= max(8, s.min_inliers):
            pose, start = self._essential_fit(q_kf, q_cur, rot.rotation)
            mask = pose.inliers | rot.inliers
            g_rot = geo.gric(rot.residuals_px[mask], sigma, 2, 3)
            g_ess = geo.gric(pose.residuals_px[mask], sigma, 3, 5)
            planar, on_ground = self._plane_ambiguous(q_kf, q_cur, pose, mask) if g_ess < g_rot else (False, None)
            on_ground_fit = on_ground is not None
            if planar:
                ground = None if on_ground is None else self._ground_refit(q_kf, q_cur, on_ground)
                if ground is not None:  # the ground's plane solution, refined by the essential model: it stands
                    fit = _Fit("essential", ground.rotation, np.abs(ground.residuals_px), ground.inliers,
                               EstimateStatus.OK)
                else:
                    # The ground is recognised (its plane solution: on_ground) but neither the essential fit nor
                    # its refinement from the ground lands on it: held (push) where the ground was recognised,
                    # not replaced by the rotation-only fit. Over the near ground seen steeply that fit carries
                    # the walker's translation since the keyframe, 2-4 deg of pitch at a camera 45 deg below
                    # level, and the keyframe a flagged frame starts kept it for good; a held frame loses only
                    # its own frame's rotation. bench_rotation --mounts, camera 25 deg down, bend walks, raw
                    # pitch RMS: 640x480 seeds 2, 4, 5: 3.4 -> 1.0, 2.2 -> 1.0, 7.6 -> 2.8 deg; 320x240 seed 2:
                    # 2.6 -> 0.6 deg (its largest frame-to-frame error 3.5 -> 1.0 deg). Tried first: the ground's
                    # own plane solution in place of the rotation-only fit, when it agreed better with the
                    # frame-to-frame tracking: better on three of those walks, worse on three 8 s ones.
                    fit = _Fit("rotation", rot.rotation, rot.residuals_px, mask, EstimateStatus.LOW_QUALITY,
                               reason="planar_ambiguity", hold=on_ground is not None and hold_ok)
            elif g_ess < g_rot:
                if start == "ambiguous":  # looking sideways to the heading, both starts fit and disagree
                    fit = _Fit("rotation", rot.rotation, rot.residuals_px, mask, EstimateStatus.LOW_QUALITY,
                               reason="translation_ambiguity")
                elif start != "sideways" and not on_ground_fit and self._models_disagree(rot, pose):
                    # The essential fit wandered further from the rotation-only fit than the parallax explains:
                    # use the rotation-only fit (biased by at most about the parallax, not by degrees) and say
                    # so; keep the tracks either model accepts, since parallax pushes good tracks out of
                    # the rotation-only inlier set. (When the second start won, travelling sideways to the view,
                    # the rotation-only fit took the translation for a rotation: its distance from the essential
                    # rotation is then no sign of a wandering fit. Nor when the ground's plane solution, a
                    # model of its own, agrees with the essential fit: over the near ground seen steeply the
                    # rotation-only fit is the one the walker's translation pulls, by more than its median
                    # residual says. Flagged there, it started keyframes 2-4 deg off in pitch, which then stayed:
                    # bench_rotation --mounts, camera 25 deg down, bend walks: worst raw pitch 42.7 -> 7.6 deg.)
                    fit = _Fit("rotation", rot.rotation, rot.residuals_px, mask, EstimateStatus.LOW_QUALITY,
                               reason="models_disagree")
                    _log.debug("t=%.3f: essential and rotation-only fits disagree; rotation-only used", t_s)
                else:
                    fit = _Fit("heading" if start == "heading" else "essential", pose.rotation,
                               np.abs(pose.residuals_px), pose.inliers, EstimateStatus.OK)
            elif start == "sideways" and self._models_disagree(rot, pose):
                # GRIC keeps the rotation-only model (one frame after a keyframe the parallax is too small for
                # it), but the second start won clearly: the camera looks across the walker's heading, where
                # the translation past near tracks reads as a rotation (a facade 1-3 m away: 2 cm a frame are
                # 0.4-1 deg) and the rotation-only fit is the biased one. The essential fit from the second
                # start is used, as it is in the frames before and after (turns seed 2, rolling_shutter seed 2:
                # the rotation-only fit was read 0.6 deg off in one frame, reported ok, and 0.6 back the next).
                # A facade is a plane, so the plane check of the branch above applies here too: where a
                # homography explains the tracks as well, neither fit is trusted (the rotation-only one, flagged;
                # held where the plane is the ground, as in the branch above)
                side_planar, side_ground = self._plane_ambiguous(q_kf, q_cur, pose, mask)
                if side_planar:
                    fit = _Fit("rotation", rot.rotation, rot.residuals_px, mask, EstimateStatus.LOW_QUALITY,
                               reason="planar_ambiguity", hold=side_ground is not None and hold_ok)
                else:
                    fit = _Fit("essential", pose.rotation, np.abs(pose.residuals_px), pose.inliers,
                               EstimateStatus.OK)
        # (not when the second start won: travelling sideways to the view, the rotation-only change between the
        # frames is the biased one, by the translation's 0.5-1 deg a frame past a facade)
        self._ground_step = False
        if (fit.status is EstimateStatus.OK and start != "sideways"
                and geo.rotation_angle_deg(chain.T @ fit.rotation) > _STEP_JUMP_DEG):
            if on_ground_fit:
                # the fit is the ground's plane solution (the one whose normal is the vertical), which the chain
                # cannot judge: over the near ground seen steeply (a camera 40-45 deg below level) one frame's
                # walk moves the tracks like a rotation of about a degree, and the chained change is the biased
                # one. The fit stands, the frame flagged ("ground_step", in push): a keyframe started on the
                # rotation-only fit, as for the other flags, took its bias up for good, about a degree per
                # flagged frame (unkind bend seed 3, camera 24 deg down: 15 deg of pitch in one second)
                self._ground_step = True
            else:
                # the fit jumps away from where the frame-to-frame tracking puts it: a fit that changed minimum
                # (the essential refinement's other basin), not a rotation the tracks saw. The rotation-only fit
                # against the keyframe is used, as for the other flags: the chained change itself, used at first,
                # fed its errors back in a fast turn (the next frame's fit starts from it; inliers fell to 12 of
                # 130 and turns seed 2 ended 57 deg off)
                fit = _Fit("rotation", rot.rotation, rot.residuals_px, rot.inliers, EstimateStatus.LOW_QUALITY,
                           reason="step_inconsistent")
        self._q_cur = q_cur
        return fit

    def _update_heading(self, centre: NDArray[np.float64], t_s: float) -> None:
        """Low-pass the walker's heading (first frame's axes) towards an accepted free essential fit's baseline."""
        if self._heading is None or self._t_prev is None:
            self._heading = centre / float(np.linalg.norm(centre))
            return
        if float(centre @ self._heading) < 0:
            centre = -centre  # a baseline's sign is not observed
        gain = 1.0 - math.exp(-max(t_s - self._t_prev, 0.0) / _HEADING_TAU_S)
        heading = self._heading + gain * (centre - self._heading)
        self._heading = heading / max(float(np.linalg.norm(heading)), 1e-12)

    def _frame_step(self, q_cur: NDArray[np.float64], inliers: NDArray[np.bool_]) -> NDArray[np.float64]:
        """The rotation from the previous frame to this one by the rotation-only model on the same tracks (one
        Kabsch solve over the rotation-only fit's inliers, which already left out the movers): biased by one
        frame's parallax only, where the fits against the keyframe carry the parallax since the keyframe and
        change with the subset of tracks that survive (during a fast turn that change alone made 2-3 deg steps).
        About 40 us for 150 tracks (two Cauchy-reweighted solves cost 5x that, 4 % of a frame)."""
        use = inliers if np.count_nonzero(inliers) >= self.s.min_inliers else np.ones(inliers.shape, bool)
        a, b = self._q_prev[use], q_cur[use]
        a = a / np.sqrt(np.einsum("ij,ij->i", a, a))[:, None]
        b = b / np.sqrt(np.einsum("ij,ij->i", b, b))[:, None]
        U, _, Vt = np.linalg.svd(a.T @ b)
        if np.linalg.det(U @ Vt) < 0:
            U[:, 2] = -U[:, 2]
        return U @ Vt

    def _accept(self, small: NDArray[np.uint8], orientation: NDArray[np.float64], fit: _Fit, t_s: float) -> bool:
        """Take the frame's orientation, keep the inlier tracks, start a new keyframe when due (returned)."""
        s = self.s
        self._last_step = self._orientation.T @ orientation
        dt = t_s - self._t_prev if self._t_prev is not None else 0.0
        # the rates a frame may be carried on at (_coast): none measured over a gap or across an unmeasured frame
        usable = self._rate is not None and not self._unmeasured and _no_gap(self._last_dt)
        self._rate_before = self._rate if usable else None
        self._rate = shutter.rate_from_step(self._last_step, dt)
        self._last_dt = dt
        self._unmeasured = False
        self._orientation = orientation
        self._R_rel = fit.rotation
        self._q_prev = self._q_cur
        # the walker's heading: the camera's optical axis low-passed over _HEADING_TAU_S (a walker looks ahead
        # on average; a torso turned towards a facade for a second leaves it behind)
        fwd = orientation[:, 2]
        if self._travel is None or self._t_prev is None:
            self._travel = fwd.copy()
        else:
            gain = 1.0 - math.exp(-max(t_s - self._t_prev, 0.0) / _HEADING_TAU_S)
            heading = self._travel + gain * (fwd - self._travel)
            self._travel = heading / max(float(np.linalg.norm(heading)), 1e-12)
        # (not from a ground_step frame: its free essential baseline is the one that strayed)
        if (self._centre is not None and fit.status is EstimateStatus.OK and fit.model == "essential"
                and not self._ground_step):
            self._update_heading(self._R_kf @ self._centre, t_s)
        self._t_prev = t_s
        self._rejected = self._pts[~fit.inliers].reshape(-1, 2)  # where the image disagrees with the camera's motion
        self._keep(fit.inliers)
        self._frames_since_kf += 1
        rel_deg = geo.rotation_angle_deg(fit.rotation)
        new_kf = (
            self._pts.shape[0] < s.keyframe_min_track_fraction * self._kf_tracks
            or self._frames_since_kf >= s.keyframe_max_frames
            or rel_deg > s.keyframe_max_rotation_deg
            or self._parallax_deg > s.keyframe_max_parallax_deg
            or fit.status is EstimateStatus.LOW_QUALITY
        )
        self._correction_deg = 0.0
        if new_kf:
            self._new_keyframe(small)  # may refine self._orientation over the keyframe window
        elif (self._vertical is not None and fit.status is EstimateStatus.OK and not self._in_turn
              and self._vertical.due(t_s)):
            self._correct_now(small)
        return bool(new_kf)

    def _correct_now(self, small: NDArray[np.uint8]) -> None:
        """The vertical lines' correction between keyframes, once a turn's doubt is left (VerticalReference.due):
        in steady walking a keyframe can hold for a second, and the drift the turn left would stay in the walk
        until then. The keyframe's orientation moves with it, so the frames after it keep the correction; the
        keyframes are not rescheduled (a keyframe forced at another frame changed the odometry's course after
        it: turns seed 1, yaw 0.6 -> 4.8 deg)."""
        assert self._vertical is not None  # the caller checked
        corrected = self._vertical.correct(small, self._orientation, self._t_s, self._normalized, self._sx,
                                           doubt_only=True)
        if corrected is self._orientation:  # the lines gave no clear view: nothing changed
            return
        self._correction_deg = geo.rotation_angle_deg(self._orientation.T @ corrected)
        world = corrected @ self._orientation.T  # the correction as a turn of the start frame
        self._orientation = corrected
        self._R_kf = corrected @ self._R_rel.T
        # every keyframe of the window carries the drift just taken out: move them all, or the next keyframe's
        # refinement would pull it back part of the way
        self._window = deque(((world @ R_j, ids, q) for R_j, ids, q in self._window), maxlen=self._window.maxlen)


@dataclass(frozen=True, slots=True)
class _Fit:
    """One frame's model choice: ``rotation`` relative to the keyframe, per-track residuals and inliers."""

    model: str
    rotation: NDArray[np.float64]
    residuals_px: NDArray[np.float64]
    inliers: NDArray[np.bool_]
    status: EstimateStatus
    #: why the frame is flagged (RotationEstimate.reason), empty when ok
    reason: str = ""
    #: no fit to trust: the frame is held and tracking restarts from it (push)
    hold: bool = False


def _noise_sd(img: NDArray[np.uint8]) -> float:
    """The image noise's standard deviation in grey levels (Immerkaer 1996: the mean absolute response to a mask
    that cancels smooth structure, times sqrt(pi / 2) / 6)."""
    r = cv2.filter2D(img, cv2.CV_16S, _NOISE_MASK)[1:-1, 1:-1]
    return float(math.sqrt(math.pi / 2.0) * float(cv2.mean(np.abs(r))[0]) / 6.0)


def _veiled(small: NDArray[np.uint8]) -> bool:
    """True for a hazy frame: its darkest 1 % of pixels at least _VEIL_RATIO of its brightest 1 %."""
    hist = cv2.calcHist([small], [0], None, [256], [0, 256]).ravel()
    c = np.cumsum(hist)
    n = c[-1]
    lo = int(np.searchsorted(c, 0.01 * n))
    hi = int(np.searchsorted(c, 0.99 * n))
    return hi > 0 and lo >= _VEIL_RATIO * hi


def _robust_cost(residuals_px: NDArray[np.float64], scale_px: float) -> float:
    """The Cauchy cost the refinements minimise: ``sum log(1 + (r/s)^2)``."""
    return float(np.sum(np.log1p((residuals_px / scale_px) ** 2)))
