"""Controllers written in Python: per robot and batched, in run, sweep and World."""

import math

import numpy as np
import pytest

import formica
from conftest import ROOT, SEED_TRANSPORT


class Wander:
    """Drives forward, turning by a random amount now and then; avoids what it senses."""

    needs = ("proximity",)

    def __init__(self, layout, speed=0.1, turn_every_s=2.0):
        self.layout = layout
        self.speed = speed
        self.every = turn_every_s
        self.turn = 0.0
        self.next_s = 0.0
        self.state = "wander"

    def step(self, r):
        if r.time_s >= self.next_s:
            self.turn = self.rng.uniform(-2.0, 2.0)
            self.next_s = r.time_s + self.every
        prox = r.proximity
        if max(prox) > 0.3:
            self.state = "avoid"
            left, right = self.layout.twist(0.0, 2.0 if sum(prox[4:]) > sum(prox[:4]) else -2.0)
            return left, right, "red"
        self.state = "wander"
        left, right = self.layout.twist(self.speed, self.turn)
        return left, right, "green", None


formica.register_controller("py-wander", Wander)


@formica.register_batched("py-swarm")
def swarm(readings, batch):
    """Every robot drives forward and turns away from the sum of its proximity readings,
    plus a per-robot random jitter."""
    prox = readings[:, :8]
    angles = np.asarray(batch.layout.proximity_angles)
    push = (prox * np.sin(angles)).sum(axis=1)
    turn = -3.0 * push + batch.rng.uniform(-0.5, 0.5)
    forward = np.where(prox.max(axis=1) > 0.5, 0.0, 0.1)
    half = turn * batch.layout.wheel_distance / 2
    return np.stack([forward - half, forward + half], axis=1)


@formica.register_batched("py-constant", needs=())
def constant(readings, speed=0.05):
    return np.full((len(readings), 2), speed)


def scenario(controller, count=8, params=None):
    sc = formica.load(SEED_TRANSPORT).set("robots.0.count", count).set("robots.0.controller", controller)
    return sc.set("robots.0.params", params or {})


def strip(rows):
    return [{k: v for k, v in r.items() if k != "wall_time_s"} for r in rows]


def test_python_controllers_are_registered_names():
    assert {"py-wander", "py-swarm", "py-constant", "external", "occlusion"} <= set(formica.controllers())


def test_a_per_robot_python_controller_is_deterministic():
    sc = scenario("py-wander", params={"speed": 0.12})
    first = formica.run(sc, seeds=[1, 2], duration=30, as_frame=False)
    again = formica.run(sc, seeds=[1, 2], duration=30, as_frame=False)
    assert strip(first) == strip(again)
    assert first[0]["controller"] == "py-wander"
    # Other seeds, other runs; the world agrees with run.
    w1, w2 = formica.World(sc, seed=1, duration=30), formica.World(sc, seed=1, duration=30)
    w1.step(100), w2.step(100)
    np.testing.assert_array_equal(w1.robot_poses, w2.robot_poses)
    assert set(w1.states) <= {"wander", "avoid"}
    assert set(formica.COLORS[c] for c in w1.leds) <= {"green", "red"}
    w3 = formica.World(sc, seed=2, duration=30)
    w3.step(100)
    assert not np.array_equal(w1.robot_poses, w3.robot_poses)
    assert strip([w1.run()]) == strip(first[:1])


def test_python_runs_on_threads_equal_the_attached_run():
    sc = scenario("py-wander")
    attached = formica.run(sc, seeds=[3, 4], duration=20, as_frame=False)
    threaded = formica.run(sc, seeds=[3, 4], duration=20, threads=2, as_frame=False)
    assert strip(attached) == strip(threaded)


def test_a_batched_python_controller_is_deterministic():
    sc = scenario("py-swarm", count=12)
    w = formica.World(sc, seed=4)
    assert w.groups[0]["batched"]
    start = w.robot_poses.copy()
    w.step(50)
    assert w.states == ["batched"] * 12
    # The batched controller drives them (0.1 m/s unless blocked): most have moved in 5 s
    # (a few, facing a neighbour or a wall, turn on the spot).
    moved = np.hypot(*(w.robot_poses[:, :2] - start[:, :2]).T)
    assert np.median(moved) > 0.2, moved
    first = formica.run(sc, seeds=[1, 2], duration=30, as_frame=False)
    assert strip(first) == strip(formica.run(sc, seeds=[1, 2], duration=30, as_frame=False))


def test_batched_params_come_as_keyword_arguments():
    w = formica.World(scenario("py-constant", count=2, params={"speed": 0.08}), seed=1)
    w.step(3)
    np.testing.assert_allclose(w.wheel_speeds, np.full((2, 2), 0.08))


