"""The two supported Drake releases (1.51.1 on Python 3.11, 1.58.0 on Python >= 3.12):
testbed.drake_support's feature test for TAMSI, the clear error where Drake lacks it, and the
sweeps that list only what the installed Drake has. Every test runs on both releases and
checks the answer that release must give."""

from importlib import metadata

import pytest
from pydrake.multibody.plant import AddMultibodyPlant, MultibodyPlantConfig
from pydrake.systems.framework import DiagramBuilder

from testbed import cli
from testbed.drake_support import available, drake_version, has_tamsi, missing_approximation
from testbed.errors import ScenarioError
from testbed.scenario import load_scenario
from testbed.studies.stability import matrix_cases
from testbed.validation.cases.sim_sweep import SimSweepCase

SCENE = """name: tamsi_probe
duration: 0.01
containers:
- name: a
  type: 1CC
  mass: 20000
  X_WC: {translation: [0, 0, 1.3]}
effects:
  contact: {model: point, approximation: tamsi}
"""


def _drake_accepts_tamsi() -> bool:
    """The ground truth the feature test must agree with: does Drake build a plant with TAMSI?"""
    try:
        AddMultibodyPlant(MultibodyPlantConfig(time_step=1e-3, discrete_contact_approximation="tamsi"), DiagramBuilder())
    except RuntimeError as e:
        assert "tamsi" in str(e)  # Drake's own message: "Unknown discrete_contact_approximation: 'tamsi'"
        return False
    return True


def test_has_tamsi_agrees_with_drake_building_a_plant():
    assert has_tamsi() == _drake_accepts_tamsi()


def test_the_pinned_releases_are_the_ones_installed():
    """pyproject.toml pins drake 1.51.1 below Python 3.12 and 1.58.0 from 3.12: TAMSI exists in the first only."""
    assert drake_version() == metadata.version("drake")
    assert drake_version() in ("1.51.1", "1.58.0")
    assert has_tamsi() == (drake_version() == "1.51.1")


def test_available_drops_tamsi_only_where_drake_lacks_it():
    names = ("sap", "tamsi", "similar", "lagged")
    assert available(names) == (names if has_tamsi() else ("sap", "similar", "lagged"))
    for name in ("auto", "sap", "similar", "lagged"):
        assert missing_approximation(name) is None
    assert (missing_approximation("tamsi") is None) == has_tamsi()


def test_a_tamsi_scene_loads_or_fails_naming_the_installed_drake(tmp_path, capsys):
    path = tmp_path / "tamsi.yaml"
    path.write_text(SCENE)
    if has_tamsi():
        assert load_scenario(path).plant.discrete_contact_approximation == "tamsi"
        return
    with pytest.raises(ScenarioError) as info:
        load_scenario(path)
    message = str(info.value)
    assert message.startswith(f"{path}: effects.contact.approximation: 'tamsi' is not available in the installed Drake {drake_version()}")
    assert "\n" not in message
    # the CLI prints it on one line and exits 2, writing no run directory
    assert cli.main(["run", str(path), "--out", str(tmp_path / "run")]) == 2
    assert "is not available in the installed Drake" in capsys.readouterr().err
    assert not (tmp_path / "run").exists()


def test_sweeps_and_the_stability_matrix_list_only_what_drake_has():
    approximations = {a for s in ("default", "full") for c in SimSweepCase().cases(s) for a in c.params["approximations"]}
    assert ("tamsi" in approximations) == has_tamsi()
    assert {"sap", "similar", "lagged"} <= approximations
    matrix = {kw.get("approximation") for _, kw in matrix_cases(quick=False)}
    assert ("tamsi" in matrix) == has_tamsi()


def test_the_validation_summary_names_the_installed_drake_and_mujoco(tmp_path):
    """`testbed validate`'s summary.md (what CI logs show) and index.html name, on their first
    screen, the Drake and MuJoCo versions the suite ran on and the commit."""
    import json

    assert cli.main(["validate", "--suite", "smoke", "--out", str(tmp_path), "--quiet", "--workers", "1"]) == 0
    (run,) = [p for p in tmp_path.iterdir() if p.is_dir()]
    env = json.loads((run / "metrics.json").read_text())["environment"]
    assert env["drake"] == drake_version()
    line = f"Drake {drake_version()}, mujoco {env['engines']['mujoco']}, "
    summary = (run / "summary.md").read_text()
    assert line in summary and line in (run / "index.html").read_text()
    assert summary.index(line) < summary.index("## ")  # before the first section: the first screen
    assert f"commit {env['commit']}" in summary


def test_the_defaults_sweep_refuses_tamsi_where_drake_lacks_it(tmp_path, capsys):
    """`testbed study defaults --approximations tamsi` under Drake >= 1.57: one line naming the
    installed Drake, exit 2, before any case runs (under 1.51.1 TAMSI is a valid axis value)."""
    if has_tamsi():
        assert missing_approximation("tamsi") is None
        return
    code = cli.main(["study", "defaults", "--approximations", "sap,tamsi", "--cases", "near_parallel", "--quiet",
                     "--out", str(tmp_path / "study")])
    err = capsys.readouterr().err
    assert code == 2 and err.count("\n") == 1
    assert f"--approximations: 'tamsi' is not available in the installed Drake {drake_version()}" in err
    assert not (tmp_path / "study" / "defaults_rows.jsonl").exists()
