#!/usr/bin/env python3
"""Writes experiments/random.toml: objects, placements and obstacle maps drawn at random.

    python3 experiments/random-cases.py > experiments/random.toml
    formica sweep experiments/random.toml --db random.db && formica report random.db --out results/random

Standard library only; the draw is fixed by SEED below, so the file it writes is the one
committed. Nothing in it was chosen by hand or tuned: the point is to run the built-in
controllers, with their defaults and the Khepera IV noise preset, where no one looked before.

- Shapes: 12 polygons, alternately a rectangle (0.5 to 0.9 m a side) with one notch or two on
  opposite sides (0.2 to 0.45 m wide, 0.15 m to 0.4 of the side deep: cavities a robot fits
  in) and a star (3 to 6 points, outer radius 0.3 to 0.45 m, inner 0.12 to 0.2 m); each turned
  at random and placed at random in the 6 x 4 m arena of scenarios/fill-transport-h.toml, at
  least 0.3 m from the walls, the goal light at random, at least 2 m from the object and 0.3 m
  from the walls. Each shape runs with `occlusion` and with `fill-transport`.
- Maps: 12 maps in a 4 x 4 m arena (scenarios/qm-middle.toml: 20 Khepera IV with relays, the
  0.4 m 5 kg box), one to three bars (0.3 to 1.6 m by 0.15 to 0.5 m, axis-aligned or turned at
  random) of which at least one cuts the straight line from the object to the goal, the object
  at least 0.45 m from every bar, and a way round for a disc of 0.25 m radius (the box's
  half-diagonal is 0.28 m: it may have to turn to pass) checked on a 5 cm grid.
- The twelve shapes again, in the same places, with `occlusion` finding the object by its colour
  in the colour scan instead of being told its centre (`perception = "camera"`), appended
  last so that the trials before keep their numbers.
- The twelve shapes once more, static, in the seed's filling set-up (scenarios/seed-fill-u.toml:
  the shape, turned as drawn, in place of the U under the beacon light at (-0.8, 0), 10 Khepera
  IV released one every 20 s, 600 s, `filling`): cavity_robots against cavity_capacity and
  false_stops on cavities no one tuned for; appended after the camera cases.
"""
import math
import random
import sys

SEED = 7
SHAPES = 12
MAPS = 12


def notched(rng):
    w, h = rng.uniform(0.5, 0.9), rng.uniform(0.5, 0.9)
    corners = [(-w / 2, -h / 2), (w / 2, -h / 2), (w / 2, h / 2), (-w / 2, h / 2)]
    sides = rng.choice([[0], [1], [2], [3], [0, 2], [1, 3]])
    pts = []
    for i in range(4):
        a, b = corners[i], corners[(i + 1) % 4]
        pts.append(a)
        if i in sides:
            length = math.dist(a, b)
            across = h if i % 2 == 0 else w
            nw = rng.uniform(0.2, min(0.45, length - 0.2))
            nd = rng.uniform(0.15, across * 0.4)
            t0 = rng.uniform(0.1, length - nw - 0.1)
            ux, uy = (b[0] - a[0]) / length, (b[1] - a[1]) / length
            nx, ny = -uy, ux  # inward normal of a counter-clockwise polygon
            p1 = (a[0] + ux * t0, a[1] + uy * t0)
            p2 = (p1[0] + nx * nd, p1[1] + ny * nd)
            p3 = (p2[0] + ux * nw, p2[1] + uy * nw)
            p4 = (p1[0] + ux * nw, p1[1] + uy * nw)
            pts += [p1, p2, p3, p4]
    return "notched rectangle", pts


def star(rng):
    n = rng.randint(3, 6)
    outer, inner = rng.uniform(0.3, 0.45), rng.uniform(0.12, 0.2)
    pts = []
    for k in range(2 * n):
        a = math.pi * k / n + rng.uniform(-0.1, 0.1)
        r = outer if k % 2 == 0 else inner
        pts.append((r * math.cos(a), r * math.sin(a)))
    return f"{n}-point star", pts


