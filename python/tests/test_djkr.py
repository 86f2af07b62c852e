"""The Python package against the command line: every number compared with what `djkr`
prints or writes for the same input (nothing hard-coded)."""

import _thread
import json
import math
import signal
import subprocess
import sys
import threading
import time
import warnings
from pathlib import Path

import h5py
import numpy as np
import pandas as pd
import pytest

import djkr
from conftest import ROOT, cli, cli_error, cli_json

VIB400 = "benches/scenes/vib400.toml"  # 1 s at 400 Hz: samples and period records
IMPACTS = "scenarios/impacts.toml"  # contact lost and regained: many events
RESONANCE = "scenarios/resonance-400hz.toml"
TINY = "tests/sweep/tiny.toml"
SERIES = ["t", "x_s", "v_s", "x_b", "x_k", "delta", "a", "a_dot", "F", "G", "w"]

# Keys of summary.json that differ between two runs of the same scenario, or with the folder.
VOLATILE = {"run_id", "files", "file_bytes"}


@pytest.fixture(autouse=True)
def at_root(monkeypatch):
    """Relative scenario paths as the command line is given them (summaries name the path)."""
    monkeypatch.chdir(ROOT)


def bits(a):
    """An array's bit patterns (NaN equal to itself, -0.0 unequal to 0.0)."""
    a = np.ascontiguousarray(a)
    return a.view(np.uint64 if a.dtype == np.float64 else a.dtype)


def assert_bits_equal(a, b, what):
    a, b = np.asarray(a), np.asarray(b)
    assert a.dtype == b.dtype, f"{what}: {a.dtype} vs {b.dtype}"
    assert a.shape == b.shape, f"{what}: {a.shape} vs {b.shape}"
    assert np.array_equal(bits(a), bits(b)), f"{what}: values differ"


def stable(summary):
    """summary.json without what differs from run to run (run id, wall times, files)."""
    s = {k: v for k, v in summary.items() if k not in VOLATILE}
    s["stats"] = {k: v for k, v in s["stats"].items() if k not in ("wall_s", "write_s")}
    return s


def cli_run(tmp_path, scenario, *sets, name="cli"):
    out = tmp_path / name
    args = ["run", scenario, "--out", out]
    for s in sets:
        args += ["--set", s]
    cli(*args)
    return out


def assert_run_matches_folder(r, folder):
    """Every array of a Run equals its dataset in folder/run.h5, bit for bit."""
    with h5py.File(folder / "run.h5", "r") as f:
        for name in SERIES:
            assert_bits_equal(getattr(r, name), f[name][()], name)
        assert_bits_equal(r.stage, f["stage"][()], "stage")
        assert set(r.cycles) == set(f["cycles"].keys())
        for name, values in r.cycles.items():
            assert_bits_equal(values, f["cycles"][name][()], f"cycles/{name}")
        ev = f["events"]
        kinds = [k.decode() if isinstance(k, bytes) else k for k in ev["kind"][()]]
        assert [e["kind"] for e in r.events] == kinds
        assert_bits_equal(np.array([e["time"] for e in r.events]), ev["time"][()], "events/time")
        assert_bits_equal(np.array([e["stage"] for e in r.events], dtype=np.int64), ev["stage"][()], "events/stage")
        for name in SERIES[1:]:
            got = np.array([e["state"][name] for e in r.events], dtype=np.float64)
            assert_bits_equal(got, ev[name][()], f"events/{name}")


@pytest.mark.parametrize("scenario", [VIB400, IMPACTS])
def test_run_arrays_equal_the_cli_hdf5_bit_for_bit(tmp_path, scenario):
    folder = cli_run(tmp_path, scenario)
    r = djkr.run(scenario)
    assert len(r) == len(r.t) > 100
    assert r.t.dtype == np.float64 and r.stage.dtype == np.int64
    assert_run_matches_folder(r, folder)
    cli_summary = json.loads((folder / "summary.json").read_text())
    assert stable(r.summary) == stable(cli_summary)
    # Without a folder there are no files to list.
    assert r.summary["files"] == {} and r.summary["file_bytes"] == {}
    # The events of summary.json are those of the run (all of them here, fewer than 10 000).
    assert len(r.events) == r.summary["events_listed"] == len(cli_summary["events"])
    for e, s in zip(r.events, cli_summary["events"]):
        assert e["kind"] == s["kind"] and e["stage"] == s["stage"] and e["time"] == s["time"]
        assert {k: v for k, v in e["state"].items() if math.isfinite(v)} == s["state"]


def test_out_writes_the_run_folder_of_djkr_run(tmp_path):
    out = tmp_path / "py"
    r = djkr.run(VIB400, out=out)
    # summary is exactly the file written, and the file is that of the command line.
    assert r.summary == json.loads((out / "summary.json").read_text())
    assert r.summary["files"] == {"hdf5": "run.h5"}
    assert_run_matches_folder(r, out)
    folder = cli_run(tmp_path, VIB400)
    assert stable(r.summary) == stable(json.loads((folder / "summary.json").read_text()))
    assert not list(out.glob(".*.partial"))


