"""formica.World: numpy arrays with the documented shapes, dtypes and units."""

import itertools
import math
import time

import numpy as np
import pytest

import formica
from conftest import SEED_TRANSPORT

#: Khepera IV: 8 proximity and 8 light sensors, then x, y, theta, beacon_x, beacon_y,
#: has_beacon, attached, time_s.
L = 8 + 8 + 8


def test_arrays_have_the_documented_shapes_and_dtypes():
    w = formica.World(SEED_TRANSPORT, seed=3)
    assert w.step(5) is None
    n, m = len(w), 1
    assert n == 20 and w.tick == 5 and math.isclose(w.time_s, 0.5)
    for arr, shape, dtype in [
        (w.robot_poses, (n, 3), np.float32),
        (w.leds, (n,), np.uint8),
        (w.released, (n,), np.bool_),
        (w.attached, (n,), np.bool_),
        (w.wheel_speeds, (n, 2), np.float32),
        (w.object_poses, (m, 3), np.float32),
        (w.object_centers, (m, 2), np.float32),
        (w.readings(), (n, L), np.float32),
        (w.robot_groups, (n,), np.int64),
    ]:
        assert arr.shape == shape and arr.dtype == dtype, (arr.shape, arr.dtype)
    assert len(w.states) == n and all(isinstance(s, str) for s in w.states)
    names = w.reading_names()
    assert len(names) == L and names[:2] == ["proximity0", "proximity1"]
    assert names[16:] == ["x", "y", "theta", "beacon_x", "beacon_y", "has_beacon", "attached", "time_s"]
    assert w.reading_slots() == {
        "proximity": (0, 8), "light": (8, 8), "x": (16, 1), "y": (17, 1), "theta": (18, 1),
        "beacon_x": (19, 1), "beacon_y": (20, 1), "has_beacon": (21, 1), "attached": (22, 1), "time_s": (23, 1),
    }


def test_reading_bounds_come_from_the_arena_the_noise_and_the_run():
    w = formica.World(SEED_TRANSPORT, seed=3)
    low, high = w.reading_bounds()
    assert low.shape == high.shape == (L,) and low.dtype == high.dtype == np.float32
    lo0, hi0 = w.reading_bounds(0)
    assert np.array_equal(low, lo0) and np.array_equal(high, hi0)
    assert (low[:16] == 0).all() and (high[:16] == 1).all()
    # 6 x 4 m arena, 0.1 m of walls, the preset's 1 cm positioning noise at 5.8 spreads.
    assert high[16] == pytest.approx(3.0 + 0.1 + 5.8 * 0.01, abs=1e-5)
    assert low[17] == pytest.approx(-(2.0 + 0.1 + 5.8 * 0.01), abs=1e-5)
    assert high[18] == np.float32(np.pi) and (low[23], high[23]) == (0.0, 1200.0)
    w.step(50)
    r = w.readings()
    assert ((r >= low) & (r <= high)).all()
    with pytest.raises(IndexError):
        w.reading_bounds(1)


def test_units_metres_radians_seconds():
    # Exact sensors (the shipped scenario has the realistic noise preset).
    w = formica.World(formica.load(SEED_TRANSPORT).set("robots.0.sensors.noise", "none"), seed=3)
    w.step(20)
    poses, r = w.robot_poses, w.readings()
    # Robots are inside the 6 m x 4 m arena, headings in (-pi, pi].
    assert np.all(np.abs(poses[:, 0]) < 3.0) and np.all(np.abs(poses[:, 1]) < 2.0)
    assert np.all(np.abs(poses[:, 2]) <= math.pi + 1e-6)
    # Noise-free positioning reads the true pose; the beacon reads the object's centre.
    np.testing.assert_allclose(r[:, 16:19], poses, atol=1e-6)
    np.testing.assert_allclose(r[:, 19:21], np.repeat(w.object_centers, len(w), axis=0), atol=1e-6)
    assert np.all(r[:, 21] == 1.0) and np.all(r[:, 23] == np.float32(w.time_s))
    # Proximity and light readings lie in [0, 1].
    assert np.all((r[:, :16] >= 0.0) & (r[:, :16] <= 1.0))
    # The box starts at (-1, 0); the goal light is at (2.5, 0): 3.5 m away.
    assert w.object_poses[0].tolist() == pytest.approx([-1.0, 0.0, 0.0], abs=0.05)
    assert w.goal == (2.5, 0.0)
    assert w.goal_distance == pytest.approx(3.5, abs=0.05)
    assert formica.COLORS[w.leds[0]] in ("white", "blue", "red", "yellow")


