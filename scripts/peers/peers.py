#!/usr/bin/env python3
"""Runs one peer relative-pose estimator (OpenCV or PoseLib, from PyPI) on a momo sequence.

Usage:
    peers.py SEQ --method METHOD --output POSES.txt [--stats STATS.json]
             [--threshold-px 1.0] [--max-angle-deg 80]

SEQ is a sequence directory as ../../../shared/FORMAT.md defines it (rig.json, matches.csv,
optional odometry.csv). The output is camera 0's trajectory in the KITTI format, exactly as
`momo run` writes it (one line per frame, the first one the identity), so `momo eval` scores it.
STATS (default: POSES with the extension .json) gets the settings, the frame counts (estimated,
degenerate) and the mean time per frame, measured around the peer call only.

Methods (one per invocation):

- ``opencv-ransac``: ``cv2.findEssentialMat(method=cv2.RANSAC, prob=0.999, threshold)`` then
  ``cv2.recoverPose`` (cheirality) on the RANSAC inliers. Camera 0 only.
- ``opencv-magsac``: the same with ``method=cv2.USAC_MAGSAC`` (OpenCV's USAC framework, MAGSAC++
  scoring; ``threshold`` is its maximum sigma). Camera 0 only.
- ``poselib``: ``poselib.estimate_relative_pose`` (LO-RANSAC around the 5-point solver, then a
  non-linear refinement of the Sampson error with a Cauchy loss on the inliers), library
  defaults except ``max_epipolar_error``. Camera 0 only.
- ``poselib-generalized``: ``poselib.estimate_generalized_relative_pose`` (LO-RANSAC around the
  generalized 6-point solver, then refinement) over all cameras of the rig with their
  extrinsics: it estimates the vehicle motion directly. Library defaults except
  ``max_epipolar_error``.

Settings, chosen the way a careful user would and the same for every sequence:

- Threshold: ``--threshold-px`` (default 1.0 px, the documented default of both OpenCV's
  ``findEssentialMat`` and PoseLib's ``max_epipolar_error``), in pixels of the camera. Every
  match is unprojected by *our* camera models (a port of crates/momo-core/src/camera.rs, so
  pinhole and Kannala-Brandt bearings are bit-for-bit the ones momo uses), then handed to the
  peer as the pixels of an ideal pinhole camera with the camera's focal length
  ``f = (fx + fy) / 2`` (``momo_core::Camera::focal_length``) and the principal point at 0:
  ``(f x/z, f y/z)``, with ``K = diag(f, f, 1)``. For a pinhole camera with ``fx == fy`` these are
  the original pixels shifted by the principal point, so the threshold means what the libraries
  document (OpenCV divides it by the focal length of K, PoseLib by ``camera.focal()``); for
  a fisheye it is the pixel threshold at the image centre. Both libraries take 2D normalised
  image points, which cannot represent rays at or beyond 90 degrees from the optical axis
  (PoseLib 2.0.5's own OPENCV_FISHEYE unprojection returns 2D points too), so bearings more
  than ``--max-angle-deg`` (default 80) off the optical axis are dropped (counted in the
  stats). Only the fisheye rig has such bearings.
- OpenCV: ``prob=0.999`` and the default ``maxIters`` (1000); ``cv2.setNumThreads(1)`` and
  ``cv2.setRNGSeed(0)`` so that the run is single-threaded (as momo's estimator) and
  deterministic. If ``findEssentialMat`` returns several stacked solutions (exactly 5 matches),
  the first one is used.
- PoseLib: ``RansacOptions`` defaults (success_prob 0.9999, 1000 to 100000 iterations, seed 0)
  with ``max_epipolar_error = threshold``; ``BundleOptions`` defaults (Cauchy loss; the Python
  binding sets its scale to half the threshold).

Scale, exactly as momo's five-point baseline (crates/momo-vo/src/baseline.rs,
crates/momo-fivepoint/src/vehicle.rs): the arc length ``l`` of frame pair k is odometry.csv's
value, or the last one (1.0 before any) when absent. A single-camera peer gives camera 0's motion
``C = [R | t]`` with unit ``t``; the vehicle motion is ``M = P C_s P^-1`` (``P`` camera 0's
``T_vehicle_camera``) with the camera translation scaled so that the vehicle's chord ``|t_M|``
equals ``l sin(theta/2) / (theta/2)``, ``theta`` the rotation angle of ``M`` (the larger root of
``s^2 + 2 (a.b) s + |b|^2 - chord^2 = 0``, the closest ``s >= 0`` if there is none; ``l = 0``:
rotation only). The generalized peer estimates ``M`` itself (its translation is metric up to
the noise); its translation is rescaled to the same chord, so that every method moves the
vehicle the odometry arc length.

Degenerate frames, as the baseline: fewer usable matches than the minimal sample (5; 6 for the
generalized solver) -> ``no_matches``; no model, a non-finite one, or fewer inliers than the
minimal sample -> ``failure``; both hold the previous motion with its translation rescaled to
this frame's arc length. Both are counted in the stats.
"""

