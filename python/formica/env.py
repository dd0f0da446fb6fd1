"""Cooperative transport as reinforcement-learning environments.

- :func:`parallel_env` -> :class:`TransportParallelEnv`, a PettingZoo ``ParallelEnv``: each
  robot is an agent (``robot_0`` ...), its observation is its readings vector (float32
  ``[L]``, named by ``env.reading_names``, bounded by ``World.reading_bounds``: the arena,
  the sensor noise's largest draw and the run's duration), its action its wheel speeds ``(left, right)`` in
  m/s (a ``Box(-max_speed, max_speed, (2,))``).
- :class:`TransportGymEnv`: the same task for one policy that drives every robot (Gymnasium
  ``Env``; observation ``[N, L]``, action ``[N, 2]``). Registered as ``formica/Transport-v0``.
- :func:`vector_env` -> :class:`TransportVectorEnv`: ``num_envs`` worlds stepped in one call
  (in parallel on every core), as VMAS does; a Gymnasium ``VectorEnv`` with observations
  ``[E, N, L]``, actions ``[E, N, 2]``, rewards ``[E]``, and same-step autoreset.

Reward (one team reward per step, the same for every robot): with ``d`` the distance from the
object's centre to the goal light (m) before and after the step,

    reward = progress_reward * (d_before - d_after)      # default 100 per metre of progress
             + success_reward  if the object reached the goal (default 10)
             - wall_penalty    if it touched a wall (default 10)
             - time_penalty                               # per step (default 0)

An episode *terminates* on success or on a wall touch (the scenario's stop rules), and is
*truncated* at the scenario's ``duration_s`` or after ``max_steps`` steps. Each step lasts
``frame_skip`` ticks (default 1 tick = 0.1 s in the shipped scenarios) with the action held.
``reset`` builds a new world (seeds count up from ``seed``, default the file's ``run.seed``)
and runs its first tick with the robots still, so the first observations are real readings.

Options of every constructor: ``scenario`` (path or :class:`formica.Scenario`), ``seed``,
``robots`` (overrides ``robots.0.count``), ``set`` (a dict of further ``Scenario.set``
overrides), ``sensors`` (which sensors to compute; default proximity, light, beacon),
``positioning`` (default True; False leaves the robot's own position and heading, ``x``,
``y``, ``theta``, out of its observation: a robot with no overhead tracker, whose policy
cannot steer by world coordinates; leave ``beacon`` out of ``sensors`` too for one that does
not know where the object is), ``frame_skip``, ``max_steps``, ``progress_reward``, ``success_reward``, ``wall_penalty``,
``time_penalty``. Every robot group runs the ``external`` controller: the policy drives it.
"""

from __future__ import annotations

import math
import numbers
import os
from typing import Any, Optional

import numpy as np

import formica

try:
    import gymnasium
    from gymnasium import spaces
except ImportError as e:  # pragma: no cover - depends on the installation
    raise ImportError(
        "formica.env needs gymnasium and pettingzoo: pip install gymnasium pettingzoo"
    ) from e

try:
    from pettingzoo import ParallelEnv
except ImportError as e:  # pragma: no cover
    raise ImportError("formica.env needs pettingzoo: pip install pettingzoo") from e

DEFAULT_SCENARIO = "scenarios/seed-transport.toml"
DEFAULT_SENSORS = ("proximity", "light", "beacon")
#: The readings a tracker gives a robot of itself, which ``positioning=False`` leaves out.
POSITION_READINGS = ("x", "y", "theta")
SENSORS = ("proximity", "light", "beacon", "camera")



def _whole(name: str, value, least: int = 1, most: Optional[int] = None) -> int:
    """``value`` as a whole number from ``least`` to ``most``; a fraction (``1.9``), a bool or
    a string is a ValueError naming ``name``, not a number cut short."""
    if isinstance(value, bool) or not isinstance(value, numbers.Integral):
        if not (isinstance(value, numbers.Real) and float(value).is_integer()):
            raise ValueError(f"{name}: expected a whole number, got {value!r}")
    if int(value) < least:
        raise ValueError(f"{name}: expected at least {least}, got {value!r}")
    if most is not None and int(value) > most:
        raise ValueError(f"{name}: expected at most {most}, got {value!r}")
    return int(value)


