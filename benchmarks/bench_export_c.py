"""Step time and size of exported C controllers (``adaptive_ftc.export.export_c``).

For each scenario: export its digital controller, compile it with the flags of the SIL test
(``cc -O2 -std=c99``, no ``-march``), and time ``aftc_step`` call by call over a run of
measurements along the scenario's own reference (``aftc_reference``) with a small offset,
so that the adaptive laws keep working. Reported per scenario: the median, 99.9th
percentile and worst step time (ns), each step timed as its fastest of 5 repetitions of the
run (the code path's cost, the operating system's interruptions removed), and the slowest
single call of all (``worst_raw_ns``: with them; on a shared machine it measures the machine,
not the controller); the object's code and data size (``size`` of ``aftc.o``: text (with the
const params), data, bss in bytes) and ``sizeof`` of the state and params structs.

Run: ``python benchmarks/bench_export_c.py [--steps N] [NAME ...]``
"""

from __future__ import annotations

import argparse
import os
import subprocess
import tempfile
from pathlib import Path

from adaptive_ftc.export import export_c

#: (scenario, sample time): every design of the thesis and a user plant
SCENARIOS = [
    ("hypersonic-direct-s1", 0.005),
    ("hypersonic-direct-s1-digital", None),
    ("hypersonic-estimation-s1", 0.005),
    ("wingrock-estimation-s1", 2.0**-12),
    ("manipulator-mimo-s1", 2.0**-10),
    ("spacecraft-mimo-s1", 0.005),
    ("hypersonic-nussbaum-s1-pos", 0.005),
    ("hypersonic-sign-s1-rho0pos", 2.0**-10),
    ("examples/own_plant.toml", 0.005),
]

DRIVER = r"""
#define _POSIX_C_SOURCE 199309L
#include <stdio.h>
#include <stdlib.h>
#include <time.h>
#include "aftc.h"

static int cmp(const void *a, const void *b)
{
    long x = *(const long *)a, y = *(const long *)b;
    return (x > y) - (x < y);
}

/* the run REPS times from init: per step its fastest time (the code path's own cost, the
   operating system's interruptions removed) and the slowest of all (with them) */
int main(int argc, char **argv)
{
    long n = argc > 1 ? atol(argv[1]) : 100000, k, i, rep, worst = 0, dt;
    long *ns = malloc(sizeof(long) * (size_t)n);
    const long REPS = 5;
    aftc_state s;
    aftc_params p = aftc_default_params;
    double y[AFTC_NY], r[AFTC_NR], u[AFTC_NU], t, sink = 0.0;
    struct timespec a, b;
    for (k = 0; k < n; k++) ns[k] = 1L << 60;
    for (rep = 0; rep < REPS; rep++) {
        aftc_init(&s, &p);
        for (k = 0; k < n; k++) {
            t = k * p.sample_time;
            aftc_reference(&p, t, r);
            for (i = 0; i < AFTC_NY; i++) y[i] = 0.0;
            for (i = 0; i < AFTC_NR / 3; i++)
                y[i] = r[3 * i] + 0.01 * (double)((k % 7) - 3) / 3.0;
            clock_gettime(CLOCK_MONOTONIC, &a);
            aftc_step(&s, &p, y, r, t, u);
            clock_gettime(CLOCK_MONOTONIC, &b);
            dt = (b.tv_sec - a.tv_sec) * 1000000000L + (b.tv_nsec - a.tv_nsec);
            if (dt < ns[k]) ns[k] = dt;
            if (dt > worst) worst = dt;
            sink += u[0];
        }
    }
    qsort(ns, (size_t)n, sizeof(long), cmp);
    printf("%ld %ld %ld %ld %zu %zu %g\n", ns[n / 2], ns[(long)(0.999 * (double)(n - 1))],
           ns[n - 1], worst, sizeof(aftc_state), sizeof(aftc_params), sink);
    free(ns);
    return 0;
}
"""


def bench(name: str, ts: float | None, steps: int, work: Path, cc: str) -> dict:
    d = work / name.replace("/", "_")
    out = export_c(name, d, sample_time=ts)
    (d / "main.c").write_text(DRIVER)
    flags = ["-O2", "-std=c99"]
    subprocess.run([cc, *flags, "-c", str(out.source), "-o", str(d / "aftc.o")], check=True)
    subprocess.run(
        [cc, *flags, str(d / "main.c"), str(d / "aftc.o"), "-o", str(d / "bench"), "-lm"],
        check=True,
    )
    size = subprocess.run(["size", str(d / "aftc.o")], capture_output=True, text=True)
    text, data, bss = (int(v) for v in size.stdout.splitlines()[1].split()[:3])
    run = subprocess.run([str(d / "bench"), str(steps)], capture_output=True, text=True)
    med, p999, worst, raw, s_state, s_params, _ = run.stdout.split()
    return {
        "scenario": name,
        "states": out.n_states,
        "median_ns": int(med),
        "p99.9_ns": int(p999),
        "worst_ns": int(worst),
        "worst_raw_ns": int(raw),
        "text_B": text,
        "data_B": data,
        "bss_B": bss,
        "sizeof_state_B": int(s_state),
        "sizeof_params_B": int(s_params),
    }


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("names", nargs="*", help="scenarios (default: every design)")
    ap.add_argument("--steps", type=int, default=200_000, help="steps timed per scenario")
    args = ap.parse_args()
    cc = os.environ.get("CC", "cc")
    chosen = [s for s in SCENARIOS if not args.names or s[0] in args.names]
    rows = []
    with tempfile.TemporaryDirectory() as tmp:
        for name, ts in chosen:
            rows.append(bench(name, ts, args.steps, Path(tmp), cc))
    keys = list(rows[0])
    print(" | ".join(keys))
    for r in rows:
        print(" | ".join(str(r[k]) for k in keys))


if __name__ == "__main__":
    main()
