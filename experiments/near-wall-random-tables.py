#!/usr/bin/env python3
"""Tables of experiments/near-wall-random.toml: successes and median times by draw and option.

    python3 experiments/near-wall-random-tables.py results/near-wall-random/trials.csv

Reads the trials as `formica report` (or `formica export`) writes them; standard library only.
Prints, for `occlusion` (defaults, `balance_turn` alone, `squeeze_s` alone, both) and
`fill-transport` (defaults, both for its pushers), the successes of each draw, of the first five
(on which the options were first measured) and of all six, with the median time of the
successes, then the shapes whose successes differ between options.
"""
import csv
import statistics
import sys
from collections import defaultdict

DRAWS = ["random", "random-seed8", "random-seed9", "random-seed10", "random-seed11", "random-seed12"]
OPTIONS = ["default", "balance", "squeeze", "both"]


def split(label):
    for option in OPTIONS[1:]:
        if label.endswith(", " + option):
            return label[: -len(option) - 2], option
    return label, "default"


def main(path):
    total = defaultdict(lambda: [0, 0, []])
    shape = defaultdict(lambda: [0, 0])
    with open(path, newline="") as f:
        for row in csv.DictReader(f):
            base, option = split(row["label"])
            controller = base.rsplit(", ", 1)[1]
            draw = base.split(" shape ")[0]
            ok = row["outcome"] == "success"
            keys = [(controller, option, draw), (controller, option, "all")]
            if draw != DRAWS[-1]:
                keys.append((controller, option, "first five"))
            for key in keys:
                t = total[key]
                t[0] += ok
                t[1] += 1
                if ok:
                    t[2].append(float(row["sim_time_s"]))
            shape[(base, option)][0] += ok
            shape[(base, option)][1] += 1
    print("| controller | option | " + " | ".join(DRAWS) + " | first five | all six |")
    print("|---" * (len(DRAWS) + 4) + "|")
    for controller in ("occlusion", "fill-transport"):
        for option in OPTIONS:
            if (controller, option, "all") not in total:
                continue
            cells = []
            for draw in DRAWS + ["first five", "all"]:
                ok, n, times = total[(controller, option, draw)]
                median = f"{statistics.median(times):.1f} s" if times else "-"
                cells.append(f"{ok} / {n} ({median})")
            print(f"| `{controller}` | {option} | " + " | ".join(cells) + " |")
    print()
    print("Shapes whose successes differ between options (of 10 seeds):")
    for base in sorted({b for b, _ in shape}):
        counts = {o: shape[(base, o)][0] for o in OPTIONS if (base, o) in shape}
        if len(set(counts.values())) > 1:
            print(f"- {base}: " + ", ".join(f"{o} {c}" for o, c in counts.items()))


if __name__ == "__main__":
    main(sys.argv[1] if len(sys.argv) > 1 else "results/near-wall-random/trials.csv")
