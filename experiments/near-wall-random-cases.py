#!/usr/bin/env python3
"""Writes experiments/near-wall-random.toml: `occlusion`'s near-wall options on the six random draws.

    python3 experiments/near-wall-random-cases.py > experiments/near-wall-random.toml
    formica sweep experiments/near-wall-random.toml --db near-wall-random.db
    formica report near-wall-random.db --out results/near-wall-random

Standard library only (Python 3.11 or newer, for tomllib). Takes every random shape of the six
committed draws (experiments/random.toml and random-seed8 to 12.toml, written by
random-cases.py with seeds 7 to 12; the sixth drawn after the options were measured on the
first five), in the place, turn and goal the draw gave it, and runs it
as the draw did (10 seeds, the Khepera IV noise preset) with:

- `occlusion`: the defaults (the draw's own trials, bit for bit), `balance_turn = 0.03`
  alone, `squeeze_s = 3` alone, and both;
- `fill-transport`: the defaults, and both options for its pushers (`push.balance_turn`,
  `push.squeeze_s`).

The draws' shape failures are wall hits where the goal lies near a wall
(docs/src/results/unseen.md, "Drawn at random"); the options were made for objects that travel
along a wall (experiments/near-wall.toml). Nothing here was tuned on these shapes.
"""
import os
import tomllib

DRAWS = ["random", "random-seed8", "random-seed9", "random-seed10", "random-seed11", "random-seed12"]
HERE = os.path.dirname(os.path.abspath(__file__))
BALANCE, SQUEEZE = 0.03, 3.0


def value(v):
    if isinstance(v, list):
        return "[" + ", ".join(value(x) for x in v) + "]"
    if isinstance(v, dict):
        return "{ " + ", ".join(f"{k} = {value(x)}" for k, x in v.items()) + " }"
    if isinstance(v, str):
        return f'"{v}"'
    if isinstance(v, float):
        return repr(v)
    return str(v)


def case(label, base, extra):
    print()
    print("[[cases]]")
    print(f'label = "{label}"')
    for k, v in list(base.items()) + list(extra):
        if k == "label":
            continue
        key = k if k == "scenario" else f'"{k}"'
        print(f"{key} = {value(v)}")


def main():
    print("# Written by experiments/near-wall-random-cases.py (see there): occlusion's near-wall options")
    print("# on every random shape of the six draws (random.toml, random-seed8 to 12.toml), 10 seeds each.")
    print("#   formica sweep experiments/near-wall-random.toml --db near-wall-random.db")
    print("#   formica report near-wall-random.db --out results/near-wall-random")
    print('name = "near-wall-random"')
    print('seeds = "1..10"')
    print()
    print("[set]")
    print('"robots.0.sensors.noise" = "realistic"')
    for draw in DRAWS:
        with open(os.path.join(HERE, draw + ".toml"), "rb") as f:
            d = tomllib.load(f)
        print()
        print(f"# --- {draw} ---")
        for c in d["cases"]:
            label = c["label"]
            if not label.startswith("shape ") or label.count(",") != 1:
                continue  # maps, the camera cases and static filling
            controller = c.get("robots.0.controller", "fill-transport")
            name = f"{draw} {label}"
            if controller == "occlusion":
                p = "robots.0.params."
                case(name, c, [])
                case(f"{name}, balance", c, [(p + "balance_turn", BALANCE)])
                case(f"{name}, squeeze", c, [(p + "squeeze_s", SQUEEZE)])
                case(f"{name}, both", c, [(p + "balance_turn", BALANCE), (p + "squeeze_s", SQUEEZE)])
            elif controller == "fill-transport":
                p = "robots.0.params.push."
                case(name, c, [])
                case(f"{name}, both", c, [(p + "balance_turn", BALANCE), (p + "squeeze_s", SQUEEZE)])


if __name__ == "__main__":
    main()
