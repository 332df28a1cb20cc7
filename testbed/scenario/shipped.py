"""The shipped scenes (testbed/scenes/*.yaml) and how a scene name is looked up: a file path, or
the name of a shipped scene, with close names suggested for a missing one."""

import difflib
from pathlib import Path

SCENES_DIR = Path(__file__).resolve().parent.parent / "scenes"


def shipped_scenes() -> dict[str, Path]:
    """Shipped scene name -> file, from testbed/scenes/."""
    return {p.stem: p for p in sorted(SCENES_DIR.glob("*.yaml"))}


def resolve_scene_path(path: str | Path) -> Path:
    """A file path, or the name of a shipped scene ('five_stack')."""
    p = Path(path)
    if p.exists() or p.suffix in (".yaml", ".yml"):
        return p
    return shipped_scenes().get(str(path), p)


def near_names(path) -> str:
    """'; did you mean two_stack? ...' for a missing scene whose name is close to shipped ones
    (difflib), with where the shipped names are listed; '' for a path in a directory, or a
    file name with a suffix and no close shipped name."""
    p = Path(path)
    if len(p.parts) > 1:
        return ""
    close = difflib.get_close_matches(p.stem, list(shipped_scenes()), n=3, cutoff=0.6)
    if close:
        return f"; did you mean {' or '.join(close)}? (`testbed scenes` lists the shipped scenes)"
    return "" if p.suffix else "; no shipped scene has that name either (`testbed scenes` lists them)"
