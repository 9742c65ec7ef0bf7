"""Side-by-side check of planetwear's sun-planet TVMS against ross-rotordynamics.

Run (from the repo root, after `cargo build --release`):

    PYTHONDONTWRITEBYTECODE=1 /tmp/rossvenv/bin/python -m pytest -s -p no:cacheprovider tests/python/test_peer_ross.py

The planetwear binary is taken from $PLANETWEAR_BIN, default
<repo>/target/release/planetwear. A missing binary is a failure, not a skip.
"""

from __future__ import annotations

import json
import math
import os
import subprocess
import sys
import warnings
from pathlib import Path

import pytest

sys.path.insert(0, str(Path(__file__).resolve().parent))
import peer_ross  # noqa: E402

REPO = Path(__file__).resolve().parents[2]
MEAN_REL_TOL = 0.30


def _planetwear_bin() -> Path:
    return Path(os.environ.get("PLANETWEAR_BIN", REPO / "target" / "release" / "planetwear"))


@pytest.fixture(scope="module")
def ross_result():
    return peer_ross.ross_sun_planet_tvms()


def run_planetwear_sun_planet() -> dict:
    """Run the planetwear CLI and return the 'sun_planet' entry of its 'meshes'."""
    exe = _planetwear_bin()
    if not exe.is_file():
        pytest.fail(
            f"planetwear binary not found at {exe}; build it with "
            "`cargo build --release` in the repo root or set PLANETWEAR_BIN"
        )
    cmd = [str(exe), "ltca", "--scene", "example-2004", "--json"]
    proc = subprocess.run(cmd, capture_output=True, text=True, cwd=REPO, timeout=600)
    assert proc.returncode == 0, f"{' '.join(cmd)} failed ({proc.returncode}):\n{proc.stderr}"
    data = json.loads(proc.stdout)
    meshes = [m for m in data["meshes"] if m.get("name") == "sun_planet"]
    assert len(meshes) == 1, f"expected one mesh named 'sun_planet', got {[m.get('name') for m in data['meshes']]}"
    return meshes[0]


def test_ross_sanity(ross_result):
    """Laws on the ross side alone, so the comparison is not vacuous."""
    k = ross_result["stiffness_N_per_m"]
    kmin, kmax, mean = min(k), max(k), ross_result["mean"]
    assert 0 < kmin < mean < kmax

    # ross's contact ratio must be the geometric one of the example pair
    # (tip radii were matched through addendum_coeff).
    eps = peer_ross.geometric_contact_ratio()
    eps_ross = ross_result["inputs"]["ross_derived"]["contact_ratio"]
    assert abs(eps_ross - eps) < 0.01 * eps, (eps_ross, eps)

    # Two-level TVMS: exactly one entry and one exit jump per cycle, and the
    # share of the cycle with two pairs in contact equals eps - 1.
    mid = 0.5 * (kmin + kmax)
    double = [v > mid for v in k]
    switches = sum(double[i] != double[i - 1] for i in range(len(double)))  # circular
    assert switches == 2, switches
    share = sum(double) / len(double)
    assert abs(share - (eps - 1.0)) < 0.02, (share, eps - 1.0)

    # Periodic with one mesh cycle (sun angle 2*pi/Z_sun), to 1 %.
    _, _, mesh = peer_ross.build_ross_mesh()
    period = 2 * math.pi / peer_ross.EXAMPLE["z_sun"]
    for frac in (0.13, 0.31, 0.52, 0.77, 0.93):
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")  # Sainsot extrapolation notice
            a, b, c = (mesh.get_variable_stiffness((frac + n) * period) for n in (0, 1, 2))
        assert abs(a - b) <= 0.01 * a and abs(a - c) <= 0.01 * a, (frac, a, b, c)


def test_mean_stiffness_vs_ross(ross_result):
    planetwear_mesh = run_planetwear_sun_planet()
    nominal = planetwear_mesh["mesh_stiffness_nominal"]
    pw_mean = float(nominal["mean"])
    pw_p2p = float(nominal["peak_to_peak"])
    r_mean = ross_result["mean"]
    r_p2p = ross_result["peak_to_peak"]
    rel_mean = (pw_mean - r_mean) / r_mean
    rel_p2p = (pw_p2p - r_p2p) / r_p2p
    to_mm = peer_ross.per_mm
    print()
    print("sun_planet TVMS, whole face width, one mesh cycle")
    print(f"{'':<12}{'mean [N/m]':>14}{'p2p [N/m]':>14}{'mean [N/(mm um)/mm]':>22}{'p2p [N/(mm um)/mm]':>21}")
    print(f"{'planetwear':<12}{pw_mean:>14.4e}{pw_p2p:>14.4e}{to_mm(pw_mean):>22.3f}{to_mm(pw_p2p):>21.3f}")
    print(f"{'ross':<12}{r_mean:>14.4e}{r_p2p:>14.4e}{to_mm(r_mean):>22.3f}{to_mm(r_p2p):>21.3f}")
    print(f"{'difference':<12}{pw_mean - r_mean:>14.4e}{pw_p2p - r_p2p:>14.4e}"
          f"{to_mm(pw_mean - r_mean):>22.3f}{to_mm(pw_p2p - r_p2p):>21.3f}")
    print(f"relative (planetwear/ross - 1): mean {rel_mean:+.3f}, peak-to-peak {rel_p2p:+.3f}")
    assert pw_mean > 0 and pw_p2p >= 0
    assert abs(rel_mean) < MEAN_REL_TOL, (
        f"mean TVMS differs from ross by {rel_mean:+.1%} (limit {MEAN_REL_TOL:.0%})"
    )
