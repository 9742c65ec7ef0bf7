"""Regression-test kit: does a model that embeds the planetwear FMU still
reproduce the FMU's reference results?

The FMU ships reference results for the example gear set
(``resources/regression/example-2004.json``, written by ``planetwear fmu
pack``; docs/REGRESSION.md): for a few speeds and worn-profile states κ, the
values of the windowed outputs ``window.*`` (mesh-force harmonics F1..F6,
Frms, mean and separation fraction of planet 1's sun–planet and ring–planet
mesh, in N and 1) that a run through the stated protocol reproduces, each
with its tolerance.

    from planetwear_fmu.regression import load_references, run_reference_case, compare

    refs = load_references("fmu/planetwear.fmu")      # the .fmu, an unpacked FMU, or the .json
    case = refs.case("kappa-0/3000rpm")
    measured = run_reference_case("fmu/planetwear.fmu", case)   # the FMU alone, through fmpy
    result = compare(case, measured)
    print(result.report())
    result.assert_ok()                                 # AssertionError naming case, quantity, values

A model that embeds the FMU runs the case with its own driver: it sets
``refs.parameters(case)`` on the FMU instance, holds ``refs.inputs(case)``
for ``refs.duration(case)`` seconds from t = 0, reads the ``window.*``
outputs and hands them to ``compare`` (or the pytest fixture
``planetwear_reference``, planetwear_fmu.pytest_plugin).

Layer 2 (FMU access): this module owns the references' format, running a
case through fmpy and the comparison. Of the package it imports only `files`
(it stands apart from the campaigns); `pytest_plugin` imports it.
"""

from __future__ import annotations

import json
import math
import zipfile
from dataclasses import dataclass, field
from pathlib import Path
from typing import Mapping

from .files import read_input

FORMAT = "planetwear-regression/1"
RESOURCE = "resources/regression/example-2004.json"


class IncompatibleReferences(ValueError):
    """The references do not belong to this FMU or this kit (format,
    interface GUID or planetwear version differ)."""


@dataclass(frozen=True)
class Case:
    """One reference case: an operating point and worn-profile state, the
    reference values of the FMU's outputs and their tolerances."""

    name: str
    kappa: int
    speed_rpm: float
    mesh_frequency_hz: float
    communication_step_s: float
    parameters: dict
    values: dict
    tolerance: dict
    budget: dict
    work: dict = field(default_factory=dict)

    def __str__(self):
        return self.name


@dataclass(frozen=True)
class References:
    """The content of a reference file."""

    format: str
    fmu_guid: str
    planetwear_version: str
    scene: str
    protocol: dict
    reference: dict
    cases: tuple
    source: str = ""

    def case(self, name) -> Case:
        """The case called `name` (e.g. ``kappa-0/3000rpm``)."""
        for c in self.cases:
            if c.name == name:
                return c
        raise KeyError(f"no reference case {name!r} in {self.source}: the cases are "
                       + ", ".join(c.name for c in self.cases))

    def parameters(self, case) -> dict:
        """FMU parameters to set before initialization for `case`: the
        protocol's and the case's (name → value)."""
        case = self._case(case)
        return {**self.protocol["parameters"], **case.parameters}

    def inputs(self, case) -> dict:
        """FMU inputs to hold constant for the whole run (name → value)."""
        return dict(self.protocol["inputs"])

    def duration(self, case) -> float:
        """Length of the run from t = 0 [s]: run-in plus window."""
        case = self._case(case)
        return self.protocol["total_cycles"] / case.mesh_frequency_hz

    def check_fmu(self, fmu) -> None:
        """Raises IncompatibleReferences unless the FMU at `fmu` (a .fmu
        file or an unpacked FMU directory) is the one these references were
        made for (same interface GUID and planetwear version)."""
        guid, version = fmu_identity(fmu)
        if guid != self.fmu_guid:
            raise IncompatibleReferences(
                f"the references {self.source} were made for the FMU with GUID {self.fmu_guid}, but {fmu} "
                f"has GUID {guid} (another variable interface): use the references shipped in the FMU "
                f"under test ({RESOURCE})")
        if version != self.planetwear_version:
            raise IncompatibleReferences(
                f"the references {self.source} were made by planetwear {self.planetwear_version}, but {fmu} "
                f"is planetwear {version}: use the references shipped in the FMU under test ({RESOURCE})")

    def _case(self, case) -> Case:
        return case if isinstance(case, Case) else self.case(case)


