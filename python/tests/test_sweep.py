"""tandem.sweep against `tandem sweep`."""

import numpy as np
import pytest

import tandem

SWEEP = {
    "base": "paper",
    "duration": 1,
    "seed": 3,
    "runs": 2,
    "vary": {
        "controller.nn.k1": {"grid": [[4, 4, 4], [8, 8, 8]]},
        "object.mass": {"uniform": [0.8, 1.2]},
    },
}

SWEEP_TOML = """base = "paper"
duration = 1
seed = 3
runs = 2

[vary]
"controller.nn.k1" = { grid = [[4, 4, 4], [8, 8, 8]] }
"object.mass" = { uniform = [0.8, 1.2] }
"""


def test_sweep_equals_cli(cli, tmp_path):
    pd = pytest.importorskip("pandas")
    f = tmp_path / "s.toml"
    f.write_text(SWEEP_TOML)
    cli("sweep", f, "--out", tmp_path / "out", "--no-figures", "--threads", "2")
    expected = pd.read_csv(tmp_path / "out" / "runs.csv")
    from_file = tandem.sweep(f, threads=2)
    from_dict = tandem.sweep(SWEEP, threads=1)
    assert len(expected) == 4
    pd.testing.assert_frame_equal(from_file, expected)
    pd.testing.assert_frame_equal(from_dict, expected)
    assert (from_dict["status"] == "completed").all()


def test_sweep_dict_of_arrays_and_shards():
    full = tandem.sweep(SWEEP, frame=False)
    assert full["index"].dtype == np.int64 and list(full["index"]) == [0, 1, 2, 3]
    assert full["rms_z1"].dtype == np.float64
    assert list(full["controller.nn.k1"]) == ["[4, 4, 4]", "[4, 4, 4]", "[8, 8, 8]", "[8, 8, 8]"]
    a = tandem.sweep(SWEEP, shard="0/2", frame=False)
    b = tandem.sweep(SWEEP, shard=(1, 2), frame=False)
    assert list(a["index"]) == [0, 2] and list(b["index"]) == [1, 3]
    assert np.array_equal(a["rms_z1"], full["rms_z1"][[0, 2]])
    assert np.array_equal(b["rms_z1"], full["rms_z1"][[1, 3]])


def test_sweep_errors():
    with pytest.raises(tandem.ScenarioError, match="did you mean `vary`"):
        tandem.sweep({"base": "paper", "vari": {}})
    with pytest.raises(tandem.ScenarioError, match="shard 2 of 2 does not exist"):
        tandem.sweep(SWEEP, shard="2/2")
