"""Peer check: TVMS of the sun-planet external spur pair from ross-rotordynamics.

This module *calls* the peer implementation ``ross.gear_element.GearElementTVMS``
/ ``ross.gear_element.Mesh`` from the PyPI package ``ross-rotordynamics``
(Apache-2.0). Nothing of ross is copied here; it is used as an external
reference only. See ``docs/PEER_ROSS.md`` for what ross models and how its
inputs differ from the planetwear example system.

Tested with ross-rotordynamics==2.3.0 and plotly==5.24.1 (ross needs plotly<6):

    python3 -m venv /tmp/rossvenv
    /tmp/rossvenv/bin/pip install "ross-rotordynamics==2.3.0" "plotly==5.24.1" pytest

Run ``python peer_ross.py`` for a short table.
"""

from __future__ import annotations

import contextlib
import io
import math
import os
import tempfile
import sys
import warnings

# ---------------------------------------------------------------------------
# Example system (scene example-2004), sun-planet pair, SI units.
# ---------------------------------------------------------------------------
EXAMPLE = {
    "module_m": 1.5e-3,
    "z_sun": 34,
    "z_planet": 18,
    "pressure_angle_deg": 21.3,  # operating = at the standard centre distance
    "centre_distance_m": 39.0e-3,
    "face_width_m": 30.0e-3,
    "E_Pa": 207e9,
    "nu": 0.3,
    "sun_bore_radius_m": 12.88e-3,
    "planet_bore_radius_m": 5.94e-3,
    "sun_tip_radius_m": 26.37e-3,
    "planet_tip_radius_m": 15.25e-3,
    "sun_root_radius_m": 23.00e-3,
    "planet_root_radius_m": 11.875e-3,
}

# ross has no profile shift: every gear is an unshifted rack-generated gear with
# tip radius r_p + ha*m and root radius r_p - (ha + c)*m, where the same ha is
# also the generating rack's flank depth. We match the tip radii (hence the path
# of contact and the contact ratio) through ha and keep ross's default c = 0.25.
# Matching the root radii as well is impossible (planet would need c < 0, the sun
# a cutter tip radius far larger than the rack tooth), see docs/PEER_ROSS.md.
_R_PITCH_SUN = EXAMPLE["module_m"] * EXAMPLE["z_sun"] / 2
_R_PITCH_PLANET = EXAMPLE["module_m"] * EXAMPLE["z_planet"] / 2
ADDENDUM_COEFF_SUN = (EXAMPLE["sun_tip_radius_m"] - _R_PITCH_SUN) / EXAMPLE["module_m"]  # 0.58
ADDENDUM_COEFF_PLANET = (
    EXAMPLE["planet_tip_radius_m"] - _R_PITCH_PLANET
) / EXAMPLE["module_m"]  # 1.1667
TIP_CLEARANCE_COEFF = 0.25  # ross default
DENSITY = 7850.0  # kg/m^3; only affects ross's mass/inertia, not the stiffness


def _import_ross():
    """Import ross quietly (its ccp dependency complains about REFPROP)."""
    # ccp looks for REFPROP in $RPPREFIX, else in the current directory, and
    # loads any shared library it finds there: a test that runs from a
    # directory holding an unpacked FMU would make it load planetwear.so.
    # An empty directory makes the import the same wherever it runs.
    if "RPPREFIX" not in os.environ:
        os.environ["RPPREFIX"] = tempfile.mkdtemp(prefix="planetwear-no-refprop-")
    # The REFPROP banner is written at file-descriptor level, so silence fds 1, 2.
    sys.stdout.flush()
    sys.stderr.flush()
    saved = [os.dup(1), os.dup(2)]
    devnull = os.open(os.devnull, os.O_WRONLY)
    try:
        os.dup2(devnull, 1)
        os.dup2(devnull, 2)
        with warnings.catch_warnings(), contextlib.redirect_stdout(io.StringIO()):
            warnings.simplefilter("ignore")
            import ross  # noqa: F401
            from ross.gear_element import GearElementTVMS, Mesh
            from ross.materials import Material
    finally:
        sys.stdout.flush()
        os.dup2(saved[0], 1)
        os.dup2(saved[1], 2)
        for fd in saved + [devnull]:
            os.close(fd)
    return ross, GearElementTVMS, Mesh, Material


def ross_inputs() -> dict:
    """The exact arguments given to ross (SI units), JSON-serialisable."""
    alpha = math.radians(EXAMPLE["pressure_angle_deg"])
    common = {
        "width": EXAMPLE["face_width_m"],
        "module": EXAMPLE["module_m"],
        "pr_angle": alpha,
        "helix_angle": 0.0,
        "tip_clearance_coeff": TIP_CLEARANCE_COEFF,
    }
    return {
        "material": {
            "name": "steel_E207",
            "rho": DENSITY,
            "E": EXAMPLE["E_Pa"],
            "Poisson": EXAMPLE["nu"],
            "G_s": "derived by ross: E/(2(1+nu))",
        },
        "sun": dict(
            common,
            n=0,
            n_teeth=EXAMPLE["z_sun"],
            bore_diameter=2 * EXAMPLE["sun_bore_radius_m"],
            addendum_coeff=ADDENDUM_COEFF_SUN,
        ),
        "planet": dict(
            common,
            n=1,
            n_teeth=EXAMPLE["z_planet"],
            bore_diameter=2 * EXAMPLE["planet_bore_radius_m"],
            addendum_coeff=ADDENDUM_COEFF_PLANET,
        ),
        "mesh": "Mesh(driving_gear=sun, driven_gear=planet)",
        "pr_angle_deg": EXAMPLE["pressure_angle_deg"],
    }