def test_wheel_speeds_are_metres_per_second():
    sc = formica.load(SEED_TRANSPORT).set("robots.0.count", 1).set("robots.0.placement", {"poses": [[0.0, 1.0, 0.0]]})
    w = formica.World(sc, controller="external")
    w.set_actions(np.array([[0.1, 0.1]]))
    w.step(20)  # 2 s at 0.1 m/s along +x, after a short acceleration
    x, y, theta = w.robot_poses[0]
    assert 0.17 < x <= 0.2 and abs(y - 1.0) < 1e-3 and abs(theta) < 1e-3
    np.testing.assert_array_equal(w.wheel_speeds, np.float32([[0.1, 0.1]]))
    # Turning on the spot: the wheels 0.1054 m apart at -+0.05 m/s turn at about 0.95 rad/s.
    w.set_actions([[-0.05, 0.05]], leds=[formica.COLORS.index("red")])
    w.step(10)
    assert 0.7 < w.robot_poses[0, 2] < 1.0
    assert formica.COLORS[w.leds[0]] == "red"


def test_same_seed_same_world_and_a_readings_buffer():
    a, b = formica.World(SEED_TRANSPORT, seed=5), formica.World(SEED_TRANSPORT, seed=5)
    a.step(50)
    b.step(50)
    np.testing.assert_array_equal(a.robot_poses, b.robot_poses)
    buf = np.empty((len(a), L), dtype=np.float32)
    assert a.readings(out=buf) is None
    np.testing.assert_array_equal(buf, b.readings())
    with pytest.raises(ValueError, match="out: expected shape"):
        a.readings(out=np.empty((3, L), dtype=np.float32))


def test_stepping_to_the_end_gives_the_run_result():
    sc = formica.load(SEED_TRANSPORT).set("robots.0.count", 6)
    w = formica.World(sc, seed=2, duration=30)
    result = w.run()
    assert w.done and w.outcome == "timeout" and result["ticks"] == 300
    assert w.step() == "timeout" and w.tick == 300
    (ref,) = formica.run(sc, seeds=2, duration=30, as_frame=False)
    result.pop("wall_time_s"), ref.pop("wall_time_s")
    assert result == ref


def test_bad_actions_are_value_errors():
    w = formica.World(SEED_TRANSPORT, controller="external")
    n = len(w)
    with pytest.raises(ValueError, match=r"shape \(20, 2\)"):
        w.set_actions(np.zeros((n, 3)))
    with pytest.raises(ValueError, match="finite"):
        w.set_actions(np.full((n, 2), np.nan))
    with pytest.raises(ValueError, match="LED code 99"):
        w.set_actions(np.zeros((n, 2)), leds=np.full(n, 99))
    with pytest.raises(ValueError, match="attach"):
        w.set_actions(np.zeros((n, 2)), attach=np.full(n, 5))
    w.set_actions(np.zeros((n, 2)))
    w.clear_actions()
    assert w.step(2) is None


def test_recorded_trajectories():
    w = formica.World(SEED_TRANSPORT, seed=1, record=True)
    w.step(10)
    tr = w.trajectories()
    assert tr["object"].shape == (11, 4) and tr["robots"].shape == (11 * 20, 5)
    assert formica.World(SEED_TRANSPORT).trajectories() is None


