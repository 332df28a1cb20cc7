"""`testbed scenes`: list the shipped scenes."""

from __future__ import annotations

NAME = "scenes"
HELP = "list the shipped scenes"


def add_arguments(parser) -> None:
    pass


def run(args) -> int:
    from testbed.scenario import load_scenario, shipped_scenes

    for name, path in shipped_scenes().items():
        scenario = load_scenario(path)
        print(f"{name:20s} {len(scenario.containers)} containers, {scenario.duration:g} s, "
              f"effects: {', '.join(scenario.declared_effects())}\n{'':20s} {scenario.description}")
    return 0
