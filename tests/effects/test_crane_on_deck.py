"""A crane on a rolling deck is refused: the crane's sheaves are fixed in W, and under deck_motion W is the
deck's frame, so such a scene would model a ship's own crane, never a quay crane's fixed rope anchor over a
rolling bay. `testbed run` and `testbed compare --no-truth` both exit 2 with one line, writing nothing."""

import pytest

from testbed import cli
from testbed.errors import ScenarioError
from testbed.scenario import load_scenario, validate_scenario

SCENE = """name: crane_on_deck
duration: 0.05
containers:
- name: base
  type: 1CC
  mass: 20000
  X_WC: {translation: [0, 0, 1.2955]}
- name: load
  type: 1CC
  mass: 20000
  X_WC: {translation: [0, 0, 4.2]}
effects:
  contact: {}
  crane:
    container: load
    trolley_height: 9.0
    moves:
    - {kind: hoist, target: 1.0, speed: 0.5, acceleration: 1.0}
DECK"""
DECK = """  deck_motion:
    roll: {amplitude: 5.0, period: 10.0}
"""


@pytest.mark.parametrize("command", [["run"], ["compare", "--no-truth"]])
def test_crane_with_deck_motion_exits_2_with_one_line(command, tmp_path, capsys):
    scene = tmp_path / "crane_on_deck.yaml"
    scene.write_text(SCENE.replace("DECK", DECK))
    out = tmp_path / "out"
    code = cli.main([*command, str(scene), "--out", str(out), "--quiet"] if command == ["run"]
                    else [*command, str(scene), "--out", str(out)])
    captured = capsys.readouterr()
    assert code == 2, captured
    err = captured.err
    assert err.count("\n") == 1, err
    for needle in (str(scene), "effects.crane", "deck_motion", "quay crane", "not modelled"):
        assert needle in err, (needle, err)
    assert not out.exists()


def test_the_same_crane_without_the_deck_is_accepted(tmp_path):
    """The refusal is about the pair: the crane alone validates (its checks are unchanged)."""
    alone = tmp_path / "crane_alone.yaml"
    alone.write_text(SCENE.replace("DECK", ""))
    effects = validate_scenario(load_scenario(alone), alone)
    assert "crane" in effects and "deck_motion" not in effects
    both = tmp_path / "both.yaml"
    both.write_text(SCENE.replace("DECK", DECK))
    with pytest.raises(ScenarioError) as info:
        validate_scenario(load_scenario(both), both)
    assert info.value.field == "effects.crane"
