"""World speed benchmark: agent-steps per second on the intersection.

One agent-step is one decision of one car with the paper's settings (1 s decision = 10 physics
steps of 0.1 s, 100 LiDAR rays, 5-frame history), random actions, one process, no rendering,
resets included. Prints agent-steps/s for 4, 8, 16 and 32 cars, the share of time in LiDAR,
physics and Python glue, and the process's peak memory.

Usage: ``python -m box2d_driving.bench [--seconds 5] [--cars 4 8 16 32] [--json FILE]``;
``--memory`` measures memory growth over resets instead (``box2d_driving/memcheck.py``), and
``--train`` training throughput with PPO updates (the training package's ``bench-train``
command).
"""

from __future__ import annotations

import json
import os
import platform
import resource
import sys
import time
from dataclasses import asdict, dataclass

import numpy as np

import box2d_driving
from box2d_driving.cli_parser import OneLineParser
from box2d_driving.envs import core

# 32 cars need 8 slots per approach, and so longer roads than the default 16-car junction.
_LARGE = {"slots_per_approach": 8, "road_length_range": (75.0, 100.0)}


@dataclass
class BenchResult:
    """One row of the table: throughput at ``cars`` cars over ``seconds`` of stepping, and the
    shares of that time spent casting LiDAR rays, in Box2D physics and in the rest (Python glue)."""

    cars: int
    agent_steps_per_s: float
    agent_steps: int
    seconds: float
    episodes: int
    lidar_share: float
    physics_share: float
    glue_share: float


class _Timer:
    """Wraps a bound method (or a module's function) and accumulates the wall time spent in it."""

    def __init__(self, obj, name: str) -> None:
        self.total = 0.0
        inner = getattr(obj, name)
        self.restore = lambda: setattr(obj, name, inner)

        def timed(*args, **kwargs):
            t0 = time.perf_counter()
            try:
                return inner(*args, **kwargs)
            finally:
                self.total += time.perf_counter() - t0

        setattr(obj, name, timed)


def env_overrides(cars: int) -> dict:
    """Env settings for ``cars`` cars: past 16 the junction needs longer roads."""
    return dict(_LARGE) if cars > 16 else {}


def run(cars: int, seconds: float, seed: int = 0) -> BenchResult:
    """Step the intersection with ``cars`` cars and random actions for about ``seconds`` (after one
    untimed warm-up step), resets included."""
    env = box2d_driving.make("intersection-v0", num_cars=cars, **env_overrides(cars))
    env.reset(seed=seed)  # first reset compiles/loads the Numba kernels; not timed
    env.step({a: 0 for a in env.agents})
    lidar_t = _Timer(core, "lidar_distances")  # the env core's LiDAR call (restored below)
    physics_t = _Timer(env.world, "advance")
    reset_physics_t = _Timer(env.world, "reset")
    rng = np.random.default_rng(seed)
    n_act = env.action_space(env.possible_agents[0]).n
    steps, episodes = 0, 0
    env.reset(seed=seed)
    t0 = time.perf_counter()
    try:
        while True:
            if not env.agents:
                env.reset()
                episodes += 1
            actions = dict(zip(env.agents, rng.integers(n_act, size=len(env.agents)).tolist()))
            env.step(actions)
            steps += len(actions)
            elapsed = time.perf_counter() - t0
            if elapsed >= seconds:
                break
    finally:
        lidar_t.restore()
    physics = physics_t.total + reset_physics_t.total
    return BenchResult(
        cars=cars, agent_steps_per_s=steps / elapsed, agent_steps=steps, seconds=elapsed,
        episodes=episodes, lidar_share=lidar_t.total / elapsed, physics_share=physics / elapsed,
        glue_share=max(0.0, 1.0 - (lidar_t.total + physics) / elapsed),
    )


def peak_memory_mib() -> float:
    """Peak resident memory of this process (MiB)."""
    kib = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss
    return kib / 1024 if sys.platform != "darwin" else kib / 2**20


