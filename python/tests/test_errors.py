"""Bad input: Python raises ScenarioError with the field path and the command line's message."""

import pytest

import tandem


def test_bad_field_value_raises_with_path():
    sc = tandem.Scenario.preset("paper")
    with pytest.raises(tandem.ScenarioError) as e:
        sc.with_(**{"controller.nn.k1": [-1, 8, 8]})
    assert e.value.path == "controller.nn.k1"
    assert str(e.value) == (
        "the scenario rejects controller.nn.k1 = [-1, 8, 8]: "
        "controller.nn.k1[0] = -1: must be finite and > 0"
    )
    assert isinstance(e.value, ValueError)


def test_unknown_field_suggests():
    with pytest.raises(tandem.ScenarioError) as e:
        tandem.Scenario.preset("paper").with_(**{"controller.nn.kk1": [8, 8, 8]})
    assert e.value.path == "controller.nn.kk1"
    assert 'did you mean "controller.nn.k1"?' in str(e.value)


def test_with_message_is_the_sweep_message(cli, tmp_path):
    # The command line's sweep says the same about the same value in [set].
    f = tmp_path / "s.toml"
    f.write_text('base = "paper"\n[set]\n"controller.nn.k1" = [-1, 8, 8]\n')
    p = cli("sweep", f, "--out", tmp_path / "o", check=False)
    assert p.returncode == 2
    with pytest.raises(tandem.ScenarioError) as e:
        tandem.Scenario.preset("paper").with_(**{"controller.nn.k1": [-1, 8, 8]})
    assert str(e.value) in p.stderr


def test_bad_file_same_message_as_cli(cli, tmp_path):
    text = tandem.Scenario.preset("paper").to_toml().replace("k_c = [", "k_c = [-", 1)
    f = tmp_path / "bad.toml"
    f.write_text(text)
    p = cli("validate", f, check=False)
    assert p.returncode == 2
    with pytest.raises(tandem.ScenarioError) as e:
        tandem.Scenario.load(f)
    # `error: <message>` on stderr; the same message, excerpt included.
    assert p.stderr.strip() == f"error: {e.value}".strip()
    assert e.value.path == "controller.k_c[0]"
    assert e.value.file == str(f)
    with pytest.raises(tandem.ScenarioError) as e:
        tandem.Scenario.from_toml(text.replace("k_c", "k_cc"))
    assert e.value.path.endswith("k_cc")
    assert "did you mean `k_c`?" in str(e.value)


def test_unknown_preset_same_message_as_cli(cli):
    p = cli("run", "papr", check=False)
    with pytest.raises(tandem.ScenarioError) as e:
        tandem.Scenario.preset("papr")
    assert p.stderr.strip() == f"error: {e.value}"
    assert "did you mean `paper`?" in str(e.value)


def test_run_arguments():
    sc = tandem.Scenario.preset("paper")
    with pytest.raises(tandem.ScenarioError, match="duration=-1: must be a positive"):
        sc.run(duration=-1)
    with pytest.raises(TypeError, match="cannot be a scenario value"):
        sc.with_(**{"run.duration": object()})


def test_presets_listed():
    assert tandem.presets()[0] == "paper"
    assert set(tandem.presets()) >= {"paper", "push", "lemniscate"}
    for name in tandem.presets():
        assert tandem.Scenario.preset(name).name == name


def test_rollout_bad_input_names_the_scenario():
    sc = tandem.Scenario.preset("paper")
    # 0.01 s is shorter than the paper's 0.03 s log period: rejected before anything runs.
    with pytest.raises(tandem.ScenarioError) as e:
        tandem.rollout([sc, sc], duration=0.01)
    assert str(e.value).startswith("scenarios[0]: embedded scenario `paper`: run.log_period")
    assert e.value.path == "run.log_period"


def test_with_is_independent_of_the_order_of_its_keys(tmp_path):
    """`kind = "replay"` is only valid with its file: both orders of the two keys give the same
    scenario (the first order used to fail), and a bad file is blamed on `controller.replay`,
    not on the kind, in either order."""
    r = tmp_path / "tau.csv"
    r.write_text("t,tau1,tau2,tau3,tau4\n0,0,0,0,0\n")
    sc = tandem.Scenario.preset("paper")
    a = sc.with_(**{"controller.kind": "replay", "controller.replay": str(r)})
    b = sc.with_(**{"controller.replay": str(r), "controller.kind": "replay"})
    assert a.get("controller.kind") == b.get("controller.kind") == "replay"
    assert a.to_toml() == b.to_toml()
    for order in (
        {"controller.kind": "replay", "controller.replay": str(tmp_path / "missing.csv")},
        {"controller.replay": str(tmp_path / "missing.csv"), "controller.kind": "replay"},
    ):
        with pytest.raises(tandem.ScenarioError) as e:
            sc.with_(**order)
        assert e.value.path == "controller.replay", (order, e.value.path, str(e.value))
