"""Inputs that used to slip through the scene loader, round trips of written scenes, and a
generated bad-input test: every mutated scene either loads or fails with one ScenarioError."""

import copy

import pytest
import yaml
from hypothesis import HealthCheck, given, settings, strategies as st
from test_bad_input import GOOD  # noqa: E402  (the same minimal valid scene)

from testbed import cli
from testbed.errors import ScenarioError
from testbed.scenario import BOUNDS, dump_scenario, load_scenario, shipped_scenes
from testbed.scene_yaml import SceneDumper, SceneLoader


def _run_bytes(tmp_path, data: bytes):
    scene = tmp_path / "scene.yaml"
    scene.write_bytes(data)
    out = tmp_path / "out" / "run"
    code = cli.main(["run", str(scene), "--out", str(out), "--quiet"])
    return code, scene, out


@pytest.mark.parametrize("data, needles", [
    # Latin-1 text (an 'ä' in a description): used to be a UnicodeDecodeError traceback
    (GOOD.replace("bad_input_probe", "k\xe4fig").encode("latin-1"), ["UTF-8", "line 1"]),
    # an empty file and a file with only comments: used to run the defaults scene silently
    (b"", ["empty"]),
    (b"# nothing here\n\n", ["empty"]),
    # physically absurd values: used to reach the solver
    (GOOD.replace("mass: 20000", "mass: 1e30").encode(), ["containers[0].mass", "supported range"]),
    (GOOD.replace("  mass: 20000", "  mass: 20000\n  V_WC: [0, 0, 0, 1e9, 0, 0]").encode(), ["containers[0].V_WC", "speed"]),
    (GOOD.replace("  mass: 20000", "  mass: 20000\n  V_WC: [0, 0, 1e4, 0, 0, 0]").encode(), ["containers[0].V_WC", "angular"]),
    (GOOD.replace("[0, 0, 1.2955]", "[1e7, 0, 1.2955]").encode(), ["containers[0].X_WC.translation", "supported range"]),
    (GOOD.replace("duration: 0.01", "duration: 1e7").encode(), ["duration", "supported range"]),
    (GOOD.replace("duration: 0.01", "duration: 0.01\nplant: {time_step: 5.0}").encode(), ["plant.time_step", "supported range"]),
])
def test_bad_bytes_exit_2_with_one_line(data, needles, tmp_path, capsys):
    code, scene, out = _run_bytes(tmp_path, data)
    err = capsys.readouterr().err
    assert code == 2, err
    assert str(scene) in err
    for needle in needles:
        assert needle in err, (needle, err)
    assert err.count("\n") == 1
    assert not out.exists()


def test_bounds_admit_the_stress_suite_and_a_small_cube():
    """The ranges must not reject the deliberately extreme but meaningful scenes."""
    assert BOUNDS["mass"][0] <= 0.37 and BOUNDS["mass"][1] >= 32500.0  # calibration cube, loaded 1AAA
    load_scenario(text=GOOD.replace("mass: 20000", "mass: 32.5"))  # the stress suite's mass ratio 1000


# ----------------------------------------------------------------------------- round trips


def _contact_variants(name):
    scenario = load_scenario(name)
    if scenario.effects.contact is None:
        return [scenario]
    out = []
    for model in ("hydroelastic", "point", "hydroelastic_with_fallback"):
        for approx in ("sap", "similar"):
            s = copy.deepcopy(scenario)
            s.effects.contact.model = model  # what run-all and the studies do in code
            s.effects.contact.approximation = approx
            out.append(s)
    return out


@pytest.mark.parametrize("name", sorted(shipped_scenes()))
def test_dumped_scenes_load_back_to_the_same_scenario(name):
    """run-all used to write a scenario.yaml that the loader rejected (plant.contact_model
    stale after effects.contact.model was changed in code)."""
    for s in _contact_variants(name):
        text = dump_scenario(s)
        back = load_scenario(text=text)
        assert back.effects.contact is None or back.effects.contact.model == s.effects.contact.model
        assert back.plant.contact_model == (s.effects.contact.model if s.effects.contact else s.plant.contact_model)
        assert dump_scenario(back) == text


def test_run_writes_a_scenario_that_loads_back(tmp_path, capsys):
    code, _, out = _run_bytes(tmp_path, GOOD.encode())
    assert code == 0, capsys.readouterr().err
    written = (out / "scenario.yaml").read_text()
    assert dump_scenario(load_scenario(out / "scenario.yaml")) == written


def test_run_all_variant_loads_back():
    from testbed.batch import _variant

    for name in ("five_stack", "windy_stack"):
        v = _variant(load_scenario(name), model="point", recorded=True)
        back = load_scenario(text=dump_scenario(v))
        assert back.effects.contact.model == "point" and back.plant.contact_model == "point"


# ----------------------------------------------------------------------------- generated bad input

_SCENES = {n: yaml.load(p.read_text(), Loader=SceneLoader) for n, p in shipped_scenes().items()}  # keeps !Rpy tags

_junk = st.one_of(
    st.none(), st.booleans(), st.integers(-10**12, 10**12),
    st.floats(allow_nan=True, allow_infinity=True), st.text(max_size=12),
    st.lists(st.floats(-1e3, 1e3), max_size=7), st.dictionaries(st.text(max_size=6), st.integers(), max_size=3),
)


def _paths(node, prefix=()):
    """Every (path) into a nested dict/list."""
    yield prefix
    if isinstance(node, dict):
        for k, v in node.items():
            yield from _paths(v, prefix + (k,))
    elif isinstance(node, list):
        for i, v in enumerate(node):
            yield from _paths(v, prefix + (i,))


@st.composite
def mutated_scene(draw):
    data = copy.deepcopy(_SCENES[draw(st.sampled_from(sorted(_SCENES)))])
    for _ in range(draw(st.integers(1, 3))):
        paths = [p for p in _paths(data) if p]
        if not paths:
            break
        path = draw(st.sampled_from(paths))
        parent = data
        for key in path[:-1]:
            parent = parent[key]
        action = draw(st.sampled_from(["replace", "delete", "rename"]))
        if action == "replace":
            parent[path[-1]] = draw(_junk)
        elif action == "delete":
            del parent[path[-1]]
        elif isinstance(parent, dict):
            parent[draw(st.text(min_size=1, max_size=8))] = parent.pop(path[-1])
    return yaml.dump(data, Dumper=SceneDumper, allow_unicode=True)


@settings(max_examples=400, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(mutated_scene())
def test_mutated_scenes_load_or_fail_cleanly(text):
    """Every outcome is a valid scene or one ScenarioError with a one-line message: never a
    traceback from PyYAML, Drake's typed loader, numpy or an effect's check."""
    try:
        scenario = load_scenario(text=text)
    except ScenarioError as e:
        message = str(e)
        assert message and "\n" not in message.strip(), message
        assert "Traceback" not in message
    else:
        assert scenario.containers and scenario.duration > 0
