#!/usr/bin/env python3
"""Tables of experiments/near-wall-random.toml: successes and median times by draw and option.

    python3 experiments/near-wall-random-tables.py results/near-wall-random/trials.csv

Reads the trials as `formica report` (or `formica export`) writes them; standard library only.
Prints, for `occlusion` (defaults, `balance_turn` alone, `squeeze_s` alone, both) and
`fill-transport` (defaults, both for its pushers), the successes of each draw (in the order the
trials list them, as near-wall-random-cases.py writes them), of all draws but the last (the
first five, on which the options were first measured) and of all, with the median time of the
successes, then the shapes whose successes differ between options.
"""
import csv
import statistics
import sys
from collections import defaultdict

OPTIONS = ["default", "balance", "squeeze", "both"]


def split(label):
    for option in OPTIONS[1:]:
        if label.endswith(", " + option):
            return label[: -len(option) - 2], option
    return label, "default"


def main(path):
    with open(path, newline="") as f:
        rows = list(csv.DictReader(f))
    draws = list(dict.fromkeys(split(row["label"])[0].split(" shape ")[0] for row in rows))
    held_out = draws[-1]
    earlier = f"first {len(draws) - 1}"
    total = defaultdict(lambda: [0, 0, []])
    shape = defaultdict(lambda: [0, 0])
    for row in rows:
        base, option = split(row["label"])
        controller = base.rsplit(", ", 1)[1]
        draw = base.split(" shape ")[0]
        ok = row["outcome"] == "success"
        keys = [(controller, option, draw), (controller, option, "all")]
        if draw != held_out:
            keys.append((controller, option, earlier))
        for key in keys:
            t = total[key]
            t[0] += ok
            t[1] += 1
            if ok:
                t[2].append(float(row["sim_time_s"]))
        shape[(base, option)][0] += ok
        shape[(base, option)][1] += 1
    print(f"| controller | option | {' | '.join(draws)} | {earlier} | all {len(draws)} |")
    print("|---" * (len(draws) + 4) + "|")
    for controller in ("occlusion", "fill-transport"):
        for option in OPTIONS:
            if (controller, option, "all") not in total:
                continue
            cells = []
            for draw in draws + [earlier, "all"]:
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
