"""Shared fixtures: the momo CLI binary and simulated sequence directories written by it."""

import os
import pathlib
import subprocess

import pytest

REPO = pathlib.Path(__file__).resolve().parents[4]


def _momo_bin() -> pathlib.Path:
    env = os.environ.get("MOMO_BIN")
    if env:
        return pathlib.Path(env)
    for profile in ("debug", "release"):
        p = REPO / "target" / profile / "momo"
        if p.exists():
            return p
    pytest.fail(
        "no momo binary: set MOMO_BIN or run `cargo build --bin momo` "
        "(scripts/python_test.sh does)"
    )


@pytest.fixture(scope="session")
def momo_bin() -> pathlib.Path:
    return _momo_bin()


def cli(momo_bin, *args) -> subprocess.CompletedProcess:
    """Runs the CLI; fails the test with its stderr on a non-zero exit."""
    r = subprocess.run([str(momo_bin), *map(str, args)], capture_output=True, text=True)
    assert r.returncode == 0, f"momo {' '.join(map(str, args))} failed: {r.stderr}"
    return r


# (scenario, frames, seed, matches per camera): a mono pinhole sequence with odometry and a
# 4-camera fisheye surround rig; small, because the tests run on a debug build.
SEQUENCES = {
    "mono": ("outliers", 40, 3, 80),
    "fisheye": ("fisheye_surround", 25, 5, 40),
}


@pytest.fixture(scope="session", params=sorted(SEQUENCES))
def simulated(request, momo_bin, tmp_path_factory):
    """A sequence directory written by `momo simulate`, and its `momo run` poses/diagnostics."""
    name = request.param
    scenario, frames, seed, matches = SEQUENCES[name]
    d = tmp_path_factory.mktemp(name)
    seq = d / "seq"
    cli(momo_bin, "simulate", "--scenario", scenario, "--frames", frames, "--seed", seed,
        "--matches", matches, seq)
    poses = d / "poses.txt"
    diags = d / "diagnostics.jsonl"
    cli(momo_bin, "run", seq, "-o", poses, "-d", diags, "-q")
    return {
        "name": name,
        "scenario": scenario,
        "frames": frames,
        "seed": seed,
        "matches": matches,
        "dir": seq,
        "poses": poses,
        "diagnostics": diags,
        "tmp": d,
    }