from __future__ import annotations

import argparse
import csv
import json
import math
import sys
import time

# CPU seconds of this thread spent in the peers' library calls (time.thread_time), summed.
PEER_CPU_SECONDS = [0.0]
from pathlib import Path

import numpy as np

METHODS = ("opencv-ransac", "opencv-magsac", "poselib", "poselib-generalized")


# --- sequence reading (FORMAT.md) ------------------------------------------------------------


class CameraModel:
    """A camera of rig.json (pinhole, kannala_brandt, radtan, double_sphere, unified), unprojected
    as crates/momo-core/src/camera.rs does."""

    def __init__(self, model: dict):
        self.type = model["type"]
        if self.type not in ("pinhole", "kannala_brandt", "radtan", "double_sphere", "unified"):
            raise ValueError(f"unknown camera model type {self.type!r}")
        if self.type == "radtan":
            self.radtan = [float(model.get(n, 0.0)) for n in ("k1", "k2", "p1", "p2", "k3")]
        self.xi = float(model.get("xi", 0.0))
        self.alpha = float(model.get("alpha", 0.0))
        self.fx = float(model["fx"])
        self.fy = float(model["fy"])
        self.cx = float(model["cx"])
        self.cy = float(model["cy"])
        self.k = [float(model.get(f"k{i}", 0.0)) for i in range(1, 5)]
        self.width = float(model["width"])
        self.height = float(model["height"])

    @property
    def focal(self) -> float:
        """A typical focal length, pixels: `Camera::focal_length`."""
        return 0.5 * (self.fx + self.fy)

    def _distort(self, theta: np.ndarray):
        k1, k2, k3, k4 = self.k
        t2 = theta * theta
        poly = 1.0 + t2 * (k1 + t2 * (k2 + t2 * (k3 + t2 * k4)))
        dpoly = 1.0 + t2 * (3.0 * k1 + t2 * (5.0 * k2 + t2 * (7.0 * k3 + t2 * 9.0 * k4)))
        return theta * poly, dpoly

    def _unproject_radtan(self, u: np.ndarray, v: np.ndarray):
        """Newton on distort(m) = target, started at the target (as `Radtan::unproject`, without
        its step halving); valid where the pixel residual ends below 1e-6 px."""
        k1, k2, p1, p2, k3 = self.radtan
        tx = (u - self.cx) / self.fx
        ty = (v - self.cy) / self.fy
        x, y = tx.copy(), ty.copy()
        for _ in range(50):
            r2 = x * x + y * y
            radial = 1.0 + r2 * (k1 + r2 * (k2 + r2 * k3))
            dradial = k1 + r2 * (2.0 * k2 + r2 * 3.0 * k3)
            ex = x * radial + 2.0 * p1 * x * y + p2 * (r2 + 2.0 * x * x) - tx
            ey = y * radial + p1 * (r2 + 2.0 * y * y) + 2.0 * p2 * x * y - ty
            a = radial + 2.0 * x * x * dradial + 2.0 * p1 * y + 6.0 * p2 * x
            b = 2.0 * x * y * dradial + 2.0 * p1 * x + 2.0 * p2 * y
            d = radial + 2.0 * y * y * dradial + 6.0 * p1 * y + 2.0 * p2 * x
            det = a * d - b * b
            with np.errstate(divide="ignore", invalid="ignore"):
                x = x - (d * ex - b * ey) / det
                y = y - (a * ey - b * ex) / det
        r2 = x * x + y * y
        radial = 1.0 + r2 * (k1 + r2 * (k2 + r2 * k3))
        ex = x * radial + 2.0 * p1 * x * y + p2 * (r2 + 2.0 * x * x) - tx
        ey = y * radial + p1 * (r2 + 2.0 * y * y) + 2.0 * p2 * x * y - ty
        ok = np.isfinite(x) & np.isfinite(y) & (np.hypot(ex * self.fx, ey * self.fy) < 1e-6)
        b = np.stack([np.where(ok, x, 0.0), np.where(ok, y, 0.0), np.ones_like(u)], 1)
        return b / np.linalg.norm(b, axis=1)[:, None], ok

    def unproject(self, u: np.ndarray, v: np.ndarray):
        """Unit bearings (n x 3) and a validity mask, as `CameraModel::unproject`."""
        if self.type == "radtan":
            return self._unproject_radtan(u, v)
        if self.type in ("double_sphere", "unified"):
            # Closed forms of `DoubleSphere::unproject` / `Unified::unproject` (without their
            # exact valid-region test at the border; the peers drop wide bearings anyway).
            mx = (u - self.cx) / self.fx
            my = (v - self.cy) / self.fy
            r2 = mx * mx + my * my
            xi = self.xi
            with np.errstate(invalid="ignore", divide="ignore"):
                if self.type == "double_sphere":
                    a = self.alpha
                    under = 1.0 - (2.0 * a - 1.0) * r2
                    mz = (1.0 - a * a * r2) / (a * np.sqrt(under) + 1.0 - a)
                    root = mz * mz + (1.0 - xi * xi) * r2
                    k = (mz * xi + np.sqrt(root)) / (mz * mz + r2)
                    b = np.stack([k * mx, k * my, k * mz - xi], 1)
                    ok = (under > 0) & (root >= 0)
                else:
                    root = 1.0 + (1.0 - xi * xi) * r2
                    k = (xi + np.sqrt(root)) / (1.0 + r2)
                    b = np.stack([k * mx, k * my, k - xi], 1)
                    ok = root >= 0
                n = np.linalg.norm(b, axis=1)
                ok &= np.isfinite(n) & (n > 0)
                return np.where(ok[:, None], b / np.where(ok, n, 1.0)[:, None], 0.0), ok
        if self.type == "pinhole":
            b = np.stack([(u - self.cx) / self.fx, (v - self.cy) / self.fy, np.ones_like(u)], 1)
            n = np.linalg.norm(b, axis=1)
            ok = np.isfinite(n) & (n > 0)
            return b / np.where(ok, n, 1.0)[:, None], ok
        mx = (u - self.cx) / self.fx
        my = (v - self.cy) / self.fy
        r = np.hypot(mx, my)
        # Newton on d(theta) = r, started at theta = r, at most 50 steps, per element until the
        # step is below 1e-14 (as the Rust code; further steps of a converged element are ~0).
        theta = r.copy()
        ok = np.ones_like(r, dtype=bool)
        active = r > 0
        for _ in range(50):
            if not active.any():
                break
            d, dd = self._distort(theta)
            bad = active & (np.abs(dd) < 1e-12)
            ok &= ~bad
            active &= ~bad
            step = np.where(active, (d - r) / np.where(active, dd, 1.0), 0.0)
            theta = theta - step
            active &= ~(np.abs(step) < 1e-14)
        d, _ = self._distort(theta)
        ok &= np.isfinite(theta) & (theta >= 0) & (np.abs(d - r) <= 1e-9 * np.maximum(r, 1.0))
        s = np.sin(theta)
        rr = np.where(r > 0, r, 1.0)
        b = np.stack([s * mx / rr, s * my / rr, np.cos(theta)], 1)
        b[r == 0] = (0.0, 0.0, 1.0)
        ok[r == 0] = True
        return b, ok


