"""Speed of the Python API (a benchmark, not a test): run from the repository root.

    python examples/python/bench.py            # every measurement, about a minute
    python examples/python/bench.py --quick    # fewer ticks

1. Per-robot Python controllers against the same logic in Rust, on seed-transport (20 robots,
   one thread, 600 ticks per seed): the `occlusion` port of examples/python/occlusion.py
   against the built-in `occlusion`, and a do-nothing Python controller against the built-in
   `constant` (the bare cost of calling Python once per robot and tick).
2. Batched Python control at N = 1000 on the random-walk world of `formica bench`'s earlier
   figures (`formica.bench_scenario`): one numpy function per
   tick decides for all robots, against the built-in `random-walk` in Rust.
3. The PettingZoo environment at 20 robots (steps per second with given actions), and the
   vectorised form with 64 worlds (vector steps and robot-steps per second).
"""

from __future__ import annotations

import argparse
import importlib.util
import json
import pathlib
import time

import numpy as np

import formica

HERE = pathlib.Path(__file__).resolve().parent
SEED_TRANSPORT = "scenarios/seed-transport.toml"


def load_occlusion_port():
    spec = importlib.util.spec_from_file_location("occlusion_port", HERE / "occlusion.py")
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)  # registers `py-occlusion`
    return mod


class Idle:
    """Does nothing, in Python: the bare cost of a per-robot call."""

    needs = ()

    def __init__(self, layout, **params):
        pass

    def step(self, r):
        return 0.1, 0.1


formica.register_controller("py-idle", Idle)


@formica.register_batched("py-walk")
def walk(readings, batch):
    """Random walk with obstacle avoidance for every robot at once (the logic of the
    built-in `random-walk`, vectorised): turn away from the strongest proximity reading, else
    drive forward with a random turn."""
    prox = readings[:, :8]
    angles = np.asarray(batch.layout.proximity_angles, dtype=np.float32)
    strongest = prox.argmax(axis=1)
    blocked = prox.max(axis=1) > 0.3
    away = -np.sign(np.sin(angles[strongest]))
    away[away == 0] = 1.0
    turn = np.where(blocked, 2.0 * away, batch.rng.uniform(-1.0, 1.0))
    forward = np.where(blocked, 0.0, 0.1)
    half = turn * batch.layout.wheel_distance / 2
    return np.stack([forward - half, forward + half], axis=1)


def per_robot(controller: str, seeds, ticks: int) -> float:
    """Microseconds per robot-tick of `controller` on seed-transport (no early stop)."""
    sc = formica.load(SEED_TRANSPORT).set("stop.on_goal", False).set("stop.on_wall", False)
    total, spent = 0, 0.0
    for s in seeds:
        w = formica.World(sc, seed=s, controller=controller)
        t0 = time.perf_counter()
        w.step(ticks)
        spent += time.perf_counter() - t0
        total += len(w) * w.tick
    return 1e6 * spent / total


def batched(controller: str, robots: int, ticks: int) -> float:
    """Robot-ticks per second of `controller` on the random-walk bench world of `robots`."""
    w = formica.World(formica.bench_scenario(robots, controller))
    w.step(5)  # warm up
    t0 = time.perf_counter()
    w.step(ticks)
    return robots * ticks / (time.perf_counter() - t0)


def parallel_env_steps(robots: int, steps: int) -> float:
    import formica.env as fenv

    env = fenv.parallel_env(robots=robots)
    env.reset(seed=1)
    rng = np.random.default_rng(0)
    actions = rng.uniform(-0.2, 0.2, size=(64, robots, 2)).astype(np.float32)
    agents = list(env.possible_agents)
    t0 = time.perf_counter()
    for k in range(steps):
        if not env.agents:
            env.reset()
        a = actions[k % 64]
        env.step({agent: a[i] for i, agent in enumerate(agents)})
    return steps / (time.perf_counter() - t0)


def vector_env_steps(num_envs: int, robots: int, steps: int) -> float:
    import formica.env as fenv

    venv = fenv.vector_env(num_envs=num_envs, robots=robots)
    venv.reset(seed=1)
    rng = np.random.default_rng(0)
    actions = rng.uniform(-0.2, 0.2, size=(8, num_envs, robots, 2)).astype(np.float32)
    t0 = time.perf_counter()
    for k in range(steps):
        venv.step(actions[k % 8])
    return steps / (time.perf_counter() - t0)


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--quick", action="store_true", help="fewer ticks and seeds")
    ap.add_argument("--json", action="store_true", help="one JSON object instead of text")
    args = ap.parse_args()
    q = args.quick
    load_occlusion_port()
    seeds = range(1, 3 if q else 6)
    ticks = 200 if q else 600
    out = {}
    out["occlusion_rust_us_per_robot_tick"] = per_robot("occlusion", seeds, ticks)
    out["occlusion_python_us_per_robot_tick"] = per_robot("py-occlusion", seeds, ticks)
    out["constant_rust_us_per_robot_tick"] = per_robot("constant", seeds, ticks)
    out["idle_python_us_per_robot_tick"] = per_robot("py-idle", seeds, ticks)
    n = 1000
    out["batched_python_robot_ticks_per_s_n1000"] = batched("py-walk", n, 40 if q else 200)
    out["random_walk_rust_robot_ticks_per_s_n1000"] = batched("random-walk", n, 40 if q else 200)
    out["parallel_env_steps_per_s_20_robots"] = parallel_env_steps(20, 500 if q else 3000)
    vec = vector_env_steps(64, 20, 20 if q else 150)
    out["vector_env_steps_per_s_64_worlds_20_robots"] = vec
    out["vector_env_world_steps_per_s_64_worlds"] = 64 * vec
    if args.json:
        print(json.dumps(out))
        return
    o = out
    print("seed-transport, 20 robots, one thread, microseconds per robot-tick (whole tick):")
    print(
        f"  occlusion: Rust {o['occlusion_rust_us_per_robot_tick']:.2f}, Python port "
        f"{o['occlusion_python_us_per_robot_tick']:.2f} "
        f"(+{o['occlusion_python_us_per_robot_tick'] - o['occlusion_rust_us_per_robot_tick']:.2f} us, "
        f"x{o['occlusion_python_us_per_robot_tick'] / o['occlusion_rust_us_per_robot_tick']:.1f})"
    )
    print(
        f"  do-nothing: Rust constant {o['constant_rust_us_per_robot_tick']:.2f}, Python "
        f"{o['idle_python_us_per_robot_tick']:.2f} "
        f"(+{o['idle_python_us_per_robot_tick'] - o['constant_rust_us_per_robot_tick']:.2f} us per call)"
    )
    print(
        f"batched Python control, N = 1000: {o['batched_python_robot_ticks_per_s_n1000']:,.0f} robot-ticks/s "
        f"(Rust random-walk: {o['random_walk_rust_robot_ticks_per_s_n1000']:,.0f})"
    )
    print(f"PettingZoo parallel env, 20 robots: {o['parallel_env_steps_per_s_20_robots']:,.0f} steps/s")
    print(
        f"vectorised env, 64 worlds x 20 robots: {vec:,.0f} steps/s "
        f"({o['vector_env_world_steps_per_s_64_worlds']:,.0f} world-steps/s)"
    )


if __name__ == "__main__":
    main()