def test_many_worlds_in_one_call():
    ws = formica.Worlds(SEED_TRANSPORT, seeds=[1, 2, 3], controller="external")
    assert len(ws) == 3 and ws.robots == 20 and ws.seeds == [1, 2, 3]
    codes = ws.step(np.full((3, 20, 2), 0.05, dtype=np.float32), 10)
    assert codes.dtype == np.int8 and codes.tolist() == [0, 0, 0]
    assert ws.readings().shape == (3, 20, L) and ws.robot_poses.shape == (3, 20, 3)
    assert ws.object_poses.shape == (3, 1, 3) and ws.goal_distances.shape == (3,)
    single = formica.World(SEED_TRANSPORT, seed=2, controller="external")
    single.set_actions(np.full((20, 2), 0.05))
    single.step(10)
    np.testing.assert_array_equal(ws.robot_poses[1], single.robot_poses)
    ws.reset(1, 9, ticks=1)
    assert ws.seeds == [1, 9, 3] and ws.ticks.tolist() == [10, 1, 10]
    with pytest.raises(ValueError, match=r"shape \(3, 20, 2\)"):
        ws.step(np.zeros((2, 20, 2)))


def test_a_readings_buffer_in_another_layout_is_refused_not_filled_out_of_order():
    w = formica.World(SEED_TRANSPORT, seed=1)
    w.step(5)
    want = w.readings()
    for buf in (np.zeros(want.shape, np.float32, order="F"), np.zeros(want.shape[::-1], np.float32).T):
        with pytest.raises(ValueError, match="C-contiguous"):
            w.readings(out=buf)
    ws = formica.Worlds(SEED_TRANSPORT, [1, 2])
    with pytest.raises(ValueError, match="C-contiguous"):
        ws.readings(out=np.zeros(ws.readings().shape, np.float32, order="F"))
    # Another dtype, a list or a wrong dimension: the error names `out` and what it must be.
    for buf in (np.zeros(want.shape), list(want), np.zeros(want.size, np.float32)):
        with pytest.raises(TypeError, match="out: expected a writable 2-dimensional float32"):
            w.readings(out=buf)
    with pytest.raises(TypeError, match="out: expected a writable 3-dimensional float32 .* dtype float64"):
        ws.readings(out=np.zeros(ws.readings().shape))


def test_a_rejected_worlds_step_changes_no_world_and_names_the_one_at_fault():
    ws = formica.Worlds(SEED_TRANSPORT, [1, 2, 3], controller="external")
    before = ws.readings().copy()
    a = np.full((3, 20, 2), 0.3)
    a[2, 5, 0] = np.nan
    with pytest.raises(ValueError, match="world 2"):
        ws.step(a, 1)
    ws.step(None, 5)
    fresh = formica.Worlds(SEED_TRANSPORT, [1, 2, 3], controller="external")
    fresh.step(None, 5)
    assert np.array_equal(ws.readings(), fresh.readings())
    assert before.shape == ws.readings().shape


def test_calls_that_would_exhaust_memory_or_outlast_the_limits_are_value_errors():
    with pytest.raises(ValueError, match="at most 1000000 seeds"):
        formica.run(SEED_TRANSPORT, seeds=range(1_000_001), duration=0.1)
    with pytest.raises(ValueError, match="at most 10000 worlds"):
        formica.Worlds(SEED_TRANSPORT, list(range(10_001)))
    with pytest.raises(ValueError, match="at most 1e6 seconds"):
        formica.World(SEED_TRANSPORT, duration=1e7)
    # Checked before the seeds are listed (range(10**12) used to take 16 s and 3.8 GB first).
    t = time.perf_counter()
    for seeds in (range(10**12), range(10**20), itertools.count()):
        with pytest.raises(ValueError, match="at most 1000000 seeds"):
            formica.run(SEED_TRANSPORT, seeds=seeds, duration=0.1)
    assert time.perf_counter() - t < 20
    with pytest.raises(ValueError, match="threads: expected 1 to 1024"):
        formica.run(SEED_TRANSPORT, seeds=[1], threads=100_000)
    # Worlds that would not fit in memory, where running out of it aborts the interpreter.
    with pytest.raises(ValueError, match="one Worlds holds at most 1000000"):
        formica.Worlds(formica.load(SEED_TRANSPORT).set("robots.0.count", 1000), list(range(1001)))
    with pytest.raises(formica.ScenarioError, match="larger than"):
        formica.load("/dev/zero")


