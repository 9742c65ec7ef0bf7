"""Wear-state files the Python tests share (not a test module)."""

import subprocess
from pathlib import Path


def write_foreign_state(exe, directory):
    """Writes `directory`/foreign.json: a worn-profile state of the example
    with its ring rim radius changed (58.95 → 60 mm), so the FMU must refuse
    it as a state of another gear set. Returns its path."""
    directory = Path(directory)
    scene = subprocess.run([exe, "scene", "show", "example-2004"], capture_output=True, text=True, check=True).stdout
    other = scene.replace("rim_radius_mm = 58.95", "rim_radius_mm = 60.0")
    assert other != scene
    (directory / "other.toml").write_text(other)
    path = directory / "foreign.json"
    subprocess.run([exe, "wear", "step", "--scene", str(directory / "other.toml"), "--revolutions", "1000",
                    "--out", str(path)], check=True, capture_output=True)
    return path
