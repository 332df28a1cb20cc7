"""A measurement names the code that made it: the commit is git's own (dirty when tracked files
changed), 'unknown' outside a checkout."""

import subprocess

from testbed import provenance


def test_commit_is_gits_short_head():
    if not (provenance.ROOT / ".git").exists():
        assert provenance.commit() == "unknown"
        return
    head = subprocess.run(["git", "-C", str(provenance.ROOT), "rev-parse", "--short", "HEAD"], capture_output=True,
                          text=True, check=True).stdout.strip()
    assert provenance.commit() in (head, head + "-dirty")


def test_outside_a_checkout_the_commit_is_unknown(tmp_path, monkeypatch):
    monkeypatch.setattr(provenance, "ROOT", tmp_path)
    assert provenance.commit() == "unknown"
    p = provenance.provenance()
    assert p["commit"] == "unknown" and p["date"].count("-") == 2 and "CPUs" in p["machine"]
