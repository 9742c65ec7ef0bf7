"""Hostile and careless input at the FMU and the Python package
(docs/LIMITS.md; the Rust side is tests/hostile_input.rs and
tests/hostile_fmu_states.rs): the package's one reader and its limits,
which must be the Rust crate's; its temporary files; an overflowing torque
through the packed FMU; an absurd wear state given to the FMU; FMU states
freed with their instance.

Needs fmu/planetwear.fmu (the test command packs it)."""

import json
import os
import re
import socket
import subprocess
import sys
import textwrap
import time
from pathlib import Path

import pytest
from fmpy import extract, read_model_description
from fmpy.fmi1 import FMICallException
from fmpy.fmi2 import FMU2Slave

from planetwear_fmu import campaign_file
from planetwear_fmu.files import LIMITS, TEMP_PREFIX, InputError, read_input, remove_stale_temps, write_atomic

REPO = Path(__file__).resolve().parents[2]
FMU = REPO / "fmu" / "planetwear.fmu"


@pytest.fixture(scope="module")
def fmu():
    if not FMU.is_file():
        pytest.fail(f"{FMU} is missing: run `cargo build --release && target/release/planetwear fmu pack`")
    return read_model_description(str(FMU)), extract(str(FMU))


# -- the one reader and its limits ---------------------------------------------------


def test_the_limits_are_the_rust_crates():
    text = (REPO / "src" / "files" / "mod.rs").read_text()
    rust = {m.group(1).lower(): int(m.group(2)) << int(m.group(3))
            for m in re.finditer(r"pub const MAX_(\w+)_BYTES: u64 = (\d+) << (\d+);", text)}
    print("Rust limits:", rust)
    assert rust == LIMITS


def test_a_fifo_a_device_a_directory_or_a_socket_is_refused_without_blocking(tmp_path):
    fifo = tmp_path / "pipe"
    os.mkfifo(fifo)
    sock = tmp_path / "sock"
    s = socket.socket(socket.AF_UNIX)
    s.bind(str(sock))
    started = time.monotonic()
    for path, what in [(fifo, "named pipe"), ("/dev/zero", "a device"), (tmp_path, "a directory"), (sock, "a socket")]:
        with pytest.raises(InputError, match=what) as e:
            read_input(path, "worn_state")
        assert str(path) in str(e.value)
    s.close()
    assert time.monotonic() - started < 5


def test_a_file_over_its_kinds_limit_is_refused_with_the_limit(tmp_path):
    big = tmp_path / "big.toml"
    with open(big, "wb") as f:
        f.truncate(LIMITS["campaign"] + 1)
    with pytest.raises(InputError, match="1 MiB a campaign file"):
        read_input(big, "campaign")
    assert len(read_input(big, "worn_state")) == LIMITS["campaign"] + 1


def test_a_campaign_file_that_is_a_fifo_or_too_large_is_a_problem_not_a_hang(tmp_path):
    fifo = tmp_path / "campaign.toml"
    os.mkfifo(fifo)
    with pytest.raises(campaign_file.CampaignError, match="named pipe"):
        campaign_file.load(fifo, probe=None)
    big = tmp_path / "big.toml"
    big.write_text("# " + "x" * LIMITS["campaign"])
    with pytest.raises(campaign_file.CampaignError, match="larger than the 1 MiB"):
        campaign_file.load(big, probe=None)


def test_temporary_files_carry_the_pattern_and_stale_ones_are_removed(tmp_path):
    write_atomic(tmp_path / "a.json", b"{}")
    assert [p.name for p in tmp_path.iterdir()] == ["a.json"]
    ended = subprocess.Popen(["true"])
    ended.wait()
    stale = tmp_path / f"{TEMP_PREFIX}{ended.pid}.0.a.json"
    live = tmp_path / f"{TEMP_PREFIX}{os.getpid()}.1.b.json"
    other = tmp_path / ".a.json.tmp"
    for p in (stale, live, other):
        p.write_bytes(b"partial")
    assert remove_stale_temps(tmp_path) == 1
    assert not stale.exists() and live.exists() and other.exists()


def test_outputs_follow_symbolic_links_and_never_replace_what_is_not_a_regular_file(tmp_path):
    real = tmp_path / "real.json"
    real.write_bytes(b"old")
    link = tmp_path / "link.json"
    link.symlink_to(real)
    write_atomic(link, b"new")
    assert link.is_symlink() and real.read_bytes() == b"new"
    dangling = tmp_path / "dangling.json"
    dangling.symlink_to(tmp_path / "nowhere")
    fifo = tmp_path / "pipe"
    os.mkfifo(fifo)
    for path, what in [(dangling, "does not exist"), (fifo, "named pipe"), (tmp_path, "a directory")]:
        with pytest.raises(InputError, match=what):
            write_atomic(path, b"x")
    assert dangling.is_symlink() and fifo.exists()
    assert not [p for p in tmp_path.iterdir() if p.name.startswith(TEMP_PREFIX)]


# -- the FMU's numerical guards ----------------------------------------------------------