def test_a_scenario_value_that_holds_itself_is_refused_not_followed():
    sc = formica.load(SEED_TRANSPORT)
    loop = []
    loop.append(loop)
    table = {}
    table["t"] = table
    for value in ({"x": loop}, table):
        with pytest.raises(ValueError, match="robots.0.params: .*at most 32 deep"):
            sc.set("robots.0.params", value)
    with pytest.raises(ValueError, match="robots.0.count: .*64-bit"):
        sc.set("robots.0.count", 2**64)
    assert len(formica.World(sc, duration=0.1).leds) == 20  # as it was


def _two_worlds_in_a_child(seed):
    return int(formica.Worlds(SEED_TRANSPORT, [seed, seed + 1], duration=1).step(None, 5)[0])


def test_worlds_work_in_a_child_forked_after_the_parent_used_them():
    import multiprocessing as mp

    formica.Worlds(SEED_TRANSPORT, [1, 2], duration=1).step(None, 3)
    with mp.get_context("fork").Pool(1) as pool:
        # It used to hang: rayon's pool threads do not exist in a forked child.
        assert pool.map_async(_two_worlds_in_a_child, [1]).get(timeout=60) == [0]


def test_built_in_controller_names_cannot_be_taken_and_errors_pickle():
    import pickle

    class Mine:
        def step(self, r):
            return (0.0, 0.0)

    for name in ("occlusion", "external"):
        with pytest.raises(ValueError, match="built-in controller"):
            formica.register_controller(name, Mine)
        with pytest.raises(ValueError, match="built-in controller"):
            formica.register_batched(name, lambda r: np.zeros((len(r), 2)))
    assert "occlusion" in formica.controllers()
    try:
        formica.run("/nonexistent.toml", seeds=[1])
    except formica.ScenarioError as e:
        again = pickle.loads(pickle.dumps(e))
        assert type(again) is formica.ScenarioError and str(again) == str(e)
    else:
        raise AssertionError("a missing file must raise ScenarioError")


def test_led_and_attach_codes_must_be_whole_numbers():
    w = formica.World(SEED_TRANSPORT, controller="external")
    n = len(w.leds)
    for leds, attach in ((np.full(n, 1.7), None), (np.full(n, np.nan), None), (None, np.full(n, 0.9))):
        with pytest.raises(ValueError, match="whole-number codes"):
            w.set_actions(np.zeros((n, 2)), leds=leds, attach=attach)
    w.set_actions(np.zeros((n, 2)), leds=np.full(n, 1.0), attach=np.zeros(n, dtype=np.int8))
    # A code out of range names the robot.
    with pytest.raises(ValueError, match="set_actions, robot 0: LED code 99 is not a colour"):
        w.set_actions(np.zeros((n, 2)), leds=np.full(n, 99))
    with pytest.raises(ValueError, match="set_actions, robot 0: attach: expected -1"):
        w.set_actions(np.zeros((n, 2)), attach=np.full(n, 5))


def test_boolean_attach_arrays_are_refused():
    # A per-robot controller's False detaches; read as a code, False would be 0, keep.
    w = formica.World(SEED_TRANSPORT, controller="external")
    n = len(w.leds)
    with pytest.raises(ValueError, match="attach must be integer codes, got booleans"):
        w.set_actions(np.zeros((n, 2)), attach=np.zeros(n, dtype=bool))


