"""formica.env: the PettingZoo environment, its Gymnasium wrapper and the vectorised form."""

import numpy as np
import pytest
from pettingzoo.test import parallel_api_test

import formica
import formica.env as fenv


def test_the_parallel_env_passes_the_pettingzoo_api_test():
    env = fenv.parallel_env(robots=6, max_steps=40)
    parallel_api_test(env, num_cycles=60)


def test_agents_observations_actions_and_rewards():
    env = fenv.parallel_env(robots=5, progress_reward=100.0)
    obs, infos = env.reset(seed=11)
    assert env.agents == [f"robot_{i}" for i in range(5)]
    space = env.observation_space("robot_0")
    assert space.shape == (24,) and space.dtype == np.float32
    assert env.action_space("robot_3").shape == (2,) and np.allclose(env.action_space("robot_3").high, 0.8)
    assert all(space.contains(o) for o in obs.values())
    assert env.reading_names[16] == "x" and infos["robot_0"]["seed"] == 11
    before = env.world.goal_distance
    obs, rew, term, trunc, info = env.step({a: np.array([0.1, 0.1], dtype=np.float32) for a in env.agents})
    after = env.world.goal_distance
    assert set(rew) == set(env.agents) and len(set(rew.values())) == 1
    assert rew["robot_0"] == pytest.approx(100.0 * (before - after), abs=1e-9)
    assert not any(term.values()) and not any(trunc.values())
    assert info["robot_0"]["tick"] == 2
    with pytest.raises(ValueError, match="finite"):
        env.step({"robot_0": np.array([np.nan, 0.0])})
    with pytest.raises(ValueError, match=r"shape \(2,\)"):
        env.step({"robot_0": np.zeros(3)})


def test_same_seed_same_episode():
    def episode():
        env = fenv.parallel_env(robots=4, max_steps=30)
        env.reset(seed=5)
        rng = np.random.default_rng(0)
        total = 0.0
        while env.agents:
            acts = {a: rng.uniform(-0.2, 0.2, 2).astype(np.float32) for a in env.agents}
            _, rew, *_ = env.step(acts)
            total += rew["robot_0"]
        return total, env.state()

    (r1, s1), (r2, s2) = episode(), episode()
    assert r1 == r2 and np.array_equal(s1, s2)


def test_the_gymnasium_wrapper():
    import warnings

    from gymnasium.utils.env_checker import check_env

    env = fenv.TransportGymEnv(robots=4, max_steps=20)
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        check_env(env, skip_render_check=True)
    assert not [str(w.message) for w in caught], "the env checker warned"
    obs, info = env.reset(seed=3)
    assert obs.shape == (4, 24) and env.action_space.shape == (4, 2)
    obs, reward, terminated, truncated, info = env.step(np.zeros((4, 2), dtype=np.float32))
    assert isinstance(reward, float) and not terminated and info["tick"] == 2
    import gymnasium

    assert isinstance(gymnasium.make("formica/Transport-v0", robots=3).unwrapped, fenv.TransportGymEnv)


def test_the_vectorised_form_steps_many_worlds_and_autoresets():
    venv = fenv.vector_env(num_envs=4, robots=5, max_steps=3)
    obs, info = venv.reset(seed=100)
    assert obs.shape == (4, 5, 24) and info["seed"].tolist() == [100, 101, 102, 103]
    actions = np.zeros((4, 5, 2), dtype=np.float32)
    for _ in range(2):
        obs, rew, term, trunc, info = venv.step(actions)
        assert rew.shape == (4,) and not trunc.any() and "final_obs" not in info
    obs, rew, term, trunc, info = venv.step(actions)
    assert trunc.all() and info["_final_obs"].all() and info["final_obs"][0].shape == (5, 24)
    # Each info array has its mask, as Gymnasium's vector infos do: every world has both.
    assert info["_outcome"].all() and info["_goal_distance"].all()
    assert info["outcome"].tolist() == [0, 0, 0, 0]  # truncated by max_steps, not ended
    # Rebuilt at once with the next seeds, first tick done.
    assert venv.worlds.seeds == [104, 105, 106, 107] and venv.worlds.ticks.tolist() == [1, 1, 1, 1]
    with pytest.raises(ValueError, match=r"shape \(4, 5, 2\)"):
        venv.step(np.zeros((4, 2)))


def test_options_that_are_not_whole_numbers_are_refused_not_cut_short():
    for kwargs, name in (({"frame_skip": 1.9}, "frame_skip"), ({"robots": 2.7}, "robots"), ({"max_steps": 2.5}, "max_steps"), ({"frame_skip": 0}, "frame_skip")):
        with pytest.raises(ValueError, match=name):
            fenv.TransportGymEnv(**kwargs)
    # Whole numbers in any numeric type still do, and one sensor may be named alone.
    env = fenv.TransportGymEnv(robots=np.int64(3), frame_skip=2.0, sensors="proximity")
    obs, _ = env.reset(seed=1)
    assert obs.shape[0] == 3


