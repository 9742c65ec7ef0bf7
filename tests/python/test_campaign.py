"""The campaign runner (python/planetwear_fmu, docs/CAMPAIGNS.md) under
faults: a worker killed in the middle of a campaign, a campaign process
killed after some points, and bad campaign files refused before any work.

Small campaigns: one worn state, 750 N·m, six speeds, 34 + 34 mesh cycles
per point with generalized-α (deterministic: a sweep continued from a
serialized FMU state must give the uninterrupted sweep's numbers). 600 steps
per mesh cycle make a point last long enough (~0.1 s) for a kill to land in
the middle of a sweep. Needs fmu/planetwear.fmu and PLANETWEAR_BIN (the
README's test command provides both).
"""

import json
import math
import os
import signal
import subprocess
import sys
import threading
import time
from pathlib import Path

import pyarrow.parquet as pq
import pytest

from planetwear_fmu import campaign_file
from planetwear_fmu.campaign import dask_client, main, run_campaign, task_specs
from planetwear_fmu.campaign_file import CampaignError
from planetwear_fmu.fmu_check import load_campaign
from planetwear_fmu.duty import read_duty_cycle
from planetwear_fmu.sweep import TIMING_COLUMNS, PointStore, run_task, task_directory
from wear_states import write_foreign_state

REPO = Path(__file__).resolve().parents[2]
FMU = REPO / "fmu" / "planetwear.fmu"
EXE = os.environ.get("PLANETWEAR_BIN", str(REPO / "target" / "release" / "planetwear"))
SPEEDS = [2000.0, 2500.0, 3000.0, 3500.0, 4000.0, 4500.0]
# A resumed sweep must equal the uninterrupted one to this relative
# difference (generalized-α with integer-count steps: bit-identical expected).
RESUME_TOLERANCE = 1e-12

SMALL = f"""
fmu = "{FMU}"
scene = "example-2004"
output_dir = "out"

[wear]
states = ["wear/example-2004/kappa-2.json"]

[speeds]
values_rpm = {SPEEDS}
directions = "both"

[load]
sun_torque_nm = [750.0]

[timing]
communication_step = "mesh cycle"
run_in_cycles = 34
window_cycles = 34

[integrator]
integrator = 0
steps_per_mesh_cycle = 600
"""


@pytest.fixture(scope="module", autouse=True)
def needs_fmu():
    if not FMU.is_file():
        pytest.fail(f"{FMU} is missing: run `cargo build --release && target/release/planetwear fmu pack`")


@pytest.fixture(scope="module")
def client():
    with dask_client(workers=2) as c:
        yield c


@pytest.fixture(scope="module")
def reference(tmp_path_factory):
    """The small campaign's sweeps run uninterrupted, in-process, no Dask:
    {(label, torque, direction, index): row}."""
    d = tmp_path_factory.mktemp("reference")
    (d / "c.toml").write_text(SMALL)
    c = load_campaign(d / "c.toml")
    rows = {}
    for spec in task_specs(c):
        run_task(spec)
        store = PointStore(spec["dir"], spec["speeds"])
        for i in range(len(spec["speeds"])):
            r = store.row(i)
            # The sweep's load duty up to the point (its FMU's dutyCycle), beside its state.
            r["_duty_revolutions"] = read_duty_cycle(store.duty_path(i))["content"]["duty"]["total"]
            rows[(r["label"], r["sun_torque_nm"], r["direction"], r["index"])] = r
    assert len(rows) == 2 * len(SPEEDS)
    return rows


def point_files(out):
    """The points written: pathlib's glob also matches hidden names, so a
    temporary file of a write under way (`.planetwear-tmp.…`) is left out."""
    return sorted(p.relative_to(out).as_posix() for p in (out / "points").glob("*/*.parquet")
                  if not p.name.startswith("."))


