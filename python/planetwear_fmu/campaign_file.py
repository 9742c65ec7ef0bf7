"""The campaign file (TOML): what a campaign computes, read and checked
before any work starts.

A campaign is the product wear states × sun torques × directions; each
element is one continuation sweep over the speed grid (one Dask task).
Every key is checked here, all problems at once, each naming its key, the
value and what is allowed (`CampaignError`). The checks that need the FMU
(a wear state the FMU refuses, an integrator setting it rejects) are made by
`fmu_check.check`, which `load` calls last when it is passed in as `probe`
(`fmu_check.load_campaign` does so). The format is documented in
docs/CAMPAIGNS.md; campaigns/example-2004.toml is the example.

Layer 1 (files and formats): this module owns the campaign file's format
and checks (`Campaign`, `Scene`, `WearState`, `Problem`, `CampaignError`,
`load`, `from_dict`, `dumps_toml`), the worn-profile state's JSON structure
(`check_state_document`, `max_wear_depth`) and finding the `planetwear`
binary. Of the package it imports only `files` (`sha256_file` is re-exported
from there); it never imports `fmu_check` or anything above it.
"""

from __future__ import annotations

import hashlib
import json
import math
import os
import re
import shutil
import subprocess
import tomllib
import zipfile
from dataclasses import dataclass, field
from pathlib import Path
from xml.etree import ElementTree

from .files import InputError, read_input, sha256_file

# Keys allowed in each table, in the order the documentation gives them.
TOP_KEYS = ("fmu", "scene", "output_dir", "planetwear_bin", "wear", "speeds", "load", "timing", "integrator",
            "outputs", "loop")
TABLE_KEYS = {
    "wear": ("states", "labels"),
    "speeds": ("from_rpm", "to_rpm", "step_rpm", "values_rpm", "directions"),
    "load": ("sun_torque_nm",),
    "timing": ("communication_step", "run_in_cycles", "window_cycles"),
    "integrator": ("integrator", "steps_per_mesh_cycle", "rho_infinity", "relative_tolerance",
                   "samples_per_mesh_cycle"),
    "outputs": ("keep",),
    "loop": ("threshold_um", "ring", "dynamic_speed_rpm", "hours_per_stage"),
}
# Campaign integrator keys → FMU parameters.
INTEGRATOR_PARAMETERS = {
    "integrator": "integrator",
    "steps_per_mesh_cycle": "stepsPerMeshCycle",
    "rho_infinity": "rhoInfinity",
    "relative_tolerance": "relativeTolerance",
    "samples_per_mesh_cycle": "samplesPerMeshCycle",
}
# The windowed outputs every campaign keeps (the plots need both F^(rms)).
REQUIRED_OUTPUTS = ("window.sunMeshFrms", "window.ringMeshFrms")
DEFAULT_OUTPUTS = tuple(
    [f"window.{m}Mesh{q}" for m in ("sun", "ring") for q in ("F1", "F2", "F3", "F4", "F5", "F6", "Frms")]
    + ["window.sunSeparation", "window.ringSeparation", "window.cycles"]
)
MAX_SPEEDS = 100_000
STATE_FORMAT = "planetwear-worn-profile"
STATE_VERSION = 1
STATE_FLANKS = ("sun_drive", "sun_coast", "planet_sun_side", "planet_ring_side", "ring_drive", "ring_coast")
LABEL = re.compile(r"^[A-Za-z0-9][A-Za-z0-9._+-]{0,63}$")
BUILT_IN_SCENES = ("example-2004",)


@dataclass(frozen=True)
class Problem:
    """One bad key: its dotted name, the value found and what is allowed."""

    key: str
    value: object
    allowed: str

    def __str__(self):
        value = self.value if isinstance(self.value, str) and len(self.value) < 200 else repr(self.value)[:200]
        return f"{self.key} = {value}: {self.allowed}"


class CampaignError(ValueError):
    """A campaign file that cannot be run; `problems` lists every bad key."""

    def __init__(self, source, problems):
        self.source = str(source)
        self.problems = list(problems)
        lines = "\n".join(f"  - {p}" for p in self.problems)
        super().__init__(f"campaign file {self.source}: {len(self.problems)} problem(s)\n{lines}")


@dataclass
class WearState:
    """One wear state of the campaign."""

    # What the FMU's wearStateFile is set to: an absolute path, a resources/ name, or '' (unworn).
    fmu_value: str
    # κ recorded in the state (0 for the unworn set).
    kappa: int
    # Label of the state's results (file-name safe, unique in the campaign).
    label: str
    # SHA-256 of the state file's bytes ('' for the unworn set).
    sha256: str
    # Largest total wear depth recorded in the state [m].
    max_wear: float
    # The state file on disk, or None when it is read from the FMU's resources or is the unworn set.
    path: Path | None = None


