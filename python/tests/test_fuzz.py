"""Fuzz test of the binding (issues 24 and 35): no input may take the interpreter down.

Seeded random inputs to ``djkr.run``, ``djkr.sweep``, ``djkr.cycle``, ``djkr.pulloff`` and
``djkr.fit``:
scenario dicts mutated from ``tests/sweep/tiny.toml`` (values replaced by numbers of every
size, NaN, infinities, strings with and without units, wrong types; keys dropped, added, made
non-strings; dicts and lists nested thousands deep, containing themselves, a million stages
long), TOML strings mutated line by line, paths to what is not a scenario file, ``set=`` and
``grid=`` dicts of real and unknown keys, and wrong types for every argument; for ``fit``, data
files (and DataFrames) drawn and mutated as a careless user's are (empty, a header alone, NaN,
infinities, 1e308, subnormals, duplicated columns, a byte-order mark, CRLF or CR line ends,
blank and comment lines, cells of a megabyte, 100 001 rows), FIFOs and devices as data, and
random ``free`` specs (every kind of key, bounds of ±1e308, NaN, units, a megabyte), ``ensemble``
up to 10**11. Each call either returns or raises ``djkr.ScenarioError`` or ``RuntimeError``;
anything else fails the test:
another exception type, ``KeyboardInterrupt``, a ``RuntimeError`` from a panic (``internal
error in djkr``), a ``RecursionError``, and above all a death by a signal (SIGSEGV, SIGABRT).

The calls run in a child process (this file run as a script), so that a signal death is seen
as such by the test instead of killing pytest. The child writes the index of each input to a
log before making the call, so the input that killed it is known and can be replayed alone.
Every input is drawn from its own generator, seeded from (seed, index), so that it is the same
on every machine and every run.

- Default: 10 000 inputs, seed 24 (about 20-40 s on one core). Runs are kept short by budgets
  (``solver.max_steps = 10000``, ``max_wall_s = 0.2``, ``max_memory = 64 MiB``) passed with
  ``set=`` or as one-value axes of ``grid=``. A fit runs tests/sweep/tiny.toml with 10 ms of
  vibration and a 5 mm/s unload (runs of a few milliseconds) on one thread; one input in 7 is a
  fit, of which about one in 60 runs (25 of 10 000 inputs at seed 24), the rest refused before
  any run. The 10 000 inputs take about 17 s.
- Long mode: ``DJKR_FUZZ_LONG=1`` runs 100 000 inputs (several minutes); ``DJKR_FUZZ_N=N`` any
  number; ``DJKR_FUZZ_SEED=S`` another seed.
- Replay one input: ``python python/tests/test_fuzz.py replay SEED INDEX`` (from the
  repository root) prints what it calls and what happens.
"""

import copy
import json
import os
import random
import signal
import subprocess
import sys
import tempfile
import time
import warnings
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]
TINY = "tests/sweep/tiny.toml"

# Keys every run gets last (a fuzzed value for one of them only when it is invalid), so no
# input runs long.
BUDGET = {"solver.max_steps": 10_000, "solver.max_wall_s": 0.2, "solver.max_memory": 64 << 20}
BAD_BUDGET = [0, -1, 1.5, "abc", float("nan"), None, [], True, "1e400", 10**400]