def _read_json_text(source: Path) -> tuple[str, str]:
    if source.is_dir():
        path = source / RESOURCE
        if not path.is_file():
            raise FileNotFoundError(f"{source} is not an unpacked planetwear FMU with references: "
                                    f"{RESOURCE} is missing")
        return read_input(path, "record").decode(), str(path)
    if not source.is_file():
        raise FileNotFoundError(f"reference source {source} does not exist (give a .fmu file, an unpacked "
                                f"FMU directory or the reference .json)")
    if zipfile.is_zipfile(source):
        with zipfile.ZipFile(source) as z:
            try:
                return z.read(RESOURCE).decode(), f"{source}!{RESOURCE}"
            except KeyError:
                raise IncompatibleReferences(
                    f"{source} holds no {RESOURCE}: an FMU packed before the regression references "
                    f"existed, or not a planetwear FMU") from None
    return read_input(source, "record").decode(), str(source)


def load_references(source) -> References:
    """Reads the references from a .fmu file (a zip), an unpacked FMU
    directory, or the reference .json itself."""
    text, where = _read_json_text(Path(source))
    try:
        doc = json.loads(text)
    except json.JSONDecodeError as e:
        raise IncompatibleReferences(f"{where} is not valid JSON: {e}") from None
    fmt = doc.get("format") if isinstance(doc, dict) else None
    if fmt != FORMAT:
        raise IncompatibleReferences(f"{where} has format {fmt!r}; this kit reads {FORMAT!r} "
                                     f"(update planetwear_fmu or use a matching FMU)")
    try:
        cases = tuple(Case(**{k: c[k] for k in Case.__dataclass_fields__ if k in c}) for c in doc["cases"])
        refs = References(format=fmt, fmu_guid=doc["fmu_guid"], planetwear_version=doc["planetwear_version"],
                          scene=doc["scene"], protocol=doc["protocol"], reference=doc["reference"],
                          cases=cases, source=where)
    except (KeyError, TypeError) as e:
        raise IncompatibleReferences(f"{where}: a required entry is missing or malformed ({e})") from None
    for c in refs.cases:
        missing = set(c.values) ^ set(c.tolerance)
        if missing or not c.values:
            raise IncompatibleReferences(f"{where}: case {c.name} has values and tolerances for different "
                                         f"quantities ({sorted(missing)})")
    return refs


def fmu_identity(fmu) -> tuple[str, str]:
    """(GUID, version) from the model description of a .fmu or an unpacked FMU."""
    from fmpy import read_model_description

    path = Path(fmu)
    if not path.exists():
        raise FileNotFoundError(f"FMU {fmu} does not exist")
    md = read_model_description(str(path))
    return md.guid, md.version


def run_reference_case(fmu, case, references=None, communication_step=None, unzipdir=None,
                       instance_name="planetwear-regression") -> dict:
    """Runs the FMU alone through the references' protocol for `case` (a
    Case or its name) with fmpy and returns the measured outputs (name →
    value) of the case's quantities, plus ``window.cycles``.

    `references` defaults to the ones shipped in `fmu`, which is then
    checked to be the FMU they belong to. `communication_step` [s] replaces
    the protocol's step of one mesh period (the run still ends at the
    protocol's duration). `unzipdir` reuses an already extracted FMU."""
    from fmpy import extract, read_model_description
    from fmpy.fmi2 import FMU2Slave

    refs = references if references is not None else load_references(fmu)
    refs.check_fmu(fmu)
    case = refs._case(case)
    md = read_model_description(str(fmu))
    variables = {v.name: v for v in md.modelVariables}
    unknown = [n for n in [*refs.parameters(case), *refs.inputs(case), *case.values] if n not in variables]
    if unknown:
        raise IncompatibleReferences(f"the FMU {fmu} has no variables {unknown} that the references name")
    if unzipdir is None:
        unzipdir = str(fmu) if Path(fmu).is_dir() else extract(str(fmu))
    slave = FMU2Slave(guid=md.guid, unzipDirectory=unzipdir, modelIdentifier=md.coSimulation.modelIdentifier,
                      instanceName=instance_name)
    # Logging off in-process (fmpy's logger shim can outlive an instance).
    slave.instantiate(loggingOn=False)
    try:
        start = float(refs.protocol["start_time"])
        slave.setupExperiment(startTime=start)
        for name, value in refs.parameters(case).items():
            _set(slave, variables[name], value)
        slave.enterInitializationMode()
        for name, value in refs.inputs(case).items():
            _set(slave, variables[name], value)
        slave.exitInitializationMode()
        duration = refs.duration(case)
        period = 1.0 / case.mesh_frequency_hz
        if communication_step is None:
            h = refs.protocol["communication_step_cycles"] * period
            n = int(round(duration / h))
        else:
            h = float(communication_step)
            if not (math.isfinite(h) and 0 < h <= duration):
                raise ValueError(f"communication_step = {communication_step}: must be a positive number of "
                                 f"seconds not longer than the run ({duration} s)")
            n = int(math.ceil(duration / h - 1e-9))
        # Communication points from integer counts; the last step ends on the duration.
        for k in range(n):
            t0 = start + k * h
            t1 = start + (duration if k == n - 1 else (k + 1) * h)
            slave.doStep(currentCommunicationPoint=t0, communicationStepSize=t1 - t0)
        names = list(case.values)
        measured = dict(zip(names, slave.getReal([variables[n].valueReference for n in names])))
        [cycles] = slave.getInteger([variables["window.cycles"].valueReference])
        measured["window.cycles"] = cycles
        if cycles < refs.protocol["window_cycles"]:
            raise RuntimeError(f"case {case.name}: the FMU's window holds {cycles} mesh cycles after the run, "
                               f"not {refs.protocol['window_cycles']}: the set did not turn at the case's speed")
        slave.terminate()
    finally:
        slave.freeInstance()
    return measured


