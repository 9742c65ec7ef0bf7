"""The load duty an FMU run produced, as a duty-cycle file.

The FMU records, for each mesh, the input revolutions spent in each bin of
load torque x input speed (parameters `dutyTorqueEdges` [N.m] and
`dutySpeedEdges` [rad/s]) and gives the whole duty since initialization as
the String output `dutyCycle`: a JSON document in the format of
`planetwear simulate --duty-cycle` (docs/DUTY.md), with a schema version,
the FNV-1a 64 checksum of its content and the gear set's fingerprint. This
module reads it from a running FMU, checks it and writes it atomically.

The checksum is computed and checked by the Rust side (the FMU writes it; a
reader of the file in the tool checks it with the gear set); here the
document's format, version, checksum field and the duty's own sums are
checked, so that a truncated or foreign file is refused with the reason.

Layer 1: imports `files` only.
"""

from __future__ import annotations

import json
import re

from .files import read_input, write_atomic

FORMAT = "planetwear-duty-cycle"
VERSION = 1
OUTPUT = "dutyCycle"


class DutyCycleError(ValueError):
    """A duty-cycle document that is not one, with the reason."""


def check_document(text):
    """The parsed duty-cycle document `text` (str), or `DutyCycleError` saying
    why not: not JSON or cut short, another format or version, no checksum,
    a duty whose sizes do not match its bins or whose bins and outside do
    not add up to its revolutions for every mesh."""
    try:
        doc = json.loads(text)
    except json.JSONDecodeError as e:
        cut = e.pos >= len(text.rstrip())
        raise DutyCycleError(("the document is truncated: " if cut else "not a JSON document: ") + str(e)) from None
    if not isinstance(doc, dict):
        raise DutyCycleError("not a duty-cycle document: the JSON is not an object")
    if doc.get("format") != FORMAT:
        raise DutyCycleError(f"format is {doc.get('format')!r}, not {FORMAT!r}")
    if doc.get("version") != VERSION:
        raise DutyCycleError(f"version {doc.get('version')!r} cannot be read, this package reads version {VERSION}")
    if not isinstance(doc.get("checksum"), str) or not re.fullmatch(r"fnv1a64:[0-9a-f]{16}", doc["checksum"]):
        raise DutyCycleError(f"checksum {doc.get('checksum')!r}: expected 'fnv1a64:' and 16 hex digits")
    try:
        duty = doc["content"]["duty"]
        torque, speed = duty["bins"]["torque"], duty["bins"]["speed"]
        planets, revolutions, outside, total = duty["planets"], duty["revolutions"], duty["outside"], duty["total"]
        doc["content"]["gear_set"]["fingerprint"]
    except (KeyError, TypeError) as e:
        raise DutyCycleError(f"the content has no {e}") from None
    per_mesh = (len(torque) - 1) * (len(speed) - 1)
    meshes = 2 * planets
    if len(revolutions) != meshes * per_mesh or len(outside) != meshes:
        raise DutyCycleError(f"{planets} planets on {per_mesh} bins need {meshes * per_mesh} revolutions and "
                             f"{meshes} outside values, found {len(revolutions)} and {len(outside)}")
    for m in range(meshes):
        s = sum(revolutions[m * per_mesh:(m + 1) * per_mesh]) + outside[m]
        if abs(s - total) > 1e-9 * max(total, 1.0):
            raise DutyCycleError(f"mesh {m + 1} has {s} revolutions in its bins and outside, the duty {total}")
    return doc


def duty_cycle_text(slave, model_description):
    """The `dutyCycle` output of an fmpy FMU2Slave (initialized), as text."""
    vr = next(v.valueReference for v in model_description.modelVariables if v.name == OUTPUT)
    value = slave.getString([vr])[0]
    return value.decode() if isinstance(value, bytes) else value


def write_duty_cycle(path, text):
    """Checks the duty-cycle document `text` (`check_document`) and writes it
    to `path` atomically; returns the parsed document."""
    doc = check_document(text)
    write_atomic(path, text.encode())
    return doc


def read_duty_cycle(path):
    """The checked duty-cycle document in the file `path` (through the
    package's one reader: a regular file within the duty-cycle limit)."""
    try:
        return check_document(read_input(path, "duty_cycle").decode())
    except DutyCycleError as e:
        raise DutyCycleError(f"duty-cycle file '{path}': {e}") from None