def read_rig(path: Path):
    """The cameras and their `T_vehicle_camera` (4x4) of rig.json."""
    rig = json.loads(path.read_text())
    cams = rig["cameras"]
    if not cams:
        raise ValueError(f"{path}: no cameras")
    models, extrinsics = [], []
    for i, c in enumerate(cams):
        models.append(CameraModel(c["model"]))
        t = np.array(c["T_vehicle_camera"], dtype=float)
        if t.shape != (4, 4) or not np.all(np.isfinite(t)):
            raise ValueError(f"{path}: camera {i}: T_vehicle_camera is not a finite 4x4 matrix")
        r = t[:3, :3]
        if np.abs(r @ r.T - np.eye(3)).max() > 1e-6 or abs(np.linalg.det(r) - 1) > 1e-6:
            raise ValueError(f"{path}: camera {i}: rotation not orthonormal")
        extrinsics.append(t)
    return models, extrinsics


def read_matches(path: Path):
    """matches.csv -> {frame: {camera: (n x 4 array u0 v0 u1 v1)}}, and the last frame.

    Cross-camera matches (the optional `camera_to` column, FORMAT.md version 5, naming another
    camera than `camera`) are skipped: the peers estimate from per-camera matches only."""
    rows = {}
    last = 0
    with path.open(newline="") as f:
        reader = csv.reader(f)
        header = None
        to = None
        for line_no, row in enumerate(reader, 1):
            if not row or all(not c.strip() for c in row):
                continue
            if header is None:
                names = [c.strip() for c in row]
                want = ["frame", "camera", "u0", "v0", "u1", "v1"]
                if sorted(names) not in (sorted(want), sorted(want + ["camera_to"])):
                    raise ValueError(f"{path}:{line_no}: bad header {row}")
                header = [names.index(w) for w in want]
                to = names.index("camera_to") if "camera_to" in names else None
                n_fields = len(names)
                continue
            if len(row) != n_fields:
                raise ValueError(
                    f"{path}:{line_no}: expected {n_fields} fields, found {len(row)}")
            frame = int(row[header[0]])
            cam = int(row[header[1]])
            if to is not None and row[to].strip() and int(row[to]) != cam:
                last = max(last, frame)
                continue
            vals = [float(row[i]) for i in header[2:]]
            rows.setdefault(frame, {}).setdefault(cam, []).append(vals)
            last = max(last, frame)
    return {k: {c: np.array(v, dtype=float) for c, v in d.items()} for k, d in rows.items()}, last


