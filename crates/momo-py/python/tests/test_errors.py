"""Every exception path: each error is a MomoError subclass carrying momo's message."""

import numpy as np
import pytest

import momo

P0 = [[0, 0, 1, 1.0], [-1, 0, 0, 0.0], [0, -1, 0, 1.65], [0, 0, 0, 1]]
PINHOLE = {"type": "pinhole", "fx": 718.856, "fy": 718.856, "cx": 607.1928, "cy": 185.2157,
           "width": 1241, "height": 376}


@pytest.fixture(scope="module")
def rig():
    return momo.Rig.mono(PINHOLE, P0)


@pytest.fixture(scope="module")
def seq_dir(tmp_path_factory):
    d = tmp_path_factory.mktemp("errs") / "seq"
    momo.simulate("clean_pinhole", frames=5, seed=1, matches=20).write(d)
    return d


def test_hierarchy():
    for e in (momo.InputError, momo.ConfigError, momo.RigError, momo.MatchError,
              momo.EstimationError, momo.SimulationError):
        assert issubclass(e, momo.MomoError)
    assert issubclass(momo.MomoError, Exception)


# InputError: files and sequence directories, with `file:line: reason`.

def test_rig_file_missing(tmp_path):
    with pytest.raises(momo.InputError, match="file not found") as e:
        momo.Rig.from_file(tmp_path / "nope.json")
    assert e.value.path.endswith("nope.json") and e.value.line is None


def test_rig_file_malformed_has_line(tmp_path):
    p = tmp_path / "rig.json"
    p.write_text('{\n  "cameras": [\n    {"name": "cam0", "model": {"type": "pinhole"}}\n  ]\n}\n')
    with pytest.raises(momo.InputError) as e:
        momo.Rig.from_file(p)
    assert str(e.value).startswith(f"{p}:3: "), str(e.value)
    assert e.value.line == 3


def test_rig_json_text(rig):
    with pytest.raises(momo.InputError, match=r"^<rig.json>:1: "):
        momo.Rig.from_json("{ not json")


def test_matches_csv_malformed_has_line(seq_dir, tmp_path):
    import shutil
    d = tmp_path / "bad"
    shutil.copytree(seq_dir, d)
    lines = (d / "matches.csv").read_text().splitlines()
    lines[3] = "2,0,nan,1,2,3"
    (d / "matches.csv").write_text("\n".join(lines) + "\n")
    for call in (lambda: momo.Sequence.read(d), lambda: momo.run(d)):
        with pytest.raises(momo.InputError) as e:
            call()
        assert str(e.value).startswith(f"{d / 'matches.csv'}:4: "), str(e.value)
        assert e.value.line == 4


def test_run_missing_dir(tmp_path):
    with pytest.raises(momo.InputError, match="rig.json: file not found"):
        momo.run(tmp_path / "missing")


def test_read_poses_malformed(tmp_path):
    p = tmp_path / "poses.txt"
    p.write_text("1 0 0 0 0 1 0 0 0 0 1 0\n1 2 3\n")
    with pytest.raises(momo.InputError, match=r"poses.txt:2: "):
        momo.read_poses(p)


def test_evaluate_lengths_and_shapes():
    gt = np.tile(np.eye(4), (5, 1, 1))
    with pytest.raises(momo.InputError, match="est has 4 poses, but the ground truth has 5"):
        momo.evaluate(gt, gt[:4])
    with pytest.raises(momo.InputError, match="expected an"):
        momo.evaluate(gt, np.zeros((5, 7)))
    bad = gt.copy()
    bad[2, 0, 0] = 2.0
    with pytest.raises(momo.InputError, match=r"est\[2\]: the rotation is not orthonormal"):
        momo.evaluate(gt, bad)


# ConfigError: parse errors with `name:line: reason`, unknown keys, values out of range.

def test_config_toml_syntax_has_line():
    with pytest.raises(momo.ConfigError, match=r"^my.toml:2: "):
        momo.Config.from_toml('[model]\ntype = \n', "my.toml")


def test_config_unknown_key():
    text = momo.Config.default().to_toml().replace("[odometry]", "[odometry]\nbogus = 1")
    with pytest.raises(momo.ConfigError, match="bogus"):
        momo.Config.from_toml(text)


def test_config_unknown_model():
    with pytest.raises(momo.ConfigError, match="no_such_model"):
        momo.Config(model="no_such_model")


def test_config_out_of_range():
    with pytest.raises(momo.ConfigError, match="loss scale must be (finite and )?positive"):
        momo.Config(loss={"scale": -1.0})
    with pytest.raises(momo.ConfigError, match="initial_arc_length"):
        momo.Config(odometry={"initial_arc_length": 0.0})