def _speeds(name: str, action) -> np.ndarray:
    """``action`` as a float32 array of wheel speeds; strings (``["1", "2"]``) are refused,
    not parsed."""
    a = np.asarray(action)
    if a.dtype.kind not in "iuf":
        raise ValueError(f"{name}: wheel speeds must be numbers, got an array of dtype {a.dtype}")
    return a.astype(np.float32, copy=False)


def _finite(name: str, value) -> float:
    """``value`` as a finite float; NaN, infinity, a bool or a string is a ValueError naming
    ``name`` (a NaN reward would make every reward NaN)."""
    if isinstance(value, bool) or not isinstance(value, numbers.Real) or not math.isfinite(value):
        raise ValueError(f"{name}: expected a finite number, got {value!r}")
    return float(value)


def prepare_scenario(scenario, robots=None, set=None, sensors=DEFAULT_SENSORS):
    """A copy of ``scenario`` (a path or a :class:`formica.Scenario`; the default
    ``scenarios/seed-transport.toml`` also works outside the repository, from a copy inside
    the package) whose robot groups all
    run the ``external`` controller, computing ``sensors``; ``robots`` sets
    ``robots.0.count``, ``set`` further overrides."""
    if isinstance(scenario, formica.Scenario):
        sc = scenario.copy()
    elif os.fspath(scenario) == DEFAULT_SCENARIO and not os.path.exists(DEFAULT_SCENARIO):
        # Outside a clone of the repository: the copy compiled into the package.
        sc = formica._formica.shipped_scenario(DEFAULT_SCENARIO)
    else:
        sc = formica.load(scenario)
    for key, value in (set or {}).items():
        sc.set(key, value)
    if robots is not None:
        sc.set("robots.0.count", _whole("robots", robots))
    if isinstance(sensors, str):
        sensors = (sensors,)
    unknown = [s for s in sensors if s not in SENSORS]
    if unknown:
        raise ValueError(f"sensors: unknown {unknown}, expected some of {list(SENSORS)}")
    params = {s: s in sensors for s in SENSORS}
    for g in range(len(sc.controllers)):
        sc.set(f"robots.{g}.controller", "external")
        sc.set(f"robots.{g}.params", params)
    return sc


class _Task:
    """What every environment shares: the scenario, the seeds and the reward."""

    def __init__(
        self,
        scenario=DEFAULT_SCENARIO,
        *,
        seed: Optional[int] = None,
        robots: Optional[int] = None,
        set: Optional[dict] = None,
        sensors=DEFAULT_SENSORS,
        positioning: bool = True,
        frame_skip: int = 1,
        max_steps: Optional[int] = None,
        progress_reward: float = 100.0,
        success_reward: float = 10.0,
        wall_penalty: float = 10.0,
        time_penalty: float = 0.0,
    ):
        # Ticks per step: at most a run's longest duration (10^6 s) at 1000 ticks/s.
        frame_skip = _whole("frame_skip", frame_skip, 1, 10**9)
        max_steps = None if max_steps is None else _whole("max_steps", max_steps)
        if isinstance(sensors, str):
            sensors = (sensors,)
        self.scenario = prepare_scenario(scenario, robots, set, tuple(sensors))
        self.frame_skip = frame_skip
        self.max_steps = max_steps
        self.progress_reward = _finite("progress_reward", progress_reward)
        self.success_reward = _finite("success_reward", success_reward)
        self.wall_penalty = _finite("wall_penalty", wall_penalty)
        self.time_penalty = _finite("time_penalty", time_penalty)
        self.next_seed = self.scenario.seed if seed is None else _whole("seed", seed, 0)
        probe = formica.World(self.scenario, seed=self.next_seed)
        self.n = len(probe)
        if self.n == 0:
            raise ValueError("the scenario has no robots")
        self.groups = probe.robot_groups
        self.layouts = [probe.layout(g) for g in range(len(probe.groups))]
        if not isinstance(positioning, bool):
            raise ValueError(f"positioning: expected True or False, got {positioning!r}")
        # Each group's readings columns observed: all, or all but the robot's own position.
        self.keep = [
            None
            if positioning
            else np.array([k for k, n in enumerate(l.names) if n not in POSITION_READINGS])
            for l in self.layouts
        ]
        # What each group's readings can hold: the arena, the noise's largest draw, the run.
        self.bounds = [
            tuple(self.view(b, g) for b in probe.reading_bounds(g)) for g in range(len(probe.groups))
        ]

    def view(self, readings: np.ndarray, group: int = 0) -> np.ndarray:
        """The observed columns of ``readings`` (last axis) of robots of ``group``."""
        keep = self.keep[group]
        return readings if keep is None else readings[..., keep]

    def names(self, group: int = 0) -> list:
        """The names of the observed columns of ``group``."""
        names = self.layouts[group].names
        keep = self.keep[group]
        return names if keep is None else [names[k] for k in keep]

    def take_seed(self, seed: Optional[int]) -> int:
        if seed is not None:
            self.next_seed = _whole("seed", seed, 0)
        s = self.next_seed
        self.next_seed += 1
        return s

    def reward(self, before: np.ndarray, after: np.ndarray, codes: np.ndarray) -> np.ndarray:
        progress = np.nan_to_num(before - after, nan=0.0)
        r = self.progress_reward * progress - self.time_penalty
        r = r + np.where(codes == 1, self.success_reward, 0.0)
        r = r - np.where(codes == 2, self.wall_penalty, 0.0)
        return r

    def space_of(self, group: int) -> spaces.Box:
        low, high = self.bounds[group]
        return spaces.Box(low, high, dtype=np.float32)

    def robots_space(self) -> spaces.Box:
        """``[N, L]``: each robot's row bounded as its group's readings."""
        low = np.stack([self.bounds[g][0] for g in self.groups])
        high = np.stack([self.bounds[g][1] for g in self.groups])
        return spaces.Box(low, high, dtype=np.float32)

    def uniform_layout(self):
        first = self.layouts[0]
        if any(l.names != first.names for l in self.layouts):
            raise ValueError("the robot groups' readings differ in layout: use parallel_env")
        return first


