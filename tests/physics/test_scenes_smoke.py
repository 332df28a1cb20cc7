"""Every shipped scene loads, builds and runs a few steps; the defaults scene is always valid."""

import numpy as np
import pytest

from testbed import Scenario, build_scene, load_scenario, run_scenario, shipped_scenes
from testbed.scenario import dump_scenario

SCENES = sorted(shipped_scenes())


def test_the_shipped_scene_set_is_complete():
    expected = {"defaults", "single_drop", "two_stack", "five_stack", "nine_mixed_stack", "bridge", "windy_stack"}
    assert expected <= set(SCENES)


@pytest.mark.parametrize("name", SCENES)
def test_scene_builds_and_runs_a_few_steps(name):
    scenario = load_scenario(name)
    result = run_scenario(scenario, duration=5 * scenario.plant.time_step)
    assert result.summary["steps"] == 5
    assert result.summary["finite_state"]
    assert np.all(np.isfinite(result.final_positions))


def test_defaults_scene_is_the_default_scenario():
    assert dump_scenario(load_scenario("defaults")) == dump_scenario(Scenario())
    build_scene(Scenario())


@pytest.mark.parametrize("name", SCENES)
def test_dumped_scenario_reloads_identically(name, tmp_path):
    scenario = load_scenario(name)
    path = tmp_path / "resolved.yaml"
    path.write_text(dump_scenario(scenario))
    assert dump_scenario(load_scenario(path)) == dump_scenario(scenario)