def pts_toml(pts):
    return "[" + ", ".join(f"[{p[0]:.3f}, {p[1]:.3f}]" for p in pts) + "]"


def print_shape_case(label, controller, shape, extra=()):
    """One case of a drawn shape: `shape` is (pts, yaw, at, goal); `extra` more key lines."""
    pts, yaw, at, goal = shape
    print()
    print("[[cases]]")
    print(f'label = "{label}"')
    print('scenario = "../scenarios/fill-transport-h.toml"')
    print(f'"robots.0.controller" = "{controller}"')
    for line in extra:
        print(line)
    print(f'"objects.0.shape" = {{ polygon = {pts_toml(pts)} }}')
    print(f'"objects.0.yaw_deg" = {yaw:.1f}')
    print(f'"objects.0.at" = [{at[0]:.2f}, {at[1]:.2f}]')
    print(f'"lights.0.at" = [{goal[0]:.2f}, {goal[1]:.2f}]')


def rect_distance(p, bar):
    """Distance from point p to a (possibly turned) rectangle; 0 inside."""
    (cx, cy), (sx, sy), yaw = bar
    a = -math.radians(yaw)
    dx, dy = p[0] - cx, p[1] - cy
    x = dx * math.cos(a) - dy * math.sin(a)
    y = dx * math.sin(a) + dy * math.cos(a)
    ex, ey = max(abs(x) - sx / 2, 0.0), max(abs(y) - sy / 2, 0.0)
    return math.hypot(ex, ey)


def way_round(obj, goal, bars, half, clearance):
    """Whether a disc of radius `clearance` can go from obj to goal (5 cm grid, BFS)."""
    step = 0.05
    n = int(round(2 * half / step)) + 1

    def free(i, j):
        p = (-half + i * step, -half + j * step)
        # The arena's walls are 0.1 m thick, centred on its border.
        if half - 0.05 - abs(p[0]) < clearance or half - 0.05 - abs(p[1]) < clearance:
            return False
        return all(rect_distance(p, b) >= clearance for b in bars)

    def cell(p):
        return (round((p[0] + half) / step), round((p[1] + half) / step))

    start, end = cell(obj), cell(goal)
    if not free(*start):
        return False
    seen, todo = {start}, [start]
    while todo:
        c = todo.pop()
        if math.dist(c, end) * step <= 0.3:
            return True
        for d in ((1, 0), (-1, 0), (0, 1), (0, -1)):
            m = (c[0] + d[0], c[1] + d[1])
            if 0 <= m[0] < n and 0 <= m[1] < n and m not in seen and free(*m):
                seen.add(m)
                todo.append(m)
    return False