def test_set_equals_cli_set(tmp_path):
    sets = {"base.amplitude": "3um", "solver.rtol": 1e-9, "stage[0].duration": 0.25}
    folder = cli_run(tmp_path, VIB400, "base.amplitude=3um", "solver.rtol=1e-09", "stage[0].duration=0.25")
    r = djkr.run(VIB400, set=sets)
    assert r.summary["overrides"] == ["base.amplitude=3um", "solver.rtol=1e-09", "stage[0].duration=0.25"]
    assert stable(r.summary) == stable(json.loads((folder / "summary.json").read_text()))
    assert_run_matches_folder(r, folder)
    # A boolean is written as TOML spells it.
    r2 = djkr.run(TINY, set={"output.csv": True})
    assert r2.summary["overrides"] == ["output.csv=true"]


def test_scenario_forms_give_the_same_run(tmp_path):
    tomllib = pytest.importorskip("tomllib")
    text = (ROOT / VIB400).read_text()
    by_path = djkr.run(VIB400)
    by_pathlib = djkr.run(ROOT / VIB400)
    by_text = djkr.run(text)
    by_dict = djkr.run(tomllib.loads(text))
    assert by_text.summary["scenario"] == "<string>"
    assert by_dict.summary["scenario"] == "<dict>"
    for other in (by_pathlib, by_text, by_dict):
        for name in SERIES:
            assert_bits_equal(getattr(other, name), getattr(by_path, name), name)
    # A dict with overrides: the same as the file with overrides.
    d = tomllib.loads(text)
    d["base"]["amplitude"] = "3um"
    assert_bits_equal(djkr.run(d).F, djkr.run(VIB400, set={"base.amplitude": "3um"}).F, "F")


def test_to_pandas(tmp_path):
    r = djkr.run(TINY)
    df = r.to_pandas()
    assert isinstance(df, pd.DataFrame)
    assert list(df.columns) == SERIES + ["stage", "segment"]
    for name in SERIES + ["stage", "segment"]:
        assert_bits_equal(df[name].to_numpy(), getattr(r, name), name)


def test_gaps_are_data(tmp_path):
    """Issue 25, item 1: the issue's scene (the paper protocol with R = 10 mm, 1 g, 200 N/m)
    skips base periods; `segment` and `gaps` say where, as run.h5 does."""
    text = (ROOT / "scenarios/paper-protocol-400hz.toml").read_text()
    text = text.replace("R = 0.051 ", "R = 0.010 ").replace("mass = 0.25 ", "mass = 0.001 ")
    text = text.replace("stiffness = 2000.0 ", "stiffness = 200.0 ")
    r = djkr.run(text, out=tmp_path / "run")
    assert r.segment.dtype == np.int64 and len(r.segment) == len(r.t)
    g = r.gaps
    assert set(g) == {"t_start", "t_end", "periods"} and len(g["t_start"]) > 0
    assert r.summary["gaps"] == len(g["t_start"])
    steps = np.nonzero(np.diff(r.segment))[0]
    assert r.segment[0] == 0 and set(np.diff(r.segment)) <= {0, 1}
    assert_bits_equal(r.t[steps], g["t_start"], "t_start")
    assert_bits_equal(r.t[steps + 1], g["t_end"], "t_end")
    with h5py.File(tmp_path / "run" / "run.h5") as f:
        assert_bits_equal(f["segment"][:], r.segment, "segment")
        described = dict(zip(f["descriptions/path"].asstr()[:], f["descriptions/text"].asstr()[:]))
        for k in g:
            assert_bits_equal(f["gaps"][k][:], g[k], k)
            assert isinstance(f["gaps"][k].attrs["units"], str)
            assert described[f"/gaps/{k}"]
        assert described["/segment"]
    assert list(r.to_pandas()["segment"]) == list(r.segment)


def gap_scene():
    """The scene of test_gaps_are_data: the paper protocol at 400 Hz with R = 10 mm, 1 g, 200 N/m,
    whose envelope following skips base periods."""
    text = (ROOT / "scenarios/paper-protocol-400hz.toml").read_text()
    text = text.replace("R = 0.051 ", "R = 0.010 ").replace("mass = 0.25 ", "mass = 0.001 ")
    return text.replace("stiffness = 2000.0 ", "stiffness = 200.0 ")


