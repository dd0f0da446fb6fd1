"""Formica from Python: the swarm-transport simulator's runs, sweeps and worlds.

>>> import formica
>>> sc = formica.load("scenarios/seed-transport.toml").set("robots.0.count", 30)
>>> runs = formica.run(sc, seeds=range(1, 11))          # DataFrame (list of dicts without pandas)
>>> world = formica.World(sc, seed=1); world.step(100)
>>> world.robot_poses.shape, world.readings().shape    # (30, 3), (30, 24)

- ``load(path)`` / ``parse(text)`` give a :class:`Scenario`; ``Scenario.set(key, value)``
  takes the keys of ``formica run --set`` and sweep files.
- ``run(scenario, seeds)`` gives the JSON lines of ``formica run --json`` as dicts (a pandas
  DataFrame when pandas is installed); ``sweep(path, db=...)`` runs a sweep file into a result
  store and ``read_store(db)`` reads one back.
- :class:`World` steps one world and hands out numpy arrays; :class:`Worlds` steps many.
- ``register_controller`` (a class, one instance per robot) and ``register_batched`` (one
  function over all robots' readings) add Python controllers that scenario files can name.
- ``formica.env`` has the PettingZoo, Gymnasium and vectorised environments.

Units everywhere: metres, radians (counter-clockwise, world frame), seconds, m/s.
"""

from __future__ import annotations

import functools
import inspect
import json
import os
import sqlite3
from typing import Any, Callable, Iterable, Optional, Sequence, Union

from . import _formica
from ._formica import (
    COLORS,
    Batch,
    Layout,
    PanicError,
    Readings,
    Rng,
    Rngs,
    Scenario,
    ScenarioError,
    World,
    Worlds,
    bench_scenario,
    load,
    parse,
)

__version__ = "0.1.0"

__all__ = [
    "COLORS",
    "Batch",
    "Layout",
    "PanicError",
    "Readings",
    "Rng",
    "Rngs",
    "Scenario",
    "ScenarioError",
    "World",
    "Worlds",
    "bench_scenario",
    "cli",
    "controllers",
    "load",
    "parse",
    "read_store",
    "register_batched",
    "register_controller",
    "run",
    "sweep",
]

#: Sensors a Python controller reads unless it says otherwise (``needs=``): the camera is
#: left out, being the dearest to compute.
DEFAULT_NEEDS = ("proximity", "light", "beacon")

PathLike = Union[str, "os.PathLike[str]"]


def _pandas():
    try:
        import pandas  # noqa: PLC0415

        return pandas
    except ImportError:
        return None


def _frame(rows: list, as_frame: Optional[bool]):
    pd = _pandas()
    if as_frame is None:
        as_frame = pd is not None
    if not as_frame:
        return rows
    if pd is None:
        raise ImportError("as_frame=True needs pandas: pip install pandas")
    return pd.DataFrame(rows)


def _as_scenario(scenario: Union[Scenario, PathLike]) -> Scenario:
    return scenario if isinstance(scenario, Scenario) else load(scenario)


def _seed_list(seeds, scenario: Scenario) -> list:
    if seeds is None:
        return [scenario.seed]
    if isinstance(seeds, int) or hasattr(seeds, "__index__") and not hasattr(seeds, "__iter__"):
        seeds = [seeds]
    if not hasattr(seeds, "__iter__"):
        raise TypeError(f"seeds: expected a seed or an iterable of seeds, got {seeds!r}")
    most = _formica._MAX_RUN_SEEDS
    too_many = "seeds: at most {} seeds a call, got {} (as `formica run --seeds`; formica.sweep stores each trial as it ends and takes more)"
    try:
        n = len(seeds) if hasattr(seeds, "__len__") else 0
    except OverflowError:  # range(10**20)
        raise ValueError(too_many.format(most, "more")) from None
    if n > most:
        raise ValueError(too_many.format(most, n))
    out = []
    for s in seeds:
        if len(out) == most:
            raise ValueError(too_many.format(most, "more"))
        if isinstance(s, bool) or not isinstance(s, int) and not hasattr(s, "__index__"):
            raise TypeError(f"seeds: expected integers, got {s!r}")
        s = int(s)
        if s < 0:
            raise ValueError(f"seeds: expected non-negative integers, got {s}")
        out.append(s)
    return out


def _count(name: str, value, least: int) -> int:
    """``value`` as a whole number of at least ``least``, or a clear error naming ``name``."""
    if isinstance(value, bool) or not hasattr(value, "__index__"):
        raise TypeError(f"{name}: expected a whole number, got {value!r}")
    value = int(value)
    if value < least:
        raise ValueError(f"{name}: expected at least {least}, got {value}")
    return value


