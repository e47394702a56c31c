"""The Python API gives exactly what the CLI gives (`momo run`, `momo simulate`, `momo eval`)."""

import json

import numpy as np
import pytest

import momo
from conftest import cli

TOL = 1e-12


def _loop(seq: momo.Sequence, config: momo.Config):
    """A researcher's loop: one process() call per frame pair, poses from Odometry.pose."""
    vo = momo.Odometry(seq.rig, config)
    arcs = seq.arc_lengths
    poses = [vo.pose]
    motions = []
    diags = []
    for k in range(1, len(seq)):
        arc = None if arcs is None or np.isnan(arcs[k]) else float(arcs[k])
        motion, d = vo.process(seq.frame(k), arc)
        poses.append(vo.pose)
        motions.append(motion)
        diags.append(d)
    return np.stack(poses), motions, diags


def test_python_loop_equals_momo_run(simulated):
    cli_poses = momo.read_poses(simulated["poses"])
    seq = momo.Sequence.read(simulated["dir"])
    poses, motions, diags = _loop(seq, momo.Config.default())
    assert poses.shape == cli_poses.shape == (simulated["frames"], 4, 4)
    diff = np.abs(poses - cli_poses).max()
    assert diff <= TOL, f"max |python - cli| = {diff}"
    # The diagnostics are those of `momo run --diagnostics`.
    rows = [json.loads(line) for line in simulated["diagnostics"].read_text().splitlines()]
    assert len(rows) == len(diags)
    for row, d in zip(rows, diags):
        assert (row["frame"], row["status"], row["scale"]) == (d.frame, d.status, d.scale_source)
        assert (row["inliers"], row["iterations"], row["matches"]) == (d.inliers, d.iterations, d.matches)
        assert np.array_equal(np.array(row["params"], dtype=float), d.params)
        # The trust fields: why a frame is flagged, and the thresholds' noise scale.
        assert (row["constraint"], row["reason"]) == (d.constraint, d.reason)
        assert (row["competing"] is None) == (d.competing is None)
        assert (row["noise_scale"], row.get("noise")) == (d.noise_scale, d.noise)
    # Composing the motions in numpy instead of Odometry.pose: the same up to rounding.
    p0 = seq.rig.cameras[0]["T_vehicle_camera"]
    v = np.eye(4)
    for k, m in enumerate(motions, start=1):
        v = v @ m
        cam = np.linalg.inv(p0) @ v @ p0
        assert np.abs(cam - cli_poses[k]).max() <= 1e-9 * max(1.0, np.abs(cli_poses[k]).max())


def test_run_equals_momo_run(simulated):
    cli_poses = momo.read_poses(simulated["poses"])
    poses, diags = momo.run(simulated["dir"])
    assert poses.shape == cli_poses.shape
    diff = np.abs(poses - cli_poses).max()
    assert diff <= TOL, f"max |run - cli| = {diff}"
    rows = [json.loads(line) for line in simulated["diagnostics"].read_text().splitlines()]
    assert list(diags["status"]) == [r["status"] for r in rows]
    assert list(diags["inliers"]) == [r["inliers"] for r in rows]
    assert list(diags["constraint"]) == [r["constraint"] for r in rows]
    assert list(diags["reason"]) == [r["reason"] or "none" for r in rows]
    assert list(diags["noise_scale"]) == [r["noise_scale"] for r in rows]
    noise = np.array([r.get("noise", np.nan) for r in rows], dtype=float)
    assert np.array_equal(diags["noise"], noise, equal_nan=True)
    assert diags["params"].shape == (len(rows), len(rows[0]["params"]))
    assert np.array_equal(diags["params"], np.array([r["params"] for r in rows], dtype=float))