def test_pieces_are_the_segments_run_h5_holds(tmp_path):
    """Issue 33: `Run.pieces()` splits the arrays where the writer's `segment` changes, each
    piece ending and starting at a gap of run.h5's `gaps/` (read with h5py: the reference), as
    views of the run's arrays that together are the whole run."""
    r = djkr.run(gap_scene(), out=tmp_path / "run")
    with h5py.File(tmp_path / "run" / "run.h5") as f:
        seg, t = f["segment"][:], f["t"][:]
        t_start, t_end = f["gaps"]["t_start"][:], f["gaps"]["t_end"][:]
    expected = np.split(np.arange(len(seg)), np.flatnonzero(np.diff(seg)) + 1)
    pieces = r.pieces()
    assert len(t_start) > 0 and len(pieces) == len(expected) == len(t_start) + 1
    for k, (p, idx) in enumerate(zip(pieces, expected)):
        assert set(p) == set(SERIES + ["stage", "segment"])
        assert_bits_equal(p["t"], t[idx], f"piece {k} t")
        assert set(p["segment"]) == {k}
        assert all(len(a) == len(idx) for a in p.values())
    for k in range(len(t_start)):
        assert pieces[k]["t"][-1] == t_start[k] and pieces[k + 1]["t"][0] == t_end[k]
    for name in SERIES + ["stage", "segment"]:
        assert_bits_equal(np.concatenate([p[name] for p in pieces]), getattr(r, name), name)
    assert np.shares_memory(pieces[0]["F"], r.F)
    # Without gaps: one piece, the whole run.
    whole = djkr.run(IMPACTS)
    assert whole.summary["gaps"] == 0
    [only] = whole.pieces()
    assert_bits_equal(only["t"], whole.t, "t")


def test_plot_helper_draws_each_piece_apart_and_marks_only_what_holds(tmp_path):
    """Issue 33: `djkr.plot.run` draws one line per piece (no vertex inside a gap), shades the
    gaps, marks the pull-off at its force and time only for a run that detached, in the
    axis's SI prefix."""
    matplotlib = pytest.importorskip("matplotlib")
    matplotlib.use("Agg")
    import djkr.plot

    r = djkr.run(gap_scene())
    fig = djkr.plot.run(r)
    ax = fig.axes[0]
    lines = [l for l in ax.get_lines() if l.get_linestyle() == "-" and l.get_marker() in ("None", "", None)]
    assert len(lines) == len(r.pieces())
    scale, unit = djkr.plot.prefixed(r.t[[0, -1]], "s")
    for l in lines:
        x = np.asarray(l.get_xdata()) / scale
        for a, b in zip(r.gaps["t_start"], r.gaps["t_end"]):
            assert not np.any((x > a) & (x < b)), "a line crosses a gap"
    assert ax.get_ylabel().endswith("(mN)")
    labels = ax.get_legend_handles_labels()[1]
    po = r.summary["pull_off"]
    assert r.summary["detached"] and po["tensile"]
    [marker] = [l for l in ax.get_lines() if l.get_label().startswith("pull-off")]
    assert marker.get_xdata()[0] == po["time"] * scale and marker.get_ydata()[0] == po["force"] * 1e3
    assert any(lab.startswith("envelope: ") for lab in labels)
    # A run that never detached: no pull-off marker, no detachment.
    impacts = djkr.plot.run(djkr.run(IMPACTS))
    labels = impacts.axes[0].get_legend_handles_labels()[1]
    assert not any(lab.startswith("pull-off") or lab == "detachment" for lab in labels), labels
    fig.savefig(tmp_path / "run.png")
    assert (tmp_path / "run.png").stat().st_size > 0


def test_resonance_peak_is_the_command_lines(tmp_path):
    """Issue 33: `djkr.resonance_peak` of the columns is the peak `djkr resonance --json`
    reports (bit for bit), and at the edge of the range it is no peak, as the command says."""
    for scene, freq, key in [(RESONANCE, (300, 500, 21), "peak"),
                             ("scenarios/paper-protocol-400hz.toml", (300, 500, 21), "no_peak_in_range")]:
        out = tmp_path / Path(scene).stem
        report = cli_json("resonance", scene, "--freq", ":".join(map(str, freq)), "--out", out)
        res = djkr.resonance(scene, freq=freq)
        for direction in ["up", "down"]:
            sel = res["direction"] == direction
            got = djkr.resonance_peak(res["frequency"][sel], res["delta_amp_over_xb"][sel])
            want = report[f"sweep_{direction}"][key]
            if key == "peak":
                assert got == {"frequency": want["frequency"], "height": want["height"]}
            else:
                assert got == {"no_peak_in_range": want}
    assert djkr.resonance_peak([], []) == {}
    with pytest.raises(djkr.ScenarioError):
        djkr.resonance_peak([1.0, 2.0], [1.0])


CYCLES = [
    (("400", "2mm", "0.5mm"), {}),
    ((300.0, 0.0015, 2e-4), {}),
    (("1.5kHz", "-0.1mm", "0.3mm"), {}),  # truncated cycle
    ((200, "11mm", "0.5mm"), {}),  # a beyond 0.2 R: a note
    ((400, "2mm", "0.5mm"), {"material": "scenarios/impacts.toml"}),
]


