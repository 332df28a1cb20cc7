"""Validate's closed-loop set covers every shipped scene with container-container contact:
each such scene (`testbed scenes` marks it [cc]: testbed.commands.scenes.container_contact) is
in the default set (testbed.gates.closed_loop.DEFAULT_SCENES), in the full suite's extra set
(FULL_EXTRA, with why the default leaves it out) or in EXCLUDED with its reason; and the suites
run what those lists say.
"""

from pathlib import Path

import pytest

from testbed.commands.scenes import container_contact
from testbed.gates import closed_loop as cl
from testbed.scenario import load_scenario
from testbed.validation.suites import suite

SCENES = Path(__file__).resolve().parents[2] / "testbed" / "scenes"
YAMLS = sorted(SCENES.glob("*.yaml"))
DEFAULT = dict(cl.DEFAULT_SCENES)
EXTRA = dict(cl.FULL_EXTRA)


def test_the_scene_files_are_found():
    assert len(YAMLS) >= 20 and (SCENES / "two_stack.yaml") in YAMLS


@pytest.mark.parametrize("path", YAMLS, ids=[p.stem for p in YAMLS])
def test_every_container_contact_scene_is_judged_or_excluded_with_a_reason(path):
    scenario = load_scenario(path)
    if not container_contact(scenario):
        # a scene without a pair the learned model decides: the closed loop cannot judge it
        assert path.stem not in DEFAULT and path.stem not in EXTRA, path.stem
        return
    places = [name for name, where in (("DEFAULT_SCENES", DEFAULT), ("FULL_EXTRA", EXTRA), ("EXCLUDED", cl.EXCLUDED))
              if path.stem in where]
    assert len(places) == 1, f"{path.stem}: in {places or 'no list'}; expected exactly one of DEFAULT_SCENES, " \
                             "FULL_EXTRA, EXCLUDED (testbed/gates/closed_loop.py)"
    if places[0] == "EXCLUDED":
        assert len(cl.EXCLUDED[path.stem].strip()) > 20, "an exclusion states its reason"


def test_the_lists_name_shipped_scenes_once_with_their_reasons():
    shipped = {p.stem for p in YAMLS}
    names = [s for s, _ in cl.DEFAULT_SCENES + cl.FULL_EXTRA] + list(cl.EXCLUDED)
    assert len(names) == len(set(names)), "a scene listed twice"
    assert set(names) <= shipped, set(names) - shipped
    assert all(d > 0 for _, d in cl.DEFAULT_SCENES + cl.FULL_EXTRA)
    assert set(cl.FULL_EXTRA_WHY) == set(EXTRA) and all(len(w) > 10 for w in cl.FULL_EXTRA_WHY.values())
    # every pinned known limit belongs to a scene some suite runs
    assert set(cl.KNOWN_LIMITS) <= set(DEFAULT) | set(EXTRA)


def _closed(name: str) -> dict:
    return {c.params["scene"]: c for c in suite(name) if c.kind == "closed_loop"}


def test_the_suites_run_the_lists():
    default, full = _closed("default"), _closed("full")
    assert set(default) == set(DEFAULT)
    assert set(full) == set(DEFAULT) | set(EXTRA)
    for scene, case in full.items():
        assert case.params["duration"] == {**DEFAULT, **EXTRA}[scene]
        # the full suite's extra cases are made like the default's: the same predictors
        assert case.params["predictors"] == next(iter(default.values())).params["predictors"]
        assert case.id == f"closed-{scene}"


def test_the_first_screen_states_what_the_closed_loop_left_out():
    from testbed.validation.summary import coverage_line

    records = [{"id": f"closed-{s}", "kind": "closed_loop", "status": "ok", "result": {"scene": s}}
               for s in DEFAULT]
    line = coverage_line(records)
    assert line.startswith(f"The closed loop judged {len(DEFAULT)} scenes here")
    for scene in list(EXTRA) + list(cl.EXCLUDED):
        assert scene in line, scene
    for why in list(cl.FULL_EXTRA_WHY.values()) + list(cl.EXCLUDED.values()):
        assert why in line
    # the full suite ran them all: nothing is said to be left to it
    full = records + [{"id": f"closed-{s}", "kind": "closed_loop", "status": "ok", "result": {"scene": s}} for s in EXTRA]
    assert "run by the full suite" not in coverage_line(full)
    assert coverage_line([]) is None