def read_odometry(path: Path):
    """odometry.csv -> {frame: arc_length} (empty if the file is absent)."""
    if not path.exists():
        return {}
    out = {}
    with path.open(newline="") as f:
        reader = csv.reader(f)
        header = None
        for row in reader:
            if not row or all(not c.strip() for c in row):
                continue
            if header is None:
                names = [c.strip() for c in row]
                header = (names.index("frame"), names.index("arc_length"))
                continue
            out[int(row[header[0]])] = float(row[header[1]])
    return out


# --- geometry (ports of momo-fivepoint's vehicle.rs and momo-vo's trajectory) ----------------


def half_angle_sinc(theta: float) -> float:
    h = 0.5 * theta
    return 1.0 - h * h / 6.0 if abs(h) < 1e-4 else math.sin(h) / h


def rotation_angle(r: np.ndarray) -> float:
    return math.acos(max(-1.0, min(1.0, 0.5 * (np.trace(r) - 1.0))))


def pose(r: np.ndarray, t: np.ndarray) -> np.ndarray:
    m = np.eye(4)
    m[:3, :3] = r
    m[:3, 3] = t
    return m


def vehicle_motion_from_camera(rc: np.ndarray, tc: np.ndarray, p: np.ndarray, arc: float):
    """`momo_fivepoint::vehicle_motion_from_camera` with `arc_length = Some(arc)`."""
    rp, pp = p[:3, :3], p[:3, 3]
    rm = rp @ rc @ rp.T
    n = np.linalg.norm(tc)
    if not n > 0:
        return pose(rm, np.zeros(3))
    tc = tc / n
    chord = abs(arc) * half_angle_sinc(rotation_angle(rm))
    if chord == 0.0:
        return pose(rm, np.zeros(3))
    a = rp @ tc
    b = pp - rm @ pp
    ab = float(a @ b)
    disc = ab * ab - float(b @ b) + chord * chord
    s = max(-ab + math.sqrt(disc), 0.0) if disc >= 0 else max(-ab, 0.0)
    return pose(rm, a * s + b)