NUMBERS = [
    0, -0.0, 1, -1, 0.5, 2, 3, 1e-300, 5e-324, -5e-324, 1e300, 1.7976931348623157e308,
    float("nan"), float("inf"), -float("inf"), 2**63, -(2**63) - 1, 2**64, 10**400, -(10**400),
    1e-12, 1e12, 1e7, 1e3, 1e-3, 0.05, 10.0, 300, 400.0,
]
UNIT_STRINGS = [
    "10um", "10 µm", "10μm", "0.5mm", "400Hz", "1e3 Hz", "2 kHz", "9.81m/s^2", "1 N", "20mN",
    "-1um", "nan", "inf", "-inf", "1e999", "1e-999", "", " ", "1,2", "10 furlongs", "0x10",
    "1_000", "1e-400 m", "\U0001f642", "\x00", "\ud800", "a\ud800b", "10um:60um:3",
    "1:2:100000000", "1:2:3log", "5e-6,1e-5", "true", "false", "pull-off", "hold", "unload",
    "approach", "rk45", "dp8", "auto", "off", "gent-schultz", "0.1 s", "1e3s", "1 ms", "∞",
]
KEYS = [
    "stage[0].duration", "stage[1].duration", "stage[0].kind", "stage[1].until",
    "stage[1].max_duration", "stage[0].vibration", "stage[0].speed", "stage[9].speed",
    "stage[-1].speed", "stage[99999999999999999999].speed", "output.sample_rate", "output.csv",
    "base.amplitude", "base.frequency", "material.R", "material.K", "material.w0", "adhesion.n",
    "adhesion.v0", "adhesion.law", "sphere.mass", "sphere.gravity", "spring.stiffness",
    "damping.c", "initial.preload", "initial.gap", "solver.rtol", "solver.atol",
    "solver.event_tol", "solver.method", "solver.envelope", "contact.formation", "version",
    "nope", "", ".", "material", "stage", "stage[0]", "a.b.c.d", "base.amplitude.x",
]
PATHS = [
    TINY, Path(TINY), "does/not/exist.toml", "/dev/zero", "/dev/null", "/", "tests/sweep", "",
    "scenarios/impacts.toml", "a\x00b", "x" * 5000, "\ud800.toml", Path("/proc/self/mem"),
]


def random_text(rng, n):
    alphabet = "abc xyz=[]{}\"'.,#\n\t\\0123456789eE+-µμ\U0001f642\x00"
    return "".join(rng.choice(alphabet) for _ in range(n))


def scalar(rng):
    """A value of any type a user might pass where a number or string goes."""
    r = rng.random()
    if r < 0.3:
        return rng.choice(NUMBERS)
    if r < 0.4:
        return rng.uniform(-1e3, 1e3)
    if r < 0.5:
        return rng.choice([-1, 1]) * 10.0 ** rng.uniform(-323, 308)
    if r < 0.55:
        return rng.randint(-(2**70), 2**70)
    if r < 0.8:
        return rng.choice(UNIT_STRINGS)
    if r < 0.85:
        return random_text(rng, rng.choice([1, 10, 100]))
    return rng.choice([True, False, None, b"10um", 1j, object(), {1, 2}, (1,), [], {}, range(3),
                       float, ValueError("x"), bytearray(b"x")])


def deep(rng, depth):
    """A dict or list nested `depth` deep (built without recursion)."""
    v = scalar(rng)
    as_list = rng.random() < 0.5
    for _ in range(depth):
        v = [v] if as_list else {"a": v}
    return v


def cyclic(rng):
    """A dict or list that contains itself, directly or through another."""
    r = rng.random()
    if r < 0.4:
        d = {"version": 1}
        d["self"] = d
        return d
    if r < 0.7:
        lst = [1]
        lst.append(lst)
        return lst
    d = {"kind": "hold", "duration": 0.1}
    d["inner"] = {"back": [d]}
    return d


def value(rng, depth=0):
    """Any value: a scalar, a container (small, deep, cyclic or huge)."""
    r = rng.random()
    if r < 0.7 or depth > 3:
        return scalar(rng)
    if r < 0.8:
        return [value(rng, depth + 1) for _ in range(rng.randint(0, 3))]
    if r < 0.88:
        return {rng.choice(["a", "kind", "duration", 1, None, ""]): value(rng, depth + 1)
                for _ in range(rng.randint(0, 3))}
    if r < 0.93:
        return deep(rng, rng.choice([10, 79, 80, 81, 200, 10_000, 50_000]))
    if r < 0.97:
        return cyclic(rng)
    return [scalar(rng)] * rng.choice([1000, 100_000, 1_000_000])


def tiny_dict():
    import tomllib

    return tomllib.loads((ROOT / TINY).read_text())


