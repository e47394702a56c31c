"""Measures the Python bindings against Rust (run by scripts/python_bench.sh on release builds).

1. Per-frame call overhead: Odometry.process from a Python loop against the same calls in a Rust
   loop (momo._native_process_loop), on an empty frame pair (the driver holds the motion: almost
   no work, so the difference is the binding) and on a small estimated frame pair.
2. A KITTI-length simulated sequence through a Python loop of Odometry.process against
   `momo run` (wall time, and the poses compared).
"""

import json
import os
import subprocess
import sys
import time

import numpy as np

import momo


def overhead(repeats: int, rounds: int) -> dict:
    sim = momo.simulate("clean_pinhole", frames=3, seed=1, matches=12)
    config = momo.Config.default()
    out = {}
    cases = {
        "empty frame (no_matches)": ([np.zeros((0, 4))], 1.0),
        "12 matches (estimated)": (sim.frame(1), float(sim.arc_lengths[1])),
    }
    for name, (matches, arc) in cases.items():
        n = repeats if "empty" in name else max(repeats // 100, 200)
        py_best = native_best = float("inf")
        for _ in range(rounds):
            native = momo._native_process_loop(sim.rig, config, matches, arc, n) / n
            vo = momo.Odometry(sim.rig, config)
            process = vo.process
            t = time.perf_counter()
            for _ in range(n):
                process(matches, arc)
            py = (time.perf_counter() - t) / n
            py_best, native_best = min(py_best, py), min(native_best, native)
        out[name] = {
            "calls": n,
            "python_us": py_best * 1e6,
            "rust_us": native_best * 1e6,
            "overhead_us": (py_best - native_best) * 1e6,
        }
        print(f"{name}: python {py_best * 1e6:.2f} us/call, rust {native_best * 1e6:.2f} us/call, "
              f"overhead {(py_best - native_best) * 1e6:.2f} us (best of {rounds} x {n} calls)",
              flush=True)
    return out


def kitti(momo_bin: str, seq_dir: str, work: str) -> dict:
    poses_path = os.path.join(work, "poses_cli.txt")
    t = time.perf_counter()
    subprocess.run([momo_bin, "run", seq_dir, "-o", poses_path, "-q"], check=True)
    cli_s = time.perf_counter() - t
    cli = momo.read_poses(poses_path)

    t = time.perf_counter()
    seq = momo.Sequence.read(seq_dir)
    read_s = time.perf_counter() - t
    frames = [seq.frame(k) for k in range(len(seq))]
    arcs = seq.arc_lengths
    arcs = [None if arcs is None or np.isnan(a) else float(a) for a in (arcs if arcs is not None else [None] * len(seq))]
    vo = momo.Odometry(seq.rig, momo.Config.default())
    poses = [vo.pose]
    rust_us = 0.0
    t = time.perf_counter()
    for k in range(1, len(seq)):
        _, d = vo.process(frames[k], arcs[k])
        rust_us += d.time_us
        poses.append(vo.pose)
    loop_s = time.perf_counter() - t
    poses = np.stack(poses)

    t = time.perf_counter()
    run_poses, _ = momo.run(seq_dir)
    run_s = time.perf_counter() - t
    res = {
        "frames": len(seq),
        "matches": seq.num_matches,
        "momo_run_s": cli_s,
        "python_read_s": read_s,
        "python_loop_s": loop_s,
        "python_loop_plus_read_s": loop_s + read_s,
        "momo.run_s": run_s,
        "estimating_s (sum of time_us)": rust_us * 1e-6,
        "max_abs_diff_loop_vs_cli": float(np.abs(poses - cli).max()),
        "max_abs_diff_run_vs_cli": float(np.abs(run_poses - cli).max()),
    }
    for k, v in res.items():
        print(f"  {k}: {v}", flush=True)
    return res


if __name__ == "__main__":
    momo_bin, seq_dir, work = sys.argv[1:4]
    result = {"overhead": overhead(repeats=200_000, rounds=5), "kitti": kitti(momo_bin, seq_dir, work)}
    with open(os.path.join(work, "python_bench.json"), "w") as f:
        json.dump(result, f, indent=2)