def _set(slave, variable, value):
    vr = [variable.valueReference]
    if variable.type == "Real":
        slave.setReal(vr, [float(value)])
    elif variable.type in ("Integer", "Enumeration"):
        slave.setInteger(vr, [int(value)])
    elif variable.type == "Boolean":
        slave.setBoolean(vr, [bool(value)])
    else:
        slave.setString(vr, [str(value)])


@dataclass(frozen=True)
class Row:
    """One quantity of a comparison."""

    quantity: str
    measured: float
    reference: float
    tolerance: float

    @property
    def error(self) -> float:
        return abs(self.measured - self.reference) if math.isfinite(self.measured) else math.inf

    @property
    def ok(self) -> bool:
        return self.error <= self.tolerance

    def describe(self) -> str:
        return (f"{self.quantity} = {self.measured:.6g}, reference {self.reference:.6g}, "
                f"|difference| {self.error:.3g} > tolerance {self.tolerance:.6g}")


@dataclass(frozen=True)
class Comparison:
    """Measured values against a case's references."""

    case: Case
    rows: tuple

    @property
    def ok(self) -> bool:
        return all(r.ok for r in self.rows)

    @property
    def failures(self) -> list:
        return [r for r in self.rows if not r.ok]

    def worst_fraction_of_f1(self) -> float:
        """E_h of the measurement: the largest |ΔF_k| (k = 1..6) over the
        compared meshes, divided by the mesh's reference F1."""
        worst = 0.0
        for r in self.rows:
            for mesh in ("sun", "ring"):
                if r.quantity.startswith(f"window.{mesh}MeshF") and r.quantity[-1].isdigit():
                    worst = max(worst, r.error / self.case.values[f"window.{mesh}MeshF1"])
        return worst

    def worst_use_of_tolerance(self) -> float:
        """max over the quantities of |difference| / tolerance (≤ 1 passes)."""
        return max((r.error / r.tolerance if r.tolerance > 0 else (0.0 if r.error == 0 else math.inf))
                   for r in self.rows)

    def report(self) -> str:
        lines = [f"case {self.case.name}: {'reproduced' if self.ok else 'NOT reproduced'} "
                 f"(E_h {self.worst_fraction_of_f1():.2e} of F1, tolerance "
                 f"{self.case.budget.get('fraction_of_f1', float('nan')):.1e} of F1)",
                 f"  {'quantity':<24}{'measured':>14}{'reference':>14}{'|difference|':>14}{'tolerance':>12}"]
        for r in self.rows:
            lines.append(f"  {r.quantity:<24}{r.measured:>14.6g}{r.reference:>14.6g}{r.error:>14.3g}"
                         f"{r.tolerance:>12.3g}{'' if r.ok else '  FAIL'}")
        return "\n".join(lines)

    def assert_ok(self) -> "Comparison":
        """Raises AssertionError naming the case and every quantity outside its tolerance."""
        if not self.ok:
            raise AssertionError(f"case {self.case.name} not reproduced: "
                                 + "; ".join(r.describe() for r in self.failures)
                                 + "\n" + self.report())
        return self


def compare(case: Case, measured: Mapping) -> Comparison:
    """Compares `measured` (output name → value, e.g. ``{"window.sunMeshF1":
    479.5, ...}``) with the case's references. Every name must be one of the
    case's quantities (``window.cycles`` is accepted and ignored); quantities
    not given are not compared, but at least one must be."""
    extra = sorted(n for n in measured if n not in case.values and n != "window.cycles")
    if extra:
        raise ValueError(f"case {case.name}: no reference for {extra}; the quantities are "
                         + ", ".join(case.values))
    rows = tuple(Row(n, float(measured[n]), case.values[n], case.tolerance[n])
                 for n in case.values if n in measured)
    if not rows:
        raise ValueError(f"case {case.name}: nothing to compare; give some of " + ", ".join(case.values))
    return Comparison(case, rows)


def assert_reproduces(case: Case, measured: Mapping) -> Comparison:
    """compare(case, measured).assert_ok()."""
    return compare(case, measured).assert_ok()