def leaves(d, path=()):
    """Paths to the values of a scenario dict (into lists of tables too), at most 3 deep and
    through the first 3 items of a list: a fuzzed dict may be cyclic, deep or huge."""
    out = []
    if len(path) >= 3:
        return out
    if isinstance(d, dict):
        for k, v in d.items():
            out.append(path + (k,))
            out += leaves(v, path + (k,))
    elif isinstance(d, list):
        for i, v in enumerate(d[:3]):
            out.append(path + (i,))
            out += leaves(v, path + (i,))
    return out


def mutate_dict(rng, base):
    d = copy.deepcopy(base)
    d.setdefault("solver", {}).update(
        {"max_steps": 10_000, "max_wall_s": 0.2, "max_memory": 64 << 20})
    for _ in range(rng.randint(1, 3)):
        paths = leaves(d)
        op = rng.random()
        path = rng.choice(paths) if paths else ()
        parent = d
        for p in path[:-1]:
            parent = parent[p]
        last = path[-1] if path else None
        if op < 0.45 and path:
            parent[last] = value(rng)
        elif op < 0.55 and path:
            del parent[last]
        elif op < 0.65:
            target = parent if isinstance(parent, dict) else d
            target[rng.choice(["x", "material", "stage", "solver", "output", 5, None, (1, 2),
                               "ü", "\ud800", "a.b"])] = value(rng)
        elif op < 0.75:
            n = rng.choice([0, 2, 100, 10_000, 100_000, 1_000_000])
            d["stage"] = [{"kind": "hold", "duration": 0.01}] * n
        elif op < 0.83 and path:
            parent[last] = deep(rng, rng.choice([50, 80, 81, 1000, 10_000]))
        elif op < 0.9 and path:
            parent[last] = cyclic(rng)
        elif path:
            parent[last] = rng.choice(UNIT_STRINGS)
    return d


def mutate_text(rng, text):
    lines = text.splitlines() + ["[solver]", "max_steps = 10000", "max_wall_s = 0.2"]
    for _ in range(rng.randint(1, 4)):
        i = rng.randrange(len(lines))
        op = rng.random()
        if op < 0.4 and "=" in lines[i]:
            key = lines[i].split("=")[0]
            v = scalar(rng)
            lines[i] = f"{key}= {v!r}" if not isinstance(v, str) else f'{key}= "{v}"'
        elif op < 0.5:
            del lines[i]
        elif op < 0.6:
            lines.insert(i, lines[i])
        elif op < 0.7:
            n = rng.choice([10, 81, 1000, 100_000])
            lines.insert(i, "x = " + "[" * n + "]" * n)
        elif op < 0.75:
            n = rng.choice([10, 81, 1000, 100_000])
            lines.insert(i, "x = " + "{a = " * n + "1" + "}" * n)
        elif op < 0.8:
            lines.insert(i, "# " + "x" * rng.choice([100, 1 << 20, 2 << 20]))
        elif op < 0.9:
            lines.insert(i, random_text(rng, rng.randint(1, 50)))
        else:
            lines.insert(i, "[[stage]]\nkind = \"hold\"\nduration = 1e3")
    return "\n".join(lines) + "\n"


def scenario(rng, base, text):
    r = rng.random()
    if r < 0.15:
        return rng.choice([TINY, base, text])
    if r < 0.5:
        return mutate_dict(rng, base)
    if r < 0.7:
        return mutate_text(rng, text)
    if r < 0.85:
        return rng.choice(PATHS)
    return value(rng)


# Plausible values of real keys: runs that start, so that the run path itself is fuzzed.
MILD = {
    "stage[0].duration": [0.01, 0.1, 1, 10, 1e3, 1e6, "5 ms"],
    "stage[1].max_duration": [0.01, 1, 100, 1e4],
    "stage[1].speed": [1e-4, 2e-3, "1 mm/s", 0.1],
    "stage[0].vibration": [True, False],
    "output.sample_rate": [0, 100, 1e4, 1e5, 1e6, 1e7, 1e9],
    "base.amplitude": ["1um", "10um", "50um", 1e-5, 0],
    "base.frequency": [100, "300Hz", 1e3, 1e4],
    "sphere.mass": [1e-3, 3e-3, 0.1, 0],
    "damping.c": [0, 0.05, 1],
    "spring.stiffness": [20, 200, 2e4],
    "initial.preload": [1e-3, 0.02, 1],
    "solver.envelope": ["off", "auto"],
    "solver.method": ["auto", "dp8", "dopri5", "dop853", "implicit", "rk4"],
    "solver.rtol": [1e-10, 1e-6, 1e-3],
    "output.csv": [True, False],
}


