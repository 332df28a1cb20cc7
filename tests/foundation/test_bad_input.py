"""Bad input: one clear message (file, field, what was expected), exit status 2, no output left."""

import subprocess
import sys

import pytest

from testbed import cli
from testbed.bodies.containers import CONTAINER_TYPES, ContainerType

GOOD = """name: bad_input_probe
duration: 0.01
containers:
- name: a
  type: 1CC
  mass: 20000
  X_WC: {translation: [0, 0, 1.2955]}
effects:
  contact: {}
"""

CASES = {
    # name: (scene text, substrings the message must contain)
    "malformed_yaml": ("name: [unclosed\n", ["malformed YAML"]),
    "unknown_field": (GOOD.replace("  mass: 20000", "  mas: 20000"), ["containers[0].mas", "unknown field", "expected one of"]),
    "unknown_effect": (GOOD + "  lightning: {}\n", ["effects.lightning", "unknown effect", "contact_log"]),
    "unknown_contact_model": (GOOD.replace("contact: {}", "contact: {model: magic}"), ["effects.contact.model", "magic", "hydroelastic_with_fallback"]),
    "unknown_approximation": (GOOD.replace("contact: {}", "contact: {approximation: fast}"), ["effects.contact.approximation", "sap"]),
    "unknown_container_type": (GOOD.replace("type: 1CC", "type: 45ft"), ["containers[0].type", "45ft", "1AAA"]),
    "negative_mass": (GOOD.replace("mass: 20000", "mass: -5"), ["containers[0].mass", "positive"]),
    "zero_mass": (GOOD.replace("mass: 20000", "mass: 0"), ["containers[0].mass", "positive"]),
    "mass_not_a_number": (GOOD.replace("mass: 20000", "mass: heavy"), ["containers[0].mass", "number"]),
    "com_outside_box": (GOOD.replace("  mass: 20000", "  mass: 20000\n  com_offset: [3.5, 0, 0]"), ["containers[0].com_offset", "outside"]),
    "overlap_at_start": (GOOD + "", None),  # filled below
    "plant_contact_model_disagrees": (GOOD + "plant: {contact_model: point}\n", ["plant.contact_model", "effects.contact"]),
    "negative_duration": (GOOD.replace("duration: 0.01", "duration: -1"), ["duration", "positive"]),
}
OVERLAP = GOOD.replace("effects:", """- name: b
  type: 1CC
  mass: 10000
  X_WC: {translation: [0, 0, 3.80]}
effects:""")
CASES["overlap_at_start"] = (OVERLAP, ["containers[1].X_WC", "overlaps", "overlap_tolerance"])


def _run_cli(tmp_path, scene_text, *extra):
    scene = tmp_path / "scene.yaml"
    scene.write_text(scene_text)
    out = tmp_path / "out" / "run"
    code = cli.main(["run", str(scene), "--out", str(out), "--quiet", *extra])
    return code, scene, out


@pytest.mark.parametrize("case", sorted(CASES))
def test_bad_scene_exits_2_with_a_clear_message(case, tmp_path, capsys):
    text, needles = CASES[case]
    code, scene, out = _run_cli(tmp_path, text)
    err = capsys.readouterr().err
    assert code == 2
    assert str(scene) in err
    for needle in needles:
        assert needle in err, (needle, err)
    assert err.count("\n") == 1  # one line
    assert not out.exists()
    assert not (tmp_path / "out").exists() or list((tmp_path / "out").iterdir()) == []


def test_good_scene_passes_the_same_path(tmp_path, capsys):
    code, _, out = _run_cli(tmp_path, GOOD)
    assert code == 0, capsys.readouterr().err
    assert {"scenario.yaml", "summary.json"} <= {p.name for p in out.iterdir()}
    assert [p.name for p in (tmp_path / "out").iterdir()] == ["run"]  # no temporary left


@pytest.mark.parametrize("override, needles", [
    ("containers[5].mass=1", ["containers[5]", "out of range (1 entries)"]),
    ("nonsense", ["--set", "key=value"]),
    ("duration=soon", ["duration", "number"]),
    ("containers[0].mass=-5", ["containers[0].mass", "positive"]),  # checked after the overrides
])
def test_bad_override(override, needles, tmp_path, capsys):
    """Every --set error says the overrides are in play, not the file alone."""
    code, scene, out = _run_cli(tmp_path, GOOD, "--set", override)
    err = capsys.readouterr().err
    assert code == 2
    assert f"{scene} (with --set overrides): " in err and err.count("\n") == 1
    for needle in needles:
        assert needle in err, (needle, err)
    assert not out.exists()