def check_exactly_once_and_equal(out, reference):
    """Every point exists once (one file per point, one row per point in the
    consolidated table) and equals the uninterrupted sweep's."""
    files = point_files(out)
    assert len(files) == len(set(files)) == len(reference), files
    table = pq.read_table(out / "results.parquet").to_pylist()
    keys = [(r["label"], r["sun_torque_nm"], r["direction"], r["index"]) for r in table]
    assert len(keys) == len(set(keys)) == len(reference)
    worst = 0.0
    for r in table:
        ref = reference[(r["label"], r["sun_torque_nm"], r["direction"], r["index"])]
        for k, v in r.items():
            if k in TIMING_COLUMNS:
                continue
            if isinstance(v, float):
                worst = max(worst, abs(v - ref[k]) / max(abs(ref[k]), 1e-300))
            else:
                assert v == ref[k], (k, v, ref[k])
    print(f"largest relative difference against the uninterrupted sweeps: {worst:.3e}")
    assert worst <= RESUME_TOLERANCE
    # Each point's load duty (cumulative over its sweep, carried through a resume by the FMU
    # state) is the uninterrupted sweep's.
    for r in table:
        ref = reference[(r["label"], r["sun_torque_nm"], r["direction"], r["index"])]
        directory = task_directory(out, r["label"], r["sun_torque_nm"], r["direction"])
        (path,) = directory.glob(f"{r['index']:03d}_*.duty.json")
        total = read_duty_cycle(path)["content"]["duty"]["total"]
        assert abs(total - ref["_duty_revolutions"]) <= RESUME_TOLERANCE * ref["_duty_revolutions"], (path, total)


def test_a_worker_killed_in_the_middle_of_a_campaign(tmp_path, client, reference):
    (tmp_path / "c.toml").write_text(SMALL)
    c = load_campaign(tmp_path / "c.toml")
    specs = {s["key"]: s for s in task_specs(c)}
    outcome = {}

    def run():
        try:
            outcome["summary"] = run_campaign(c, client=client, progress=False, plots=False)
        except BaseException as e:  # reported by the assertion below
            outcome["error"] = e

    th = threading.Thread(target=run)
    th.start()
    killed = None
    deadline = time.monotonic() + 120
    while th.is_alive() and killed is None and time.monotonic() < deadline:
        for addr, keys in client.processing().items():
            for key in keys:
                spec = specs.get(str(key).rsplit("-", 1)[0])
                if spec is None:
                    continue
                done = PointStore(spec["dir"], spec["speeds"]).done()
                if 1 <= done <= len(SPEEDS) - 3:
                    pid = client.run(os.getpid, workers=[addr])[addr]
                    os.kill(pid, signal.SIGKILL)
                    killed = (spec["key"], done, pid)
                    break
            if killed:
                break
        time.sleep(0.01)
    th.join(timeout=300)
    assert not th.is_alive(), "the campaign did not complete within 300 s"
    assert "error" not in outcome, outcome.get("error")
    assert killed is not None, "no sweep was caught in the middle: the kill did not happen"
    s = outcome["summary"]
    print(f"killed worker pid {killed[2]} while {killed[0]} had {killed[1]} of {len(SPEEDS)} points;",
          json.dumps([{k: t[k] for k in ("key", "done", "resumed_from", "restarted")} for t in s["tasks"]]))
    assert s["failed"] == [] and s["points_done"] == s["points"] == 2 * len(SPEEDS)
    task = next(t for t in s["tasks"] if t["key"] == killed[0])
    # The sweep ran again on a live worker and continued from its last written point.
    assert task["restarted"] and task["resumed_from"] >= killed[1]
    assert s["computed"] == s["points"]
    check_exactly_once_and_equal(c.output_dir, reference)