def set_dict(rng):
    if rng.random() < 0.3:
        s = {}
        for key in rng.sample(sorted(MILD), rng.randint(0, 3)):
            s[key] = rng.choice(MILD[key])
        s.update(BUDGET)
        return s
    if rng.random() < 0.05:
        return value(rng)  # not a dict at all
    s = {}
    for _ in range(rng.randint(0, 3)):
        key = rng.choice(KEYS) if rng.random() < 0.9 else scalar(rng)
        try:
            s[key] = value(rng)
        except TypeError:  # an unhashable key
            pass
    if rng.random() < 0.05:
        s[rng.choice(list(BUDGET))] = rng.choice(BAD_BUDGET)
    else:
        s.update(BUDGET)
    return s


def grid_dict(rng):
    if rng.random() < 0.05:
        return value(rng)
    g = {}
    for _ in range(rng.randint(0, 2)):
        key = rng.choice(KEYS) if rng.random() < 0.9 else scalar(rng)
        r = rng.random()
        if r < 0.4:
            v = [scalar(rng) for _ in range(rng.randint(1, 3))]
        elif r < 0.6:
            v = rng.choice(["1e-6:2e-5:2", "10um:60um:3", "1:2:3log", "1:2:100000000", "1,2",
                            "", ":", "1:2:0", "nan:1:2", "1e400:2:2"])
        else:
            v = value(rng)
            # A grid of a thousand valid points is a long sweep, not a fuzzed input; a list of a
            # million is kept (refused by its size).
            if isinstance(v, list) and 3 < len(v) < 1_000_000:
                v = v[:3]
        try:
            g[key] = v
        except TypeError:
            pass
    for k, v in BUDGET.items():
        g[k] = [v]
    return g


def material(rng, base):
    r = rng.random()
    if r < 0.6:
        return None
    if r < 0.8:
        m = {"material": copy.deepcopy(base["material"]),
             "adhesion": copy.deepcopy(base["adhesion"])}
        key = rng.choice(["K", "R", "w0"])
        m["material"][key] = value(rng)
        return m
    if r < 0.9:
        return rng.choice(PATHS)
    return value(rng)


# A fit's data: columns (conditions, observables, sigma) and plausible values of each.
FIT_CONDITIONS = [
    ("base.amplitude [um]", ["5", "10", "20", "30"]), ("base.frequency [Hz]", ["250", "300"]),
    ("solver.method", ["auto", "implicit"]), ("base.amplitude [Hz]", ["1"]),
    ("base.wobble", ["1"]), ("material.K [MPa]", ["9.33"]), ("stage[7].speed", ["1e-3"]),
]
FIT_OBSERVABLES = [
    ("pull_off_amplification [1]", ["2", "3.5", "7", "9.5"]), ("pull_off_force [mN]", ["-5"]),
    ("force_mean [N]", ["0.01"]), ("delta_amp [um]", ["1"]), ("steps [1]", ["100"]),
    ("pull_off_force [Hz]", ["1"]),
]
FIT_CELLS = [
    "nan", "NaN", "inf", "-inf", "1e308", "-1e308", "1e-308", "5e-324", "1e-200", "0", "", " ",
    "abc", "0x10", "1e400", '"1"', '"a,b"', "1_000", "10um", "\u221e", "\x1b[2J", "#",
]
FIT_KEYS = [
    "adhesion.n", "adhesion.v0", "damping.c", "material.w0", "base.phase", "adhesion.law",
    "base.amplitude", "solver.rtol", "nope", "", "stage[9].speed", "solver.max_steps",
]
FIT_BOUNDS = [
    "", "0", "0.1", "2", "1e-3", "10", "-1", "-1e308", "1e308", "nan", "inf", "5e-324", "2um/s",
    "1Hz", "abc", "6.283185307179586",
]
# Every fit gets these (so that its runs take milliseconds) unless a fuzzed set= replaces them.
FIT_SET = {**BUDGET, "stage[0].duration": 0.01, "stage[1].speed": "5mm/s"}


