#!/usr/bin/env python3
"""Prints the `fill-transport` tables of docs/src/results/obstacles.md from the full design's store.

    formica merge qmo-full.db qmo-n5-15.db qmo-n20.db qmo-n30.db qmo-n30-chen.db \
        qmo-n5-15-ft.db qmo-n20-ft.db qmo-n30-ft.db \
        --sweep experiments/queiroz-macrae-obstacles.toml --allow-mixed
    python3 experiments/obstacle-tables.py qmo-full.db

or from slice stores before they are merged (their trials together; a cell no store has
reads "?"):

    python3 experiments/obstacle-tables.py qmo-n5-15-ft.db qmo-n20-ft.db qmo-n30-ft.db

Standard library only. A cell is the successes of the 350 trials (7 shapes x 50 seeds) and,
in brackets, the time by which half of them had arrived: the ceil(n/2)-th arrival, none if
fewer than half did. For an even count this is the lower of the two middle times, where
`formica report`'s censored median takes their mean (and needs more than half to arrive), so
the report's medians of the same trials can be 1 to 5 s higher.
"""
import sqlite3
import sys

MAPS = ["qm-open", "qm-middle", "qm-corner", "qm-two-corners", "offset-gap", "obstacle-wall"]
SIZES = [5, 10, 15, 20, 30]
FT, OCC, CHEN = "fill-transport with relays", "occlusion with relays", "Chen's rule alone"


def load(dbs):
    out = {}
    q = 'SELECT label, scenario, robots, "objects.0.shape", outcome, sim_time_s, path_efficiency FROM trials'
    for db in dbs:
        for label, scen, n, shape, outcome, t, eff in sqlite3.connect(db).execute(q):
            m = scen.rsplit("/", 1)[-1].removesuffix(".toml")
            out.setdefault((label, m, n), []).append(("polygon" in shape, outcome == "success", t, eff))
    return out


def cell(trials, median=True):
    if not trials:
        return "?"
    times = sorted(x[2] for x in trials if x[1])
    half = (len(trials) + 1) // 2
    if median and len(times) >= half:
        return f"{len(times)} ({times[half - 1]:.0f} s)"
    return str(len(times))


def main():
    d = load(sys.argv[1:] or ["qmo-full.db"])
    print("## fill-transport with relays against occlusion with relays, N = 20\n")
    print("| map | fill-transport | concave | convex | occlusion | concave | convex |")
    print("|---|---|---|---|---|---|---|")
    for m in MAPS:
        row = []
        for label in (FT, OCC):
            t = d.get((label, m, 20), [])
            row += [cell(t), cell([x for x in t if x[0]], False), cell([x for x in t if not x[0]], False)]
        print(f"| {m} | " + " | ".join(row) + " |")
    print("\n## against swarm size\n")
    head = [f"fill-transport, N = {SIZES[0]}"] + [str(n) for n in SIZES[1:]]
    head += [f"occlusion, N = {SIZES[0]}"] + [str(n) for n in SIZES[1:]]
    print("| map | " + " | ".join(head) + " |")
    print("|---" * (1 + len(head)) + "|")
    for m in MAPS:
        cells = [cell(d.get((label, m, n), [])) for label in (FT, OCC) for n in SIZES]
        print(f"| {m} | " + " | ".join(cells) + " |")
    print("\n## totals over the six maps (of 2100)\n")
    for label in (FT, OCC, CHEN):
        tot = [sum(x[1] for m in MAPS for x in d.get((label, m, n), [])) for n in SIZES]
        print(f"- {label}: " + " / ".join(map(str, tot)) + f" at N = {' / '.join(map(str, SIZES))}")
    print("\n## success over every N, and path efficiency (successful trials, mean), by map\n")
    print("| map | " + " | ".join(f"{l} | efficiency" for l in (CHEN, OCC, FT)) + " |")
    print("|---" * 7 + "|")
    for m in MAPS:
        cells = []
        for label in (CHEN, OCC, FT):
            t = [x for n in SIZES for x in d.get((label, m, n), [])]
            effs = [x[3] for x in t if x[1] and x[3] is not None]
            cells.append(f"{sum(x[1] for x in t)} of {len(t)}")
            cells.append(f"{sum(effs) / len(effs):.2f}" if effs else "–")
        print(f"| {m} | " + " | ".join(cells) + " |")
    print("\n## concave (plus, H, L) and convex objects on qm-open, fill-transport\n")
    for n in SIZES:
        t = d.get((FT, "qm-open", n), [])
        print(f"- N = {n}: concave {cell([x for x in t if x[0]], False)} of 150, "
              f"convex {cell([x for x in t if not x[0]], False)} of 200")


if __name__ == "__main__":
    main()
