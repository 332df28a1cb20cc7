"""`testbed scenes`: list the shipped scenes, marking those with container-container contact.

The mark follows from the scene alone: a scene exercises container-container contact (the
learned model has a pair to decide, the closed loop and `testbed compare` can judge it)
when it has two or more containers, at least one of them free (a pair of welded
containers is never simulated). With one container the learned model is never asked.
"""

from __future__ import annotations

NAME = "scenes"
HELP = "list the shipped scenes (marking those with container-container contact)"
RULE = ("[cc] container-container contact: two or more containers, at least one free (the learned model has a pair "
        "to decide; `testbed compare` judges it only on these)")


def add_arguments(parser) -> None:
    pass


def container_contact(scenario) -> bool:
    """Whether `scenario` has a container pair the learned model decides (see the module doc)."""
    free = sum(not c.fixed for c in scenario.containers)
    return len(scenario.containers) >= 2 and free >= 1


def run(args) -> int:
    from testbed.scenario import load_scenario, shipped_scenes

    print(RULE)
    for name, path in shipped_scenes().items():
        scenario = load_scenario(path)
        mark = "[cc]" if container_contact(scenario) else "    "
        print(f"{mark} {name:20s} {len(scenario.containers)} containers, {scenario.duration:g} s, "
              f"effects: {', '.join(scenario.declared_effects())}\n{'':25s} {scenario.description}")
    return 0
