"""Rig from arrays, Odometry state, estimate, Diagnostics, Sequence, and the GIL."""

import threading
import time

import numpy as np
import pytest

import momo


@pytest.fixture(scope="module")
def sim():
    return momo.simulate("clean_pinhole", frames=12, seed=4, matches=60)


def test_rig_from_arrays_equals_file(sim, tmp_path):
    rig = sim.rig
    again = momo.Rig(rig.cameras)
    assert again == rig
    rig.write(tmp_path / "rig.json")
    assert momo.Rig.from_file(tmp_path / "rig.json") == rig
    assert momo.Rig.from_json(rig.to_json()) == rig
    cam = rig.cameras[0]
    assert cam["T_vehicle_camera"].shape == (4, 4)
    assert momo.Rig.mono(cam["model"], cam["T_vehicle_camera"], cam["name"]) == rig
    assert len(rig) == 1


def test_fisheye_rig_from_arrays():
    rig = momo.simulate("fisheye_surround", frames=2, seed=1, matches=5).rig
    assert len(rig) == 4
    assert {c["model"]["type"] for c in rig.cameras} == {"kannala_brandt"}
    assert momo.Rig(rig.cameras) == rig
    assert rig.max_lever_arm > 0


def test_process_returns_motion_and_diagnostics(sim):
    vo = momo.Odometry(sim.rig, momo.Config.default())
    assert np.array_equal(vo.pose, np.eye(4))
    motion, d = vo.process(sim.frame(1), float(sim.arc_lengths[1]))
    assert motion.shape == (4, 4) and motion.dtype == np.float64
    assert d.status == "estimated" and d.scale_source == "odometry"
    assert d.frame == 1 and d.matches == 60 and 0 < d.inliers <= 60
    assert d.iterations > 0 and d.time_us > 0 and d.termination
    n = len(d.free)
    assert d.covariance.shape == (n, n)
    assert np.allclose(d.covariance, d.covariance.T)
    assert len(d.params) == len(d.param_names) == len(vo.param_names)
    assert d.to_dict()["status"] == "estimated"
    # Trusted, no second motion, the thresholds as written (no noise read yet).
    assert (d.constraint, d.reason, d.competing) == ("well", None, None)
    # No support test disagreed with the stage (the neighbourhood guard did not act).
    assert d.guard_alternative is None and d.to_dict()["guard_alternative"] is None
    assert d.noise_scale == 1.0 and d.to_dict()["noise_scale"] == 1.0
    # Against the truth: the vehicle moved forward by the arc length.
    v = sim.vehicle_poses
    true_motion = np.linalg.inv(v[0]) @ v[1]
    assert np.abs(motion[:3, 3] - true_motion[:3, 3]).max() < 0.05
    # No matches: the previous motion is held, and NaN arc length means unknown.
    motion2, d2 = vo.process([np.zeros((0, 4))], float("nan"))
    assert d2.status == "no_matches" and d2.frame == 2
    assert np.allclose(motion2, motion)
    assert vo.frames == 3


def test_matches_accept_lists_and_float32(sim):
    a = momo.Odometry(sim.rig)
    b = momo.Odometry(sim.rig)
    m = sim.frame(1)[0]
    ma, _ = a.process([m], 1.0)
    mb, _ = b.process([m.tolist()], 1.0)
    assert np.array_equal(ma, mb)
    c = momo.Odometry(sim.rig)
    mc, _ = c.process([np.asfortranarray(m)], 1.0)
    assert np.array_equal(ma, mc)


def test_estimate_stateless(sim):
    m = sim.frame(3)
    arc = float(sim.arc_lengths[3])
    v = sim.vehicle_poses
    truth = np.linalg.inv(v[2]) @ v[3]
    motion, info = momo.estimate(sim.rig, m, arc_length=arc)
    assert motion.shape == (4, 4)
    assert info["termination"] and info["iterations"] > 0
    assert info["params"][info["param_names"].index("arc_length")] == arc
    assert np.abs(motion[:3, 3] - truth[:3, 3]).max() < 0.05
    # Same inputs, same answer (no state); another model and loss give another answer.
    again, _ = momo.estimate(sim.rig, m, arc_length=arc)
    assert np.array_equal(motion, again)
    st, info2 = momo.estimate(sim.rig, m, model="single_track_2d", loss={"type": "huber", "scale": 0.002},
                              arc_length=arc)
    assert info2["param_names"] == ["yaw", "arc_length"]
    assert not np.array_equal(st, motion)
    # From an explicit start.
    start = np.array(info["params"])
    m2, info3 = momo.estimate(sim.rig, m, initial=start, arc_length=arc)
    assert np.abs(m2 - motion).max() < 1e-6
    assert info3["covariance"].shape[0] == len(info3["free"])


def test_sequence_accessors(sim):
    assert len(sim) == sim.num_frames == 12
    assert len(sim.matches) == 12 and [a.shape for a in sim.matches[0]] == [(0, 4)]
    assert sim.frame(5)[0].shape == (60, 4)
    assert np.isnan(sim.arc_lengths[0])
    assert sim.ground_truth.shape == (12, 4, 4)
    with pytest.raises(IndexError):
        sim.frame(12)


def test_simulate_along_trajectory(sim):
    gt = sim.ground_truth
    again = momo.simulate("clean_pinhole", frames=12, seed=4, matches=60, trajectory=gt)
    assert np.abs(again.ground_truth - gt).max() < 1e-9


def test_simulate_along_travel():
    """A camera pitched 1 deg nose down driving straight: turned along its travel, the
    ground truth's camera moves along its optical axis (no vertical component)."""
    a = np.radians(1.0)
    pitch = np.array([[1, 0, 0], [0, np.cos(a), np.sin(a)], [0, -np.sin(a), np.cos(a)]])
    cams = np.tile(np.eye(4), (20, 1, 1))
    cams[:, :3, :3] = pitch
    cams[:, 2, 3] = 1.2 * np.arange(20)
    as_given = momo.simulate("clean_pinhole", frames=10, seed=4, matches=60, trajectory=cams)
    turned = momo.simulate(
        "clean_pinhole", frames=10, seed=4, matches=60, trajectory=cams, along_travel=True
    )
    def step(gt):
        return np.linalg.inv(gt[0]) @ gt[1]

    assert abs(step(as_given.ground_truth)[1, 3]) > 0.01
    assert abs(step(turned.ground_truth)[1, 3]) < 1e-9


def test_gil_released_during_run(tmp_path):
    """While `run` estimates in one thread, another Python thread keeps running."""
    d = tmp_path / "seq"
    # Long enough that the call takes well over 0.05 s in the test build (opt-level 1: 40 frames
    # took 0.037 s), so that the ticker's count means something.
    momo.simulate("clean_pinhole", frames=300, seed=1, matches=150).write(d)
    ticks = 0
    done = threading.Event()

    def tick():
        nonlocal ticks
        while not done.is_set():
            ticks += 1
            time.sleep(0.001)

    t = threading.Thread(target=tick)
    t.start()
    start = time.perf_counter()
    ticks_before = ticks
    momo.run(d)
    elapsed = time.perf_counter() - start
    during = ticks - ticks_before
    done.set()
    t.join()
    # With the GIL held, the ticker could not run at all during the call.
    assert elapsed > 0.05
    assert during >= 10, f"{during} ticks in {elapsed:.3f} s"