@dataclass
class Scene:
    """The scene the campaign's FMU instances and the wear stepper use, with
    its gear set's kinematics as the Rust side computes them
    (`planetwear scene show --json`, or the packed FMU's
    resources/<scene>.kinematics.json)."""

    # The campaign file's value: a built-in name or a path.
    spec: str
    # What the FMU's sceneFile is set to ('' selects the FMU's built-in example-2004).
    fmu_value: str
    # What `planetwear wear step --scene` is given.
    cli_value: str
    # The scene's TOML text.
    text: str
    # The gear set's kinematics (model::kinematics::Kinematics, SI).
    kinematics: dict

    @property
    def face_width(self):
        """Face width of the sun [m]."""
        return self.kinematics["face_width"]

    @property
    def held(self):
        return self.kinematics["held"]

    @property
    def input(self):
        return self.kinematics["input"]

    def mesh_cycles_per_revolution(self):
        """Mesh cycles per revolution of the input member."""
        return self.kinematics["mesh_cycles_per_input_revolution"]

    def balanced_torques(self, input_torque):
        """(sun, ring, carrier) external torques [N·m] balancing `input_torque`
        on the input member; the held member's is zero."""
        return tuple(k * input_torque for k in self.kinematics["balanced_torques_per_input_torque"])


@dataclass
class Campaign:
    """A checked campaign file (every path absolute)."""

    source: Path
    fmu: Path
    fmu_sha256: str
    scene: Scene
    output_dir: Path
    planetwear_bin: str | None
    states: list
    speeds: list  # rpm, increasing
    directions: list  # "up" and/or "down"
    torques: list  # N·m on the sun
    communication_step: float | None  # s; None = one mesh cycle
    run_in_cycles: int
    window_cycles: int
    integrator: dict  # FMU parameter name → value
    outputs: list  # FMU output names, in table order
    output_types: dict  # name → "Real" | "Integer"
    loop: dict
    raw: dict = field(repr=False, default_factory=dict)
    # Where the FMU is unpacked for the tasks (default <output_dir>/.fmu).
    unpack_dir: Path | None = None

    def tasks(self):
        """The campaign's sweeps: (state, torque, direction) in a fixed order."""
        return [(s, t, d) for s in self.states for t in self.torques for d in self.directions]

    def points(self):
        return len(self.tasks()) * len(self.speeds)


def find_planetwear_bin(value=None, base=None):
    """The `planetwear` binary: the campaign's planetwear_bin, then
    $PLANETWEAR_BIN, then PATH; None when none is found."""
    if value:
        p = Path(value)
        if not p.is_absolute() and base is not None:
            p = base / p
        return str(p) if p.is_file() and os.access(p, os.X_OK) else None
    env = os.environ.get("PLANETWEAR_BIN")
    if env:
        return env if Path(env).is_file() and os.access(env, os.X_OK) else None
    return shutil.which("planetwear")


def _number(x):
    return isinstance(x, (int, float)) and not isinstance(x, bool)


def speed_grid(start, stop, step):
    """from, from + step, … up to `stop` (included within 1e-9 of a step)."""
    n = int(math.floor((stop - start) / step + 1e-9)) + 1
    return [start + step * i for i in range(n)]


def max_wear_depth(content):
    """Largest total wear depth [m] a state records: the last update's
    total_wear, or the flanks' depths of a state with no update."""
    history = content.get("history") or []
    if history and isinstance(history[-1], dict) and history[-1].get("total_wear"):
        return max(float(w["depth"]) for w in history[-1]["total_wear"])
    depths = [float(d) for fl in content.get("flanks", {}).values() for s in fl for d in s.get("depth", [])]
    return max(depths, default=0.0)