def fit_text(rng):
    """A data file's text: plausible columns and rows, then up to four mutations."""
    cols = [rng.choice(FIT_CONDITIONS) for _ in range(rng.randint(1, 2))]
    cols += [rng.choice(FIT_OBSERVABLES) for _ in range(1 + (rng.random() < 0.15))]
    if rng.random() < 0.4:
        cols.append((rng.choice(["sigma [1]", "sigma", "sigma [mN]"]), ["0.1", "0.5", "1"]))
    lines = [[c[0] for c in cols]]
    lines += [[rng.choice(c[1]) for c in cols] for _ in range(rng.randint(0, 5))]
    sep, prefix = "\n", ""
    for _ in range(rng.randint(0, 4)):
        op = rng.random()
        row = rng.randrange(len(lines))
        if op < 0.3 and len(lines) > 1:
            r = lines[rng.randrange(1, len(lines))]
            if r:
                r[rng.randrange(len(r))] = rng.choice(FIT_CELLS)
        elif op < 0.4 and lines[0]:
            j = rng.randrange(len(lines[0]))
            for r in lines:
                if j < len(r):
                    r.append(r[j])
        elif op < 0.5 and lines[row]:
            lines[row][rng.randrange(len(lines[row]))] = rng.choice("x9\u00e9") * rng.choice(
                [100, 5000, 1 << 20])
        elif op < 0.55:
            prefix = "\ufeff"
        elif op < 0.65:
            sep = rng.choice(["\r\n", "\r", "\n\n"])
        elif op < 0.72:
            lines.insert(rng.randrange(len(lines) + 1), [rng.choice(["# c", "", "  ", "#"])])
        elif op < 0.77:
            lines[row].append(rng.choice(FIT_CELLS))
        elif op < 0.82:
            lines = lines[:1]
        elif op < 0.85:
            return ""
        elif op < 0.9:
            lines.insert(rng.randrange(len(lines) + 1), [random_text(rng, rng.randint(1, 40))])
        elif op < 0.92 and len(lines) > 1 and sum(map(len, lines[1])) < 100:
            # More rows than a data file may hold (the last mutation: the rows share a list).
            lines += [lines[1]] * 100_001
            return prefix + sep.join(",".join(r) for r in lines) + sep
        else:
            text = prefix + sep.join(",".join(r) for r in lines) + sep
            return text[:rng.randrange(len(text) + 1)]
    return prefix + sep.join(",".join(r) for r in lines) + sep


def fit_free(rng):
    r = rng.random()
    if r < 0.15:
        return rng.choice(["adhesion.n", ["adhesion.n=0.1:2"], ["adhesion.v0"], "damping.c=0:1"])
    if r < 0.9:
        specs = []
        for _ in range(rng.randint(1, 2)):
            k = rng.choice(FIT_KEYS)
            form = rng.random()
            if form < 0.4:
                specs.append(k)
            elif form < 0.8:
                specs.append(f"{k}={rng.choice(FIT_BOUNDS)}:{rng.choice(FIT_BOUNDS)}")
            elif form < 0.9:
                specs.append(f"{k}={'9' * 100_000}:1")
            else:
                specs.append(f"{k}={rng.choice(FIT_BOUNDS)}")
        return specs if rng.random() < 0.7 else specs[0]
    return value(rng)