def main():
    # An optional seed draws another set (experiments/random-seed8.toml: the second draw), and
    # an optional robot model runs the same draw with that model in every case
    # (experiments/random-seed9-e-puck.toml: `random-cases.py 9 e-puck`).
    seed = int(sys.argv[1]) if len(sys.argv) > 1 else SEED
    model = sys.argv[2] if len(sys.argv) > 2 else None
    name = "random" if seed == SEED and model is None else f"random-seed{seed}"
    if model is not None:
        name += f"-{model}"
    rng = random.Random(seed)
    args = "" if seed == SEED and model is None else f" {seed}"
    if model is not None:
        args += f" {model}"
    print("# Objects, placements and obstacle maps drawn at random by experiments/random-cases.py")
    print(f"# (seed {seed}: `python3 experiments/random-cases.py{args}` gives this file back). Report:")
    print(f"# results/{name}/summary.md; discussion on docs/src/results/unseen.md. 10 seeds per case.")
    print(f"#   formica sweep experiments/{name}.toml --db {name}.db && formica report {name}.db --out results/{name}")
    print(f'name = "{name}"')
    print('seeds = "1..10"')
    print()
    print("[set]")
    print('"robots.0.sensors.noise" = "realistic"')
    if model is not None:
        print(f'"robots.0.model" = "{model}"')
    print()
    print("# --- random shapes at random places in the open: occlusion and fill-transport ------------")
    drawn = []
    for i in range(SHAPES):
        kind, pts = notched(rng) if i % 2 == 0 else star(rng)
        yaw = rng.uniform(0.0, 360.0)
        radius = max(math.hypot(*p) for p in pts)
        m = radius + 0.3
        while True:
            at = (rng.uniform(-2.95 + m, 2.95 - m), rng.uniform(-1.95 + m, 1.95 - m))
            goal = (rng.uniform(-2.65, 2.65), rng.uniform(-1.65, 1.65))
            if math.dist(at, goal) >= 2.0:
                break
        drawn.append((kind, (pts, yaw, at, goal)))
        for controller in ("occlusion", "fill-transport"):
            print_shape_case(f"shape {i}: {kind}, {controller}", controller, drawn[-1][1])
    print()
    print("# --- random obstacle maps, 4 x 4 m: occlusion with relays ---------------------------------")
    for i in range(MAPS):
        while True:
            bars = []
            for _ in range(rng.randint(1, 3)):
                yaw = rng.choice([0.0, 0.0, 90.0, rng.uniform(0.0, 180.0)])
                bars.append(
                    (
                        (rng.uniform(-1.2, 1.2), rng.uniform(-1.2, 1.2)),
                        (rng.uniform(0.3, 1.6), rng.uniform(0.15, 0.5)),
                        yaw,
                    )
                )
            obj = (rng.uniform(-1.6, 1.6), rng.uniform(-1.6, 1.6))
            goal = (rng.uniform(-1.7, 1.7), rng.uniform(-1.7, 1.7))
            if math.dist(obj, goal) < 2.0:
                continue
            if any(rect_distance(obj, b) < 0.45 for b in bars):
                continue
            if any(rect_distance(goal, b) < 0.3 for b in bars):
                continue
            line = [(obj[0] + (goal[0] - obj[0]) * t / 50, obj[1] + (goal[1] - obj[1]) * t / 50) for t in range(51)]
            if not any(rect_distance(p, b) == 0.0 for p in line for b in bars):
                continue
            if not way_round(obj, goal, bars, 2.0, 0.25):
                continue
            break
        walls = ", ".join(
            f"{{ at = [{c[0]:.2f}, {c[1]:.2f}], size = [{s[0]:.2f}, {s[1]:.2f}], yaw_deg = {yaw:.1f}, height = 0.2 }}"
            for c, s, yaw in bars
        )
        print()
        print("[[cases]]")
        print(f'label = "map {i}: {len(bars)} bar{"s" if len(bars) > 1 else ""}, relays"')
        print('scenario = "../scenarios/qm-middle.toml"')
        print('"arena.size" = [4.0, 4.0]')
        print('"robots.0.placement" = { random = { min = [-1.9, -1.9], max = [1.9, 1.9] } }')
        print(f'"walls" = [{walls}]')
        print(f'"objects.0.at" = [{obj[0]:.2f}, {obj[1]:.2f}]')
        print(f'"lights.0.at" = [{goal[0]:.2f}, {goal[1]:.2f}]')
    print()
    print("# --- the same shapes and places, occlusion without the beacon (finds the object by its colour) --")
    for i, (kind, shape) in enumerate(drawn):
        camera = ['"robots.0.params.perception" = "camera"']
        print_shape_case(f"shape {i}: {kind}, occlusion, camera", "occlusion", shape, camera)
    print()
    print("# --- the same shapes, static, filled as in the seed's Experiment 1 (filling) ----------------")
    for i, (kind, (pts, yaw, _, _)) in enumerate(drawn):
        print()
        print("[[cases]]")
        print(f'label = "shape {i}: {kind}, static, filling"')
        print('scenario = "../scenarios/seed-fill-u.toml"')
        print(f'"objects.0.parts" = [{{ polygon = {pts_toml(pts)}, yaw_deg = {yaw:.1f}, at = [-0.8, 0.0] }}]')


if __name__ == "__main__":
    main()
