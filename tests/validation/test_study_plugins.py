"""Studies are plug-ins (testbed/studies/: one package each, registered with
testbed.studies.register): a study registered from outside the package appears in `testbed
study --help` with its own option group and runs through the CLI, with no other edit."""

import importlib.util
import json

import pytest

from testbed import studies as study_registry
from testbed.cli import main

DUMMY = '''
import dataclasses, json
from pathlib import Path

from testbed.errors import TestbedError
from testbed.studies import register
from testbed.studies.base import Study


@dataclasses.dataclass
class EchoConfig:
    words: int = 3


@register
class EchoStudy(Study):
    name = "echo_plugin"
    help = "repeats a word (a test's dummy study)"
    Config = EchoConfig

    def add_arguments(self, group):
        group.add_argument("--echo-words", type=int, help="how many words the dummy study writes")

    def configure(self, args):
        words = args.echo_words if args.echo_words is not None else (1 if args.quick else 3)
        if words < 1:
            raise TestbedError(f"--echo-words: expected at least 1, got {words}")
        return EchoConfig(words)

    def run(self, config, out, map_calls=None):
        Path(out).mkdir(parents=True, exist_ok=True)
        return {"words": ["echo"] * config.words}

    def report(self, result, out):
        path = Path(out) / "echo.json"
        path.write_text(json.dumps(result))
        return [path]

    def summary(self, result):
        return [" ".join(result["words"])]
'''


@pytest.fixture
def dummy_study(tmp_path, monkeypatch):
    """The dummy study registered for this test alone (the registry's entries restored after)."""
    monkeypatch.setattr(study_registry._REGISTRY, "_entries", dict(study_registry.studies()))
    path = tmp_path / "echo_plugin_study.py"
    path.write_text(DUMMY)
    spec = importlib.util.spec_from_file_location("echo_plugin_study", path)
    spec.loader.exec_module(importlib.util.module_from_spec(spec))
    return "echo_plugin"


def test_the_shipped_studies_are_registered():
    assert {"sim", "query", "stability", "defaults", "scale", "truth"} <= set(study_registry.studies())
    with pytest.raises(ValueError, match="unknown study 'nonesuch'"):
        study_registry.study("nonesuch")


def test_help_groups_each_study_s_options(dummy_study, capsys):
    with pytest.raises(SystemExit) as e:
        main(["study", "--help"])
    assert e.value.code == 0
    text = capsys.readouterr().out
    assert "echo_plugin study (repeats a word" in text and "--echo-words" in text
    # the shipped studies' options, each under its own study's group
    groups = text[text.index("\noptions:"):]  # past the usage line, which names every option
    assert groups.index("\nscale study (") < groups.index("\n  --sizes") < groups.index("\ntruth study (") < groups.index("\n  --rungs")


def test_a_registered_study_runs_through_the_cli(dummy_study, tmp_path, capsys):
    out = tmp_path / "out"
    assert main(["study", dummy_study, "--echo-words", "2", "--out", str(out)]) == 0
    assert json.loads((out / "echo.json").read_text()) == {"words": ["echo", "echo"]}
    printed = capsys.readouterr().out
    assert "echo echo" in printed and f"study output: {out}" in printed


def test_a_study_s_bad_option_is_one_line_and_exit_2(dummy_study, tmp_path, capsys):
    out = tmp_path / "out"
    assert main(["study", dummy_study, "--echo-words", "0", "--out", str(out)]) == 2
    err = capsys.readouterr().err.strip()
    assert "--echo-words: expected at least 1, got 0" in err and "\n" not in err
    assert not out.exists()


def test_an_unknown_study_is_refused_by_the_parser(capsys):
    with pytest.raises(SystemExit) as e:
        main(["study", "nonesuch"])
    assert e.value.code == 2 and "invalid choice 'nonesuch'" in capsys.readouterr().err