def fit_data(rng, tmp):
    """What `data` gets: a file of drawn text (mostly), a DataFrame, a FIFO or a device, junk."""
    r = rng.random()
    if r < 0.8:
        path = os.path.join(tmp, f"data{rng.randrange(10**9)}.csv")
        text = fit_text(rng)
        if rng.random() < 0.1 and "\n" in text:
            # A file and a spec a user means would follow: a clean file.
            text = ("base.amplitude [um],pull_off_amplification [1]\n"
                    + "".join(f"{a},{rng.choice(['2', '3.5', '7'])}\n" for a in (5, 10, 20, 30)))
        with open(path, "w", encoding="utf-8", newline="") as f:
            f.write(text)
        return path
    if r < 0.85:
        try:
            import pandas as pd
        except ImportError:
            return TINY
        return pd.DataFrame({"base.amplitude [um]": [5, 10, 20],
                             "pull_off_amplification [1]": [rng.choice(NUMBERS) for _ in range(3)]})
    if r < 0.9 and hasattr(os, "mkfifo"):
        path = os.path.join(tmp, f"fifo{rng.randrange(10**9)}")
        os.mkfifo(path)
        return path
    if r < 0.95:
        return rng.choice(PATHS)
    return value(rng)


def fit_call(rng, base, tmp):
    import djkr

    data = fit_data(rng, tmp)
    scn = TINY if rng.random() < 0.8 else rng.choice([base, value(rng), "/dev/zero"])
    kw = {"free": fit_free(rng), "jobs": 1}
    kw["set"] = dict(FIT_SET) if rng.random() < 0.9 else set_dict(rng)
    if rng.random() < 0.1:
        kw["observable"] = rng.choice(["pull_off_force", "wall_s", "", 5, None, "x" * 100_000])
    if rng.random() < 0.1:
        kw["ensemble"] = rng.choice([0, 1, 2, -1, 10**11, 2**70, 1.5, "2", True])
    if rng.random() < 0.05:
        kw["jobs"] = rng.choice([0, 2, -1, 1.5, None])
    return "fit", lambda: djkr.fit(data, scn, **kw)


def call(rng, base, text, tmp):
    """One input: (function name, thunk)."""
    import djkr

    r = rng.random()
    if r >= 0.85:
        return fit_call(rng, base, tmp)
    r /= 0.85
    if r < 0.4:
        scn, s = scenario(rng, base, text), set_dict(rng)
        kw = {"set": s}
        if rng.random() < 0.03:
            kw["out"] = rng.choice([os.path.join(tmp, f"run{rng.randrange(10**9)}"), 5, [],
                                    "/dev/null/x", "\ud800"])
        return "run", lambda: djkr.run(scn, **kw)
    if r < 0.55:
        scn, g = scenario(rng, base, text), grid_dict(rng)
        kw = {"grid": g}
        if rng.random() < 0.5:
            kw["ensemble"] = rng.choice([None, 1, 2, 0, -1, 2**70, 1.5, "2", True])
        if rng.random() < 0.5:
            kw["seed"] = rng.choice([0, 3, -1, 2**64, 2**64 - 1, 1.5, "x", None])
        if rng.random() < 0.5:
            kw["jobs"] = rng.choice([1, 2, 0, -1, 2**70, 1.5, "2", None, 10**6])
        return "sweep", lambda: djkr.sweep(scn, **kw)
    if r < 0.8:
        args = [scalar(rng) if rng.random() < 0.5 else rng.choice(
            ["400Hz", 400, "2mm", "0.5mm", 1e-3, 300]) for _ in range(3)]
        kw = {}
        if rng.random() < 0.3:
            kw["material"] = material(rng, base)
        return "cycle", lambda: djkr.cycle(*args, **kw)
    args = [scalar(rng) if rng.random() < 0.5 else rng.choice(
        ["400Hz", 400, "0.5mm", 1e-3, 300]) for _ in range(2)]
    kw = {}
    if rng.random() < 0.5:
        kw["method"] = rng.choice(["exact", "approx", "yi", "shui", "bogus", 5, None, "\ud800"])
    if rng.random() < 0.3:
        kw["beta"] = scalar(rng)
    if rng.random() < 0.3:
        kw["material"] = material(rng, base)
    return "pulloff", lambda: djkr.pulloff(*args, **kw)


