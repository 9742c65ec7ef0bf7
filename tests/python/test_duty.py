"""The load duty the FMU records (dutyCycle, docs/DUTY.md) and the duty-cycle
file the package writes from it (planetwear_fmu.duty).

Needs fmu/planetwear.fmu (the README's test command builds and packs it)."""

import json
import math

import pytest
from fmpy.fmi1 import FMICallException
from fmpy.fmi2 import FMU2Slave

from planetwear_fmu.duty import DutyCycleError, check_document, duty_cycle_text, read_duty_cycle, write_duty_cycle

# The packed FMU, extracted once per module (its fixture is test_fmu's).
from test_fmu import fmu  # noqa: E402,F401

OMEGA = 3000 * math.pi / 30


def started(md, unzipdir, strings=None):
    s = FMU2Slave(guid=md.guid, unzipDirectory=unzipdir, modelIdentifier=md.coSimulation.modelIdentifier,
                  instanceName="duty")
    s.instantiate()
    s.setupExperiment(startTime=0.0)
    vrs = {v.name: v.valueReference for v in md.modelVariables}
    for name, value in (strings or {}).items():
        s.setString([vrs[name]], [value])
    s.enterInitializationMode()
    s.exitInitializationMode()
    return s


def steps(s, t, n, h=1e-3):
    for _ in range(n):
        s.doStep(t, h)
        t += h
    return t


def mesh_bins(doc, m):
    duty = doc["content"]["duty"]
    per = (len(duty["bins"]["torque"]) - 1) * (len(duty["bins"]["speed"]) - 1)
    return duty["revolutions"][m * per:(m + 1) * per]


def test_the_duty_of_a_run_at_its_operating_point_is_its_revolutions_in_the_operating_bin(fmu, tmp_path):
    md, unzipdir = fmu
    s = started(md, unzipdir)
    steps(s, 0.0, 50)
    doc = write_duty_cycle(tmp_path / "duty.json", duty_cycle_text(s, md))
    s.terminate()
    s.freeInstance()
    duty = doc["content"]["duty"]
    print("dutyCycle after 50 steps of 1 ms:", duty["total"], "revolutions,", duty["duration"], "s")
    # 3000 rpm for 0.05 s: 2.5 input revolutions (the speed settles within 1 %).
    assert abs(duty["total"] / (OMEGA * 0.05 / (2 * math.pi)) - 1) < 0.01
    assert duty["duration"] == pytest.approx(0.05, rel=1e-12)
    # The default bins: 0 to twice 750 N.m and 0 to twice 3000 rpm, 11 each; the operating
    # point mid-bin (5, 5) for every mesh of the four planets.
    assert len(duty["bins"]["torque"]) == 12 and duty["bins"]["torque"][-1] == pytest.approx(1500.0)
    for m in range(2 * duty["planets"]):
        bins = mesh_bins(doc, m)
        assert bins[5 * 11 + 5] == pytest.approx(duty["total"], rel=1e-12), m
    assert read_duty_cycle(tmp_path / "duty.json") == doc
    assert doc["content"]["source"] == "fmu"


def test_a_restored_state_counts_a_step_taken_again_once(fmu):
    md, unzipdir = fmu
    s = started(md, unzipdir, {"dutyTorqueEdges": "0, 500, 700, 800, 1000", "dutySpeedEdges": "0, 300, 330, 400"})
    t = steps(s, 0.0, 20)
    state = s.getFMUstate()
    serialized = s.serializeFMUstate(state)
    steps(s, t, 10)
    straight = json.loads(duty_cycle_text(s, md))
    s.setFMUstate(state)
    steps(s, t, 10)
    again = json.loads(duty_cycle_text(s, md))
    s.setFMUstate(s.deSerializeFMUstate(serialized))
    steps(s, t, 10)
    from_bytes = json.loads(duty_cycle_text(s, md))
    s.freeFMUstate(state)
    s.terminate()
    s.freeInstance()
    assert again["content"]["duty"] == straight["content"]["duty"]
    assert from_bytes["content"]["duty"] == straight["content"]["duty"]
    duty = straight["content"]["duty"]
    assert duty["bins"]["torque"] == [0, 500, 700, 800, 1000]
    assert duty["duration"] == pytest.approx(0.03, rel=1e-12)


def test_bad_bin_edges_are_refused_by_name(fmu, capfd):
    md, unzipdir = fmu
    for name, value in [("dutyTorqueEdges", "0, 100, 100"), ("dutySpeedEdges", "fast"), ("dutyTorqueEdges", "5")]:
        s = FMU2Slave(guid=md.guid, unzipDirectory=unzipdir, modelIdentifier=md.coSimulation.modelIdentifier,
                      instanceName="bad")
        s.instantiate(loggingOn=True)
        s.setupExperiment(startTime=0.0)
        vr = next(v.valueReference for v in md.modelVariables if v.name == name)
        s.setString([vr], [value])
        s.enterInitializationMode()
        with pytest.raises(FMICallException):
            s.exitInitializationMode()
        s.freeInstance()
        log = capfd.readouterr().out
        print(log)
        assert f"{name} = " in log, log


def test_documents_that_are_not_duty_cycles_are_refused_with_the_reason(fmu, tmp_path):
    md, unzipdir = fmu
    s = started(md, unzipdir)
    steps(s, 0.0, 5)
    text = duty_cycle_text(s, md)
    s.terminate()
    s.freeInstance()
    doc = json.loads(text)
    cases = {
        "truncated": text[: len(text) // 2],
        "format": json.dumps({**doc, "format": "planetwear-worn-profile"}),
        "version 2": json.dumps({**doc, "version": 2}),
        "checksum": json.dumps({**doc, "checksum": "none"}),
    }
    broken = json.loads(text)
    broken["content"]["duty"]["revolutions"][0] += 1.0
    cases["in its bins and outside"] = json.dumps(broken)
    for reason, bad in cases.items():
        with pytest.raises(DutyCycleError, match=reason):
            check_document(bad)
    target = tmp_path / "kept.json"
    write_duty_cycle(target, text)
    with pytest.raises(DutyCycleError):
        write_duty_cycle(target, cases["truncated"])
    assert target.read_text() == text, "a refused document leaves the file as it was"
    target.write_text(cases["truncated"])
    with pytest.raises(DutyCycleError, match="kept.json.*truncated"):
        read_duty_cycle(target)