def scale_vehicle_motion(m: np.ndarray, arc: float) -> np.ndarray:
    """A vehicle motion with its translation rescaled to the chord of the arc `arc`."""
    rm, tm = m[:3, :3], m[:3, 3]
    chord = abs(arc) * half_angle_sinc(rotation_angle(rm))
    n = np.linalg.norm(tm)
    if chord == 0.0 or not n > 1e-12:
        return pose(rm, np.zeros(3))
    return pose(rm, tm * (chord / n))


def finite(m) -> bool:
    return m is not None and bool(np.all(np.isfinite(m)))


# --- the peers -------------------------------------------------------------------------------


class Peer:
    """One method; `estimate` returns the vehicle motion (4x4) or None, and the seconds spent
    in the peer's call."""

    min_matches = 5

    def __init__(self, method, models, extrinsics, threshold_px):
        self.method = method
        self.models = models
        self.extrinsics = extrinsics
        self.threshold_px = threshold_px
        if method.startswith("opencv"):
            import cv2

            cv2.setNumThreads(1)
            cv2.setRNGSeed(0)
            self.cv2 = cv2
            self.cv_method = cv2.RANSAC if method == "opencv-ransac" else cv2.USAC_MAGSAC
        else:
            import poselib

            self.poselib = poselib
        if method == "poselib-generalized":
            self.min_matches = 6
            # PoseLib's camera extrinsics map the rig (vehicle) frame into the camera:
            # T_camera_vehicle = T_vehicle_camera^-1.
            self.ext = []
            for t in extrinsics:
                cp = poselib.CameraPose()
                inv = np.linalg.inv(t)
                cp.R = inv[:3, :3]
                cp.t = inv[:3, 3]
                self.ext.append(cp)

    def virtual_camera(self, cam):
        f = self.models[cam].focal
        return {"model": "PINHOLE", "width": int(round(self.models[cam].width)),
                "height": int(round(self.models[cam].height)), "params": [f, f, 0.0, 0.0]}

    def estimate_single(self, x0, x1, cam, arc):
        """x0, x1: ideal-pinhole pixels (n x 2) of camera `cam`."""
        f = self.models[cam].focal
        if self.method.startswith("opencv"):
            cv2 = self.cv2
            k = np.array([[f, 0.0, 0.0], [0.0, f, 0.0], [0.0, 0.0, 1.0]])
            start, cpu_start = time.perf_counter(), time.thread_time()
            e, mask = cv2.findEssentialMat(x0, x1, k, method=self.cv_method, prob=0.999,
                                           threshold=self.threshold_px)
            ok = e is not None and e.shape[0] >= 3 and e.shape[1] == 3
            if ok:
                e = np.ascontiguousarray(e[:3])
                n_in, r, t, _ = cv2.recoverPose(e, x0, x1, k, mask=mask)
            elapsed = time.perf_counter() - start
            PEER_CPU_SECONDS[0] += time.thread_time() - cpu_start
            if not ok or n_in < self.min_matches or not finite(r) or not finite(t):
                return None, elapsed
            # OpenCV: x1 = R x0 + t (frame k-1 -> frame k); momo's camera motion C is the pose
            # of the camera at k in the camera at k-1: [R^T | -R^T t].
            rc, tc = r.T, -r.T @ t.reshape(3)
        else:
            cam_dict = self.virtual_camera(cam)
            start, cpu_start = time.perf_counter(), time.thread_time()
            p, info = self.poselib.estimate_relative_pose(
                x0, x1, cam_dict, cam_dict, {"max_epipolar_error": self.threshold_px}, {})
            elapsed = time.perf_counter() - start
            PEER_CPU_SECONDS[0] += time.thread_time() - cpu_start
            r, t = np.asarray(p.R), np.asarray(p.t).reshape(3)
            if info.get("num_inliers", 0) < self.min_matches or not finite(r) or not finite(t):
                return None, elapsed
            rc, tc = r.T, -r.T @ t  # PoseLib: x1 = R x0 + t, as OpenCV
        return vehicle_motion_from_camera(rc, tc, self.extrinsics[cam], arc), elapsed

    def estimate_generalized(self, per_cam, arc):
        """per_cam: {cam: (x0, x1)} ideal-pinhole pixels."""
        pl = self.poselib
        matches = []
        for cam, (x0, x1) in sorted(per_cam.items()):
            m = pl.PairwiseMatches()
            m.cam_id1 = cam
            m.cam_id2 = cam
            m.x1 = x0
            m.x2 = x1
            matches.append(m)
        cams = [self.virtual_camera(c) for c in range(len(self.models))]
        start, cpu_start = time.perf_counter(), time.thread_time()
        p, info = pl.estimate_generalized_relative_pose(
            matches, self.ext, cams, self.ext, cams, {"max_epipolar_error": self.threshold_px}, {})
        elapsed = time.perf_counter() - start
        PEER_CPU_SECONDS[0] += time.thread_time() - cpu_start
        r, t = np.asarray(p.R), np.asarray(p.t).reshape(3)
        if info.get("num_inliers", 0) < self.min_matches or not finite(r) or not finite(t):
            return None, elapsed
        # PoseLib maps the rig frame at k-1 into the rig frame at k: M = [R^T | -R^T t].
        return scale_vehicle_motion(pose(r.T, -r.T @ t), arc), elapsed


