"""The registered Gymnasium ids with the design's own command: does the design, run as a digital
controller at the id's control period, still track? And the cost of a step.

Run: ``python benchmarks/bench_gym.py [--quick]`` (``--quick``: the first 10 s of each
scenario). For each id of ``adaptive_ftc.gym.CATALOGUE_IDS`` it runs one episode in
``mode="residual"`` with a zero correction (the design's own command, which is the simulator's
digital run of the scenario: tests/test_gym.py), and prints how it ended, the RMS tracking error
over the last 20 % of the episode (worst output) and the wall time per step. The table in
docs/deploying.md comes from this script.
"""

from __future__ import annotations

import argparse
import time

import numpy as np

from adaptive_ftc.gym import CATALOGUE_IDS, ScenarioEnv


def episode(name: str, kwargs: dict, t_final: float | None) -> dict:
    env = ScenarioEnv(name, mode="residual", t_final=t_final, **kwargs)
    env.reset(seed=0)  # compiles (or loads) the loop
    zero = np.zeros(env.action_space.shape)
    errors, times = [], []
    start = time.perf_counter()
    steps = 0
    while True:
        _, _, terminated, truncated, info = env.step(zero)
        steps += 1
        if terminated or truncated:
            break
        errors.append(info["tracking_error"])
        times.append(info["time"])
    wall = time.perf_counter() - start
    e, t = np.array(errors), np.array(times)
    tail = e[t >= 0.8 * env.loop.t_final] if e.size else e
    rms = float(np.sqrt((tail**2).mean(axis=0)).max()) if tail.size else float("nan")
    return {
        "status": str(info["status"]),
        "at": info["time"],
        "rms": rms,
        "us_per_step": 1e6 * wall / steps,
        "dt": env.dt,
        "t_final": env.loop.t_final,
    }


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="the first 10 s of each scenario")
    args = parser.parse_args()
    print("| id | scenario | period | design's own command | RMS error, last 20 % | us/step |")
    print("|---|---|---|---|---|---|")
    for env_id, (name, kwargs) in CATALOGUE_IDS.items():
        r = episode(name, kwargs, 10.0 if args.quick else None)
        how = r["status"] if r["status"] != "diverged" else f"diverged at {r['at']:.3g} s"
        print(
            f"| `{env_id}` | {name} | {1e3 * r['dt']:g} ms | {how} | {r['rms']:.2g} | "
            f"{r['us_per_step']:.0f} |",
            flush=True,
        )


if __name__ == "__main__":
    main()