def test_a_killed_campaign_resumes_without_recomputing_a_point(tmp_path, client, reference):
    (tmp_path / "c.toml").write_text(SMALL)
    out = tmp_path / "out"
    env = dict(os.environ, PLANETWEAR_BIN=EXE)
    proc = subprocess.Popen([sys.executable, "-m", "planetwear_fmu.campaign", "run", str(tmp_path / "c.toml"),
                             "--workers", "1", "--no-progress", "--no-plots"], env=env, start_new_session=True,
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE)
    # The cluster's start-up alone can take a minute on a loaded machine.
    deadline = time.monotonic() + 300
    try:
        while time.monotonic() < deadline and proc.poll() is None and len(point_files(out) if out.exists() else []) < 3:
            time.sleep(0.01)
    finally:
        # The whole campaign — client, scheduler, nanny and worker — dies at once.
        os.killpg(proc.pid, signal.SIGKILL)
        proc.wait()
    c = load_campaign(tmp_path / "c.toml")
    done = sum(PointStore(s["dir"], s["speeds"]).done() for s in task_specs(c))
    print(f"campaign process killed with {done} of {2 * len(SPEEDS)} points written")
    assert 3 <= done < 2 * len(SPEEDS), "the campaign was not interrupted in the middle"
    # Continued by the same command, on a running cluster given by its scheduler's address.
    run = ["run", str(tmp_path / "c.toml"), "--scheduler", client.scheduler.address, "--no-plots"]
    assert main(run) == 0
    s = json.loads((out / "summary.json").read_text())
    print(f"resumed: {s['computed']} points computed, {s['points_before']} found done")
    assert s["points_before"] == done
    assert s["computed"] == 2 * len(SPEEDS) - done
    check_exactly_once_and_equal(out, reference)
    # A third run finds everything done and computes nothing.
    assert main(run) == 0
    again = json.loads((out / "summary.json").read_text())
    assert again["computed"] == 0 and again["sweeps_run"] == 0


def _foreign_state(tmp_path):
    return write_foreign_state(EXE, tmp_path).name


def _shipped_state(tmp_path, kappa=1):
    import zipfile

    with zipfile.ZipFile(FMU) as z:
        return z.read(f"resources/wear/example-2004/kappa-{kappa}.json").decode()


BAD = {
    # name: (edit of the small campaign, key the error must name, words it must hold)
    "fmu path missing": (lambda t, d: t.replace(f'fmu = "{FMU}"', 'fmu = "no/such/planetwear.fmu"'), "fmu",
                         "no such file"),
    "empty speed list": (lambda t, d: t.replace(f"values_rpm = {SPEEDS}", "values_rpm = []"), "speeds.values_rpm",
                         "non-empty"),
    "empty speed grid": (lambda t, d: t.replace(f"values_rpm = {SPEEDS}", "from_rpm = 4000\nto_rpm = 1000\n"
                                                "step_rpm = 500"), "speeds.to_rpm", "empty"),
    "negative speed": (lambda t, d: t.replace(f"values_rpm = {SPEEDS}", "values_rpm = [-1000.0, 2000.0]"),
                       "speeds.values_rpm[0]", "positive"),
    "negative grid start": (lambda t, d: t.replace(f"values_rpm = {SPEEDS}", "from_rpm = -500\nto_rpm = 1000\n"
                                                   "step_rpm = 500"), "speeds.from_rpm", "positive"),
    "non-finite speed": (lambda t, d: t.replace(f"values_rpm = {SPEEDS}", "values_rpm = [1000.0, inf]"),
                         "speeds.values_rpm[1]", "finite"),
    "bad torque": (lambda t, d: t.replace("sun_torque_nm = [750.0]", "sun_torque_nm = [750.0, nan]"),
                   "load.sun_torque_nm[1]", "finite"),
    "unknown output": (lambda t, d: t + '\n[outputs]\nkeep = ["window.sunMeshF7"]\n', "outputs.keep[0]",
                       "model description"),
    "unknown key": (lambda t, d: t.replace("[timing]", "[timing]\nwindow_revolutions = 2"),
                    "timing.window_revolutions", "unknown key"),
    "integrator setting the FMU refuses": (
        lambda t, d: t.replace("steps_per_mesh_cycle = 600", "steps_per_mesh_cycle = 2"),
        "integrator.steps_per_mesh_cycle", "must be between"),
    "corrupt wear state (cut short)": (
        lambda t, d: (d / "cut.json").write_text(_shipped_state(d)[:5000]) and t.replace(
            "wear/example-2004/kappa-2.json", "cut.json"), "wear.states[0]", "not a JSON document"),
    "corrupt wear state (altered value)": (
        lambda t, d: (d / "altered.json").write_text(_shipped_state(d).replace('"kappa": 1', '"kappa": 2', 1))
        and t.replace("wear/example-2004/kappa-2.json", "altered.json"), "wear.states[0]", "checksum"),
    "foreign wear state": (
        lambda t, d: t.replace("wear/example-2004/kappa-2.json", _foreign_state(d)), "wear.states[0]",
        "ring.body_radius"),
}