@pytest.mark.parametrize("args,kw", CYCLES)
def test_cycle_equals_cli_json(args, kw):
    freq, a_mean, a_amp = args
    flags = ["--freq", freq, "--a-mean", a_mean, "--a-amp", a_amp]
    if "material" in kw:
        flags += ["--material", kw["material"]]
    expected = cli_json("cycle", *flags)
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        got = djkr.cycle(*args, **kw)
    assert got == expected
    # The notes are also warnings, as on the command line's stderr.
    assert [str(w.message) for w in caught] == expected["notes"]
    assert all(w.category is RuntimeWarning for w in caught)


PULLOFFS = [
    ((400, "0.5mm"), {}, []),
    (("300Hz", 1e-3), {"method": "approx"}, ["--method", "approx"]),
    ((200, "0.25mm"), {"method": "approx", "beta": 4.17}, ["--method", "approx", "--beta", "4.17"]),
    ((400, "0.5mm"), {"method": "yi"}, ["--method", "yi"]),
    ((400, "0.5mm"), {"material": "scenarios/impacts.toml"}, ["--material", "scenarios/impacts.toml"]),
]


@pytest.mark.parametrize("args,kw,flags", PULLOFFS)
def test_pulloff_equals_cli_json(args, kw, flags):
    freq, a_amp = args
    expected = cli_json("pulloff", "--freq", freq, "--a-amp", a_amp, *flags)
    assert djkr.pulloff(*args, **kw) == expected


def test_material_as_text_and_dict():
    tomllib = pytest.importorskip("tomllib")
    text = (ROOT / IMPACTS).read_text()
    expected = djkr.pulloff(400, "0.5mm", material=IMPACTS)
    assert djkr.pulloff(400, "0.5mm", material=text) == expected
    assert djkr.pulloff(400, "0.5mm", material=tomllib.loads(text)) == expected


def drop_wall(v):
    """A report without its wall times."""
    if isinstance(v, dict):
        return {k: drop_wall(x) for k, x in v.items() if k != "wall_s"}
    if isinstance(v, list):
        return [drop_wall(x) for x in v]
    return v


def test_validate_equals_cli_json():
    expected = cli_json("validate", RESONANCE)
    got = djkr.validate(RESONANCE)
    assert drop_wall(got) == drop_wall(expected)
    expected = cli_json("validate", RESONANCE, "--set", "base.amplitude=0.3um")
    assert drop_wall(djkr.validate(RESONANCE, set={"base.amplitude": "0.3um"})) == drop_wall(expected)


def csv_columns(path):
    """A djkr CSV as {name: values}, the header's `name [unit]` cut to the name."""
    df = pd.read_csv(path, dtype=str, keep_default_na=False)
    return {c.split(" [")[0]: list(df[c]) for c in df.columns}


def assert_columns_equal(got, expected, skip=()):
    assert list(got) == list(expected)
    for name, col in expected.items():
        if name in skip:
            continue
        g = got[name]
        if g.dtype.kind == "f":
            assert_bits_equal(g, np.array([float(x) for x in col]), name)
        elif g.dtype.kind == "i":
            assert_bits_equal(g, np.array([int(x) for x in col], dtype=np.int64), name)
        else:
            assert list(g) == col, name


@pytest.mark.parametrize("direction", ["both", "down"])
def test_resonance_columns_equal_cli_csv(tmp_path, direction):
    out = tmp_path / "res"
    cli("resonance", RESONANCE, "--freq", "380:420:5", "--sweep", direction, "--out", out)
    got = djkr.resonance(RESONANCE, freq=(380, 420, 5), sweep=direction)
    assert_columns_equal(got, csv_columns(out / "resonance.csv"))
    assert set(got["direction"]) == ({"up", "down"} if direction == "both" else {"down"})
    # Units welcome, as on the command line.
    again = djkr.resonance(RESONANCE, freq=("0.38kHz", "420Hz", 5), sweep=direction)
    assert_bits_equal(again["delta_amp_over_xb"], got["delta_amp_over_xb"], "delta_amp_over_xb")


def test_sweep_columns_equal_cli_csv(tmp_path):
    out = tmp_path / "sweep"
    cli("sweep", TINY, "--set", "base.amplitude=5um,10um", "--set", "base.frequency=250:300:2",
        "--ensemble", "2", "--seed", "3", "--jobs", "2", "--out", out)
    got = djkr.sweep(TINY, grid={"base.amplitude": ["5um", "10um"], "base.frequency": "250:300:2"},
                     ensemble=2, seed=3, jobs=2)
    expected = csv_columns(out / "sweep.csv")
    assert_columns_equal(got, expected, skip={"wall_s"})
    assert len(got["point"]) == 2 * 2 * 2
    # A list of SI floats is the same as the list of strings with units.
    si = djkr.sweep(TINY, grid={"base.amplitude": [5e-6, 1e-5]}, jobs=1)
    strings = djkr.sweep(TINY, grid={"base.amplitude": ["5e-06", "1e-05"]}, jobs=1)
    assert_bits_equal(si["pull_off_force"], strings["pull_off_force"], "pull_off_force")