def check_state_document(text):
    """Checks a worn-profile state's JSON structure; returns (content, None)
    or (None, reason). The checksum and the gear set are checked by the FMU."""
    try:
        doc = json.loads(text)
    except json.JSONDecodeError as e:
        return None, f"not a JSON document ({e.msg} at line {e.lineno}, column {e.colno}): cut short or corrupt"
    if not isinstance(doc, dict):
        return None, "not a JSON object: not a worn-profile state"
    if doc.get("format") != STATE_FORMAT:
        return None, f"format {doc.get('format')!r}: a worn-profile state has format {STATE_FORMAT!r}"
    if doc.get("version") != STATE_VERSION:
        return None, f"version {doc.get('version')!r}: this runner reads version {STATE_VERSION}"
    if not isinstance(doc.get("checksum"), str) or not re.fullmatch(r"fnv1a64:[0-9a-f]{16}", doc["checksum"]):
        return None, f"checksum {doc.get('checksum')!r}: expected 'fnv1a64:' and 16 hex digits"
    c = doc.get("content")
    if not isinstance(c, dict):
        return None, "no 'content' object"
    k = c.get("kappa")
    if not isinstance(k, int) or isinstance(k, bool) or k < 0:
        return None, f"content.kappa {k!r}: must be a whole number ≥ 0"
    gs = c.get("gear_set")
    if not isinstance(gs, dict) or not isinstance(gs.get("parameters"), dict):
        return None, "content.gear_set.parameters missing: the state does not say which gear set it belongs to"
    flanks = c.get("flanks")
    if not isinstance(flanks, dict) or sorted(flanks) != sorted(STATE_FLANKS):
        got = sorted(flanks) if isinstance(flanks, dict) else flanks
        return None, f"content.flanks {got}: expected the six flanks {', '.join(STATE_FLANKS)}"
    for name, slices in flanks.items():
        if not isinstance(slices, list) or not slices:
            return None, f"content.flanks.{name}: expected a list of face slices"
        for s in slices:
            if not isinstance(s, dict) or not isinstance(s.get("depth"), list) or not isinstance(s.get("roll"), list):
                return None, f"content.flanks.{name}: each slice needs 'depth' and 'roll' lists"
            if len(s["depth"]) != len(s["roll"]):
                return None, f"content.flanks.{name}: 'depth' and 'roll' differ in length"
            if not all(_number(v) and math.isfinite(v) for v in s["depth"] + s["roll"]):
                return None, f"content.flanks.{name}: depths and roll angles must be finite numbers"
    history = c.get("history", [])
    if not isinstance(history, list):
        return None, "content.history: expected a list"
    for h in history:
        tw = h.get("total_wear") if isinstance(h, dict) else None
        if tw is not None and not (isinstance(tw, list) and all(isinstance(w, dict) and _number(w.get("depth"))
                                                                 for w in tw)):
            return None, "content.history[].total_wear: expected a list of {flank, depth, …}"
    return c, None


# The variables a campaign task sets: an FMU without them is not the planetwear FMU.
TASK_VARIABLES = ("sceneFile", "wearStateFile", "driveMode", "harmonicWindowCycles", "initialSpeed",
                  "inputSpeedReference", "sunTorque", "ringTorque", "carrierTorque") + tuple(
                      INTEGRATOR_PARAMETERS.values())


def model_variables(fmu_path):
    """{output name: type} of the FMU's model description, and the names of
    all its variables."""
    with zipfile.ZipFile(fmu_path) as z:
        root = ElementTree.fromstring(z.read("modelDescription.xml"))
    outputs, names = {}, set()
    for v in root.iter("ScalarVariable"):
        names.add(v.get("name"))
        if v.get("causality") == "output":
            kind = next((c.tag for c in v if c.tag in ("Real", "Integer", "Boolean", "String")), None)
            outputs[v.get("name")] = kind
    return outputs, names


def _kinematics_from_bin(exe, scene_arg):
    """The scene's TOML text and kinematics from `planetwear scene show --json`;
    raises ValueError with the binary's reason."""
    out = subprocess.run([exe, "scene", "show", scene_arg, "--json"], capture_output=True, text=True)
    if out.returncode != 0:
        raise ValueError(f"{exe} scene show: {out.stderr.strip()}")
    doc = json.loads(out.stdout)
    return doc["toml"], doc["kinematics"]


def _scene_text(spec, base, fmu_path, bin_value):
    """The scene's TOML text, what the FMU and the wear stepper are given, and
    its kinematics from the Rust side; raises ValueError with the reason."""
    p = Path(spec)
    if not p.is_absolute():
        p = base / p
    exe = find_planetwear_bin(bin_value, base)
    if p.exists():
        text = read_input(p, "scene").decode()
        _check_gear_tables(text)
        if not exe:
            raise ValueError("a scene file's kinematics come from the planetwear binary: set planetwear_bin or "
                             "PLANETWEAR_BIN, or name a scene the FMU ships")
        return text, str(p), str(p), _kinematics_from_bin(exe, str(p))[1]
    if spec in BUILT_IN_SCENES or not spec.endswith(".toml"):
        fmu_value = "" if spec == "example-2004" else f"{spec}.toml"
        if exe:
            try:
                text, kinematics = _kinematics_from_bin(exe, spec)
            except ValueError as e:
                raise ValueError(f"neither a file nor a built-in scene ({e})") from None
            return text, fmu_value, spec, kinematics
        # No binary: the FMU ships the built-in scenes and their kinematics in resources/.
        with zipfile.ZipFile(fmu_path) as z:
            name = f"resources/{spec}.toml"
            if name in z.namelist():
                kin = f"resources/{spec}.kinematics.json"
                if kin not in z.namelist():
                    raise ValueError(f"the FMU ships no {kin}: pack it with this version's planetwear fmu pack, "
                                     "or set planetwear_bin")
                return z.read(name).decode(), fmu_value, spec, json.loads(z.read(kin))
    raise ValueError(f"no such file (relative to the campaign file) and not a built-in scene "
                     f"({', '.join(BUILT_IN_SCENES)})")


def _check_gear_tables(text):
    """Raises ValueError unless the TOML text has the three gear tables."""
    s = tomllib.loads(text)
    missing = [t for t in ("sun", "planet", "ring") if not isinstance(s.get(t), dict)]
    if missing:
        raise ValueError(f"not a planetary gear set scene (no [{'], ['.join(missing)}] table)")


