"""Yard blocks: a `yards:` field expands into plain containers.

Positions are checked to 1e-9 m (the expansion rounds to 1 nm); the layout is exact
arithmetic on ISO 668 sizes: centre pitch = size + gap, tier pitch = height.
"""

import numpy as np
import pytest

from testbed.bodies.containers import CONTAINER_TYPES
from testbed.bodies.yards import YardSpec
from testbed.errors import ScenarioError
from testbed.scenario import Scenario, dump_scenario, load_scenario, validate_scenario

L, W, H = CONTAINER_TYPES["1AA"].size

SCENE = """
name: yard_test
duration: 0.5
yards:
- name: blk
  type: 1AA
  origin: [10.0, -5.0]
  rows: 2
  bays: 3
  tiers: 2
  masses: [24000.0, 14000.0]
effects: {contact: {model: point}, friction: {}}
"""


def _by_name(scenario):
    return {c.name: c for c in scenario.containers}


def test_a_block_expands_into_touching_stacks_with_the_gaps():
    s = load_scenario(text=SCENE)
    assert len(s.containers) == 12 and s.yards == []  # no default container beside the block
    c = _by_name(s)
    p = {n: np.asarray(x.pose().translation()) for n, x in c.items()}
    assert np.allclose(p["blk_r1_b1_t1"], [10.0 - (L + 0.6), -5.0 - (W + 0.4) / 2, H / 2], atol=1e-9)
    assert np.allclose(p["blk_r2_b3_t2"] - p["blk_r1_b1_t1"], [2 * (L + 0.6), W + 0.4, H], atol=1e-9)
    assert p["blk_r1_b2_t2"][2] - p["blk_r1_b2_t1"][2] == pytest.approx(H, abs=1e-9)  # face on face, no overlap
    assert [c[f"blk_r1_b1_t{t}"].mass for t in (1, 2)] == [24000.0, 14000.0]
    assert all(x.type == "1AA" and not x.fixed for x in c.values())


def test_yaw_turns_the_block_about_its_centre():
    s = load_scenario(text=SCENE.replace("origin: [10.0, -5.0]", "origin: [0.0, 0.0]\n  yaw_deg: 90.0"))
    c = _by_name(s)
    p = np.asarray(c["blk_r1_b1_t1"].pose().translation())
    assert np.allclose(p, [(W + 0.4) / 2, -(L + 0.6), H / 2], atol=1e-9)
    assert np.allclose(c["blk_r1_b1_t1"].pose().rotation().matrix()[:, 0], [0, 1, 0], atol=1e-12)  # length along world y


def test_drawn_masses_follow_the_seed_and_sit_heaviest_at_the_bottom():
    text = SCENE.replace("masses: [24000.0, 14000.0]", "mass_range: [5000.0, 30000.0]\n  seed: 7")
    a, b = load_scenario(text=text), load_scenario(text=text)
    masses = [c.mass for c in a.containers]
    assert masses == [c.mass for c in b.containers]
    assert masses != [c.mass for c in load_scenario(text=text.replace("seed: 7", "seed: 8")).containers]
    assert all(5000.0 <= m <= 30000.0 for m in masses)
    assert all(masses[k] >= masses[k + 1] for k in range(0, len(masses), 2))  # tier 1 >= tier 2 per stack


def test_empty_slots_tares_and_listed_containers():
    text = SCENE.replace("  masses: [24000.0, 14000.0]\n", "  empty: [{row: 2, bay: 2}]\n") + \
        "containers:\n- {name: load, type: 1CC, X_WC: {translation: [0, 0, 20]}}\n"
    s = load_scenario(text=text)
    names = [c.name for c in s.containers]
    assert names[0] == "load" and len(names) == 1 + 10 and "blk_r2_b2_t1" not in names
    assert all(c.total_mass() == CONTAINER_TYPES["1AA"].tare_mass for c in s.containers[1:])


def test_the_dump_lists_plain_containers_and_reloads_identically(tmp_path):
    s = load_scenario(text=SCENE)
    text = dump_scenario(s)
    assert "yards: []" in text
    again = load_scenario(text=text)
    assert dump_scenario(again) == text


def test_overrides_reach_the_block():
    s = load_scenario(text=SCENE, overrides=["yards[0].rows=3", "yards[0].masses=[20000.0, 10000.0]"])
    assert len(s.containers) == 18 and s.containers[0].mass == 20000.0