def build_ross_mesh():
    """Return (sun, planet, mesh) ross objects for the example pair (sun driving)."""
    _, GearElementTVMS, Mesh, Material = _import_ross()
    inp = ross_inputs()
    mat_in = inp["material"]
    mat = Material(name=mat_in["name"], rho=mat_in["rho"], E=mat_in["E"], Poisson=mat_in["Poisson"])
    with warnings.catch_warnings():
        # ross warns on every foundation evaluation that the Sainsot coefficients
        # are extrapolated (sun M = 1.0796 < 1.08, planet P = 2.458 < 2.56).
        warnings.simplefilter("ignore")
        sun = GearElementTVMS(material=mat, **inp["sun"])
        planet = GearElementTVMS(material=mat, **inp["planet"])
        mesh = Mesh(sun, planet)
    return sun, planet, mesh


def geometric_contact_ratio() -> float:
    """Transverse contact ratio of the example pair from its own radii (independent of ross)."""
    m = EXAMPLE["module_m"]
    alpha = math.radians(EXAMPLE["pressure_angle_deg"])
    rb1 = _R_PITCH_SUN * math.cos(alpha)
    rb2 = _R_PITCH_PLANET * math.cos(alpha)
    ra1 = EXAMPLE["sun_tip_radius_m"]
    ra2 = EXAMPLE["planet_tip_radius_m"]
    a = EXAMPLE["centre_distance_m"]
    length = math.sqrt(ra1**2 - rb1**2) + math.sqrt(ra2**2 - rb2**2) - a * math.sin(alpha)
    return length / (math.pi * m * math.cos(alpha))


def ross_sun_planet_tvms(n_points: int = 1000) -> dict:
    """ross TVMS of the sun-planet pair over one mesh cycle.

    Angle is the sun (driving gear) rotation in [0, 2*pi/Z_sun), n_points uniform
    samples (end point excluded so that the mean is a true cycle average).
    Stiffness is along the line of action, whole face width, summed over the
    tooth pairs in contact (ross sums at most two pairs), N/m.
    """
    sun, planet, mesh = build_ross_mesh()
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        theta, k = mesh.get_stiffness_for_mesh_period(n_mesh_period=1, n_points=n_points + 1)
    theta = [float(t) for t in theta[:-1]]
    k = [float(v) for v in k[:-1]]
    mean = sum(k) / len(k)
    inputs = ross_inputs()
    inputs["ross_derived"] = {
        "contact_ratio": float(mesh.contact_ratio),
        "hertzian_stiffness_N_per_m": float(mesh.hertzian_stiffness),
        "sun_radii_m": {key: float(v) for key, v in sun.radii_dict.items()},
        "planet_radii_m": {key: float(v) for key, v in planet.radii_dict.items()},
        "sun_form_radius_m": float(sun.base_radius / math.cos(sun.pr_angles_dict["start_point"])),
        "planet_form_radius_m": float(planet.base_radius / math.cos(planet.pr_angles_dict["start_point"])),
        "G_s_Pa": float(sun.material.G_s),
    }
    return {
        "angle_rad": theta,
        "stiffness_N_per_m": k,
        "mean": mean,
        "peak_to_peak": max(k) - min(k),
        "inputs": inputs,
    }


def per_mm(k_n_per_m: float) -> float:
    """N/m over the whole face width -> N/(mm*um) per mm of face width."""
    return k_n_per_m / EXAMPLE["face_width_m"] / 1e9


if __name__ == "__main__":
    res = ross_sun_planet_tvms()
    d = res["inputs"]["ross_derived"]
    k = res["stiffness_N_per_m"]
    print("ross-rotordynamics GearElementTVMS, sun (driving) - planet, one mesh cycle")
    print(f"  contact ratio ross {d['contact_ratio']:.4f}  geometric {geometric_contact_ratio():.4f}")
    print(f"  ross radii sun   (mm): tip {d['sun_radii_m']['addendum']*1e3:.3f} root {d['sun_radii_m']['root']*1e3:.3f} "
          f"base {d['sun_radii_m']['base']*1e3:.3f} form {d['sun_form_radius_m']*1e3:.3f}")
    print(f"  ross radii planet(mm): tip {d['planet_radii_m']['addendum']*1e3:.3f} root {d['planet_radii_m']['root']*1e3:.3f} "
          f"base {d['planet_radii_m']['base']*1e3:.3f} form {d['planet_form_radius_m']*1e3:.3f}")
    print(f"  {'quantity':<14}{'N/m':>14}{'N/(mm um)/mm':>16}")
    for name, v in (("mean", res["mean"]), ("peak_to_peak", res["peak_to_peak"]), ("min", min(k)), ("max", max(k))):
        print(f"  {name:<14}{v:>14.4e}{per_mm(v):>16.3f}")
    print(f"  {'angle_rad':>12}{'k [N/m]':>14}")
    step = max(1, len(k) // 20)
    for t, v in list(zip(res["angle_rad"], k))[::step]:
        print(f"  {t:>12.5f}{v:>14.4e}")
