"""A mistyped predictor name (learned_contact.sources.load_predictor): one line with the closest
shipped names and the other forms a predictor may take (a file, module:attribute), exit status
2 from the commands; a path that is missing still says the file is not found."""

from __future__ import annotations

import pytest

from learned_contact import WeightsError
from learned_contact.sources import SHIPPED_NAMES, load_predictor, looks_like_a_name
from testbed import cli


@pytest.mark.parametrize("typed, meant", [("improoved", "improved"), ("Paper", "paper"), ("impoved", "improved")])
def test_a_mistyped_name_suggests_the_shipped_one(typed, meant):
    with pytest.raises(WeightsError) as info:
        load_predictor(typed)
    message = str(info.value)
    assert "\n" not in message
    close = message.split("did you mean ", 1)[1].split("?", 1)[0]
    assert close.split(" or ")[0] == repr(meant)  # the closest shipped name first
    listed = message.split("expected one of: ", 1)[1].split(";", 1)[0]
    assert listed.split(", ") == list(SHIPPED_NAMES)
    assert all(form in message for form in (".npz", ".onnx", "module:attribute"))


def test_a_word_near_no_name_lists_the_names_without_a_guess():
    with pytest.raises(WeightsError) as info:
        load_predictor("no-such-predictor-name")
    assert "did you mean" not in str(info.value) and "expected one of: improved, paper" in str(info.value)


def test_paths_are_not_taken_for_names(tmp_path):
    assert looks_like_a_name("improoved") and not looks_like_a_name("weights/mine") and not looks_like_a_name("mine.npz")
    with pytest.raises(WeightsError, match="not found") as info:
        load_predictor(tmp_path / "absent.npz")
    assert "did you mean" not in str(info.value)


@pytest.mark.parametrize("argv", [["compare", "two_stack", "--predictor", "improoved", "--duration", "0.01", "--no-replay"],
                                  ["bench", "improoved", "--quick"]])
def test_the_commands_exit_2_with_one_line(argv, tmp_path, capsys):
    code = cli.main([*argv, "--out", str(tmp_path / "out")])
    err = capsys.readouterr().err.strip()
    assert code == 2 and len(err.splitlines()) == 1, err
    assert "did you mean 'improved'?" in err and "module:attribute" in err
    assert not (tmp_path / "out").exists()