def test_config_unknown_section():
    with pytest.raises(momo.ConfigError, match="unknown section `modle`"):
        momo.Config(modle="se3")


def test_config_json_and_file(tmp_path):
    with pytest.raises(momo.ConfigError, match=r"^x.json:1: "):
        momo.Config.from_json("{", "x.json")
    with pytest.raises(momo.ConfigError, match="missing.toml"):
        momo.Config.from_file(tmp_path / "missing.toml")


def test_run_bad_config_and_estimator(seq_dir):
    with pytest.raises(momo.ConfigError, match="config must be"):
        momo.run(seq_dir, config=123)
    with pytest.raises(momo.ConfigError, match="unknown estimator"):
        momo.run(seq_dir, estimator="seven-point")


def test_estimate_initial_length(rig):
    with pytest.raises(momo.ConfigError, match="initial has 2 values"):
        momo.estimate(rig, [np.zeros((0, 4))], initial=[0.0, 1.0])


# RigError: invalid rigs, a model/metric that does not fit the rig.

def test_rig_empty():
    with pytest.raises(momo.RigError, match="no cameras"):
        momo.Rig([])


def test_rig_not_orthonormal():
    t = np.array(P0, dtype=float)
    t[0, 0] = 0.5
    with pytest.raises(momo.RigError, match="orthonormal"):
        momo.Rig.mono(PINHOLE, t)


def test_rig_bad_intrinsics_and_model():
    with pytest.raises(momo.RigError, match="`fx` must be a positive"):
        momo.Rig.mono(dict(PINHOLE, fx=-1.0), P0)
    with pytest.raises(momo.RigError, match="unknown variant"):
        momo.Rig.mono(dict(PINHOLE, type="fisheye"), P0)
    with pytest.raises(momo.RigError, match="4x4"):
        momo.Rig.mono(PINHOLE, np.eye(3))
    with pytest.raises(momo.RigError, match="missing `T_vehicle_camera`"):
        momo.Rig([{"model": PINHOLE}])


def test_metric_does_not_fit_rig():
    """geo_line needs pinhole cameras: the stateless estimate raises when it solves; the
    odometry rejects the configuration before the first frame (momo's validation)."""
    seq = momo.simulate("fisheye_surround", frames=2, seed=1, matches=20)
    with pytest.raises(momo.EstimationError, match="pinhole"):
        momo.estimate(seq.rig, seq.frame(1), metric="geo_line", loss={"scale": 1.0}, arc_length=1.0)
    with pytest.raises(momo.ConfigError, match="pinhole"):
        vo = momo.Odometry(seq.rig, momo.Config(metric="geo_line", loss={"scale": 1.0}))
        vo.process(seq.frame(1), 1.0)


# MatchError: malformed matches; the odometry is unchanged after one.

def test_matches_errors(rig):
    vo = momo.Odometry(rig)
    good = np.array([[600.0, 180.0, 601.0, 181.0]])
    with pytest.raises(momo.MatchError, match="2 entries, but the rig has 1"):
        vo.process([good, good])
    with pytest.raises(momo.MatchError, match=r"expected an \(N, 4\) array"):
        vo.process([np.zeros((3, 3))])
    with pytest.raises(momo.MatchError, match="non-finite"):
        vo.process([np.array([[np.nan, 1.0, 2.0, 3.0]])])
    with pytest.raises(momo.MatchError, match=r"row 0: .*outside"):
        vo.process([np.array([[1e5, 1.0, 2.0, 3.0]])])
    with pytest.raises(momo.MatchError, match="one .N, 4. array per camera"):
        vo.process("matches")
    with pytest.raises(momo.MatchError, match="not an array of numbers"):
        vo.process([[["a", "b", "c", "d"]]])
    assert vo.frames == 1  # nothing was processed
    _, d = vo.process([None])
    assert d.status == "no_matches" and d.frame == 1


# EstimationError and SimulationError.

def test_estimate_too_few_matches(rig):
    with pytest.raises(momo.EstimationError, match="matches for"):
        momo.estimate(rig, [np.array([[600.0, 180.0, 601.0, 181.0]])])


def test_simulation_errors():
    with pytest.raises(momo.SimulationError, match="unknown scenario `nope`"):
        momo.simulate("nope")
    with pytest.raises(momo.SimulationError, match="frames must be"):
        momo.simulate("clean_pinhole", frames=0)
    with pytest.raises(momo.SimulationError, match="no poses"):
        momo.simulate("clean_pinhole", frames=5, trajectory=np.zeros((0, 4, 4)))
