"""Config: construction, round trips through TOML, JSON and dicts, the CLI's default."""

import momo
from conftest import cli


def test_default_round_trips():
    c = momo.Config.default()
    assert momo.Config.from_toml(c.to_toml()) == c
    assert momo.Config.from_json(c.to_json()) == c
    assert momo.Config.from_dict(c.to_dict()) == c
    assert momo.Config() == c


def test_non_default_round_trips():
    c = momo.Config(
        model="single_track_3d",
        metric="angle_plane",
        loss={"type": "huber", "scale": 0.0017453292519943296},
        solver={"max_iterations": 17},
        refine_loss={"type": "tukey", "scale": 0.0075},
        odometry={"min_matches": 11, "rotation_change_sigma": 0.0031},
        five_point={"seed": 7},
    )
    assert c != momo.Config.default()
    d = c.to_dict()
    assert d["model"]["type"] == "single_track_3d"
    assert d["loss"] == {"type": "huber", "scale": 0.0017453292519943296}
    assert d["solver"]["max_iterations"] == 17
    assert d["refine_loss"]["type"] == "tukey"
    assert d["odometry"]["min_matches"] == 11
    assert d["five_point"]["seed"] == 7
    for back in (momo.Config.from_toml(c.to_toml()), momo.Config.from_json(c.to_json()),
                 momo.Config.from_dict(d)):
        assert back == c
        assert back.to_dict() == d
    assert (c.model, c.metric, c.loss) == ("single_track_3d", "angle_plane", "huber")
    # replace() changes only what it names; refine_loss=None removes the second loss.
    r = c.replace(refine_loss=None, odometry={"min_matches": 20})
    assert "refine_loss" not in r.to_dict()
    assert r.to_dict()["odometry"]["min_matches"] == 20
    assert r.to_dict()["loss"] == d["loss"]


def test_file_round_trip(tmp_path):
    c = momo.Config(loss={"scale": 0.002})
    (tmp_path / "c.toml").write_text(c.to_toml())
    (tmp_path / "c.json").write_text(c.to_json())
    assert momo.Config.from_file(tmp_path / "c.toml") == c
    assert momo.Config.from_file(tmp_path / "c.json") == c


def test_cli_default_is_config_default(momo_bin):
    text = cli(momo_bin, "config").stdout
    assert momo.Config.from_toml(text, "momo config") == momo.Config.default()
    assert momo.Config.default().to_toml() == text