def as_python(message, key, shown):
    """The command line's `--set KEY=VALUE: rest` as Python words it: `set={'KEY': shown}: rest`
    (a flag named alone becomes its argument: `--set does not` -> `set= does not`)."""
    head, rest = message.split(": ", 1)
    assert head.startswith(f"--set {key}="), head
    return f"set={{'{key}': {shown}}}: " + rest.replace("--set does not", "set= does not")


def test_bad_input_raises_scenario_error_with_the_cli_message():
    """The command line's message, in Python's words (issue 27): the override named as the
    `set=` entry it came from, never as `--set`."""
    cases = [
        (lambda: djkr.run(VIB400, set={"base.amplitude": "-1um"}),
         ["run", VIB400, "--set", "base.amplitude=-1um"], ("base.amplitude", "'-1um'")),
        # An unknown key: the value plays no part (`...`).
        (lambda: djkr.run(VIB400, set={"base.amplitud": "30um"}),
         ["run", VIB400, "--set", "base.amplitud=30um"], ("base.amplitud", "...")),
        (lambda: djkr.validate(VIB400, set={"stage[7].speed": 1e-3}),
         ["validate", VIB400, "--set", "stage[7].speed=0.001"], ("stage[7].speed", "0.001")),
        (lambda: djkr.run(VIB400, set={"stage[0].vibration": "yes"}),
         ["run", VIB400, "--set", "stage[0].vibration=yes"], ("stage[0].vibration", "'yes'")),
        (lambda: djkr.run("tests/scenarios/bad/negative-radius.toml"),
         ["run", "tests/scenarios/bad/negative-radius.toml"], None),
    ]
    for call, args, named in cases:
        if not (ROOT / args[1]).exists():
            continue
        with pytest.raises(djkr.ScenarioError) as e:
            call()
        assert isinstance(e.value, ValueError)
        expected = cli_error(*args)
        if named:
            expected = as_python(expected, *named)
        assert str(e.value) == expected
        assert "--" not in str(e.value)
    assert str(pytest.raises(djkr.ScenarioError, djkr.run, VIB400, set={"base.amplitud": 1})
               .value).startswith("set={'base.amplitud': ...}: unknown key")
    # Function arguments are named as in Python.
    with pytest.raises(djkr.ScenarioError, match="^freq = -400: must be a finite number > 0"):
        djkr.cycle(-400, "2mm", "0.5mm")
    with pytest.raises(djkr.ScenarioError, match="a_mean = -1mm"):
        djkr.cycle(400, "-1mm", "0.5mm")
    with pytest.raises(djkr.ScenarioError, match="beta has no effect"):
        djkr.pulloff(400, "0.5mm", beta=3)
    # A sweep names the argument each key came from, and the point.
    with pytest.raises(djkr.ScenarioError) as e:
        djkr.sweep(TINY, grid={"base.amplitude": ["10um", "-1um"]})
    rest = cli_error("sweep", TINY, "--set", "base.amplitude=10um,-1um", "--out", "/nonexistent/x")
    assert rest.startswith("--set base.amplitude=-1um (point 1): ")
    assert str(e.value) == "grid={'base.amplitude': [..., '-1um', ...]} (point 1): " + rest.split(": ", 1)[1]
    with pytest.raises(djkr.ScenarioError, match=r"^set=\{'base.amplitude': '-1um'\}: must be a finite number >= 0"):
        djkr.sweep(TINY, set={"base.amplitude": "-1um"}, grid={"base.frequency": [250, 300]})
    with pytest.raises(djkr.ScenarioError, match=r"^grid=\{'base.amplitude': \.\.\.\}: value 2 '1m/s' of the list: unknown unit"):
        djkr.sweep(TINY, grid={"base.amplitude": ["10um", "1m/s"]})
    with pytest.raises(djkr.ScenarioError, match=r"^set=\{'base.amplitude': '1um,2um'\}: one value per key"):
        djkr.sweep(TINY, set={"base.amplitude": "1um,2um"})
    with pytest.raises(djkr.ScenarioError, match=r"^grid=\{'base.amplitude': \.\.\.\}: base.amplitude is also in set="):
        djkr.sweep(TINY, set={"base.amplitude": "1um"}, grid={"base.amplitude": [1e-6, 2e-6]})
    with pytest.raises(djkr.ScenarioError, match=r"^ensemble = 2: .* which grid=\{'base.phase': '1,2'\} also sets"):
        djkr.sweep(TINY, grid={"base.phase": [1, 2]}, ensemble=2)
    # A point whose scenario is invalid names its overrides by the argument they came from.
    no_freq = (ROOT / TINY).read_text().replace("frequency = 300.0", "")
    with pytest.raises(djkr.ScenarioError,
                       match=r"^point 0: <string> set=\{'solver.rtol': 1e-09\} grid=\{'base.amplitude': 1e-06\}: base.frequency: missing"):
        djkr.sweep(no_freq, set={"solver.rtol": 1e-9}, grid={"base.amplitude": [1e-6, 2e-6]})
    # A run that a budget stopped: a RuntimeError, in Python's words too.
    with pytest.raises(RuntimeError) as e:
        djkr.run(TINY, set={"solver.max_steps": 50})
    assert str(e.value).startswith(f"{TINY} set={{'solver.max_steps': 50}}: run stopped: step budget exhausted")
    assert "--set" not in str(e.value)
    with pytest.raises(djkr.ScenarioError, match=r"^ensemble = 0: must be"):
        djkr.sweep(TINY, ensemble=0)
    with pytest.raises(djkr.ScenarioError, match=r"^seed = 3: seeds the ensemble's phases; give ensemble=N"):
        djkr.sweep(TINY, seed=3)
    with pytest.raises(djkr.ScenarioError, match="freq"):
        djkr.resonance(RESONANCE, freq=(500, 400, 3))
    with pytest.raises(djkr.ScenarioError, match=r"<dict>: material\.R"):
        djkr.run({"version": 1, "material": {"K": 9.33e6, "R": -1, "w0": 0.24},
                  "stage": [{"kind": "hold", "duration": 0.1}]})
    with pytest.raises(TypeError):
        djkr.run(42)