def _resolve_state(entry, base, fmu_path, fmu_names):
    """(path or None, fmu_value, bytes) of a wear.states entry; raises ValueError."""
    if entry == "":
        return None, "", None
    p = Path(entry)
    if not p.is_absolute():
        p = base / p
    if p.exists():
        return p, str(p), read_input(p, "worn_state")
    name = f"resources/{entry}"
    if name in fmu_names:
        with zipfile.ZipFile(fmu_path) as z:
            return None, entry, z.read(name)
    shipped = sorted(n[len("resources/"):] for n in fmu_names if n.startswith("resources/wear/"))
    raise ValueError("no such file (relative to the campaign file) and not a resource of the FMU "
                     f"(the FMU ships: {', '.join(shipped) or 'none'})")


def load(path, output_dir=None, *, probe):
    """Reads and checks a campaign file; returns a `Campaign` or raises
    `CampaignError` listing every problem. `probe` is the FMU's verdict:
    a function with the signature of `fmu_check.check` (which asks the FMU,
    in a subprocess, whether it accepts each wear state with the campaign's
    settings; its logged refusal becomes the problem's reason), or None for
    the checks of this module alone. It is a required keyword so that no
    caller skips the FMU's verdict by leaving it out;
    `fmu_check.load_campaign` is this function with `fmu_check.check`."""
    path = Path(path).resolve()
    try:
        raw = tomllib.loads(read_input(path, "campaign").decode())
    except FileNotFoundError:
        raise CampaignError(path, [Problem("(file)", str(path), "no such campaign file")]) from None
    except InputError as e:
        raise CampaignError(path, [Problem("(file)", str(path), str(e))]) from None
    except tomllib.TOMLDecodeError as e:
        raise CampaignError(path, [Problem("(file)", str(path), f"not valid TOML: {e}")]) from None
    return from_dict(raw, path, output_dir=output_dir, probe=probe)


def from_dict(raw, source, output_dir=None, *, probe):
    """Checks a campaign given as a dict (as read from TOML); relative paths
    are taken relative to the directory of `source`. `probe` as in `load`.

    The checks run in a fixed order, so the problems are listed in it: the
    keys and tables, fmu, planetwear_bin, scene, output_dir, [speeds],
    [load], [timing], [integrator], [outputs], [loop], [wear], and last the
    FMU's verdict (`probe`). Each step is a function below; a step that
    needs an earlier one's result (the FMU, the scene) skips what it cannot
    check without it."""
    source = Path(source).resolve()
    base = source.parent
    problems = []

    def bad(key, value, allowed):
        problems.append(Problem(key, value, allowed))

    tab = _check_keys(raw, bad)
    fmu, fmu_names, outputs_md = _check_fmu(raw, base, bad)
    bin_value = _check_planetwear_bin(raw, base, bad)
    scene = _check_scene(raw, base, fmu, bin_value, bad)
    out = _check_output_dir(raw, base, output_dir, bad)
    speeds, directions = _check_speeds(raw, tab["speeds"], bad)
    torques = _check_torques(raw, tab["load"], bad)
    step, cycles = _check_timing(tab["timing"], bad)
    integ = _check_integrator(tab["integrator"], bad)
    outputs, output_types = _check_outputs(tab["outputs"], outputs_md, bad)
    lp = _check_loop(tab["loop"], bad)
    wv, states, state_index = _check_wear(raw, tab["wear"], base, fmu, fmu_names, bad)
    problems += _probe_problems(probe, fmu, scene, integ, cycles, speeds, torques, wv, state_index)
    if problems:
        raise CampaignError(source, problems)
    return Campaign(source=source, fmu=fmu, fmu_sha256=sha256_file(fmu), scene=scene, output_dir=out,
                    planetwear_bin=bin_value, states=states, speeds=speeds, directions=directions,
                    torques=torques, communication_step=step, run_in_cycles=cycles["run_in_cycles"],
                    window_cycles=cycles["window_cycles"], integrator=integ, outputs=outputs,
                    output_types=output_types, loop=lp, raw=raw)


def _check_keys(raw, bad):
    """The keys of the campaign file: no unknown key at the top or in a
    table of TABLE_KEYS, each of those tables a table, and the [wear],
    [speeds] and [load] tables present. Returns every table of TABLE_KEYS
    as a dict ({} when it is missing or not a table)."""
    for k in raw:
        if k not in TOP_KEYS:
            bad(k, raw[k], f"unknown key; allowed are {', '.join(TOP_KEYS)}")
    for table, keys in TABLE_KEYS.items():
        if table in raw:
            if not isinstance(raw[table], dict):
                bad(table, raw[table], "must be a table ([" + table + "])")
                continue
            for k in raw[table]:
                if k not in keys:
                    bad(f"{table}.{k}", raw[table][k], f"unknown key; allowed are {', '.join(keys)}")
    for table in ("wear", "speeds", "load"):
        if table not in raw:
            bad(table, "(missing)", f"the [{table}] table is required")
    return {t: raw.get(t) if isinstance(raw.get(t), dict) else {} for t in TABLE_KEYS}