def test_bad_parameters_fail_where_the_scenario_names_them(tmp_path):
    path = tmp_path / "bad-params.toml"
    path.write_text(
        '[arena]\nsize = [2.0, 2.0]\n[[robots]]\ncontroller = "py-wander"\n'
        "params = { sped = 0.1 }\nplacement = { poses = [[0.0, 0.0, 0.0]] }\n"
    )
    with pytest.raises(formica.ScenarioError, match=r"bad-params.toml:5:10: robots\[0\] controller `py-wander`: TypeError: .*sped"):
        formica.World(path)


def test_wrong_shapes_and_nan_from_a_batched_controller_are_value_errors():
    @formica.register_batched("py-bad-shape")
    def bad_shape(readings):
        return np.zeros((len(readings), 3))

    @formica.register_batched("py-nan")
    def nan(readings):
        return np.full((len(readings), 2), np.nan)

    with pytest.raises(ValueError, match=r"py-bad-shape.*shape \(4, 2\), got \[4, 3\]"):
        formica.World(scenario("py-bad-shape", count=4)).step(2)
    with pytest.raises(ValueError, match="py-nan.*finite"):
        formica.run(scenario("py-nan", count=4), seeds=1, duration=5)


def test_an_exception_in_a_controller_comes_out_and_the_world_is_spent():
    class Boom:
        def __init__(self, layout):
            pass

        def step(self, r):
            if r.time_s > 0.25:
                raise KeyError("boom")
            return 0.0, 0.0

    formica.register_controller("py-boom", Boom)
    w = formica.World(scenario("py-boom", count=3))
    with pytest.raises(KeyError, match="boom"):
        w.step(10)
    with pytest.raises(RuntimeError, match="half-way"):
        w.step()
    with pytest.raises(KeyError, match="boom"):
        formica.run(scenario("py-boom", count=3), seeds=[1, 2], threads=2, duration=5)
    # In Worlds: the exception as raised, noting which world; the world is named after.
    ws = formica.Worlds(scenario("py-boom", count=3), [1, 2, 3])
    with pytest.raises(KeyError, match="boom") as raised:
        ws.step(None, 10)
    if hasattr(raised.value, "__notes__"):  # Python 3.11+
        assert "in world 0 of this Worlds" in raised.value.__notes__[0]
    with pytest.raises(RuntimeError, match=r"world 0 stopped half-way.*reset\(0, seed\)"):
        ws.step(None, 1)
    ws.reset(0, 1)
    with pytest.raises(KeyError, match="boom"):
        ws.step(None, 10)


def test_a_step_returning_nonsense_is_a_clear_error():
    class Nonsense:
        def __init__(self, layout):
            pass

        def step(self, r):
            return float("nan"), 0.0

    formica.register_controller("py-nonsense", Nonsense)
    with pytest.raises(ValueError, match="py-nonsense.*finite"):
        formica.World(scenario("py-nonsense", count=1)).step(2)


def test_a_rust_panic_is_a_python_exception():
    with pytest.raises(formica.PanicError, match="panic_for_test"):
        formica._formica.panic_for_test()
    assert issubclass(formica.PanicError, RuntimeError)


def test_the_rng_is_deterministic_per_seed():
    a, b = formica.Rng(3), formica.Rng(3)
    assert [a.random() for _ in range(5)] == [b.random() for _ in range(5)]
    assert 0.0 <= a.uniform(0.0, 1.0) < 1.0 and a.integers(2, 3) == 2
    for low, high in ((1.0, 0.0), (-1e308, 1e308)):
        with pytest.raises(ValueError, match="uniform"):
            a.uniform(low, high)
    for mean, sd in ((0.0, -1.0), (0.0, float("nan")), (float("inf"), 1.0)):
        with pytest.raises(ValueError, match="sd >= 0"):
            a.normal(mean, sd)
    assert a.normal(2.0, 0.0) == 2.0


def test_a_sweep_runs_python_controllers_into_a_store(tmp_path):
    sweep = tmp_path / "wander.toml"
    # A sweep file names its scenario relative to itself.
    sweep.write_text(
        f'name = "wander"\nscenario = "{ROOT / SEED_TRANSPORT}"\nseeds = "1..2"\n'
        'duration_s = 10\n[set]\n"robots.0.controller" = "py-wander"\n'
        '[vary]\n"robots.0.count" = [3, 5]\n'
    )
    db = tmp_path / "wander.db"
    df = formica.sweep(sweep, db=db, threads=1)
    assert len(df) == 4 and set(df["controller"]) == {"py-wander"}
    assert sorted(df["robots"]) == [3, 3, 5, 5]
    for threads, error in ((-1, ValueError), (2.7, TypeError), (True, TypeError)):
        with pytest.raises(error, match="threads"):
            formica.sweep(sweep, db=db, threads=threads)
    # Resumable: a second call runs nothing new and reads the same store.
    again = formica.sweep(sweep, db=db)
    assert again["sim_time_s"].tolist() == df["sim_time_s"].tolist()
    rows = formica.read_store(db, as_frame=False)
    assert [r["seed"] for r in rows] == [1, 2, 1, 2]
    # The same trial through formica.run gives the same numbers.
    sc = formica.load(SEED_TRANSPORT).set("robots.0.controller", "py-wander").set("robots.0.count", 3)
    (ref,) = formica.run(sc, seeds=1, duration=10, as_frame=False)
    assert rows[0]["object_path_m"] == ref["object_path_m"] and rows[0]["ticks"] == ref["ticks"]