def test_bad_files_give_the_cli_message():
    """Every bad scenario of the corpus: the same message from Python as from `djkr check`."""
    bad = sorted((ROOT / "tests/scenarios/bad").glob("*.toml"))
    assert bad
    for path in bad:
        rel = str(path.relative_to(ROOT))
        expected = cli("check", rel, check=False).stderr.strip().splitlines()[0]
        with pytest.raises(djkr.ScenarioError) as e:
            djkr.run(rel)
        assert "error: " + str(e.value) == expected, rel


class interrupt_after:
    """Send Ctrl-C (KeyboardInterrupt) to the main thread after `seconds`, unless the block
    ended before; the block must raise KeyboardInterrupt. `elapsed`: the block's wall time."""

    def __init__(self, seconds):
        self.timer = threading.Timer(seconds, _thread.interrupt_main)

    def __enter__(self):
        # Python's own Ctrl-C handler, as in an interactive session or Jupyter. A process
        # started in the background by a non-interactive shell (nohup, `cmd &` in a CI script)
        # inherits SIGINT ignored, and then Python installs no handler and interrupt_main()
        # does nothing.
        self.previous = signal.signal(signal.SIGINT, signal.default_int_handler)
        self.t0 = time.perf_counter()
        self.timer.start()
        return self

    def __exit__(self, kind, value, tb):
        self.elapsed = time.perf_counter() - self.t0
        self.timer.cancel()
        signal.signal(signal.SIGINT, self.previous)
        assert kind is KeyboardInterrupt, f"the call ended without interruption ({self.elapsed:.3f} s)"
        return True


LONG = {"stage[0].duration": "1000s", "output.sample_rate": 10, "solver.envelope": "off"}


def test_keyboard_interrupt_stops_a_long_run():
    with interrupt_after(0.3) as i:
        djkr.run(VIB400, set=LONG)  # several seconds of work uninterrupted
    assert i.elapsed < 0.8, f"KeyboardInterrupt took {i.elapsed - 0.3:.3f} s"
    # The module is usable afterwards, and a folder of an interrupted run holds no run.
    assert djkr.cycle(400, "2mm", "0.5mm")["force_mean"] < 0


def test_keyboard_interrupt_stops_resonance_and_sweep(tmp_path):
    long_grid = {"stage[0].duration": ["1000s", "1001s"], "solver.envelope": ["off"]}
    # The resonance of 2001 frequencies takes 0.36 s on an idle machine: interrupted well before
    # it ends (at 0.3 s it could finish first, and did once).
    for call, after in (
        (lambda: djkr.resonance(RESONANCE, freq=(300, 500, 2001)), 0.08),
        (lambda: djkr.sweep(VIB400, grid=long_grid, jobs=2), 0.3),
    ):
        with interrupt_after(after) as i:
            call()
        assert i.elapsed < after + 0.5, f"KeyboardInterrupt took {i.elapsed - after:.3f} s"