def test_missing_scene_file(tmp_path, capsys):
    code = cli.main(["run", str(tmp_path / "nope.yaml"), "--quiet", "--out", str(tmp_path / "o")])
    err = capsys.readouterr().err
    assert code == 2 and "nope.yaml" in err and "cannot read" in err


def test_missing_sdf(tmp_path, capsys, monkeypatch):
    broken = ContainerType(**{**CONTAINER_TYPES["1CC"].__dict__, "model_url": "package://testbed/containers/missing.sdf"})
    monkeypatch.setitem(CONTAINER_TYPES, "1CC", broken)
    from testbed.bodies import models as model_loading

    model_loading._read_model.cache_clear()
    code, _, out = _run_cli(tmp_path, GOOD)
    err = capsys.readouterr().err
    assert code == 2 and "missing.sdf" in err and "not found" in err
    assert not out.exists()


def test_exit_status_is_2_from_the_real_command(tmp_path):
    scene = tmp_path / "scene.yaml"
    scene.write_text(GOOD.replace("type: 1CC", "type: 45ft"))
    out = subprocess.run([sys.executable, "-m", "testbed.cli", "run", str(scene), "--quiet", "--out", str(tmp_path / "o")],
                         capture_output=True, text=True, timeout=300)
    assert out.returncode == 2
    assert "containers[0].type" in out.stderr
    assert not (tmp_path / "o").exists()


@pytest.mark.parametrize("override,field,suggestion", [
    ("containers[0].masss=3", "containers[0].masss", "did you mean 'mass'?"),
    ("effects.cran={}", "effects.cran", "did you mean 'crane'?"),
    ("containers[0].type=1AAA2", "containers[0].type", "did you mean '1AAA' or '1AA'?"),
])
def test_a_mistyped_name_gets_the_names_it_was_close_to(override, field, suggestion):
    """One line naming the field, the close names first, then the whole short list."""
    from testbed.errors import ScenarioError
    from testbed.scenario import load_scenario

    with pytest.raises(ScenarioError) as info:
        load_scenario("two_stack", overrides=[override])
    message = str(info.value)
    assert f": {field}: " in message and suggestion in message and "expected one of: " in message, message
    assert "\n" not in message


def test_a_long_list_of_names_is_cut_and_counted():
    from testbed.errors import LISTED, one_of

    names = [f"blk_r{i}_b1_t1" for i in range(200)]
    text = one_of("blk_r1_b1_t9", names)
    assert text.startswith("did you mean 'blk_r1_b1_t1'") and f"({200 - LISTED} more, 200 in all)" in text
    assert len(text) < 300  # was 2,952 characters for a 200-container yard
    assert one_of("zzz", ["a", "b"]) == "expected one of: a, b"


def test_set_reaches_a_rotations_angles():
    """--set containers[i].X_WC.rotation.deg[k]: into a scene's !Rpy rotation, or from no rotation (the
    identity); a rotation given otherwise is refused naming the field (it was 'the parent is not a mapping')."""
    import numpy as np

    from testbed.errors import ScenarioError
    from testbed.scenario import load_scenario

    def rpy(scenario, i):
        return np.degrees(scenario.containers[i].pose().rotation().ToRollPitchYaw().vector())

    assert np.allclose(rpy(load_scenario("corner_drop", overrides=["containers[3].X_WC.rotation.deg[1]=7.5"]), 3),
                       [6.0, 7.5, 3.0], atol=1e-6)
    assert np.allclose(rpy(load_scenario("two_stack", overrides=["containers[1].X_WC.rotation.deg[2]=30"]), 1),
                       [0.0, 0.0, 30.0], atol=1e-6)
    with pytest.raises(ScenarioError, match=r"containers\[1\]\.X_WC\.rotation\.deg: --set: the rotation is not given"):
        load_scenario("two_stack", overrides=["containers[1].X_WC.rotation=!AngleAxis {angle_deg: 10, axis: [0, 0, 1]}",
                                              "containers[1].X_WC.rotation.deg[2]=30"])


@pytest.mark.parametrize("argv, wanted", [
    (["compare", "two_stack", "--engine", "mujocoo"], "did you mean 'mujoco'?"),
    (["study", "sclae"], "did you mean 'scale'?"),
    (["compar", "two_stack"], "did you mean 'compare'?"),
])
def test_a_mistyped_choice_is_one_line_with_a_suggestion(argv, wanted, capsys):
    """argparse's choices (engines, studies, commands) answer as the scene fields do: one line on stderr
    naming the option and the closest choice, exit status 2, nothing on stdout."""
    from testbed import cli

    with pytest.raises(SystemExit) as info:
        cli.main(argv)
    out, err = capsys.readouterr()
    assert info.value.code == 2 and out == ""
    assert len(err.strip().splitlines()) == 1 and err.startswith("testbed: error: ") and wanted in err
    assert "expected one of:" in err
