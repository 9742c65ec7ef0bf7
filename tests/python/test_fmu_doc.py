"""The fmpy snippets of docs/FMU.md ("Using the FMU from fmpy") run as they
stand from the repository's root, so the page cannot drift from the FMU."""

import os
import re
import subprocess
import sys
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parents[2]
SECTION = "## Using the FMU from fmpy"


def snippets():
    text = (REPO / "docs" / "FMU.md").read_text()
    start = text.index(SECTION)
    end = text.find("\n## ", start + len(SECTION))
    return re.findall(r"```python\n(.*?)```", text[start:end if end > 0 else None], re.S)


def test_the_section_has_its_snippets():
    assert len(snippets()) == 4


@pytest.mark.parametrize("index", range(4))
def test_a_snippet_runs_from_the_repository_root(index):
    code = snippets()[index]
    # Each in its own interpreter: fmpy's logging shim keeps the last logger
    # (docs/FMU.md), which must not outlive the snippet that made it.
    r = subprocess.run([sys.executable, "-c", code], cwd=REPO, capture_output=True, text=True, timeout=600,
                       env=dict(os.environ))
    assert r.returncode == 0, r.stderr
    out = r.stdout
    print(out)
    if index == 0:
        assert re.search(r"\d+ rpm; sun mesh force at most \d+ N/mm; carrier reaction -?\d+ N·m", out), out
    elif index == 1:
        assert re.search(r"peak sun mesh force \d+ N, carrier reaction -?\d+ N·m", out), out
    elif index == 2:
        rms = [float(x) for x in re.findall(r"F_rms of the sun-planet mesh ([\d.]+) N/mm", out)]
        assert len(rms) == 2 and all(x > 0 for x in rms) and rms[0] != rms[1], out
    else:
        assert "status 3" in out and "module = -0.0015 m" in out, out