# Cases also run through the command line (each load asks the FMU in a
# child process: about a second).
CLI_CASES = ("fmu path missing", "negative speed", "empty speed grid", "foreign wear state")


@pytest.mark.parametrize("case", list(BAD))
def test_a_bad_campaign_file_is_refused_before_any_work_naming_the_key(tmp_path, case, capsys):
    edit, key, words = BAD[case]
    text = edit(SMALL, tmp_path)
    (tmp_path / "c.toml").write_text(text)
    with pytest.raises(CampaignError) as e:
        load_campaign(tmp_path / "c.toml")
    message = str(e.value)
    print(message)
    assert any(p.key == key for p in e.value.problems), message
    assert f"{key} = " in message and words in message, message
    if case in CLI_CASES:
        # The command line refuses it the same way, before a cluster or a file exists.
        assert main(["run", str(tmp_path / "c.toml"), "--workers", "1", "--no-progress"]) == 2
        assert key in capsys.readouterr().err
    assert not (tmp_path / "out").exists()


def test_the_balancing_ring_torque_is_the_model_descriptions_start_value():
    """ringTorque's start value balances the default 750 N·m on the sun with
    the carrier held (T_ring = T_sun r_b,ring/r_b,sun = 750 · 70/34)."""
    c = campaign_file.from_dict(campaign_file.tomllib.loads(SMALL), REPO / "c.toml", probe=False)
    from xml.etree import ElementTree
    import zipfile

    root = ElementTree.fromstring(zipfile.ZipFile(FMU).read("modelDescription.xml"))
    start = {v.get("name"): float(v[0].get("start")) for v in root.iter("ScalarVariable")
             if v.get("name") in ("ringTorque", "sunTorque")}
    sun, ring, carrier = c.scene.balanced_torques(start["sunTorque"])
    assert abs(ring / start["ringTorque"] - 1) < 1e-12 and carrier == 0.0
    assert c.scene.mesh_cycles_per_revolution() == 34
    assert math.isclose(c.scene.face_width, 0.030)


def test_the_loop_alternates_campaigns_and_the_wear_stepper_with_manifests(tmp_path, client):
    """κ 0 → 1 → 2 of the unworn example at two speeds: each stage's
    manifest records the state in and out with their checksums, the wear
    stepper's output is the next stage's input, the deepest wear grows by
    the stepper's update (2.5 µm), the gathered table holds every stage."""
    import hashlib

    from planetwear_fmu.loop import run_loop

    text = SMALL.replace(f"values_rpm = {SPEEDS}", "values_rpm = [2000.0, 3000.0]").replace(
        'directions = "both"', 'directions = "up"').replace("steps_per_mesh_cycle = 600", "steps_per_mesh_cycle = 120")
    text = text.replace('states = ["wear/example-2004/kappa-2.json"]', 'states = ["wear/example-2004/kappa-0.json"]')
    text = f'planetwear_bin = "{EXE}"\n' + text
    (tmp_path / "c.toml").write_text(text)
    c = load_campaign(tmp_path / "c.toml")
    record = run_loop(c, to_kappa=2, client=client, progress=False)
    assert [s["kappa"] for s in record["stages"]] == [0, 1, 2]
    manifests = [json.loads(Path(s["manifest"]).read_text()) for s in record["stages"]]
    for m, nxt in zip(manifests, manifests[1:]):
        out = m["wear_step"]["state_out"]
        assert out["sha256"] == hashlib.sha256(Path(out["path"]).read_bytes()).hexdigest()
        assert nxt["state_in"]["sha256"] == out["sha256"] and out["kappa"] == m["kappa"] + 1
        assert abs(out["max_wear_um"] - m["state_in"]["max_wear_um"] - 2.5) < 1e-6
        assert m["runs"][-1]["campaign"]["points_done"] == 2
    assert manifests[-1]["wear_step"] is None
    for m in manifests:
        assert m["campaign_file"]["sha256"] == campaign_file.sha256_file(m["campaign_file"]["path"])
    table = pq.read_table(c.output_dir / "loop" / "results.parquet").to_pylist()
    assert sorted({r["kappa"] for r in table}) == [0, 1, 2] and len(table) == 6
    # The stepper's κ = 1 state is the one the FMU ships (the same stepper made it at pack time).
    shipped = _shipped_state(tmp_path, 1)
    stepped = Path(manifests[0]["wear_step"]["state_out"]["path"]).read_text()
    assert json.loads(stepped)["checksum"] == json.loads(shipped)["checksum"]
    assert (c.output_dir / "loop" / "plots" / "frms_change_T750.png").stat().st_size > 10_000
    # Run again: nothing is computed or stepped again, the manifests keep the first run.
    again = run_loop(c, to_kappa=2, client=client, progress=False)
    assert [s["computed"] for s in again["stages"]] == [0, 0, 0]
    for s, m in zip(again["stages"], manifests):
        m2 = json.loads(Path(s["manifest"]).read_text())
        assert len(m2["runs"]) == 2 and m2["runs"][0] == m["runs"][0] and m2["wear_step"] == m["wear_step"]