def test_interrupted_run_publishes_its_folder_as_stopped(tmp_path):
    """Ctrl-C stays KeyboardInterrupt; the run folder keeps what the run computed, with reason
    SIGINT (as `djkr run` does)."""
    out = tmp_path / "interrupted"
    with interrupt_after(0.3):
        djkr.run(VIB400, set=LONG, out=out)
    summary = json.loads((out / "summary.json").read_text())
    assert summary["status"] == "stopped" and summary["reason"] == "SIGINT"
    assert summary["final_state"]["t"] > 0
    with h5py.File(out / "run.h5", "r") as f:
        assert len(f["t"]) == summary["samples"]
    assert not list(out.glob(".*.partial"))


def test_a_stopped_run_raises_runtime_error_with_the_partial_run(tmp_path):
    """A budget (here max_steps) raises RuntimeError as before, with the run up to the stop as
    the exception's `run`; its summary and folder say stopped, max_steps."""
    out = tmp_path / "stopped"
    with pytest.raises(RuntimeError) as e:
        djkr.run(TINY, set={"solver.max_steps": 3000, "output.sample_rate": 0}, out=out)
    assert not isinstance(e.value, djkr.ScenarioError)
    assert "max_steps" in str(e.value)
    run = e.value.run
    assert isinstance(run, djkr.Run)
    assert run.summary["status"] == "stopped" and run.summary["reason"] == "max_steps"
    assert "in stage" in run.summary["message"]
    assert len(run.t) == run.summary["samples"] > 0
    assert run.t[-1] <= run.summary["final_state"]["t"]
    on_disk = json.loads((out / "summary.json").read_text())
    assert on_disk["reason"] == "max_steps" and on_disk["samples"] == len(run.t)
    with h5py.File(out / "run.h5", "r") as f:
        assert_bits_equal(f["t"][:], run.t, "t")
    # A failure mid-way: status failed, the partial run attached.
    with pytest.raises(RuntimeError) as e:
        djkr.run(TINY, set={"stage[1].max_duration": 0.01})
    assert e.value.run.summary["status"] == "failed"
    assert e.value.run.summary["reason"] == "stage-timeout"
    # A run that went to its end: status ok, no reason.
    ok = djkr.run(TINY)
    assert ok.summary["status"] == "ok"
    assert "reason" not in ok.summary and "message" not in ok.summary


def test_the_memory_budget_stops_a_run_with_per_step_output():
    """solver.max_memory (1 MiB here) caps the samples a run holds; it stops with reason memory
    and keeps what it holds."""
    with pytest.raises(RuntimeError) as e:
        djkr.run(TINY, set={"solver.max_memory": 1 << 20, "output.sample_rate": 0,
                            "stage[0].duration": 5, "solver.envelope": "off"})
    run = e.value.run
    assert run.summary["status"] == "stopped" and run.summary["reason"] == "memory"
    assert 1000 < len(run.t) <= (1 << 20) // 96


def test_calls_release_the_interpreter_lock():
    """Another Python thread runs while a run is in Rust."""
    ticks = []
    stop = threading.Event()

    def ticker():
        while not stop.is_set():
            ticks.append(time.perf_counter())
            time.sleep(0.005)

    th = threading.Thread(target=ticker)
    th.start()
    try:
        t0 = time.perf_counter()
        djkr.run(VIB400, set={"stage[0].duration": "20s", "solver.envelope": "off"})
        t1 = time.perf_counter()
    finally:
        stop.set()
        th.join()
    assert t1 - t0 > 0.05
    during = [t for t in ticks if t0 < t < t1]
    assert len(during) >= 0.3 * (t1 - t0) / 0.005


def test_the_package_ships_type_stubs():
    pkg = Path(djkr.__file__).parent
    assert (pkg / "py.typed").exists()
    stub = (pkg / "__init__.pyi").read_text()
    for name in djkr.__all__:
        assert name in stub


def test_the_example_runs(tmp_path):
    script = ROOT / "examples" / "python_study.py"
    p = subprocess.run([sys.executable, str(script), str(tmp_path)], capture_output=True, text=True, cwd=ROOT)
    assert p.returncode == 0, p.stderr
    for name in ("amplification.png", "resonance.png"):
        assert (tmp_path / name).stat().st_size > 1000
    assert "amplification" in p.stdout


def _samples(_):
    return len(djkr.run(TINY).t)


def test_calls_from_other_threads_and_forked_processes():
    """Off the main thread a call runs in place; a forked child starts its own worker."""
    expected = len(djkr.run(TINY).t)
    got = []
    th = threading.Thread(target=lambda: got.append(_samples(None)))
    th.start()
    th.join()
    assert got == [expected]
    import multiprocessing

    if "fork" in multiprocessing.get_all_start_methods():
        with multiprocessing.get_context("fork").Pool(2) as pool:
            assert pool.map(_samples, range(2)) == [expected, expected]