def cpu_model() -> str:
    """The CPU's model name (``/proc/cpuinfo`` where there is one, else what ``platform`` says)."""
    cpu = platform.processor() or platform.machine()
    try:
        with open("/proc/cpuinfo") as fh:
            cpu = next((ln.split(":", 1)[1].strip() for ln in fh if ln.startswith("model name")), cpu)
    except OSError:
        pass
    return cpu


def machine() -> str:
    """This machine in one line (CPU model, cores, memory, Python): every benchmark prints it, so
    a published number says where it was measured."""
    cpu = cpu_model()
    memory = ""
    try:
        pages, size = os.sysconf("SC_PHYS_PAGES"), os.sysconf("SC_PAGE_SIZE")
        memory = f", {pages * size / 2**30:.0f} GiB"
    except (ValueError, OSError, AttributeError):
        pass
    return f"{cpu}, {os.cpu_count()} cores{memory}, {platform.system()}, python {platform.python_version()}"


def format_table(results: list[BenchResult]) -> str:
    """The results as a markdown table."""
    lines = [
        "| cars | agent-steps/s | LiDAR | physics | glue | episodes |",
        "|---:|---:|---:|---:|---:|---:|",
    ]
    for r in results:
        lines.append(f"| {r.cars} | {r.agent_steps_per_s:,.0f} | {r.lidar_share:.0%} | "
                     f"{r.physics_share:.0%} | {r.glue_share:.0%} | {r.episodes} |")
    return "\n".join(lines)


def main(argv: list[str] | None = None) -> int:
    """``box2d-driving bench``: the world table, or ``--memory`` / ``--train`` handed to their own
    benchmarks; returns the exit status."""
    argv = list(sys.argv[1:] if argv is None else argv)
    if "--memory" in argv:  # memory growth over resets: its own table (box2d_driving/memcheck.py)
        from box2d_driving import memcheck

        return memcheck.main([a for a in argv if a != "--memory"])
    if "--train" in argv:  # training throughput, updates included (needs the train extra)
        from box2d_driving import plugins

        try:
            bench_train = plugins.require("bench-train")
        except plugins.CommandMissing as exc:
            print(f"box2d-driving bench --train: error: {exc}", file=sys.stderr)
            return 2
        return bench_train([a for a in argv if a != "--train"])
    parser = OneLineParser(prog="box2d-driving bench", description=__doc__.split("\n\n")[0])
    # the other modes are picked above, before parsing; listed here so that --help shows them
    parser.add_argument("--train", action="store_true",
                        help="training throughput with PPO updates instead (needs the train extra; "
                             "`bench --train --help` for its options)")
    parser.add_argument("--memory", action="store_true",
                        help="memory growth over env resets instead (`bench --memory --help` for its options)")
    parser.add_argument("--seconds", type=float, default=5.0, help="timed seconds per car count (default 5)")
    parser.add_argument("--cars", type=int, nargs="+", default=[4, 8, 16, 32],
                        help="car counts to time, one row each (default 4 8 16 32)")
    parser.add_argument("--seed", type=int, default=0, help="seed of the episodes stepped (default 0)")
    parser.add_argument("--json", help="also write the results to this JSON file")
    args = parser.parse_args(argv)
    if args.seconds <= 0 or any(c < 1 for c in args.cars):
        parser.error("--seconds must be positive and --cars at least 1")
    print(f"box2d-driving {box2d_driving.__version__} world benchmark: intersection-v0, random "
          f"actions, 10 x 0.1 s physics steps per decision, 100 rays, history 5, one process")
    results = []
    for cars in args.cars:
        r = run(cars, args.seconds, args.seed)
        results.append(r)
        print(f"  {cars:>3} cars: {r.agent_steps_per_s:,.0f} agent-steps/s", flush=True)
    print()
    print(format_table(results))
    print(f"\npeak memory: {peak_memory_mib():.0f} MiB; 32 cars use {env_overrides(32)}\nmachine: {machine()}")
    if args.json:
        with open(args.json, "x") as f:
            json.dump({"results": [asdict(r) for r in results], "peak_memory_mib": peak_memory_mib(),
                       "machine": machine()},
                      f, indent=2)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