_CODES = {None: 0, "success": 1, "wall": 2, "timeout": 3}


class TransportParallelEnv(ParallelEnv):
    """Cooperative transport, one agent per robot (PettingZoo ``ParallelEnv``); see the
    module docs for observations, actions, reward and options."""

    metadata = {"name": "formica_transport_v0", "render_modes": [], "is_parallelizable": True}

    def __init__(self, scenario=DEFAULT_SCENARIO, render_mode=None, **options):
        if render_mode is not None:
            raise ValueError("formica environments do not render; use `formica serve` to watch")
        self.render_mode = None
        self._task = _Task(scenario, **options)
        t = self._task
        self.possible_agents = [f"robot_{i}" for i in range(t.n)]
        self.agents: list = []
        self._index = {a: i for i, a in enumerate(self.possible_agents)}
        group_obs = [t.space_of(g) for g in range(len(t.layouts))]
        group_act = [
            spaces.Box(-l.max_speed, l.max_speed, shape=(2,), dtype=np.float32) for l in t.layouts
        ]
        self.observation_spaces = {a: group_obs[t.groups[i]] for a, i in self._index.items()}
        self.action_spaces = {a: group_act[t.groups[i]] for a, i in self._index.items()}
        self.reading_names = t.names(0)
        self.world: Optional[formica.World] = None
        self._wheels = np.zeros((t.n, 2), dtype=np.float32)
        self._dist = math.nan
        self._steps = 0

    def observation_space(self, agent):
        return self.observation_spaces[agent]

    def action_space(self, agent):
        return self.action_spaces[agent]

    def _observe(self) -> dict:
        rows = {}
        for g in range(len(self._task.layouts)):
            idx = np.flatnonzero(self._task.groups == g)
            r = self._task.view(self.world.readings(group=g), g)
            for k, i in enumerate(idx):
                rows[self.possible_agents[i]] = r[k]
        return rows

    def reset(self, seed=None, options=None):
        """Builds a new world (see the module docs) and returns ``(observations, infos)``."""
        s = self._task.take_seed(seed)
        self.world = formica.World(self._task.scenario, seed=s)
        self.world.step(1)
        self.agents = self.possible_agents[:]
        self._dist = self.world.goal_distance
        self._steps = 0
        obs = self._observe()
        return obs, {a: {"seed": s} for a in self.agents}

    def step(self, actions: dict):
        """Applies each agent's wheel speeds for ``frame_skip`` ticks (agents without an
        action stand still) and returns ``(observations, rewards, terminations, truncations,
        infos)``."""
        if self.world is None or not self.agents:
            raise RuntimeError("call reset() first (and again after the episode ended)")
        t = self._task
        self._wheels[:] = 0.0
        for agent, action in actions.items():
            i = self._index.get(agent)
            if i is None:
                raise ValueError(f"unknown agent {agent!r}")
            a = _speeds(agent, action)
            if a.shape != (2,):
                raise ValueError(f"{agent}: expected an action of shape (2,), got {a.shape}")
            if not np.all(np.isfinite(a)):
                raise ValueError(f"{agent}: wheel speeds must be finite, got {a.tolist()}")
            self._wheels[i] = a
        self.world.set_actions(self._wheels)
        outcome = self.world.step(t.frame_skip)
        self._steps += 1
        dist = self.world.goal_distance
        code = np.array([_CODES[outcome]])
        reward = float(t.reward(np.array([self._dist]), np.array([dist]), code)[0])
        self._dist = dist
        terminated = outcome in ("success", "wall")
        truncated = not terminated and (
            outcome == "timeout" or (t.max_steps is not None and self._steps >= t.max_steps)
        )
        obs = self._observe()
        agents = self.agents
        rewards = {a: reward for a in agents}
        terms = {a: terminated for a in agents}
        truncs = {a: truncated for a in agents}
        info = {"outcome": outcome, "goal_distance": dist, "tick": self.world.tick}
        infos = {a: dict(info) for a in agents}
        obs = {a: obs[a] for a in agents}
        if terminated or truncated:
            self.agents = []
        return obs, rewards, terms, truncs, infos

    def state(self) -> np.ndarray:
        """Global state: every robot's pose, then every object's, flattened (float32)."""
        if self.world is None:
            raise RuntimeError("call reset() first")
        return np.concatenate([self.world.robot_poses.ravel(), self.world.object_poses.ravel()])

    def render(self):
        return None

    def close(self):
        self.world = None