def run(
    scenario: Union[Scenario, PathLike],
    seeds: Union[int, Iterable[int], None] = None,
    threads: Optional[int] = None,
    *,
    duration: Optional[float] = None,
    controller: Optional[str] = None,
    as_frame: Optional[bool] = None,
):
    """Runs ``scenario`` once per seed (default: the file's ``run.seed``).

    Returns one result per seed, in order: the JSON lines ``formica run --json --seeds``
    prints (same fields, same values but ``wall_time_s``), as a pandas DataFrame when pandas is
    installed, else as a list of dicts (``as_frame`` forces either). ``threads``: worker
    threads, default every core; scenarios with Python controllers run on the calling thread
    unless ``threads`` says otherwise. ``duration`` (s) and ``controller`` override the file,
    as ``--duration`` and ``--controller`` do.
    """
    sc = _as_scenario(scenario)
    rows = _formica.run_seeds(sc, _seed_list(seeds, sc), threads, duration, controller)
    return _frame(rows, as_frame)


def sweep(
    path: PathLike,
    db: Optional[PathLike] = None,
    *,
    threads: Optional[int] = None,
    shard: Optional[str] = None,
    limit: Optional[int] = None,
    trajectories: bool = False,
    progress: bool = False,
    as_frame: Optional[bool] = None,
):
    """Runs the sweep file ``path`` into the result store ``db`` (default: the sweep file
    with ``.db``), exactly as ``formica sweep`` does (resumable: trials already stored are
    skipped), with Python controllers available to it. Returns the store's trials, as
    :func:`read_store` does. ``shard`` is ``"K/N"``; ``limit`` caps the trials run.
    """
    args = ["sweep", os.fspath(path)]
    if db is not None:
        args += ["--db", os.fspath(db)]
    if threads is not None:
        args += ["--threads", str(_count("threads", threads, 1))]
    if shard is not None:
        args += ["--shard", str(shard)]
    if limit is not None:
        args += ["--limit", str(_count("limit", limit, 0))]
    if trajectories:
        args.append("--trajectories")
    if not progress:
        args.append("--quiet")
    _formica.command(args)
    store = db if db is not None else os.path.splitext(os.fspath(path))[0] + ".db"
    return read_store(store, as_frame=as_frame)


def read_store(db: PathLike, *, trajectories: bool = False, as_frame: Optional[bool] = None):
    """Reads a result store (SQLite, written by ``formica sweep`` / ``merge`` or
    :func:`sweep`): one row per trial with columns ``trial``, ``params`` (JSON), ``seed``, one
    per varied key, every metric of the JSON line (``scenario_name`` for ``scenario``) and every
    end-of-run field of loop functions; ordered by trial and seed.

    With ``trajectories=True`` returns ``(trials, samples)``, ``samples`` having one row per
    stored object sample: ``params``, ``seed``, ``t`` (s), ``x``, ``y`` (m), ``theta`` (rad).
    """
    path = os.fspath(db)
    if not os.path.exists(path):
        raise FileNotFoundError(f"{path}: no such result store")
    con = sqlite3.connect(f"file:{path}?mode=ro", uri=True)
    try:
        try:
            cur = con.execute("SELECT * FROM trials ORDER BY trial, seed")
        except sqlite3.DatabaseError as e:
            # A scenario or sweep file, or an SQLite file of something else.
            raise ValueError(
                f"{path}: not a result store ({e}); a store is the SQLite file that "
                "`formica sweep` or formica.sweep writes (its --db / db=)"
            ) from e
        cols = [c[0] for c in cur.description]
        rows = [dict(zip(cols, r)) for r in cur.fetchall()]
        if not trajectories:
            return _frame(rows, as_frame)
        samples = []
        for params, seed, text in con.execute(
            "SELECT params, seed, samples FROM trajectories ORDER BY params, seed"
        ):
            for t, x, y, theta in json.loads(text):
                samples.append(
                    {"params": params, "seed": seed, "t": t, "x": x, "y": y, "theta": theta}
                )
        return _frame(rows, as_frame), _frame(samples, as_frame)
    finally:
        con.close()


def cli(*args: Union[str, "os.PathLike[str]"]) -> None:
    """Runs a ``formica`` subcommand in this process, with the controllers registered from
    Python available to it: ``formica.cli("check", "my.toml")``, ``formica.cli("record",
    "my.toml", "--out", "run.gif")``, ``formica.cli("report", "study.db", "--out", "report")``.
    Output goes to this process's stdout and stderr; bad input raises :class:`ScenarioError`,
    other failures ``RuntimeError``. (``serve`` runs until the process is killed: Ctrl-C is not
    seen while it runs.)
    """
    _formica.command([os.fspath(a) for a in args])


def controllers() -> list:
    """Every controller name scenarios can use: the built-ins, ``external`` (driven from
    Python by ``World.set_actions``) and those registered from Python."""
    return _formica.controller_names()


# The controllers Formica comes with (`external` included), as registered at import: a
# Python controller may not take one's name, since every scenario and environment that uses
# it would silently run the replacement.
_BUILTIN_CONTROLLERS = frozenset(_formica.controller_names())