def _check_fmu(raw, base, bad):
    """fmu (required): an existing file, relative to the campaign file's
    directory, that is a zip archive with a model description declaring
    every variable a task sets (TASK_VARIABLES). Returns (the FMU's absolute
    path or None when it is unusable, the names in the archive, {output
    name: type} of the model description)."""
    fmu = None
    fmu_names = set()
    outputs_md = {}
    if "fmu" not in raw:
        bad("fmu", "(missing)", "required: the path of the planetwear FMU (.fmu)")
    elif not isinstance(raw["fmu"], str) or not raw["fmu"]:
        bad("fmu", raw["fmu"], "must be the path of an FMU file")
    else:
        fmu = Path(raw["fmu"])
        fmu = (fmu if fmu.is_absolute() else base / fmu).resolve()
        if not fmu.is_file():
            bad("fmu", raw["fmu"], f"no such file ({fmu}); build it with `planetwear fmu pack --out {raw['fmu']}`")
            fmu = None
        else:
            try:
                with zipfile.ZipFile(fmu) as z:
                    fmu_names = set(z.namelist())
                outputs_md, names = model_variables(fmu)
            except (zipfile.BadZipFile, KeyError, ElementTree.ParseError) as e:
                bad("fmu", raw["fmu"], f"not an FMU (a zip archive with modelDescription.xml): {e}")
                fmu = None
            else:
                missing = [n for n in TASK_VARIABLES if n not in names]
                if missing:
                    bad("fmu", raw["fmu"], f"not the planetwear FMU (it has no {', '.join(missing)})")
                    fmu, outputs_md = None, {}
    return fmu, fmu_names, outputs_md


def _check_planetwear_bin(raw, base, bad):
    """planetwear_bin (optional): the path of an executable file, relative
    to the campaign file's directory. Returns the value as given, or None
    when it is missing or bad."""
    bin_value = raw.get("planetwear_bin")
    if bin_value is not None and (not isinstance(bin_value, str) or not find_planetwear_bin(bin_value, base)):
        bad("planetwear_bin", bin_value, "must be the path of the planetwear binary (an executable file)")
        bin_value = None
    return bin_value


def _check_scene(raw, base, fmu, bin_value, bad):
    """scene (default example-2004): a built-in scene name or a scene file
    that can be read as a planetary gear set whose input member is the sun
    (the campaign's torque levels are sun torques). Read only when the FMU
    is usable, since without the binary the built-in scenes come from the
    FMU's resources. Returns the `Scene`, or None."""
    scene = None
    spec = raw.get("scene", "example-2004")
    if not isinstance(spec, str) or not spec:
        bad("scene", spec, f"must be a built-in scene name ({', '.join(BUILT_IN_SCENES)}) or a scene file")
    elif fmu is not None:
        try:
            text, fmu_value, cli_value, kinematics = _scene_text(spec, base, fmu, bin_value)
            scene = Scene(spec=spec, fmu_value=fmu_value, cli_value=cli_value, text=text, kinematics=kinematics)
        except KeyError as e:
            bad("scene", spec, f"cannot be read: the key {e} is missing")
        except (ValueError, tomllib.TOMLDecodeError) as e:
            bad("scene", spec, f"cannot be read: {e}")
        if scene is not None and scene.input != "sun":
            bad("scene", spec, f"operation.input = {scene.input}: the campaign's torque levels are sun torques, "
                               "so the scene's input member must be the sun")
            scene = None
    return scene


def _check_output_dir(raw, base, output_dir, bad):
    """output_dir (required; the `output_dir` argument takes the place of
    the file's key): a directory one may write in, or a path that can be
    created (its nearest existing ancestor is a directory one may write
    in). Returns the absolute path, the path as given when it is a bad
    directory, or None when it is missing or not a path."""
    out = output_dir if output_dir is not None else raw.get("output_dir")
    if out is None:
        bad("output_dir", "(missing)", "required: the directory of the results")
    elif not isinstance(out, (str, os.PathLike)) or not str(out):
        bad("output_dir", out, "must be a directory path")
        out = None
    else:
        out = Path(out)
        out = (out if out.is_absolute() else base / out).resolve()
        if out.exists() and not out.is_dir():
            bad("output_dir", str(out), "exists and is not a directory")
        elif not out.exists():
            # Checked before any run: the directory must be creatable, so
            # its nearest existing ancestor is a directory one may write in.
            anc = out.parent
            while not anc.exists() and anc != anc.parent:
                anc = anc.parent
            if not anc.is_dir():
                bad("output_dir", str(out), f"cannot be created: {anc} is not a directory")
            elif not os.access(anc, os.W_OK | os.X_OK):
                bad("output_dir", str(out), f"cannot be created: no permission to write in {anc}")
        elif not os.access(out, os.W_OK | os.X_OK):
            bad("output_dir", str(out), "is a directory without permission to write in it")
    return out