def outcome(thunk):
    """What a call did: ("ok" | "ScenarioError" | "RuntimeError", None) or ("failure", text)."""
    import djkr

    try:
        thunk()
        return "ok", None
    except djkr.ScenarioError:
        return "ScenarioError", None
    except RecursionError as e:
        return "failure", f"RecursionError: {e}"
    except RuntimeError as e:
        if "internal error in djkr" in str(e):
            return "failure", f"panic: {str(e)[:300]}"
        return "RuntimeError", None
    except BaseException as e:  # noqa: BLE001 - every other type is what the test looks for
        return "failure", f"{type(e).__name__}: {str(e)[:300]}"


def child(seed, start, count, log_path):
    """Make `count` calls from index `start`; print a JSON report."""
    warnings.simplefilter("ignore")
    os.chdir(ROOT)
    base, text = tiny_dict(), (ROOT / TINY).read_text()
    tally, failures, slow = {}, [], []
    t0 = time.monotonic()
    with open(log_path, "w") as log, tempfile.TemporaryDirectory() as tmp:
        for i in range(start, start + count):
            rng = random.Random(seed * 1_000_003 + i)
            name, thunk = call(rng, base, text, tmp)
            log.write(f"{i} {name}\n")
            log.flush()
            t = time.monotonic()
            kind, why = outcome(thunk)
            dt = time.monotonic() - t
            if dt > 2.0:
                slow.append((i, name, round(dt, 2)))
            tally[f"{name} {kind}"] = tally.get(f"{name} {kind}", 0) + 1
            if why is not None:
                failures.append((i, name, why))
    print(json.dumps({"tally": tally, "failures": failures, "slow": slow,
                      "seconds": time.monotonic() - t0}))


def replay(seed, index):
    os.chdir(ROOT)
    base, text = tiny_dict(), (ROOT / TINY).read_text()
    rng = random.Random(seed * 1_000_003 + index)
    with tempfile.TemporaryDirectory() as tmp:
        name, thunk = call(rng, base, text, tmp)
        print(f"input {index} of seed {seed}: djkr.{name}", flush=True)
        print(outcome(thunk))


def test_fuzz_run_sweep_cycle_pulloff_fit(tmp_path):
    n = int(os.environ.get("DJKR_FUZZ_N") or (100_000 if os.environ.get("DJKR_FUZZ_LONG") else 10_000))
    seed = int(os.environ.get("DJKR_FUZZ_SEED", "24"))
    log = tmp_path / "fuzz.log"
    t0 = time.monotonic()
    # A hang (a FIFO read without end) fails the test instead of blocking the suite.
    p = subprocess.run([sys.executable, __file__, "child", str(seed), "0", str(n), str(log)],
                       cwd=ROOT, capture_output=True, text=True, timeout=900)
    elapsed = time.monotonic() - t0
    if p.returncode != 0:
        last = log.read_text().splitlines()[-1:] if log.exists() else []
        died = (f"killed by {signal.Signals(-p.returncode).name}" if p.returncode < 0
                else f"exit status {p.returncode}")
        raise AssertionError(
            f"the fuzzing child was {died} at input {last} (replay: python {__file__} replay "
            f"{seed} INDEX)\nstderr: {p.stderr[-3000:]}")
    report = json.loads(p.stdout.strip().splitlines()[-1])
    calls = sum(report["tally"].values())
    print(f"\nfuzz: {calls} inputs (seed {seed}) in {elapsed:.1f} s: "
          f"{json.dumps(report['tally'], sort_keys=True)}; slow: {report['slow']}")
    assert calls == n
    assert not report["failures"], (
        f"{len(report['failures'])} inputs raised what they must not (replay: python "
        f"{__file__} replay {seed} INDEX): {report['failures'][:10]}")


if __name__ == "__main__":
    if sys.argv[1] == "child":
        child(int(sys.argv[2]), int(sys.argv[3]), int(sys.argv[4]), sys.argv[5])
    elif sys.argv[1] == "replay":
        replay(int(sys.argv[2]), int(sys.argv[3]))