# --- the driver --------------------------------------------------------------------------------


def fmt(v: float) -> str:
    return repr(float(v)) if v != 0 else "0"


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("seq", type=Path, help="sequence directory (FORMAT.md)")
    ap.add_argument("--method", required=True, choices=METHODS)
    ap.add_argument("--output", "-o", required=True, type=Path, help="KITTI poses of camera 0")
    ap.add_argument("--stats", type=Path, help="JSON stats (default: OUTPUT with .json)")
    ap.add_argument("--threshold-px", type=float, default=1.0,
                    help="inlier threshold in pixels (OpenCV threshold, PoseLib "
                         "max_epipolar_error); default 1.0")
    ap.add_argument("--max-angle-deg", type=float, default=80.0,
                    help="drop bearings further than this from the optical axis (2D "
                         "normalised points cannot hold rays near or beyond 90 deg); default 80")
    args = ap.parse_args(argv)

    models, extrinsics = read_rig(args.seq / "rig.json")
    matches, last_match = read_matches(args.seq / "matches.csv")
    odometry = read_odometry(args.seq / "odometry.csv")
    last = max([last_match] + list(odometry.keys()))
    n_frames = last + 1
    peer = Peer(args.method, models, extrinsics, args.threshold_px)
    generalized = args.method == "poselib-generalized"
    cams_used = list(range(len(models))) if generalized else [0]
    min_z = math.cos(math.radians(args.max_angle_deg))

    # Bearings -> ideal-pinhole pixels per camera, once per frame (outside the timing).
    def prepare(rows: np.ndarray, cam: int):
        m = models[cam]
        b0, ok0 = m.unproject(rows[:, 0], rows[:, 1])
        b1, ok1 = m.unproject(rows[:, 2], rows[:, 3])
        unusable = int(np.count_nonzero(~(ok0 & ok1)))
        keep = ok0 & ok1 & (b0[:, 2] > min_z) & (b1[:, 2] > min_z)
        dropped = int(np.count_nonzero(~keep)) - unusable
        f = m.focal
        x0 = np.ascontiguousarray(f * b0[keep, :2] / b0[keep, 2:3])
        x1 = np.ascontiguousarray(f * b1[keep, :2] / b1[keep, 2:3])
        return x0, x1, dropped, unusable

    vehicle = np.eye(4)
    p0 = extrinsics[0]
    p0_inv = np.linalg.inv(p0)
    previous = np.eye(4)
    last_arc = 1.0
    counts = {"estimated": 0, "no_matches": 0, "failure": 0}
    dropped_total = unusable_total = matches_total = 0
    peer_seconds = 0.0
    calls = 0
    lines = ["1 0 0 0 0 1 0 0 0 0 1 0"]
    for k in range(1, n_frames):
        arc = odometry.get(k)
        if arc is None or not math.isfinite(arc) or arc < 0:
            arc = last_arc
        frame = matches.get(k, {})
        per_cam = {}
        for cam in cams_used:
            rows = frame.get(cam)
            if rows is None or len(rows) == 0:
                continue
            x0, x1, dropped, unusable = prepare(rows, cam)
            dropped_total += dropped
            unusable_total += unusable
            matches_total += len(rows)
            if len(x0):
                per_cam[cam] = (x0, x1)
        n = sum(len(v[0]) for v in per_cam.values())
        motion = None
        status = "no_matches"
        if n >= peer.min_matches:
            calls += 1
            if generalized:
                motion, dt = peer.estimate_generalized(per_cam, arc)
            elif 0 in per_cam:
                motion, dt = peer.estimate_single(per_cam[0][0], per_cam[0][1], 0, arc)
            peer_seconds += dt
            status = "estimated" if finite(motion) else "failure"
        if status != "estimated":
            # Hold the previous motion, rescaled to this frame's arc length (baseline.rs).
            motion = previous.copy()
            nt = np.linalg.norm(motion[:3, 3])
            if nt > 1e-12:
                motion[:3, 3] *= arc / nt
        counts[status] += 1
        if arc > 0:
            last_arc = arc
        previous = motion
        vehicle = vehicle @ motion
        cam0 = p0_inv @ vehicle @ p0
        lines.append(" ".join(fmt(cam0[r, c]) for r in range(3) for c in range(4)))

    args.output.parent.mkdir(parents=True, exist_ok=True)
    tmp = args.output.with_name(args.output.name + ".tmp")
    tmp.write_text("\n".join(lines) + "\n")
    tmp.replace(args.output)

    versions = {"python": sys.version.split()[0], "numpy": np.__version__}
    if args.method.startswith("opencv"):
        versions["opencv"] = peer.cv2.__version__
    else:
        from importlib.metadata import version

        versions["poselib"] = version("poselib")
    pairs = n_frames - 1
    stats = {
        "sequence": str(args.seq),
        "method": args.method,
        "cameras_used": cams_used,
        "threshold_px": args.threshold_px,
        "max_angle_deg": args.max_angle_deg,
        "frames": n_frames,
        "frame_pairs": pairs,
        **counts,
        "degenerate": counts["no_matches"] + counts["failure"],
        "matches": matches_total,
        "bearings_dropped_beyond_max_angle": dropped_total,
        "bearings_not_unprojectable": unusable_total,
        "peer_calls": calls,
        "ms_per_frame": 1e3 * peer_seconds / pairs if pairs else float("nan"),
        "ms_per_call": 1e3 * peer_seconds / calls if calls else float("nan"),
        # CPU time of the library calls (this thread), per frame pair: less sensitive than the
        # wall clock to other processes on a loaded machine.
        "cpu_ms_per_frame": 1e3 * PEER_CPU_SECONDS[0] / pairs if pairs else float("nan"),
        "versions": versions,
    }
    stats_path = args.stats or args.output.with_suffix(".json")
    stats_path.write_text(json.dumps(stats, indent=2) + "\n")
    return 0


if __name__ == "__main__":
    sys.exit(main())
