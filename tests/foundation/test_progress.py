"""Progress output off a terminal: a redirected stderr gets whole lines,
at most one per OFF_TTY_INTERVAL_S of wall time (plus the first), never carriage returns."""

import io
import subprocess
import sys
import time
from pathlib import Path

from test_bad_input import GOOD

from testbed.progress import OFF_TTY_INTERVAL_S, progress

ROOT = Path(__file__).resolve().parents[2]


def test_testbed_run_with_stderr_to_a_file_writes_few_lines(tmp_path):
    """A one-second simulated run (200 progress chunks): before, carriage-return redraws (19 for
    5 s simulated here); now the first line and at most one more per OFF_TTY_INTERVAL_S of the run."""
    scene = tmp_path / "scene.yaml"
    scene.write_text(GOOD.replace("duration: 0.01", "duration: 1.0"))
    err_path = tmp_path / "stderr.txt"
    start = time.monotonic()
    with err_path.open("wb") as err:
        proc = subprocess.run([sys.executable, "-m", "testbed.cli", "run", str(scene), "--out", str(tmp_path / "out")],
                              stdout=subprocess.DEVNULL, stderr=err, cwd=ROOT, timeout=600, check=False,
                              env={"PYTHONPATH": str(ROOT), "PATH": "/usr/bin:/bin"})
    wall = time.monotonic() - start
    text = err_path.read_text()
    assert proc.returncode == 0, text
    assert "\r" not in text, repr(text[:500])
    lines = [ln for ln in text.splitlines() if ln.strip()]
    assert any("sim s" in ln for ln in lines), text  # progress is still shown, as lines
    assert len(lines) <= 1 + wall / OFF_TTY_INTERVAL_S + 1, (wall, lines)


def test_off_a_terminal_a_busy_bar_prints_one_line_per_interval():
    stream = io.StringIO()  # not a terminal
    bar = progress(total=1000, desc="busy", file=stream, leave=True)
    for i in range(1000):
        bar.n = i + 1
        bar.refresh()  # what simulation.py does per chunk
        bar.set_postfix_str(str(i))  # what the validation executor does per case
    bar.close()
    text = stream.getvalue()
    assert "\r" not in text
    assert text.count("\n") == 2, text  # the first state and the final one (leave=True)
    assert "1000/1000" in text.splitlines()[-1]