def test_run_with_config_file_equals_momo_run(simulated, momo_bin):
    """A non-default configuration, given to the CLI as TOML and to Python as a Config."""
    config = momo.Config(model="single_track_3d", loss={"scale": 0.002}, odometry={"min_matches": 12})
    path = simulated["tmp"] / "config.toml"
    path.write_text(config.to_toml())
    out = simulated["tmp"] / "poses_st3d.txt"
    cli(momo_bin, "run", simulated["dir"], "-o", out, "-c", path, "-q")
    cli_poses = momo.read_poses(out)
    seq = momo.Sequence.read(simulated["dir"])
    loop_poses, _, _ = _loop(seq, config)
    run_poses, _ = momo.run(simulated["dir"], config)
    file_poses, _ = momo.run(simulated["dir"], path)
    for p in (loop_poses, run_poses, file_poses):
        assert np.abs(p - cli_poses).max() <= TOL
    # And it is a different trajectory from the default's (the configuration was applied).
    assert np.abs(cli_poses - momo.read_poses(simulated["poses"])).max() > 1e-9


def test_simulate_equals_momo_simulate(simulated):
    s = simulated
    seq = momo.simulate(s["scenario"], frames=s["frames"], seed=s["seed"], matches=s["matches"])
    assert seq == momo.Sequence.read(s["dir"])
    assert len(seq) == s["frames"]
    assert seq.ground_truth.shape == (s["frames"], 4, 4)
    assert seq.vehicle_poses.shape == (s["frames"], 4, 4)
    # Written back, it is the same directory content.
    out = s["tmp"] / "rewritten"
    seq.write(out)
    assert momo.Sequence.read(out) == seq


def test_simulate_with_static_tracks_equals_momo_simulate(simulated, momo_bin):
    """`static_tracks` as `momo simulate --static-tracks`; out of [0, 1] it is an error."""
    s = simulated
    out = s["tmp"] / "tracked"
    cli(momo_bin, "simulate", "--scenario", s["scenario"], "--frames", s["frames"],
        "--seed", s["seed"], "--matches", s["matches"], "--static-tracks", 0.8, out, "-q")
    kw = dict(frames=s["frames"], seed=s["seed"], matches=s["matches"])
    seq = momo.simulate(s["scenario"], static_tracks=0.8, **kw)
    assert seq == momo.Sequence.read(out)
    assert seq != momo.simulate(s["scenario"], **kw)
    with pytest.raises(momo.SimulationError, match="static_tracks"):
        momo.simulate(s["scenario"], static_tracks=1.5, **kw)


def test_simulate_in_memory_loop_equals_cli(simulated):
    """No files at all on the Python side: simulate, then loop."""
    s = simulated
    seq = momo.simulate(s["scenario"], frames=s["frames"], seed=s["seed"], matches=s["matches"])
    poses, _, _ = _loop(seq, momo.Config.default())
    assert np.abs(poses - momo.read_poses(s["poses"])).max() <= TOL


def test_evaluate_equals_momo_eval(simulated, momo_bin):
    gt = simulated["dir"] / "poses.txt"
    r = cli(momo_bin, "eval", "--gt", gt, "--est", simulated["poses"], "--json")
    doc = json.loads(r.stdout)
    expected = doc["estimates"][0]
    del expected["path"]
    from_files = momo.evaluate(str(gt), str(simulated["poses"]))
    from_arrays = momo.evaluate(momo.read_poses(gt), momo.read_poses(simulated["poses"]))
    # `momo eval --json` also carries ATE, RPE and the KITTI tables, and the Cramér-Rao bound
    # from the bound.csv beside the ground truth (which `evaluate` does not read: its
    # `bound_deg` and `efficiency` are None); every other figure `evaluate` returns must be
    # there and equal.
    for got in (from_files, from_arrays):
        assert set(got) <= set(expected), set(got) - set(expected)
        assert got["bound_deg"] is None and got["efficiency"] is None
        shared = [k for k in got if k not in ("bound_deg", "efficiency")]
        assert {k: got[k] for k in shared} == {k: expected[k] for k in shared}
    assert expected["rotation_deg"]["count"] == simulated["frames"] - 1


def test_evaluate_long_path_has_kitti_errors(tmp_path):
    """A path over 100 m gets the KITTI devkit errors (the short sequences above do not)."""
    seq = momo.simulate("clean_pinhole", frames=150, seed=2, matches=30)
    gt = seq.ground_truth
    est = gt.copy()
    est[:, :3, 3] *= 1.01
    e = momo.evaluate(gt, est)
    assert e["t_err_percent"] is not None and 0.5 < e["t_err_percent"] < 2.0
    assert e["rotation_deg"]["max"] < 1e-9
