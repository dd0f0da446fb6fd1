#!/usr/bin/env python3
"""Writes a corpus of mutated scenario files (issue 15) from the shipped scenarios/*.toml.

Deterministic: the same seed and count give the same files. Each file is a shipped scenario
with one to four mutations: a number replaced by a hostile value (overflow, zero, tiny, huge,
non-finite), a hostile line inserted, a line deleted, duplicated or swapped, a table repeated,
the text cut short, or a byte inserted. Besides the random files, every hostile line is put
once into every shipped scenario's first table of each kind, so the known classes are always
covered.

    python3 fuzz/corpus.py OUT_DIR [--count 2400] [--seed 1]

fuzz/run-corpus.sh runs every file through `formica check` and `formica run`.
"""

import argparse
import pathlib
import random
import re

NUMBERS = [
    "0", "-0.0", "1", "-1", "2", "0.5", "1e-23", "1e-7", "0.0009", "0.001", "1000", "1001",
    "1e5", "100000", "100001", "1e7", "3e7", "3.4e38", "-3e38", "3e38", "1e39", "1e300",
    "4294967296", "4000000000", "770000000000000000", "9223372036854775807",
    "9223372036854775808", "18446744073709551615", "-9223372036854775808", "nan", "inf",
    "-inf", "0.001e-3", "2000", "-2000", "36001",
]

SNIPPETS = [
    "count = 4294967296",
    "count = 770000000000000000",
    "count = 100000",
    "tick_hz = 0.001",
    "tick_hz = 2",
    "substeps = 1",
    "duration_s = 1e30",
    "seed = 9223372036854775808",
    "seed = 18446744073709551615",
    "wall_thickness = -1.0",
    "wall_thickness = 0",
    "wall_height = 0",
    "shape = { regular = { sides = 4000000000, radius = 0.3 } }",
    "shape = { regular = { sides = 1000, radius = 0.001 } }",
    "shape = { disc = 1e-23 }",
    "shape = { box = [1000.0, 0.5] }",
    "shape = { box = [0.5, 900.0] }",
    "shape = { polygon = [[0, 0], [1, 0], [2, 0]] }",
    "shape = { polygon = [[0, 0], [0, 0], [1, 1]] }",
    "shape = { polygon = [[0, 0], [1, 0], [0.5, 0], [0, 1]] }",
    "parts = [{ disc = 0.2 }, { box = [0.1, 0.1], at = [0.3, 0] }]",
    "at = [3e7, 3e7]",
    "at = [3.4e38, 0]",
    "at = [499.0, 499.0]",
    "size = [1000.0, 1000.0]",
    "size = [1000.0, 0.5]",
    "center = [1000.0, -1000.0]",
    "placement = { random = { min = [-3e38, -3e38], max = [3e38, 3e38] } }",
    "placement = { random = { min = [-499, 0], max = [499, 0.001] } }",
    "placement = { grid = { center = [0, 0], spacing = 0.001 } }",
    "placement = { grid = { center = [0, 0], spacing = 0.2, columns = 100000 } }",
    "placement = { poses = [[0, 0, 0], [0, 0, 0]] }",
    "sensors = { proximity_noise = -1.0, camera_range = -1.0 }",
    "sensors = { camera_range = 1e30, scan_bins = 4000000000 }",
    "sensors = { noise = \"none\", beacon_range = 0 }",
    "release = { interval_s = 1e30 }",
    "interval_s = 0.0001",
    "params = { left = 1e30, right = -1e30 }",
    "on_filled = 0",
    "goal_radius = -1",
    "intensity = 1e38",
    "mass = 1e-30",
    "floor_mu = 1e30",
    "yaw_deg = 1e30",
    "heading_deg = nan",
    "[run]",
    "[arena]",
    "[[robots]]",
    "[[objects]]",
    "[[walls]]",
    "[[lights]]",
    "a = " + "[" * 40 + "1" + "]" * 40,
    "x = \"\\u0000\\u007f\"",
]

NUMBER = re.compile(r"(?<![A-Za-z0-9_])-?[0-9][0-9._eE+-]*")


def mutate(text, rng):
    """One to four random mutations of `text`."""
    for _ in range(rng.randint(1, 4)):
        kind = rng.randrange(10)
        if kind <= 3:
            nums = list(NUMBER.finditer(text))
            if nums:
                m = rng.choice(nums)
                text = text[: m.start()] + rng.choice(NUMBERS) + text[m.end():]
        elif kind <= 5:
            lines = text.split("\n")
            lines.insert(rng.randint(0, len(lines)), rng.choice(SNIPPETS))
            text = "\n".join(lines)
        elif kind == 6:
            lines = text.split("\n")
            i = rng.randrange(len(lines))
            op = rng.randrange(3)
            if op == 0:
                del lines[i]
            elif op == 1:
                lines.insert(i, lines[i])
            else:
                j = rng.randrange(len(lines))
                lines[i], lines[j] = lines[j], lines[i]
            text = "\n".join(lines)
        elif kind == 7:
            at = text.find("[[")
            if at >= 0:
                end = text.find("\n[", at + 2)
                block = text[at: end if end >= 0 else len(text)]
                text += ("\n" + block) * rng.randint(1, 49)
        elif kind == 8:
            text = text[: rng.randint(0, len(text))]
        else:
            i = rng.randint(0, len(text))
            text = text[:i] + rng.choice("[]{}=,.\"'#\n-+_0e ") + text[i:]
    return text


def put_in_table(text, table, line):
    """`line` put into the first `table` (replacing the key it sets, if the table has it),
    or None if there is no such table."""
    at = text.find("\n" + table + "\n")
    if at < 0:
        return None
    at += len(table) + 2
    end = text.find("\n[", at)
    end = len(text) if end < 0 else end + 1
    key = line.split("=")[0].strip() if "=" in line and not line.startswith("[") else None
    if key:
        m = re.search(r"(?m)^" + re.escape(key) + r"\s*=.*$", text[at:end])
        if m:
            return text[: at + m.start()] + line + text[at + m.end():]
    return text[:at] + line + "\n" + text[at:]


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("out", type=pathlib.Path)
    ap.add_argument("--count", type=int, default=2400, help="random mutants (default 2400)")
    ap.add_argument("--seed", type=int, default=1)
    a = ap.parse_args()
    root = pathlib.Path(__file__).resolve().parent.parent
    bases = sorted((root / "scenarios").glob("*.toml"))
    texts = [(p.stem, p.read_text()) for p in bases]
    a.out.mkdir(parents=True, exist_ok=True)
    rng = random.Random(a.seed)
    n = 0
    for k in range(a.count):
        stem, text = rng.choice(texts)
        (a.out / f"m{k:05d}-{stem}.toml").write_text(mutate(text, rng))
        n += 1
    # Every hostile line in every kind of table of two scenarios of each kind.
    for stem, text in texts[::4]:
        for s, line in enumerate(SNIPPETS):
            for table in ["[arena]", "[[objects]]", "[[robots]]", "[run]"]:
                t = put_in_table(text, table, line)
                if t is not None:
                    name = f"s{s:02d}-{table.strip('[]')}-{stem}.toml"
                    (a.out / name).write_text(t)
                    n += 1
    print(f"{n} files in {a.out}")


if __name__ == "__main__":
    main()