def _check_name(name: str) -> None:
    if name in _BUILTIN_CONTROLLERS:
        raise ValueError(
            f"{name!r} is a built-in controller; register yours under another name "
            f"(built in: {', '.join(sorted(_BUILTIN_CONTROLLERS))})"
        )


def _needs(needs, obj) -> list:
    if needs is None:
        needs = getattr(obj, "needs", DEFAULT_NEEDS)
    if isinstance(needs, str):
        needs = [needs]
    return [str(n) for n in needs]


def register_controller(name: str, cls: Optional[type] = None, *, needs: Optional[Sequence[str]] = None):
    """Registers a per-robot Python controller class under ``name``, for scenario files
    (``controller = "name"``) run through Python: ``run``, ``sweep``, ``World``.

    Each robot gets ``cls(layout, **params)`` (``layout``: a :class:`Layout`; ``params``: the
    group's ``params`` table); one more instance is made, and dropped, as each world is built,
    to check the parameters where the scenario is checked, so keep ``__init__`` free of side
    effects that count robots. Before its first step the instance gets ``self.rng``, the
    robot's own :class:`Rng` (draw only from it and runs stay deterministic per seed). Every
    tick ``step(readings)`` gets a :class:`Readings` and returns ``(left, right)`` wheel speeds
    (m/s), optionally followed by an LED colour (a name from ``COLORS``, a code, or None) and an
    attach command (None / ``"keep"``, ``True`` / ``"attach"``, ``False`` / ``"detach"``), and
    ``coast`` (``True``: motors off, the wheel speeds ignored; the wheels roll along the heading
    and skid sideways). A
    ``state`` str attribute, if the instance has one (set in ``__init__`` or any later
    ``step``), is its state name after each step (a process keeps the first 4,096 distinct
    names; later new ones read ``"other"``; a value that is not a str is not a state name). ``needs`` (or a class
    attribute ``needs``) lists the sensors it reads, from ``proximity``, ``light``, ``beacon``,
    ``camera`` (``readings.blobs``) and ``scan`` (the colour scan, ``readings.scan``); default:
    ``proximity``, ``light`` and ``beacon``. A sensor left out is not computed, and reading it
    raises ``AttributeError``.

    Registering a name again replaces what it named (as re-running a notebook cell does);
    a built-in's name is refused. Usable as a decorator:
    ``@formica.register_controller("mine")``.
    """
    if cls is None:
        return functools.partial(register_controller, name, needs=needs)
    _check_name(name)
    if not callable(getattr(cls, "step", None)):
        raise TypeError(f"{cls!r}: a controller class needs a step(readings) method")
    _formica.register_robot(name, cls, _needs(needs, cls))
    return cls


def _positional(fn: Callable, skip: int = 0) -> int:
    """How many positional parameters without defaults ``fn`` takes (a ``*args``: many)."""
    try:
        params = list(inspect.signature(fn).parameters.values())[skip:]
    except (TypeError, ValueError):
        return 1
    n = 0
    for p in params:
        if p.kind is p.VAR_POSITIONAL:
            return 99
        if p.kind in (p.POSITIONAL_ONLY, p.POSITIONAL_OR_KEYWORD) and p.default is p.empty:
            n += 1
    return n


def register_batched(name: str, fn: Optional[Callable] = None, *, needs: Optional[Sequence[str]] = None):
    """Registers a batched Python controller under ``name``: one call per robot group and
    tick decides for all the group's released robots at once.

    ``fn(readings)`` gets a float32 array ``[N, L]`` (one row per released robot, in world
    order; columns named by ``Layout.names``) and returns wheel speeds ``[N, 2]`` (m/s), or a
    tuple ``(wheels, leds, attach)`` with LED codes ``[N]`` and attach codes ``[N]`` (-1, 0, 1),
    either of them None. LEDs left out (None, or wheels alone) keep each robot's last colour
    (``World.set_actions`` without ``leds`` turns them off; so does a per-robot controller that
    leaves its LED out). A function with a second positional parameter also gets a
    :class:`Batch`: the rows' robot indices, their own generators (``batch.rng``), the layout
    and the time. The group's ``params`` come as keyword arguments. A class instead of a
    function is made once per group and world as ``cls(layout, **params)``, and its
    ``step(readings[, batch])`` is called every tick. ``needs`` as in
    :func:`register_controller`. Usable as a decorator.
    """
    if fn is None:
        return functools.partial(register_batched, name, needs=needs)
    _check_name(name)
    if inspect.isclass(fn):
        step = getattr(fn, "step", None)
        if not callable(step):
            raise TypeError(f"{fn!r}: a batched controller class needs a step(readings) method")
        takes_batch = _positional(step, skip=1) >= 2

        def maker(layout, params, _cls=fn):
            return _cls(layout, **params).step

    else:
        if not callable(fn):
            raise TypeError(f"{fn!r} is not callable")
        takes_batch = _positional(fn) >= 2

        def maker(layout, params, _fn=fn):
            return functools.partial(_fn, **params) if params else _fn

    _formica.register_batch(name, maker, _needs(needs, fn), takes_batch)
    return fn
