#!/usr/bin/env python3
"""Release-build benchmarks of `djkr sweep` (the studies issue), in one run.

    cargo build --release
    python3 benches/sweep.py [--repeats N]

1. Overhead: a sweep of 24 runs of the paper protocol (300 Hz, X_b 10…60 µm, 0.1–0.4 s each)
   with --jobs 1: the sweep's whole-process wall time against the sum of its runs' own
   `wall_s [s]` (sweep.csv). Target ≤ 5 % over.
2. Speed-up: the same sweep with --jobs 2 against --jobs 1 (wall, median of the repeats,
   interleaved). Target ≥ 1.8 on 2 cores; it needs an otherwise idle machine.
3. Memory: peak RSS of sweeps of 50, 200 and 800 points of tests/sweep/tiny.toml (--jobs 1):
   flat in the number of points.

Prints a markdown report; run outputs go to a temporary directory. Timings on a shared machine
are noisy: the report gives the load average.
"""
import argparse
import csv
import os
import statistics
import tempfile
import time

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
DJKR = os.path.join(ROOT, "target", "release", "djkr")
PROTOCOL = os.path.join(ROOT, "scenarios", "paper-protocol-300hz.toml")
TINY = os.path.join(ROOT, "tests", "sweep", "tiny.toml")


def measured(argv):
    """Run argv silently: (wall s, peak RSS bytes)."""
    t0 = time.perf_counter()
    pid = os.fork()
    if pid == 0:
        devnull = os.open(os.devnull, os.O_WRONLY)
        os.dup2(devnull, 1)
        os.dup2(devnull, 2)
        os.execv(argv[0], argv)
    _, status, usage = os.wait4(pid, 0)
    wall = time.perf_counter() - t0
    if os.waitstatus_to_exitcode(status) != 0:
        raise RuntimeError(f"{' '.join(argv)} failed with {status}")
    return wall, usage.ru_maxrss * 1024


def rows(out):
    with open(os.path.join(out, "sweep.csv"), newline="") as f:
        return list(csv.DictReader(f))


def protocol_sweep(tmp, tag, jobs):
    out = os.path.join(tmp, f"p-{tag}-{jobs}")
    argv = [DJKR, "sweep", PROTOCOL, "--set", "base.amplitude=10um:60um:24",
            "--jobs", str(jobs), "--out", out]
    wall, _ = measured(argv)
    r = rows(out)
    assert all(x["status"] == "ok" for x in r), "a run failed"
    return wall, sum(float(x["wall_s [s]"]) for x in r)


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--repeats", type=int, default=3)
    args = ap.parse_args()
    if not os.path.exists(DJKR):
        raise SystemExit(f"{DJKR} not found: run `cargo build --release` first")
    print("# Sweep benchmarks\n")
    print(f"{time.strftime('%Y-%m-%d %H:%M UTC', time.gmtime())}, {os.cpu_count()} CPUs, "
          f"load average {' '.join(f'{x:.2f}' for x in os.getloadavg())}.\n")
    with tempfile.TemporaryDirectory(prefix="djkr-sweep-bench-") as tmp:
        one, two, over = [], [], []
        for i in range(args.repeats):
            w1, s1 = protocol_sweep(tmp, i, 1)
            w2, _ = protocol_sweep(tmp, i, 2)
            one.append(w1)
            two.append(w2)
            over.append(w1 / s1 - 1.0)
        print("## Overhead and speed-up (24 paper-protocol runs, X_b 10–60 µm)\n")
        print("| repeat | --jobs 1 wall (s) | sum of runs' wall_s (s) | overhead | --jobs 2 wall (s) | speed-up |")
        print("|---|---|---|---|---|---|")
        for i in range(args.repeats):
            print(f"| {i + 1} | {one[i]:.3f} | {one[i] / (1 + over[i]):.3f} | {100 * over[i]:.1f} % "
                  f"| {two[i]:.3f} | {one[i] / two[i]:.2f} |")
        print(f"\nMedians: overhead {100 * statistics.median(over):.1f} % (target ≤ 5 %), speed-up "
              f"{statistics.median(one) / statistics.median(two):.2f} (target ≥ 1.8).\n")
        print("## Memory against the number of points (tests/sweep/tiny.toml, --jobs 1)\n")
        print("| points | wall (s) | peak RSS (MiB) |")
        print("|---|---|---|")
        for n in (50, 200, 800):
            out = os.path.join(tmp, f"tiny-{n}")
            wall, rss = measured([DJKR, "sweep", TINY, "--set", f"base.amplitude=1um:20um:{n}",
                                  "--jobs", "1", "--out", out])
            print(f"| {n} | {wall:.2f} | {rss / 2**20:.1f} |")
        print(f"\nLoad average at the end: {' '.join(f'{x:.2f}' for x in os.getloadavg())}.")


if __name__ == "__main__":
    main()
