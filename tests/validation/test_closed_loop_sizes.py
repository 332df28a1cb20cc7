"""validate's closed-loop case runs a reported predictor only on scenes whose sizes it declares: the
paper's MLP (20 / 40 ft) sits out half_height_stack instead of failing the case, while the gated one
runs everywhere."""

from __future__ import annotations

import pytest

from testbed.scenario import load_scenario, resolve_scene_path
from testbed.validation.cases.closed_loop import ClosedLoopCase, _answers_sizes


@pytest.mark.parametrize("spec, scene, answers", [("paper", "two_stack", True), ("paper", "half_height_stack", False),
                                                  ("paper", "crane_45ft_landing", False),
                                                  ("improved", "half_height_stack", True),
                                                  ("improved", "crane_45ft_landing", True)])
def test_a_predictor_answers_the_scenes_of_its_sizes(spec, scene, answers):
    assert _answers_sizes(spec, load_scenario(resolve_scene_path(scene))) is answers


def test_the_case_runs_without_the_predictor_that_cannot_answer():
    result = ClosedLoopCase().run("half_height_stack", 0.05, ["improved", "paper"])
    assert set(result["predictors"]) == {"improved"}
    assert not result["predictors"]["improved"]["diverged"]
