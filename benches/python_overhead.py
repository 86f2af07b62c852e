"""The Python binding's overhead over the same work in Rust (issue 13's targets: <= 5 % on a
1 s run at 400 Hz, <= 20 us per `cycle` call).

    cargo build --release --example api_timing
    pip install ./python
    python benches/python_overhead.py [ROUNDS]

Run from the repository root. Each round times the Rust side (target/release/examples/
api_timing: the same djkr::api calls the binding makes, in Rust) and then the Python side, so
that a change of load on the machine hits both alike; the medians over all rounds are compared.

- run: `djkr.run("benches/scenes/vib400.toml")` (1 s at 400 Hz, every step sampled: the arrays
  as numpy, events and period records kept) against reading the file and `djkr::api::run`.
- cycle: `djkr.cycle(400.0, 0.002, 0.0005)` (a dict back) against `djkr::api::cycle` and its
  JSON object, per call, in batches of 1000.
"""

import json
import statistics
import subprocess
import sys
import timeit
from pathlib import Path

import djkr

SCENE = "benches/scenes/vib400.toml"
RUST = Path("target/release/examples/api_timing")


def rust(runs, batches):
    out = subprocess.run([str(RUST), SCENE, str(runs), str(batches)], capture_output=True, text=True, check=True)
    return json.loads(out.stdout)


def python(runs, batches):
    djkr.run(SCENE)  # warm: imports, page cache
    run_s = timeit.repeat(lambda: djkr.run(SCENE), number=1, repeat=runs)
    cycle_s = [t / 1000 for t in timeit.repeat(lambda: djkr.cycle(400.0, 0.002, 0.0005), number=1000, repeat=batches)]
    return run_s, cycle_s


def main():
    rounds = int(sys.argv[1]) if len(sys.argv) > 1 else 5
    if not RUST.exists():
        sys.exit(f"{RUST} missing: cargo build --release --example api_timing")
    r_run, r_cycle, p_run, p_cycle = [], [], [], []
    samples = None
    for _ in range(rounds):
        r = rust(20, 10)
        r_run += r["run_s"]
        r_cycle += r["cycle_s"]
        samples = r["samples"]
        pr, pc = python(20, 10)
        p_run += pr
        p_cycle += pc
    assert len(djkr.run(SCENE).t) == samples
    mr, mp = statistics.median(r_run), statistics.median(p_run)
    cr, cp = statistics.median(r_cycle), statistics.median(p_cycle)
    print(f"{SCENE}: {samples} samples; {rounds} rounds of 20 runs and 10 x 1000 cycles per side")
    print(f"run    Rust {mr * 1e3:8.3f} ms   Python {mp * 1e3:8.3f} ms   overhead {(mp - mr) * 1e3:+.3f} ms = {100 * (mp / mr - 1):+.2f} %  (target <= 5 %)")
    print(f"cycle  Rust {cr * 1e6:8.2f} us   Python {cp * 1e6:8.2f} us   overhead {(cp - cr) * 1e6:+.2f} us per call  (target <= 20 us)")
    # Minima: the machine's load (other processes) moves medians by several percent; the fastest
    # call of each side is the least disturbed.
    nr, np_ = min(r_run), min(p_run)
    print(f"min    run Rust {nr * 1e3:.3f} ms, Python {np_ * 1e3:.3f} ms ({100 * (np_ / nr - 1):+.2f} %); "
          f"cycle Rust {min(r_cycle) * 1e6:.2f} us, Python {min(p_cycle) * 1e6:.2f} us")


if __name__ == "__main__":
    main()