def test_stepping_before_reset_says_to_reset():
    for env, action in (
        (fenv.TransportGymEnv(robots=2), np.zeros((2, 2), dtype=np.float32)),
        (fenv.vector_env(num_envs=2, robots=2), np.zeros((2, 2, 2), dtype=np.float32)),
    ):
        with pytest.raises(RuntimeError, match=r"reset\(\) first"):
            env.step(action)


def test_seeds_rewards_and_actions_that_are_not_what_they_say_are_refused():
    for options, match in (
        ({"seed": 1.7}, "seed: expected a whole number"),
        ({"seed": "5"}, "seed: expected a whole number"),
        ({"progress_reward": float("nan")}, "progress_reward: expected a finite number"),
        ({"wall_penalty": "10"}, "wall_penalty: expected a finite number"),
        ({"frame_skip": 10**30}, "frame_skip: expected at most"),
    ):
        with pytest.raises(ValueError, match=match):
            fenv.parallel_env(robots=2, **options)
    env = fenv.parallel_env(robots=2)
    env.reset(seed=1)
    with pytest.raises(ValueError, match="must be numbers"):
        env.step({"robot_0": ["1", "2"]})
    with pytest.raises(ValueError, match="seed: expected a whole number"):
        env.reset(seed=2.5)


def test_the_gymnasium_env_refuses_to_step_past_the_end():
    # It used to pay the success reward again at every later step.
    env = fenv.TransportGymEnv(robots=2, set={"objects.0.at": [2.3, 0.0]})
    env.reset(seed=1)
    _, reward, terminated, _, info = env.step(np.zeros((2, 2), dtype=np.float32))
    assert terminated and info["outcome"] == "success" and reward > 0
    with pytest.raises(RuntimeError, match=r"reset\(\) first"):
        env.step(np.zeros((2, 2), dtype=np.float32))
    env.reset(seed=2)
    env.step(np.zeros((2, 2), dtype=np.float32))
    with pytest.raises(RuntimeError, match=r"reset\(\) first"):
        fenv.parallel_env(robots=2).state()


def test_the_default_scenario_works_outside_the_repository(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    env = fenv.parallel_env(robots=3)
    obs, _ = env.reset(seed=1)
    assert len(obs) == 3 and env._task.scenario.name == "seed-transport"


def test_observations_stay_within_bounds_that_the_arena_and_noise_give():
    # Noise far above the preset's, robots released one every 2 s: every observation of an
    # episode lies in the space, and the space is finite and no wider than the arena allows.
    env = fenv.TransportGymEnv(
        robots=8,
        frame_skip=5,
        set={
            "robots.0.sensors.position_noise": 0.05,
            "robots.0.sensors.heading_noise": 1.0,
            "robots.0.release": {"interval_s": 2.0},
            "run.duration_s": 60.0,
        },
    )
    space = env.observation_space
    assert np.isfinite(space.low).all() and np.isfinite(space.high).all()
    names = env.reading_names
    x, theta, t = names.index("x"), names.index("theta"), names.index("time_s")
    # seed-transport's arena: 6 m wide, centred on the origin.
    assert 3.0 < space.high[0, x] < 3.0 + 0.1 + 5.8 * 0.05 + 1e-5
    assert space.high[0, theta] == np.float32(np.pi) and space.high[0, t] == 60.0
    obs, _ = env.reset(seed=4)
    steps, done = 0, False
    rng = np.random.default_rng(1)
    while not done:
        assert space.contains(obs), steps
        obs, _, term, trunc, _ = env.step(rng.uniform(-0.8, 0.8, (8, 2)).astype(np.float32))
        steps, done = steps + 1, term or trunc
    assert space.contains(obs)
    assert steps == 120 or term


def test_positioning_false_leaves_the_robots_own_position_out_of_every_observation():
    # A robot with no overhead tracker: no x, y, theta in what the policy sees, in each form.
    opts = dict(robots=4, seed=3, positioning=False, sensors=("proximity", "light"))
    full = fenv.TransportGymEnv(robots=4, seed=3, sensors=("proximity", "light"))
    blind = fenv.TransportGymEnv(**opts)
    assert {"x", "y", "theta"} <= set(full.reading_names)
    assert not {"x", "y", "theta"} & set(blind.reading_names)
    assert len(blind.reading_names) == len(full.reading_names) - 3
    a, _ = full.reset(seed=3)
    b, _ = blind.reset(seed=3)
    kept = [full.reading_names.index(n) for n in blind.reading_names]
    assert np.array_equal(a[:, kept], b)  # the same world, the position columns dropped
    assert blind.observation_space.shape == b.shape and blind.observation_space.contains(b)
    par = fenv.parallel_env(**opts)
    obs, _ = par.reset(seed=3)
    assert all(o.shape == (len(blind.reading_names),) for o in obs.values())
    assert all(par.observation_space(k).contains(o) for k, o in obs.items())
    vec = fenv.vector_env(2, **opts)
    v, _ = vec.reset(seed=3)
    assert v.shape == (2, 4, len(blind.reading_names)) and np.array_equal(v[0], b)
    with pytest.raises(ValueError, match="positioning: expected True or False"):
        fenv.TransportGymEnv(positioning="no")