def _check_speeds(raw, sp, bad):
    """[speeds]: either values_rpm or from_rpm/to_rpm/step_rpm (not both),
    and directions: up, down, both (the default) or a list of up/down
    without repeats. Returns (the speeds [rpm], increasing, [] when bad;
    the directions, [] when bad)."""
    speeds = []
    grid_keys = [k for k in ("from_rpm", "to_rpm", "step_rpm") if k in sp]
    if "values_rpm" in sp and grid_keys:
        bad("speeds", "values_rpm and " + ", ".join(grid_keys), "give either values_rpm or from_rpm/to_rpm/step_rpm")
    elif "values_rpm" in sp:
        speeds = _speed_values(sp["values_rpm"], bad)
    elif "speeds" in raw:
        speeds = _speed_range(sp, bad)
    d = sp.get("directions", "both")
    directions = {"up": ["up"], "down": ["down"], "both": ["up", "down"]}.get(d) if isinstance(d, str) else None
    if isinstance(d, list) and d and all(x in ("up", "down") for x in d) and len(set(d)) == len(d):
        directions = list(d)
    if directions is None:
        bad("speeds.directions", d, "allowed are up, down, both (or a list of up/down)")
        directions = []
    return speeds, directions


def _speed_values(v, bad):
    """speeds.values_rpm: a non-empty, strictly increasing list of positive
    finite speeds [rpm] (each bad element named by its index). Returns the
    speeds as floats, or [] when any is bad."""
    if not isinstance(v, list) or not v:
        bad("speeds.values_rpm", v, "must be a non-empty list of speeds [rpm]")
        return []
    fine = True
    for i, x in enumerate(v):
        if not _number(x) or not math.isfinite(x) or x <= 0:
            bad(f"speeds.values_rpm[{i}]", x, "must be a positive finite speed [rpm]")
            fine = False
    if not fine:
        return []
    if any(b <= a for a, b in zip(v, v[1:])):
        bad("speeds.values_rpm", v, "must be strictly increasing (directions set the sweep order)")
        return []
    return [float(x) for x in v]


def _speed_range(sp, bad):
    """speeds.from_rpm, to_rpm and step_rpm: all three positive finite
    numbers [rpm], to_rpm not below from_rpm and at most MAX_SPEEDS speeds
    in the grid. Returns the grid (`speed_grid`), or [] when any is bad."""
    ok = True
    for k in ("from_rpm", "to_rpm", "step_rpm"):
        x = sp.get(k)
        if x is None:
            bad(f"speeds.{k}", "(missing)", "required with from_rpm/to_rpm/step_rpm (or give values_rpm)")
            ok = False
        elif not _number(x) or not math.isfinite(x) or x <= 0:
            bad(f"speeds.{k}", x, "must be a positive finite number [rpm]")
            ok = False
    if not ok:
        return []
    if sp["to_rpm"] < sp["from_rpm"]:
        bad("speeds.to_rpm", sp["to_rpm"], f"is below from_rpm = {sp['from_rpm']}: the grid would be empty")
        return []
    if (sp["to_rpm"] - sp["from_rpm"]) / sp["step_rpm"] + 1 > MAX_SPEEDS:
        bad("speeds.step_rpm", sp["step_rpm"], f"gives more than {MAX_SPEEDS} speeds")
        return []
    return speed_grid(float(sp["from_rpm"]), float(sp["to_rpm"]), float(sp["step_rpm"]))


def _check_torques(raw, ld, bad):
    """load.sun_torque_nm (checked when [load] is given): a sun torque
    [N·m] or a non-empty list of them, each non-zero and finite, none
    repeated. Returns the torques as floats, or [] when any is bad."""
    if "load" not in raw:
        return []
    tq = ld.get("sun_torque_nm")
    if isinstance(tq, (int, float)) and not isinstance(tq, bool):
        tq = [tq]
    if not isinstance(tq, list) or not tq:
        bad("load.sun_torque_nm", tq, "must be a non-empty list of sun torques [N·m]")
        return []
    for i, x in enumerate(tq):
        if not _number(x) or not math.isfinite(x) or x == 0:
            bad(f"load.sun_torque_nm[{i}]", x, "must be a non-zero finite torque [N·m]")
    if not all(_number(x) and math.isfinite(x) and x != 0 for x in tq):
        return []
    if len(set(tq)) != len(tq):
        bad("load.sun_torque_nm", tq, "must not repeat a torque")
        return []
    return [float(x) for x in tq]


