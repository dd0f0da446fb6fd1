"""examples/python: the Python port of `occlusion` runs seed-transport deterministically."""

import importlib.util
import subprocess
import sys

import formica
from conftest import ROOT, SEED_TRANSPORT


def load_port():
    spec = importlib.util.spec_from_file_location("occlusion_port", ROOT / "examples/python/occlusion.py")
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    return mod


def test_the_occlusion_port_transports_the_box_deterministically():
    port = load_port()
    assert port.light_bearing([0.0, 0.5, 0.5, 0.0], [0.0, 1.0, 2.0, 3.0]) == 1.5
    sc = formica.load(SEED_TRANSPORT)
    first = formica.run(sc, seeds=[1, 2], controller="py-occlusion", as_frame=False)
    again = formica.run(sc, seeds=[1, 2], controller="py-occlusion", as_frame=False)
    strip = lambda rows: [{k: v for k, v in r.items() if k != "wall_time_s"} for r in rows]  # noqa: E731
    assert strip(first) == strip(again)
    assert [r["outcome"] for r in first] == ["success", "success"]
    assert all(r["controller"] == "py-occlusion" for r in first)


def test_the_readme_example_runs():
    code = (
        "import formica\n"
        'sc = formica.load("scenarios/seed-transport.toml").set("robots.0.count", 30)\n'
        "runs = formica.run(sc, seeds=range(1, 4), duration=60)\n"
        "world = formica.World(sc, seed=1); world.step(100)\n"
        "print(runs.outcome.tolist(), world.robot_poses.shape, world.readings().shape)\n"
    )
    out = subprocess.run([sys.executable, "-c", code], cwd=ROOT, check=True, capture_output=True, text=True)
    assert out.stdout.strip().endswith("(30, 3) (30, 24)")


def test_the_random_studies_are_what_their_script_draws():
    # experiments/random.toml is written by experiments/random-cases.py (seed 7), and
    # random-seed8.toml to random-seed13.toml by `random-cases.py 8` to `13`, and the third
    # draw with other robot models by `random-cases.py 9 e-puck` and `9 foot-bot`: the committed
    # cases must be the script's, so that anyone can see how they were drawn and draw more.
    draws = (
        ([], "random.toml"),
        (["8"], "random-seed8.toml"),
        (["9"], "random-seed9.toml"),
        (["10"], "random-seed10.toml"),
        (["11"], "random-seed11.toml"),
        (["12"], "random-seed12.toml"),
        (["13"], "random-seed13.toml"),
        (["9", "e-puck"], "random-seed9-e-puck.toml"),
        (["9", "foot-bot"], "random-seed9-foot-bot.toml"),
    )
    for args, name in draws:
        out = subprocess.run(
            [sys.executable, "experiments/random-cases.py", *args],
            cwd=ROOT,
            check=True,
            capture_output=True,
            text=True,
        )
        assert out.stdout == (ROOT / "experiments" / name).read_text()


def test_the_near_wall_random_study_is_what_its_script_writes():
    # experiments/near-wall-random.toml is written by experiments/near-wall-random-cases.py from
    # the six draws' files: a draw changed without writing it again would leave the study
    # running shapes the draws no longer have.
    out = subprocess.run(
        [sys.executable, "experiments/near-wall-random-cases.py"],
        cwd=ROOT,
        check=True,
        capture_output=True,
        text=True,
    )
    assert out.stdout == (ROOT / "experiments" / "near-wall-random.toml").read_text()
    assert out.stdout.count("[[cases]]") == 6 * 12 * (4 + 2)


def test_the_stall_study_runs_the_draws_stars_as_drawn():
    # experiments/fill-transport-stall.toml copies every 3-point star of the random draws with
    # its placement and goal: each copy must be the draw's `fill-transport` case, key for key.
    import tomllib

    exp = ROOT / "experiments"
    files = {"7": "random.toml", "8": "random-seed8.toml", "10": "random-seed10.toml", "11": "random-seed11.toml"}
    study = tomllib.loads((exp / "fill-transport-stall.toml").read_text())
    stars = [c for c in study["cases"] if c["label"].startswith("draw seed ")]
    assert len(stars) == 8
    for case in stars:
        head, shape = case["label"].split(", ", 1)
        draw = tomllib.loads((exp / files[head.removeprefix("draw seed ")]).read_text())
        label = shape.replace(": 3-point star", ": 3-point star, fill-transport")
        (original,) = [c for c in draw["cases"] if c["label"] == label]
        strip = lambda c: {k: v for k, v in c.items() if k != "label"}  # noqa: E731
        assert strip(case) == strip(original), case["label"]