def test_sweep_set_is_the_cli_fixed_set_and_points_is_points_csv(tmp_path):
    """Issue 27: `set=` beside `grid=` is the command line's fixed `--set KEY=VALUE` beside the
    swept keys (rows and columns), and `djkr.points(rows)` is the sweep's points.csv: a numeric
    and a text key, points whose members all stopped (NaN statistics) and one that ran."""
    out = tmp_path / "sweep"
    cli("sweep", TINY, "--set", "base.frequency=280", "--set", "solver.method=dopri5,auto",
        "--set", "solver.max_steps=300,100000", "--ensemble", "3", "--seed", "2", "--jobs", "2",
        "--out", out)
    rows = djkr.sweep(TINY, grid={"solver.method": ["dopri5", "auto"], "solver.max_steps": [300, 100000]},
                      set={"base.frequency": 280}, ensemble=3, seed=2, jobs=2)
    assert_columns_equal(rows, csv_columns(out / "sweep.csv"), skip={"wall_s"})
    assert set(rows["status"]) >= {"ok", "stopped"}
    # The override took effect: the scenario's own 300 Hz gives other forces.
    at_300 = djkr.sweep(TINY, grid={"solver.method": ["auto"], "solver.max_steps": [100000]}, ensemble=3, seed=2)
    assert not np.array_equal(at_300["pull_off_force"], rows["pull_off_force"][-3:])
    points = djkr.points(rows)
    assert_columns_equal(points, csv_columns(out / "points.csv"))
    # The rows as a DataFrame, and in another order, give the same points.
    df = pd.DataFrame(rows)
    assert_columns_equal(djkr.points(df), csv_columns(out / "points.csv"))
    assert_columns_equal(djkr.points(df.iloc[::-1]), csv_columns(out / "points.csv"))
    # Independently: the last point's mean and sample std over its members, from the rows.
    last = df[(df.point == 3) & (df.status == "ok")].pull_off_amplification
    assert points["pull_off_amplification_mean"][3] == pytest.approx(last.mean(), rel=1e-14)
    assert points["pull_off_amplification_std"][3] == pytest.approx(last.std(ddof=1), rel=1e-12)
    with pytest.raises(djkr.ScenarioError, match="^rows: no column 'status'"):
        djkr.points({k: v for k, v in rows.items() if k != "status"})
    with pytest.raises(djkr.ScenarioError, match="^rows: column 'status' has 2 values"):
        djkr.points({**rows, "status": rows["status"][:2]})
    with pytest.raises(TypeError):
        djkr.points(42)


def test_a_set_key_the_call_replaces_is_refused():
    # Issue 25: an override is honoured or refused, never ignored.
    with pytest.raises(djkr.ScenarioError, match=r"set=\{'solver.rtol': \.\.\.\}: has no effect on validate"):
        djkr.validate("scenarios/resonance-400hz.toml", set={"solver.rtol": 1e-6})
    with pytest.raises(djkr.ScenarioError, match="has no effect on resonance: the frequencies come from freq="):
        djkr.resonance("scenarios/resonance-400hz.toml", freq=(390, 400, 3), set={"base.frequency": 300})


def test_fit_recovers_n_and_equals_the_cli(tmp_path):
    # Data made by djkr at n = 0.45 (the file has 0.531) on the paper protocol with short dwells
    # and a fast unload, 1 % sigma, no noise: the fit from the file's n finds 0.45 within its
    # sigma, and a DataFrame gives the CLI's fit.json.
    paper = "scenarios/paper-protocol-300hz.toml"
    short = {"stage[1].duration": 0.1, "stage[2].duration": 0.2, "stage[3].speed": "100um/s"}
    grid = {"base.amplitude": ["5um", "10um", "15um"], "adhesion.n": [0.45]}
    grid.update({k: [v] for k, v in short.items()})
    made = djkr.sweep(paper, grid=grid, jobs=1)
    amp = made["pull_off_amplification"]
    df = pd.DataFrame({
        "base.amplitude [m]": made["base.amplitude"],
        "pull_off_amplification [1]": amp,
        "sigma [1]": 0.01 * amp,
    })
    got = djkr.fit(df, paper, free=["adhesion.n=0.1:2"], set=short)
    (p,) = got["parameters"]
    assert p["key"] == "adhesion.n" and p["unit"] == "1" and p["initial"] == 0.531
    assert got["converged"] and got["observable"] == "pull_off_amplification", got
    assert abs(p["value"] - 0.45) < 3 * p["sigma"], got
    data = tmp_path / "data.csv"
    df.to_csv(data, index=False)
    out = tmp_path / "fit"
    sets = [a for k, v in short.items() for a in ("--set", f"{k}={v}")]
    cli("fit", data, "--scenario", paper, "--free", "adhesion.n=0.1:2", *sets, "--out", out)
    expected = json.loads((out / "fit.json").read_text())
    for k in ("parameters", "correlation", "chi2", "aic", "bic", "forward_runs", "iterations"):
        assert got[k] == expected[k], k
    with pytest.raises(djkr.ScenarioError, match="not a numeric key"):
        djkr.fit(df, paper, free=["adhesion.law"])