def test_strings_are_not_taken_for_numbers():
    w = formica.World(SEED_TRANSPORT, controller="external")
    n = len(w.leds)
    with pytest.raises(ValueError, match="wheel speeds must be numbers"):
        w.set_actions([["0.1", "0.1"]] * n)
    with pytest.raises(ValueError, match="leds must be numbers"):
        w.set_actions(np.zeros((n, 2)), leds=["1"] * n)
    ws = formica.Worlds(SEED_TRANSPORT, seeds=[1, 2], controller="external")
    with pytest.raises(ValueError, match="wheel speeds must be numbers"):
        ws.step(np.full((2, n, 2), "0.1"))
    formica.register_batched("strings", lambda r: np.full((len(r), 2), "0.1"))
    with pytest.raises(ValueError, match="wheel speeds must be numbers"):
        formica.World(SEED_TRANSPORT, controller="strings").step(1)
    # Lists of numbers, booleans and integer arrays still do.
    w.set_actions([[0.1, 0.1]] * n, leds=np.ones(n, dtype=np.int64))
    assert np.allclose(w.wheel_speeds, 0.1)


def test_another_thread_waits_for_a_step_and_a_controller_may_not_reach_back():
    import threading

    w = formica.World(SEED_TRANSPORT, duration=100000, controller="random-walk")
    ready, seen, errors = threading.Event(), [], []

    def reader():
        ready.set()
        time.sleep(0.1)
        try:
            w.robot_poses
            seen.append(w.tick)
        except Exception as e:  # it used to be "this World is in use"
            errors.append(e)

    th = threading.Thread(target=reader)
    th.start()
    ready.wait()
    w.step(20000)
    th.join()
    assert errors == [] and seen == [20000]

    class Reach:
        def __init__(self, layout, **params):
            pass

        def step(self, readings):
            other.robot_poses
            return (0.0, 0.0)

    formica.register_controller("reach-back", Reach)
    other = formica.World(SEED_TRANSPORT, controller="reach-back")
    with pytest.raises(RuntimeError, match="being stepped by this very thread"):
        other.step(1)


def test_a_bool_is_not_taken_for_a_number():
    # Python's bool is an int: seed=True ran seed 1 and duration=True one second.
    for kwargs in ({"seed": True}, {"duration": True}):
        with pytest.raises(TypeError, match="got a bool"):
            formica.World(SEED_TRANSPORT, **kwargs)
    with pytest.raises(TypeError, match="got a bool"):
        formica.Worlds(SEED_TRANSPORT, [1, False])
    with pytest.raises(TypeError, match="got a bool"):
        formica.run(SEED_TRANSPORT, seeds=[1], duration=False)
    with pytest.raises(TypeError, match="got a bool"):
        formica.run(SEED_TRANSPORT, seeds=[1], threads=True)
    ws = formica.Worlds(SEED_TRANSPORT, [1, 2])
    for call in (lambda: ws.reset(0, True), lambda: ws.step(None, True), lambda: formica.Rng(True)):
        with pytest.raises(TypeError, match="got a bool"):
            call()
    with pytest.raises(ValueError, match="0 or more, got -1"):
        ws.reset(0, -1)
    # A negative one is said to be negative (it was "can't convert negative int to unsigned").
    with pytest.raises(ValueError, match="0 or more, got -1"):
        formica.World(SEED_TRANSPORT, seed=-1)
    with pytest.raises(ValueError, match="0 or more, got -2"):
        formica.World(SEED_TRANSPORT).step(-2)


def test_the_goal_radius_is_none_without_a_goal():
    assert formica.World(SEED_TRANSPORT).goal_radius > 0
    filling = formica.World(SEED_TRANSPORT.replace("seed-transport", "seed-fill-u"))
    assert filling.goal is None and filling.goal_radius is None