def _check_timing(tm, bad):
    """[timing]: communication_step "mesh cycle" (the default) or a positive
    step [s]; run_in_cycles (default 34, at least 0) and window_cycles
    (default 68, at least 1) whole numbers of mesh cycles up to 1 000 000.
    Returns (the step, None for one mesh cycle or when bad; {key: value as
    given} of the two cycle counts)."""
    h = tm.get("communication_step", "mesh cycle")
    step = None
    if isinstance(h, str):
        if h.strip().lower() not in ("mesh cycle", "one mesh cycle"):
            bad("timing.communication_step", h, "allowed are \"mesh cycle\" or a positive step in seconds")
    elif not _number(h) or not math.isfinite(h) or h <= 0:
        bad("timing.communication_step", h, "allowed are \"mesh cycle\" or a positive step in seconds")
    else:
        step = float(h)
    cycles = {}
    for k, default, least in (("run_in_cycles", 34, 0), ("window_cycles", 68, 1)):
        x = tm.get(k, default)
        if not isinstance(x, int) or isinstance(x, bool) or x < least or x > 1_000_000:
            bad(f"timing.{k}", x, f"must be a whole number of mesh cycles, at least {least}")
        cycles[k] = x
    return step, cycles


def _check_integrator(ig, bad):
    """[integrator] (the FMU checks the settings once more): integrator 0
    (generalized-α) or 1 (Runge-Kutta 5(4)); steps_per_mesh_cycle and
    samples_per_mesh_cycle whole numbers ≥ 1; rho_infinity in [0, 1];
    relative_tolerance in (0, 1). Returns {FMU parameter name: value} of
    the good settings, in the table's order."""
    integ = {}
    for k, x in ig.items():
        if k not in INTEGRATOR_PARAMETERS:
            continue
        name = INTEGRATOR_PARAMETERS[k]
        if k == "integrator":
            if x not in (0, 1) or isinstance(x, bool):
                bad("integrator.integrator", x, "allowed are 0 (generalized-α) and 1 (Runge-Kutta 5(4))")
                continue
        elif k in ("steps_per_mesh_cycle", "samples_per_mesh_cycle"):
            if not isinstance(x, int) or isinstance(x, bool) or x < 1:
                bad(f"integrator.{k}", x, "must be a whole number ≥ 1")
                continue
        elif k == "rho_infinity":
            if not _number(x) or not 0 <= x <= 1:
                bad("integrator.rho_infinity", x, "must be in [0, 1]")
                continue
        elif k == "relative_tolerance":
            if not _number(x) or not (0 < x < 1):
                bad("integrator.relative_tolerance", x, "must be in (0, 1)")
                continue
        integ[name] = x
    return integ


def _check_outputs(op, outputs_md, bad):
    """outputs.keep (default DEFAULT_OUTPUTS): a list of names of Real or
    Integer outputs of the FMU's model description (checked against it
    when the FMU is usable; a name not found comes with the outputs
    starting alike). Returns (the kept outputs followed by REQUIRED_OUTPUTS,
    each once, in that order; {name: "Real" | "Integer"})."""
    keep = op.get("keep", list(DEFAULT_OUTPUTS))
    outputs, output_types = [], {}
    if not isinstance(keep, list) or not all(isinstance(x, str) for x in keep):
        bad("outputs.keep", keep, "must be a list of FMU output names")
    elif outputs_md:
        for i, name in enumerate(keep):
            if name not in outputs_md:
                close = [n for n in outputs_md if n.lower().startswith(name.lower()[:8])][:6]
                hint = f" (outputs starting alike: {', '.join(close)})" if close else ""
                bad(f"outputs.keep[{i}]", name, f"not an output of the FMU's model description{hint}")
            elif outputs_md[name] not in ("Real", "Integer"):
                bad(f"outputs.keep[{i}]", name, "only Real and Integer outputs can be kept")
        for name in list(keep) + list(REQUIRED_OUTPUTS):
            if name in outputs_md and outputs_md[name] in ("Real", "Integer") and name not in outputs:
                outputs.append(name)
                output_types[name] = outputs_md[name]
    return outputs, output_types


def _check_loop(table, bad):
    """[loop], the wear stepper's settings of `campaign loop`: threshold_um
    a positive wear depth below 1000 µm, ring true or false,
    dynamic_speed_rpm a positive speed, hours_per_stage a positive number
    of operating hours below 10⁶ (and not given with dynamic_speed_rpm: the
    stage's duty cycle sets the loads and speeds). Returns a copy of the
    table."""
    lp = dict(table)
    if "threshold_um" in lp and (not _number(lp["threshold_um"]) or not 0 < lp["threshold_um"] < 1000):
        bad("loop.threshold_um", lp["threshold_um"], "must be a positive wear depth below 1000 µm")
    if "ring" in lp and not isinstance(lp["ring"], bool):
        bad("loop.ring", lp["ring"], "must be true or false")
    if "dynamic_speed_rpm" in lp and (not _number(lp["dynamic_speed_rpm"]) or not lp["dynamic_speed_rpm"] > 0):
        bad("loop.dynamic_speed_rpm", lp["dynamic_speed_rpm"], "must be a positive speed [rpm]")
    if "hours_per_stage" in lp:
        if not _number(lp["hours_per_stage"]) or not 0 < lp["hours_per_stage"] < 1e6:
            bad("loop.hours_per_stage", lp["hours_per_stage"], "must be a positive number of operating hours")
        elif "dynamic_speed_rpm" in lp:
            bad("loop.dynamic_speed_rpm", lp["dynamic_speed_rpm"],
                "cannot be given with loop.hours_per_stage: the stage's duty cycle sets the loads and speeds")
    return lp