def test_a_scenario_built_in_code_expands_when_validated():
    s = Scenario(containers=[], yards=[YardSpec(rows=1, bays=2, tiers=3)])
    validate_scenario(s)
    assert len(s.containers) == 6 and s.yards == []
    validate_scenario(s)  # idempotent
    assert len(s.containers) == 6


BAD = [
    ("type: 1AA", "type: 1XX", "yards[0].type"),
    ("type: 1AA", "type: box", "yards[0].type"),
    ("rows: 2", "rows: 0", "yards[0].rows"),
    ("rows: 2", "rows: 2.5", "yards[0].rows"),
    ("bays: 3", "bays: -1", "yards[0].bays"),
    ("tiers: 2", "tiers: 13", "yards[0].tiers"),
    ("rows: 2", "rows: 200", "yards[0]"),
    ("origin: [10.0, -5.0]", "origin: [10.0]", "yards[0].origin"),
    ("origin: [10.0, -5.0]", "origin: [10.0, .nan]", "yards[0].origin"),
    ("origin: [10.0, -5.0]", "origin: [10.0, -5.0]\n  yaw_deg: .inf", "yards[0].yaw_deg"),
    ("origin: [10.0, -5.0]", "origin: [10.0, -5.0]\n  row_gap: -0.1", "yards[0].row_gap"),
    ("origin: [10.0, -5.0]", "origin: [10.0, -5.0]\n  bay_gap: .nan", "yards[0].bay_gap"),
    ("masses: [24000.0, 14000.0]", "masses: [24000.0]", "yards[0].masses"),
    ("masses: [24000.0, 14000.0]", "masses: [24000.0, 1000.0]", "yards[0].masses[1]"),
    ("masses: [24000.0, 14000.0]", "masses: [24000.0, 14000.0]\n  mass_range: [5000.0, 9000.0]", "yards[0].mass_range"),
    ("masses: [24000.0, 14000.0]", "mass_range: [9000.0, 5000.0]", "yards[0].mass_range"),
    ("masses: [24000.0, 14000.0]", "mass_range: [5000.0, 90000.0]", "yards[0].mass_range"),
    ("masses: [24000.0, 14000.0]", "mass_range: [5000.0, 9000.0]\n  seed: -1", "yards[0].seed"),
    ("masses: [24000.0, 14000.0]", "empty: [{row: 3, bay: 1}]", "yards[0].empty[0].row"),
    ("masses: [24000.0, 14000.0]", "empty: [{row: 1, bay: 1}, {row: 1, bay: 1}]", "yards[0].empty[1]"),
    ("masses: [24000.0, 14000.0]", "empty: [{row: 1, bay: 1}, {row: 1, bay: 2}, {row: 1, bay: 3}, {row: 2, bay: 1}, "
                                   "{row: 2, bay: 2}, {row: 2, bay: 3}]", "yards[0].empty"),
    ("masses: [24000.0, 14000.0]", "masses: [24000.0, 14000.0]\n  colour: red", "yards[0].colour"),
    ("name: blk", "name: 'a b'", "yards[0].name"),
    ("effects:", "containers:\n- {name: blk_r1_b1_t1, type: 1CC, X_WC: {translation: [50, 0, 1.2955]}}\neffects:", "yards[0].name"),
]


@pytest.mark.parametrize("old,new,field", BAD)
def test_bad_yard_fields_name_the_field(old, new, field):
    assert old in SCENE
    with pytest.raises(ScenarioError) as info:
        load_scenario(text=SCENE.replace(old, new, 1))
    assert info.value.field == field, str(info.value)
    assert "\n" not in str(info.value)


@pytest.mark.parametrize("name, count", [("yard_small", 8), ("yard_block", 96), ("yard_crane_slot", 5), ("yard_wind", 18)])
def test_shipped_yards(name, count):
    s = load_scenario(name)
    assert len(s.containers) == count


def test_a_block_beyond_the_supported_positions_names_its_origin():
    with pytest.raises(ScenarioError) as info:
        load_scenario(text=SCENE.replace("origin: [10.0, -5.0]", "origin: [995.0, 0.0]"))
    assert info.value.field == "yards[0].origin"
