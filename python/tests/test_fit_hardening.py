"""`djkr.fit` attacked as issue 35 attacked `djkr fit` (items 1, 3, 4, 6, 11, 12): an ensemble too
large to hold killed the interpreter; a FIFO as the data file hung it; a file that is not data had
its first field shown; data whose chi2 cannot be finite gave `inf` and a meaningless sigma. Each
now raises ``djkr.ScenarioError`` at once, with the command line's message in Python's words.

The reproducers that took the interpreter down run in a child process, so that a regression
(SIGABRT) fails the test with the signal's name instead of killing pytest."""

import math
import os
import signal
import subprocess
import sys
import threading
import time

import pytest

import djkr
from conftest import ROOT, cli_error

TINY = "tests/sweep/tiny.toml"
HEADER = "base.amplitude [um],pull_off_amplification [1]"


@pytest.fixture(autouse=True)
def at_root(monkeypatch):
    monkeypatch.chdir(ROOT)


def good(tmp_path):
    p = tmp_path / "good.csv"
    p.write_text(f"{HEADER}\n5,2\n10,3\n20,4\n")
    return p


def test_an_ensemble_too_large_raises_at_once(tmp_path):
    # In a child: before the fix, this aborted the interpreter on a 28.8 TB allocation.
    data = good(tmp_path)
    code = f"""
import djkr, time
t0 = time.monotonic()
try:
    djkr.fit({str(data)!r}, {TINY!r}, free="adhesion.n", ensemble=10**11)
    print("RETURNED")
except djkr.ScenarioError as e:
    print(f"{{time.monotonic() - t0:.3f}}")
    print(e)
"""
    p = subprocess.run([sys.executable, "-c", code], cwd=ROOT, capture_output=True, text=True,
                       timeout=120)
    if p.returncode < 0:
        pytest.fail(f"killed by {signal.Signals(-p.returncode).name}: {p.stderr[-2000:]}")
    assert p.returncode == 0, p.stderr
    seconds, message = p.stdout.split("\n", 1)
    assert float(seconds) < 2.0, seconds
    assert "ensemble = 100000000000: 3 rows x 100000000000 members x 3 parameter sets" in message
    assert "more than 10000000 runs" in message, message
    # The command line says the same, in its own words.
    line = cli_error("fit", data, "--scenario", TINY, "--free", "adhesion.n", "--ensemble",
                     str(10**11), "--out", tmp_path / "o")
    assert line.replace("--ensemble ", "ensemble = ") == message.strip()
    with pytest.raises(djkr.ScenarioError, match="more than solver.max_memory = 1048576 bytes"):
        djkr.fit(data, TINY, free="adhesion.n", ensemble=100_000,
                 set={"solver.max_memory": 1 << 20})


@pytest.mark.skipif(not hasattr(os, "mkfifo"), reason="no FIFOs on this system")
def test_a_fifo_or_a_device_as_data_raises_at_once(tmp_path):
    fifo = tmp_path / "data.csv"
    os.mkfifo(fifo)
    result = {}

    def call():
        try:
            djkr.fit(fifo, TINY, free="adhesion.n")
        except djkr.ScenarioError as e:
            result["error"] = str(e)

    # A hang would block pytest: the call runs on a thread that a writer can release.
    t = threading.Thread(target=call, daemon=True)
    t.start()
    t.join(10)
    if t.is_alive():
        with open(fifo, "w") as f:  # release the reader
            f.write("")
        pytest.fail("djkr.fit on a FIFO hung")
    assert f"{fifo}: is a FIFO (named pipe), not a regular file" in result["error"], result
    with pytest.raises(djkr.ScenarioError, match="/dev/zero: is a character device"):
        djkr.fit("/dev/zero", TINY, free="adhesion.n")
    big = tmp_path / "big.csv"
    with open(big, "wb") as f:
        f.truncate(17 << 20)
    with pytest.raises(djkr.ScenarioError, match=r"the limit for a fit data file"):
        djkr.fit(big, TINY, free="adhesion.n")


def test_a_file_that_is_not_data_is_not_shown(tmp_path):
    shadow = tmp_path / "shadow"
    shadow.write_text("root:$6$s3cr3tHash$abc:19000:0:99999:7:::\n")
    with pytest.raises(djkr.ScenarioError) as e:
        djkr.fit(shadow, TINY, free="adhesion.n")
    assert "not shown" in str(e.value)
    assert "root:" not in str(e.value) and "s3cr3t" not in str(e.value), e.value
    cell = tmp_path / "cell.csv"
    cell.write_text(f"{HEADER}\n5,2\n10,{'x' * 1_000_000}\n")
    with pytest.raises(djkr.ScenarioError) as e:
        djkr.fit(cell, TINY, free="adhesion.n")
    assert len(str(e.value)) < 600 and "line 3, column 2" in str(e.value), str(e.value)[:1000]


def test_data_whose_chi2_cannot_be_finite_raise(tmp_path):
    huge = tmp_path / "huge.csv"
    huge.write_text(f"{HEADER}\n5,2\n10,1e308\n20,4\n")
    with pytest.raises(djkr.ScenarioError,
                       match=r"huge.csv: line 3, column 2 .*chi2 cannot be finite"):
        djkr.fit(huge, TINY, free="adhesion.n")
    small = tmp_path / "small.csv"
    small.write_text(f"{HEADER},sigma [1]\n5,0,1e-200\n10,0,1e-200\n20,0,1e-200\n")
    with pytest.raises(djkr.ScenarioError, match=r"line 2, column 3 'sigma \[1\]'"):
        djkr.fit(small, TINY, free="adhesion.n")
    # Fittable, if absurd: every number of the report finite, no Rust Debug text in the notes.
    extreme = tmp_path / "extreme.csv"
    extreme.write_text(f"{HEADER},sigma [1]\n5,0,1e-152\n10,0,1e-152\n20,0,1e-152\n")
    r = djkr.fit(extreme, TINY, free="adhesion.n")
    for k in ("chi2", "reduced_chi2", "aic", "bic"):
        assert isinstance(r[k], float) and math.isfinite(r[k]), r
    assert r["parameters"][0]["sigma"] is None or r["parameters"][0]["sigma"] > 0, r
    assert not any("Numerical(" in n for n in r["notes"]), r["notes"]


def test_crlf_lines_and_huge_bounds(tmp_path):
    crlf = tmp_path / "crlf.csv"
    crlf.write_bytes(f"{HEADER}\r\n5,2\r\n\r\n10,x\r\n".encode())
    with pytest.raises(djkr.ScenarioError, match="crlf.csv: line 4, column 2"):
        djkr.fit(crlf, TINY, free="adhesion.n")
    with pytest.raises(djkr.ScenarioError,
                       match=r"LO '-1e308' lies outside the range of adhesion.n") as e:
        djkr.fit(good(tmp_path), TINY, free="adhesion.n=-1e308:1e308")
    assert "nan" not in str(e.value)


def test_wrong_types_raise_scenario_type_error(tmp_path):
    # Found by the fuzz test: free=5 raised a bare TypeError.
    for free in (5, 1.5, None, True):
        with pytest.raises(djkr.ScenarioTypeError, match="free: expected a key"):
            djkr.fit(good(tmp_path), TINY, free=free)
    with pytest.raises(djkr.ScenarioError, match="adhesion.n is already free"):
        djkr.fit(good(tmp_path), TINY, free=["adhesion.n"] * 1_000_000)