def parallel_env(scenario=DEFAULT_SCENARIO, **options) -> TransportParallelEnv:
    """A PettingZoo ``ParallelEnv`` for cooperative transport (see the module docs)."""
    return TransportParallelEnv(scenario, **options)


class TransportGymEnv(gymnasium.Env):
    """Cooperative transport for one policy driving every robot (Gymnasium ``Env``):
    observation ``[N, L]`` float32, action ``[N, 2]`` wheel speeds (m/s), the team reward of
    the module docs. All robot groups must share one readings layout."""

    metadata = {"render_modes": []}

    def __init__(self, scenario=DEFAULT_SCENARIO, render_mode=None, **options):
        if render_mode is not None:
            raise ValueError("formica environments do not render; use `formica serve` to watch")
        self._task = _Task(scenario, **options)
        t = self._task
        t.uniform_layout()  # one layout for every robot: refused otherwise
        self.observation_space = t.robots_space()
        speed = np.array([t.layouts[g].max_speed for g in t.groups], dtype=np.float32)
        speed = np.repeat(speed[:, None], 2, axis=1)
        self.action_space = spaces.Box(-speed, speed, dtype=np.float32)
        self.reading_names = t.names(0)
        self.world: Optional[formica.World] = None
        self._dist = math.nan
        self._steps = 0
        self._ended = False

    def reset(self, *, seed=None, options=None):
        super().reset(seed=seed)
        s = self._task.take_seed(seed)
        self.world = formica.World(self._task.scenario, seed=s)
        self.world.step(1)
        self._dist = self.world.goal_distance
        self._steps = 0
        self._ended = False
        return self._task.view(self.world.readings()), {"seed": s}

    def step(self, action):
        if self.world is None or self._ended:
            # Stepping on would pay the ending's reward again (a success every step).
            raise RuntimeError("call reset() first (and again after the episode ended)")
        t = self._task
        a = _speeds("action", action)
        if a.shape != (t.n, 2):
            raise ValueError(f"expected an action of shape ({t.n}, 2), got {a.shape}")
        self.world.set_actions(a)
        outcome = self.world.step(t.frame_skip)
        self._steps += 1
        dist = self.world.goal_distance
        reward = float(t.reward(np.array([self._dist]), np.array([dist]), np.array([_CODES[outcome]]))[0])
        self._dist = dist
        terminated = outcome in ("success", "wall")
        truncated = not terminated and (
            outcome == "timeout" or (t.max_steps is not None and self._steps >= t.max_steps)
        )
        info = {"outcome": outcome, "goal_distance": dist, "tick": self.world.tick}
        self._ended = terminated or truncated
        return self._task.view(self.world.readings()), reward, terminated, truncated, info