def _initialized(md, unzipdir, name):
    s = FMU2Slave(guid=md.guid, unzipDirectory=unzipdir, modelIdentifier=md.coSimulation.modelIdentifier,
                  instanceName=name)
    s.instantiate()
    s.setupExperiment(startTime=0.0)
    s.enterInitializationMode()
    s.exitInitializationMode()
    return s


@pytest.mark.parametrize("torque", [1e300, 1e20, 1e9])
def test_an_overflowing_torque_is_discarded_at_once_never_ok(fmu, torque):
    md, unzipdir = fmu
    vr = {v.name: v.valueReference for v in md.modelVariables}
    s = _initialized(md, unzipdir, "overflow")
    s.doStep(currentCommunicationPoint=0.0, communicationStepSize=1e-4)
    s.setReal([vr["sunTorque"]], [torque])
    started = time.monotonic()
    with pytest.raises(FMICallException) as e:
        s.doStep(currentCommunicationPoint=1e-4, communicationStepSize=1e-4)
    took = time.monotonic() - started
    print(f"sunTorque {torque:e}: {e.value} in {took:.3f} s")
    assert e.value.status == 2  # fmi2Discard
    assert took < 1.0
    # The outputs are still those of the last accepted step: finite.
    speed = s.getReal([vr["sun.speed"]])[0]
    assert abs(speed) < 1e4, speed
    s.terminate()
    s.freeInstance()


# -- an absurd wear state given to the FMU ------------------------------------------------


def _fnv1a64(data):
    h = 0xCBF29CE484222325
    for b in data:
        h = ((h ^ b) * 0x100000001B3) & 0xFFFFFFFFFFFFFFFF
    return h


def _reseal(text):
    """The document with its checksum recomputed: FNV-1a 64 of the content
    written compactly (the file's content is already in key order, and none
    of its strings holds white space)."""
    start = text.index('"content": ') + len('"content": ')
    end = text.index(',\n  "format"')
    compact = re.sub(r"\s+", "", text[start:end]).encode()
    return re.sub(r'"fnv1a64:[0-9a-f]{16}"', f'"fnv1a64:{_fnv1a64(compact):016x}"', text, count=1)


@pytest.mark.parametrize("depth", ["0.001", "1.0", "1e+300"])  # as serde_json writes them
def test_an_absurd_wear_depth_is_refused_by_the_fmu_with_the_figure(fmu, tmp_path, depth):
    md, unzipdir = fmu
    text = (Path(unzipdir) / "resources" / "wear" / "example-2004" / "kappa-0.json").read_text()
    assert _reseal(text) == text, "the checksum is not reproduced"
    m = re.search(r'"depth": \[(.*?)\]', text, flags=re.S)
    deep = text[:m.start(1)] + re.sub(r"\d[\d.e+-]*", depth, m.group(1)) + text[m.end(1):]
    path = tmp_path / "deep.json"
    path.write_text(_reseal(deep))
    code = textwrap.dedent(f"""
        from fmpy import read_model_description, extract
        from fmpy.fmi2 import FMU2Slave
        md = read_model_description({str(FMU)!r}); u = extract({str(FMU)!r})
        vr = {{v.name: v.valueReference for v in md.modelVariables}}
        s = FMU2Slave(guid=md.guid, unzipDirectory=u, modelIdentifier=md.coSimulation.modelIdentifier, instanceName="d")
        s.instantiate(loggingOn=True)
        s.setupExperiment(startTime=0.0)
        s.setString([vr["wearStateFile"]], [{str(path)!r}])
        s.enterInitializationMode()
        try:
            s.exitInitializationMode()
            print("accepted")
        except Exception as e:
            print("refused:", e)
    """)
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=120)
    log = out.stdout + out.stderr
    print(log)
    assert "refused" in log and "accepted" not in log, log
    assert "not a plausible worn state" in log and "depth[0]" in log, log


# -- FMU states freed with their instance -----------------------------------------------------


def test_states_held_at_free_instance_are_freed_memory_flat_over_10000_cycles(fmu):
    """10 000 cycles of instantiate, three fmi2GetFMUstate held, free
    instance, in a child process; its resident memory after the last cycle
    against after the first 500 (a leak of the ~2.7 kB states would be
    80 MB)."""
    md, unzipdir = fmu
    code = textwrap.dedent(f"""
        import ctypes
        from fmpy.fmi2 import FMU2Slave
        s = FMU2Slave(guid={md.guid!r}, unzipDirectory={str(unzipdir)!r},
                      modelIdentifier={md.coSimulation.modelIdentifier!r}, instanceName="held")
        def rss():
            return int(open("/proc/self/statm").read().split()[1]) * 4096
        def cycle():
            s.instantiate()
            held = [s.getFMUState() for _ in range(3)]
            # fmi2FreeInstance alone: fmpy's freeInstance also unloads the library.
            s.fmi2FreeInstance(s.component)
            return held
        for _ in range(500):
            cycle()
        before = rss()
        for _ in range(10000):
            cycle()
        print(rss() - before)
    """)
    started = time.monotonic()
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=300)
    assert out.returncode == 0, out.stderr
    grown = int(out.stdout.split()[-1])
    print(f"resident memory grew by {grown} bytes over 10 000 cycles ({time.monotonic() - started:.1f} s)")
    assert grown < 8 << 20, grown