def test_a_batched_controller_in_a_sweep_and_the_command_in_process(tmp_path, capfd):
    sweep = tmp_path / "swarm.toml"
    sweep.write_text(
        f'scenario = "{ROOT / SEED_TRANSPORT}"\nseeds = [4]\nduration_s = 5\n'
        '[vary]\n"robots.0.controller" = ["py-swarm", "py-wander"]\n'
    )
    rows = formica.sweep(sweep, as_frame=False)
    assert [r["controller"] for r in rows] == ["py-swarm", "py-wander"]
    assert (tmp_path / "swarm.db").exists()
    formica.cli("check", str(ROOT / SEED_TRANSPORT))
    assert "seed-transport" in capfd.readouterr().out
    with pytest.raises(formica.ScenarioError, match="missing.toml: cannot read"):
        formica.cli("check", "missing.toml")


def test_a_bad_sweep_file_raises_scenario_error(tmp_path):
    sweep = tmp_path / "bad.toml"
    sweep.write_text('seeds = "1..2"\nscenario = "nowhere.toml"\n')
    with pytest.raises(formica.ScenarioError, match="nowhere.toml"):
        formica.sweep(sweep, db=tmp_path / "bad.db")


def test_a_per_robot_controller_sees_its_row_of_the_readings():
    seen = {}

    class Recorder:
        def __init__(self, layout):
            assert layout.size == 24 and layout.names[16] == "x" and layout.slots["light"] == (8, 8)
            assert len(layout.proximity_angles) == 8 and layout.max_speed == pytest.approx(0.8)

        def step(self, r):
            x, y, theta = r.pose
            assert (x, y) == (r.x, r.y) and r["theta"] == theta and len(r) == 24
            assert len(r.proximity) == 8 and r.beacon == (r.beacon_x, r.beacon_y)
            assert r.attached is False
            with pytest.raises(AttributeError, match="`camera` is not read"):
                r.blobs  # the camera is not among the default needs
            seen[round(r.time_s, 3), x] = r.vector
            return 0.05, 0.05

    formica.register_controller("py-recorder", Recorder)
    w = formica.World(scenario("py-recorder", count=3), seed=1)
    w.step(4)
    rows = w.readings()
    for row in rows:
        np.testing.assert_array_equal(seen[round(float(row[23]), 3), float(row[16])], row)


def test_a_per_robot_controller_can_switch_its_motors_off():
    # Driven at 0.2 m/s for 1 s, then "coast" with the wheels still commanded at 0.3 m/s: the
    # speeds are ignored and the robot rolls to a stop against its rolling resistance
    # (0.15 N on 0.4 kg: 0.375 m/s^2, about 5 cm), where driving on would go 0.6 m in 2 s.
    class Coaster:
        def __init__(self, layout):
            pass

        def step(self, r):
            if r.time_s < 1.0:
                return 0.2, 0.2
            return 0.3, 0.3, None, None, True

    formica.register_controller("py-coaster", Coaster)
    world = formica.World(scenario("py-coaster", count=1), seed=1)
    world.step(11)
    start = world.robot_poses[0, :2].copy()
    world.step(20)
    travel = float(np.linalg.norm(world.robot_poses[0, :2] - start))
    assert 0.02 < travel < 0.1, travel

    class BadCoast:
        def __init__(self, layout):
            pass

        def step(self, r):
            return 0.1, 0.1, None, None, "yes"

    formica.register_controller("py-badcoast", BadCoast)
    with pytest.raises(TypeError, match="py-badcoast.*coast"):
        formica.World(scenario("py-badcoast", count=1)).step(2)


def test_the_layout_gives_the_radius_of_the_object_the_beacon_tracks():
    seen = []

    class Sizer:
        needs = ()

        def __init__(self, layout):
            seen.append(layout.beacon_radius)

        def step(self, r):
            return 0.0, 0.0

    formica.register_controller("py-sizer", Sizer)
    formica.World(scenario("py-sizer", count=2), seed=1, duration=1).step(1)
    # The seed's 0.5 m box: half its diagonal.
    assert len(seen) >= 2 and all(abs(s - 0.5 * 2**0.5 / 2) < 1e-3 for s in seen)