def _check_wear(raw, wt, base, fmu, fmu_names, bad):
    """[wear] (checked when given): states a non-empty list of state files
    or FMU resource names ('' for the unworn set), labels (optional) one
    file-name safe label per state. Each state is read and its JSON
    structure checked when the FMU is usable (the FMU's verdict comes
    later, from `probe`); no two states may share a label. Returns
    (wear.states as given, [] when bad; the `WearState`s read; {index in
    wear.states: its WearState})."""
    states = []
    state_index = {}
    wv = wt.get("states")
    labels = wt.get("labels")
    if "wear" not in raw:
        return wv, states, state_index
    if not isinstance(wv, list) or not wv or not all(isinstance(x, str) for x in wv):
        bad("wear.states", wv, "must be a non-empty list of state files or FMU resource names "
                               "('' for the unworn set)")
        wv = []
    if labels is not None and (not isinstance(labels, list) or len(labels) != len(wv)
                               or not all(isinstance(x, str) and LABEL.match(x) for x in labels)):
        bad("wear.labels", labels, f"must be a list of {len(wv)} labels of letters, digits, '.', '_', '+', '-'")
        labels = None
    for i, entry in enumerate(wv if fmu is not None else []):
        state = _read_wear_state(f"wear.states[{i}]", entry, labels[i] if labels else None, base, fmu,
                                 fmu_names, bad)
        if state is not None:
            states.append(state)
            state_index[i] = state
    _check_wear_labels(wv, state_index, bad)
    return wv, states, state_index


def _read_wear_state(key, entry, label, base, fmu, fmu_names, bad):
    """One wear.states entry (`key` names it): a state file or a resource
    of the FMU whose JSON structure is a worn-profile state, or '' for the
    unworn set. Its label is `label`, or when None "unworn" or
    kappa-<κ>. Returns the `WearState`, or None when it is bad."""
    try:
        p, fmu_value, data = _resolve_state(entry, base, fmu, fmu_names)
    except ValueError as e:
        bad(key, entry, str(e))
        return None
    if data is None:
        return WearState("", 0, label if label is not None else "unworn", "", 0.0, None)
    content, reason = check_state_document(data.decode("utf-8", errors="replace"))
    if reason:
        bad(key, entry, f"not a usable worn-profile state: {reason}")
        return None
    if label is None:
        label = f"kappa-{content['kappa']}"
    return WearState(fmu_value, content["kappa"], label, hashlib.sha256(data).hexdigest(),
                     max_wear_depth(content), p)


def _check_wear_labels(wv, state_index, bad):
    """No two wear states read share a label (each later one is named,
    with the first state of that label)."""
    seen = {}
    for i, s in state_index.items():
        if s.label in seen:
            j = seen[s.label]
            bad(f"wear.states[{i}]", wv[i], f"its label {s.label} is also that of wear.states[{j}] = {wv[j]}: "
                                            "give wear.labels to tell them apart")
        seen.setdefault(s.label, i)


def _probe_problems(probe, fmu, scene, integ, cycles, speeds, torques, wv, state_index):
    """The FMU's verdict (`probe`) on the integrator settings and on each
    wear state that passed the checks above, asked at the campaign's window
    (68 mesh cycles when window_cycles is bad), first speed (3000 rpm when
    there is none) and first torque (750 N·m when there is none). Returns
    its problems; [] without a probe or when the FMU or the scene is
    unusable."""
    if not (probe and fmu is not None and scene is not None):
        return []
    window = cycles["window_cycles"]
    return probe(fmu, scene, integ, window if isinstance(window, int) and window >= 1 else 68,
                 speeds[0] if speeds else 3000.0, torques[0] if torques else 750.0,
                 [(i, wv[i], s) for i, s in state_index.items()])


def dumps_toml(data):
    """A TOML text of a campaign dict (strings, numbers, booleans, lists of
    them, one level of tables): the stage files of `campaign loop`."""

    def value(v):
        if isinstance(v, bool):
            return "true" if v else "false"
        if isinstance(v, int):
            return str(v)
        if isinstance(v, float):
            if not math.isfinite(v):
                raise ValueError(f"{v} cannot be written to a campaign file")
            return repr(v)
        if isinstance(v, str):
            return json.dumps(v, ensure_ascii=False)
        if isinstance(v, list):
            return "[" + ", ".join(value(x) for x in v) + "]"
        raise TypeError(f"cannot write {type(v).__name__} to TOML")

    lines = [f"{k} = {value(v)}" for k, v in data.items() if not isinstance(v, dict)]
    for k, v in data.items():
        if isinstance(v, dict):
            lines += ["", f"[{k}]"] + [f"{kk} = {value(vv)}" for kk, vv in v.items()]
    return "\n".join(lines) + "\n"
