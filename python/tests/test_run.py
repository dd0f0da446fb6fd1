"""formica.run gives the JSON lines of `formica run --json` for the same seeds."""

import json
import subprocess

import pandas as pd
import pytest

import formica
from conftest import ROOT, SEED_TRANSPORT


def cli_lines(formica_bin, *args):
    out = subprocess.run([formica_bin, "run", *args, "--json"], check=True, capture_output=True, text=True)
    return [json.loads(line) for line in out.stdout.splitlines() if line.strip()]


def without_wall_time(rows):
    return [{k: v for k, v in r.items() if k != "wall_time_s"} for r in rows]


def test_run_equals_the_cli_json_for_the_same_seeds(formica_bin):
    # The CLI prints one line per seed, then a summary line.
    lines = cli_lines(
        formica_bin, SEED_TRANSPORT, "--seeds", "1..4", "--set", "robots.0.count=10", "--duration", "120"
    )
    cli, summary = lines[:-1], lines[-1]
    assert summary["trials"] == 4
    sc = formica.load(SEED_TRANSPORT).set("robots.0.count", 10)
    rows = formica.run(sc, seeds=range(1, 5), duration=120, as_frame=False)
    assert [r["seed"] for r in rows] == [1, 2, 3, 4]
    assert without_wall_time(rows) == without_wall_time(cli)
    # The same keys in the same order as the JSON line.
    assert [list(r) for r in rows] == [list(r) for r in cli]


def test_one_seed_and_the_controller_override_equal_the_cli(formica_bin):
    cli = cli_lines(formica_bin, SEED_TRANSPORT, "--seed", "7", "--duration", "30", "--controller", "random-walk")
    rows = formica.run(SEED_TRANSPORT, seeds=7, duration=30, controller="random-walk", as_frame=False)
    assert without_wall_time(rows) == without_wall_time(cli)


def test_a_dataframe_when_pandas_is_installed():
    df = formica.run(SEED_TRANSPORT, seeds=[1, 2], duration=20)
    assert isinstance(df, pd.DataFrame)
    assert list(df["seed"]) == [1, 2]
    assert {"outcome", "sim_time_s", "goal_distance_m", "controller"} <= set(df.columns)
    rows = formica.run(SEED_TRANSPORT, seeds=[1, 2], duration=20, as_frame=False)
    assert without_wall_time(df.to_dict("records")) == without_wall_time(rows)


def test_results_do_not_depend_on_threads():
    one = formica.run(SEED_TRANSPORT, seeds=range(1, 5), duration=30, threads=1, as_frame=False)
    two = formica.run(SEED_TRANSPORT, seeds=range(1, 5), duration=30, threads=2, as_frame=False)
    assert without_wall_time(one) == without_wall_time(two)


def test_default_seed_is_the_files():
    rows = formica.run(SEED_TRANSPORT, duration=10, as_frame=False)
    assert [r["seed"] for r in rows] == [formica.load(SEED_TRANSPORT).seed]


def test_bad_arguments_are_value_errors():
    with pytest.raises(ValueError, match="duration"):
        formica.run(SEED_TRANSPORT, seeds=1, duration=float("nan"))
    with pytest.raises(ValueError, match="unknown controller `nope`"):
        formica.run(SEED_TRANSPORT, seeds=1, controller="nope")
    with pytest.raises(ValueError, match="non-negative"):
        formica.run(SEED_TRANSPORT, seeds=[-1])


def test_ctrl_c_stops_a_sweep_between_trials_and_keeps_what_it_ran(tmp_path):
    # A notebook's interrupt (SIGINT) used to wait for the whole sweep: 40 trials of 900 s
    # ran to the end before KeyboardInterrupt came. Now no new trial starts, those finished
    # stay in the store, and running the sweep again resumes.
    import signal
    import sqlite3
    import subprocess
    import sys
    import time

    study = tmp_path / "long.toml"
    study.write_text(
        f'scenario = "{ROOT / "scenarios/seed-transport.toml"}"\nseeds = "1..40"\n'
        "duration_s = 900\n[set]\n\"stop.on_goal\" = false\n\"stop.on_wall\" = false\n"
    )
    db = tmp_path / "long.db"
    code = (
        "import formica, sys\n"
        "try:\n"
        f"    formica.sweep({str(study)!r}, db={str(db)!r}, threads=1)\n"
        "except KeyboardInterrupt:\n"
        "    sys.exit(42)\n"
    )
    child = subprocess.Popen([sys.executable, "-c", code], stderr=subprocess.PIPE, text=True)
    # Wait for the first stored trial, then interrupt.
    deadline = time.time() + 120
    def stored():
        try:
            with sqlite3.connect(db) as c:
                return c.execute("SELECT COUNT(*) FROM trials").fetchone()[0]
        except sqlite3.Error:
            return 0
    while stored() == 0 and time.time() < deadline and child.poll() is None:
        time.sleep(0.1)
    child.send_signal(signal.SIGINT)
    _, err = child.communicate(timeout=120)
    assert child.returncode == 42, err
    kept = stored()
    assert 1 <= kept < 40, kept
    assert "interrupted after" in err, err