def test_the_layout_reads_a_proximity_value_through_the_models_curve():
    seen = []

    class Reader:
        needs = ()

        def __init__(self, layout):
            seen.append([layout.proximity_distance(v) for v in (0.0, 0.2, 0.5, 1.0)] + [layout.proximity_range])

        def step(self, r):
            return 0.0, 0.0

    formica.register_controller("py-reader", Reader)
    per_model = []
    for model in ("khepera4", "foot-bot", "e-puck"):
        sc = scenario("py-reader", count=1).set("robots.0.model", model)
        formica.World(sc, seed=1, duration=1).step(1)
        per_model.append(seen[-1])

    # Each model's curve inverted (crates/formica-core/src/robot.rs): nothing reads the range,
    # saturation 0, and the readings between give the distances that produce them.
    kh, fb, ep = per_model
    assert kh[0] == kh[4] and abs(kh[4] - 0.12) < 1e-6 and kh[3] == 0.0
    assert abs(kh[1] - (-math.log((0.2 + 0.085) / 4.14) / 33.0)) < 1e-5
    assert abs(fb[1] - (0.0100527 / 0.2 - 0.000163144)) < 1e-5 and abs(fb[2] - (0.0100527 / 0.5 - 0.000163144)) < 1e-5
    assert abs(ep[2] - 0.5 * 0.05) < 1e-6


class LateState:
    """Names its state only once it steps."""

    def __init__(self, layout):
        self.layout = layout

    def step(self, r):
        self.state = "late" if r.time_s > 0.15 else "early"
        return 0.0, 0.0


formica.register_controller("py-late-state", LateState)


def test_a_state_first_set_in_step_is_shown():
    w = formica.World(scenario("py-late-state", count=3))
    w.step(1)
    assert w.states == ["early"] * 3
    w.step(2)
    assert w.states == ["late"] * 3


class Wordy:
    """Returns its wheel speeds as strings."""

    def __init__(self, layout):
        pass

    def step(self, r):
        return "1", "2"


formica.register_controller("py-wordy", Wordy)


def test_wheel_speeds_that_are_not_numbers_name_the_controller():
    w = formica.World(scenario("py-wordy", count=2))
    with pytest.raises(TypeError, match="py-wordy.*left wheel speed must be a number .*got str"):
        w.step(1)


@formica.register_batched("py-bad-led")
def bad_led(readings):
    return np.zeros((len(readings), 2)), np.full(len(readings), 99)


def test_a_batched_controllers_bad_code_names_it_and_the_row():
    with pytest.raises(ValueError, match="py-bad-led.*row 0: LED code 99 is not a colour"):
        formica.World(scenario("py-bad-led", count=2)).step(2)


class Seer:
    """Stands still and keeps what its colour scan shows; reads only the scan."""

    needs = ("scan",)
    seen = []

    def __init__(self, layout):
        self.layout = layout

    def step(self, r):
        Seer.seen.append((r.pose, r.scan))
        with pytest.raises(AttributeError, match="`light` is not read: this controller's needs leave it out"):
            r.light
        with pytest.raises(AttributeError, match="`beacon` is not read"):
            r.beacon
        with pytest.raises(AttributeError, match="`camera` is not read"):
            r.blobs
        return 0.0, 0.0


formica.register_controller("py-seer", Seer)


def test_a_python_controller_reads_the_colour_scan_and_only_the_sensors_it_needs():
    # One robot 0.6 m west of the box's centre, facing it (east), no noise: the bins ahead meet
    # the box's west face 0.35 m away (in 0.02 m steps) and show its colour; the bin behind
    # meets nothing within the scan's 1 m.
    Seer.seen.clear()
    sc = (
        scenario("py-seer", count=1)
        .set("robots.0.placement", {"poses": [[-1.6, 0.0, 0.0]]})
        .set("robots.0.sensors.noise", "none")
    )
    w = formica.World(sc, seed=2, duration=0.3)
    w.run()
    assert Seer.seen
    _, scan = Seer.seen[-1]
    assert len(scan) == 36
    assert scan[0][0] == "green" and abs(scan[0][1] - 0.35) <= 0.011, scan[0]
    assert scan[18] == ("off", 1.0), scan[18]
    # The box's face spans about +-35 degrees from here: bins 0, 1, 2, 3 and 33, 34, 35 see it.
    green = [i for i, (c, _) in enumerate(scan) if c == "green"]
    assert set(green) == {0, 1, 2, 3, 33, 34, 35}, green


def test_a_batched_controller_may_not_ask_for_what_its_array_cannot_hold():
    for sensor in ("camera", "scan"):
        with pytest.raises(ValueError, match=f"a batched controller reads the readings array, which has no `{sensor}`"):
            formica.register_batched(f"py-bad-{sensor}", lambda readings: readings[:, :2] * 0, needs=(sensor,))