class TransportVectorEnv(gymnasium.vector.VectorEnv):
    """``num_envs`` transport worlds stepped in one call (Gymnasium ``VectorEnv``, same-step
    autoreset): observations ``[E, N, L]``, actions ``[E, N, 2]``, rewards ``[E]``. A world that
    ends is rebuilt at once with the next seed; its last observation is in
    ``infos["final_obs"]`` (where ``infos["_final_obs"]`` is true), its outcome code (1
    success, 2 wall, 3 timeout; 0 for a world whose run has not ended, also one cut off by
    ``max_steps``) in ``infos["outcome"]``, with the masks
    ``infos["_outcome"]`` and ``infos["_goal_distance"]`` (all true) of Gymnasium's
    vector-info convention."""

    metadata = {"render_modes": [], "autoreset_mode": gymnasium.vector.AutoresetMode.SAME_STEP}

    def __init__(self, num_envs: int = 64, scenario=DEFAULT_SCENARIO, **options):
        if int(num_envs) < 1:
            raise ValueError(f"num_envs: expected at least 1, got {num_envs}")
        self._task = _Task(scenario, **options)
        t = self._task
        self.num_envs = int(num_envs)
        t.uniform_layout()  # one layout for every robot: refused otherwise
        self.single_observation_space = t.robots_space()
        speed = np.array([t.layouts[g].max_speed for g in t.groups], dtype=np.float32)
        speed = np.repeat(speed[:, None], 2, axis=1)
        self.single_action_space = spaces.Box(-speed, speed, dtype=np.float32)
        self.observation_space = gymnasium.vector.utils.batch_space(
            self.single_observation_space, self.num_envs
        )
        self.action_space = gymnasium.vector.utils.batch_space(
            self.single_action_space, self.num_envs
        )
        self.reading_names = t.names(0)
        self.worlds: Optional[formica.Worlds] = None
        self._dist = np.full(self.num_envs, np.nan)
        self._steps = np.zeros(self.num_envs, dtype=np.int64)
        self._obs = None

    def reset(self, *, seed=None, options=None):
        t = self._task
        seeds = [t.take_seed(seed if k == 0 else None) for k in range(self.num_envs)]
        self.worlds = formica.Worlds(t.scenario, seeds)
        self.worlds.step(None, 1)
        self._dist = self.worlds.goal_distances
        self._steps[:] = 0
        self._obs = t.view(self.worlds.readings())
        return self._obs, {"seed": np.array(seeds)}

    def step(self, actions):
        if self.worlds is None:
            raise RuntimeError("call reset() first")
        t = self._task
        a = _speeds("actions", actions)
        if a.shape != (self.num_envs, t.n, 2):
            raise ValueError(f"expected actions of shape ({self.num_envs}, {t.n}, 2), got {a.shape}")
        codes = self.worlds.step(a, t.frame_skip)
        self._steps += 1
        dist = self.worlds.goal_distances
        reward = t.reward(self._dist, dist, codes)
        terminated = (codes == 1) | (codes == 2)
        truncated = ~terminated & (codes == 3)
        if t.max_steps is not None:
            truncated |= ~terminated & (self._steps >= t.max_steps)
        obs = t.view(self.worlds.readings())
        done = terminated | truncated
        # Every world has both every step: their masks (Gymnasium's vector-info convention)
        # are all true.
        every = np.ones(self.num_envs, dtype=bool)
        infos: dict[str, Any] = {
            "outcome": codes,
            "_outcome": every,
            "goal_distance": dist,
            "_goal_distance": every.copy(),
        }
        if done.any():
            final = np.empty(self.num_envs, dtype=object)
            for i in np.flatnonzero(done):
                final[i] = obs[i].copy()
                # The new world runs its first tick with the robots still, as in reset().
                self.worlds.reset(int(i), t.take_seed(None), ticks=1)
            infos["final_obs"] = final
            infos["_final_obs"] = done
            obs = t.view(self.worlds.readings())
            dist = np.where(done, self.worlds.goal_distances, dist)
            self._steps[done] = 0
        self._dist = dist
        self._obs = obs
        return obs, reward, terminated, truncated, infos

    def close(self, **kwargs):
        self.worlds = None


def vector_env(num_envs: int = 64, scenario=DEFAULT_SCENARIO, **options) -> TransportVectorEnv:
    """``num_envs`` transport worlds stepped together (see :class:`TransportVectorEnv`)."""
    return TransportVectorEnv(num_envs, scenario, **options)


gymnasium.register(id="formica/Transport-v0", entry_point="formica.env:TransportGymEnv")
