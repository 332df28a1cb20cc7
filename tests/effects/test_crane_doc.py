"""docs/scenes.md's crane section keeps up with the crane effect: every field of its config
dataclasses (CraneConfig, CraneMove) and every move kind is named there, and the worked
example's slot positions and profile times are what the shipped yard_crane_slot scene and the
effect's own profile give."""

from __future__ import annotations

import dataclasses
from pathlib import Path

import pytest

from testbed.effects.crane import CraneConfig, CraneMove, Profile
from testbed.scenario import load_scenario

DOC = Path(__file__).resolve().parents[2] / "docs" / "scenes.md"
HEADING = "## The crane effect: `crane`"


def _section() -> str:
    text = DOC.read_text()
    assert HEADING in text, f"{DOC} has no section {HEADING!r}"
    after = text.split(HEADING, 1)[1]
    return after.split("\n## ", 1)[0]


@pytest.mark.parametrize("config", [CraneConfig, CraneMove])
def test_every_field_of_the_crane_config_is_documented(config):
    section = _section()
    missing = [f.name for f in dataclasses.fields(config) if f"`{f.name}`" not in section]
    assert not missing, f"docs/scenes.md's crane section does not name {config.__name__}'s fields {missing}"


def test_every_move_kind_is_documented():
    section = _section()
    # the kinds the effect's check accepts (its error message lists them): each a row of the moves table
    for kind in ("trolley", "hoist", "pause"):
        assert f"| `{kind}` |" in section


def test_the_worked_example_is_the_shipped_scene_s():
    scenario = load_scenario("yard_crane_slot")
    section = _section()
    beside = {c.name: c.pose().translation() for c in scenario.containers if c.name.startswith("blk_r1")}
    x, y, z = beside["blk_r1_b1_t2"]
    assert f"({x:.3f}, {y:.1f})" in section and f"z = {z:.4f} m" in section
    crane = scenario.effects.crane
    load = next(c for c in scenario.containers if c.name == crane.container)
    profile = Profile(crane.moves, load.pose().translation()[0])  # the trolley starts over the load
    assert f"ends at {profile.end_time:.3f} s" in section and f"inside the scene's {scenario.duration:g} s" in section
    assert profile.end_time < scenario.duration
    assert f"trolley_height: {crane.trolley_height:g}" in section
