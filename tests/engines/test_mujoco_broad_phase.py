"""MuJoCo as a peer at yard scale: explicit <pair>s only for the container pairs that
can meet, the rest found by MuJoCo's own broad phase; the matched parameters still reach every
contact (testbed/engines/mujoco/model.py, contact_pairs / geom_parameters)."""

import numpy as np
import pytest

from testbed.scenario import load_scenario

mujoco = pytest.importorskip("mujoco")

from testbed.engines.mujoco.model import build_model, can_meet, matched_pair  # noqa: E402


def _contact_params(scene: str, steps: int):
    """Per step's contacts: ((a, b) body indices, solref, solimp, friction, the expected PairParams or None)."""
    scenario = load_scenario(scene)
    model, data, tr = build_model(scenario)
    index = np.array([tr.body_names.index(model.geom(g).name) for g in range(model.ngeom)])
    expected = {(p.a, p.b): p for p in tr.pairs}
    out = []
    for _ in range(steps):
        mujoco.mj_step(model, data)
        for c in data.contact[:data.ncon] if data.ncon else []:
            a, b = sorted((int(index[c.geom1]), int(index[c.geom2])))
            out.append(((a, b), np.array(c.solref), np.array(c.solimp), float(c.friction[0]), expected.get((a, b))))
    return scenario, tr, out


@pytest.mark.parametrize("scene", ["yard_small", "crane_misaligned", "bridge"])
def test_every_contact_gets_its_pairs_matched_parameters(scene):
    """Every contact MuJoCo makes in the first 0.2 s belongs to an explicit pair and carries that
    pair's matched solref, solimp and friction exactly (the per-pair derivation unchanged)."""
    _, _, rows = _contact_params(scene, 200)
    assert rows
    for pair, solref, solimp, mu, expected in rows:
        assert expected is not None, pair
        np.testing.assert_array_equal(solref, expected.solref)
        np.testing.assert_array_equal(solimp, expected.solimp)
        assert mu == expected.friction


def test_yard_lists_neighbours_not_every_pair():
    """yard_block (96 containers): the explicit pairs are the quay's 96 and the neighbours'
    (same column, or within NEIGHBOUR_REACH), not the 4,560 container pairs; two equal
    containers meeting through the broad phase get their pair's parameters from the geoms' mix."""
    scenario = load_scenario("yard_block")
    meet = can_meet(scenario)
    n = len(scenario.containers)
    assert np.array_equal(meet, meet.T) and 0 < meet.sum() // 2 < n * (n - 1) // 20
    model, _, tr = build_model(scenario)
    assert model.npair == len(tr.pairs) == n + meet.sum() // 2
    assert mujoco.mj_isSparse(model)
    spec = scenario.containers[0]
    own = tr.geoms[0]
    _, _, solref, solimp, _ = matched_pair(scenario, spec, spec, scenario.plant.time_step)
    assert own.solref == solref and own.solimp == solimp  # mixing two of these gives exactly these