def test_an_output_dir_that_cannot_be_created_is_refused_before_any_run(tmp_path):
    """The output directory is checked when the campaign is read: below a
    regular file it can never be created, and the problem names the key."""
    blocker = tmp_path / "a-file"
    blocker.write_text("not a directory")
    raw = campaign_file.tomllib.loads(SMALL)
    raw["output_dir"] = str(blocker / "out")
    with pytest.raises(campaign_file.CampaignError, match=r"output_dir.*cannot be created: .*a-file is not a directory"):
        campaign_file.from_dict(raw, tmp_path / "c.toml", probe=False)
    raw["output_dir"] = str(blocker)
    with pytest.raises(campaign_file.CampaignError, match=r"output_dir.*exists and is not a directory"):
        campaign_file.from_dict(raw, tmp_path / "c.toml", probe=False)


def test_a_loop_with_hours_per_stage_wears_each_stage_by_the_duty_its_campaign_produced(tmp_path, client):
    """loop.hours_per_stage: each stage's state is worn by the duty cycle of the
    stage's own sweeps (the FMU's dutyCycle at each sweep's last point) for
    that many hours; the state records the duty and the hours, the loop's
    record gives κ and the deepest wear against operating hours."""
    from planetwear_fmu.loop import print_loop, run_loop

    text = SMALL.replace(f"values_rpm = {SPEEDS}", "values_rpm = [2000.0, 3000.0]").replace(
        'directions = "both"', 'directions = "up"').replace("steps_per_mesh_cycle = 600", "steps_per_mesh_cycle = 120")
    text = text.replace('states = ["wear/example-2004/kappa-2.json"]', 'states = ["wear/example-2004/kappa-0.json"]')
    text = f'planetwear_bin = "{EXE}"\n' + text + "\n[loop]\nhours_per_stage = 20.0\n"
    (tmp_path / "c.toml").write_text(text)
    c = load_campaign(tmp_path / "c.toml")
    record = run_loop(c, to_kappa=2, client=client, progress=False)
    print_loop(record)
    hours = [s["operating_hours"] for s in record["stages"]]
    wear = [s["max_wear_um"] for s in record["stages"]]
    kappas = [s["kappa"] for s in record["stages"]]
    assert hours == pytest.approx([20.0 * i for i in range(len(hours))], rel=1e-9)
    assert kappas[-1] >= 2 and all(b > a for a, b in zip(kappas, kappas[1:]))
    assert all(b > a for a, b in zip(wear, wear[1:]))
    manifests = [json.loads(Path(s["manifest"]).read_text()) for s in record["stages"]]
    first = manifests[0]["wear_step"]
    assert "--duty-cycle" in first["command"] and first["command"][first["command"].index("--hours") + 1] == "20.0"
    state = json.loads(Path(first["state_out"]["path"]).read_text())["content"]
    (duty,) = state["duty_cycles"]
    assert duty["source"] == "fmu" and duty["operating_time"] == pytest.approx(72000.0, rel=1e-9)
    used = read_duty_cycle(first["command"][first["command"].index("--duty-cycle") + 1])
    assert duty["checksum"] == used["checksum"]
    # The wear against operating hours, drawn.
    assert (c.output_dir / "loop" / "plots" / "wear_hours.png").stat().st_size > 10_000
