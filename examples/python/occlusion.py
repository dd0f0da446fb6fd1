"""A Python port of the built-in `occlusion` controller (beacon perception), run on seed-transport.

Occlusion-based cooperative transport (Chen et al., IEEE T-RO 2015), as in
crates/formica-core/src/controllers/occlusion.rs: each robot approaches the object (steering to
its centre, which the beacon gives), circles it with the left-hand rule watching the goal light,
and pushes along the surface normal (biased toward where it triangulated the goal) while the
object hides the goal; time-outs free stuck robots. Only the beacon perception is ported (the
scenario's default), and not the pushers' spreading over the hidden side (results format 11),
so it is Chen's rule with the goal bias; the arithmetic is in float64 where Rust uses f32, so single runs differ
while success rates compare.

    python examples/python/occlusion.py                 # seeds 1..20, Python and Rust side by side
    python examples/python/occlusion.py --seeds 1..100 --rust-only

Registered as `py-occlusion`; a scenario file names it like any controller.
"""

from __future__ import annotations

import argparse
import pathlib
import math
import statistics
import time

import formica

PI = math.pi
HALF_PI = math.pi / 2


def wrap(a: float) -> float:
    """Angle wrapped to [-pi, pi)."""
    return (a + PI) % (2 * PI) - PI


NOISE_FLOOR = 0.03  # proximity readings at or below this are nothing (as Rust)


def light_contrast(light):
    """Strongest reading minus the mean of the weaker half of the ring (as Rust)."""
    if not light:
        return 0.0
    srt = sorted(light)
    half = max(len(srt) // 2, 1)
    return srt[-1] - sum(srt[:half]) / half


def light_bearing(light, angles):
    """Bearing of a light: the vertex of the parabola through the strongest sensor and its two
    neighbours, readings less the ring's background (as Rust; no spread law assumed)."""
    n = min(len(light), len(angles))
    if n == 0:
        return None
    i = max(range(n), key=lambda k: light[k])
    ri = light[i]
    background = ri - light_contrast(light[:n])
    if ri - background <= 0.0:
        return None
    if n < 3:
        return angles[i]
    p, q = (i + n - 1) % n, (i + 1) % n
    y0 = ri - background
    ym = max(light[p] - background, 0.0)
    yp = max(light[q] - background, 0.0)
    xm = wrap(angles[p] - angles[i])
    xp = wrap(angles[q] - angles[i])
    den = xm * xp * (xm - xp)
    if abs(den) < 1e-9:
        return angles[i]
    a = (xp * (ym - y0) - xm * (yp - y0)) / den
    b = (xm * xm * (yp - y0) - xp * xp * (ym - y0)) / den
    offset = -b / (2.0 * a) if a < 0.0 else 0.0
    offset = min(max(offset, min(xm, xp) / 2.0), max(xm, xp) / 2.0)
    return wrap(angles[i] + offset)


class GoalFix:
    """Least-squares intersection of the bearing lines along which the goal was seen."""

    def __init__(self):
        self.a = [0.0, 0.0, 0.0]
        self.b = [0.0, 0.0]
        self.last = None

    def add(self, px, py, direction):
        nx, ny = -math.sin(direction), math.cos(direction)
        c = nx * px + ny * py
        self.a[0] += nx * nx
        self.a[1] += nx * ny
        self.a[2] += ny * ny
        self.b[0] += nx * c
        self.b[1] += ny * c
        self.last = (px, py, direction)

    def estimate(self):
        xx, xy, yy = self.a
        det = xx * yy - xy * xy
        tr = xx + yy
        if tr <= 0.0 or det < 0.0005 * tr * tr or self.last is None:
            return None
        gx = (yy * self.b[0] - xy * self.b[1]) / det
        gy = (xx * self.b[1] - xy * self.b[0]) / det
        px, py, direction = self.last
        dx, dy = gx - px, gy - py
        if math.hypot(dx, dy) > 1e-3 and abs(wrap(math.atan2(dy, dx) - direction)) < 0.5:
            return gx, gy
        return None


LED = {"push": "red", "circle": "blue", "escape": "yellow", "search": "white", "approach": "white"}


class Occlusion:
    """The occlusion controller's core (beacon only): the parameters it has take the Rust one's
    defaults. Not ported: spreading pushers over the hidden side (it pushes where it first finds
    the goal hidden, as Rust's `spread_s = 0`), `circle_side`, the light thresholds
    `lit_contrast` / `dark_contrast`, sliding, and the near-wall options."""

    needs = ("proximity", "light", "beacon")

    def __init__(
        self,
        layout,
        approach_speed=0.1,
        circle_speed=0.1,
        push_speed=0.1,
        search_speed=0.1,
        max_turn=3.0,
        turn_gain=3.0,
        circle_gap=0.03,
        gap_gain=12.0,
        contact_gap=0.06,
        push_align=0.5,
        push_goal_bias_deg=45.0,
        hidden_s=0.3,
        visible_s=0.3,
        avoid_threshold=0.3,
        stuck_s=8.0,
        push_stuck_s=30.0,
        stuck_dist=0.03,
        escape_s=2.0,
        block_s=3.0,
        reverse_s=20.0,
        object_reach=None,
        occluder_angle_deg=30.0,
        push_needs_goal=True,
    ):
        self.layout = layout
        self.prox_angles = list(layout.proximity_angles)
        self.light_angles = list(layout.light_angles)
        self.half_wheels = layout.wheel_distance / 2.0
        self.range = layout.proximity_range
        self.approach_speed, self.circle_speed = approach_speed, circle_speed
        self.push_speed, self.search_speed = push_speed, search_speed
        self.max_turn, self.turn_gain = max_turn, turn_gain
        self.circle_gap, self.gap_gain, self.contact_gap = circle_gap, gap_gain, contact_gap
        self.push_align, self.push_bias = push_align, math.radians(push_goal_bias_deg)
        self.hidden_s, self.visible_s = hidden_s, visible_s
        self.avoid_threshold = avoid_threshold
        self.stuck_s, self.push_stuck_s, self.stuck_dist = stuck_s, push_stuck_s, stuck_dist
        self.escape_s, self.block_s, self.reverse_s = escape_s, block_s, reverse_s
        if object_reach is None:
            # As the Rust controller: 0.6 m, or the tracked object's radius + 0.2 m if more.
            radius = layout.beacon_radius
            object_reach = 0.6 if radius is None or radius + 0.2 <= 0.6 else radius + 0.2
        self.object_reach = object_reach
        self.occluder = math.radians(occluder_angle_deg)
        self.push_needs_goal = push_needs_goal and occluder_angle_deg < 180.0
        # Behaviour state.
        self.state = "approach"
        self.since_s = 0.0
        self.last_s = 0.0
        self.hidden_since = None
        self.visible_since = None
        self.goal_lit = False  # the goal counts as visible (hysteresis, as Rust)
        self.smooth = None  # smoothed own position, for the progress watch
        self.anchor = (0.0, 0.0)
        self.anchor_s = math.nan
        self.side = 1.0
        self.reverse_until = -math.inf
        self.blocked_since = None
        self.goal_dir = None
        self.goal_fix = GoalFix()
        self.escape_turn = 1.0
        self.walk_turn = 0.0
        self.walk_left_s = 0.0

    # -- helpers ---------------------------------------------------------------------------

    def twist(self, forward, turn):
        t = min(max(turn, -self.max_turn), self.max_turn)
        half = t * self.half_wheels
        return forward - half, forward + half

    def set_state(self, s, t, x, y):
        if s != self.state:
            self.state = s
            self.since_s = t
            self.anchor = self.smooth or (x, y)
            self.anchor_s = t

    def stuck(self, t, x, y, limit):
        x, y = self.smooth or (x, y)
        ax, ay = self.anchor
        if math.isnan(self.anchor_s) or math.hypot(x - ax, y - ay) >= self.stuck_dist:
            self.anchor = (x, y)
            self.anchor_s = t
            return False
        return t - self.anchor_s >= limit

    def goal_direction(self, x, y):
        est = self.goal_fix.estimate()
        if est is not None and math.hypot(est[0] - x, est[1] - y) > 0.05:
            return math.atan2(est[1] - y, est[0] - x)
        return self.goal_dir

    def perceive(self, prox, centre):
        """(surface bearing, gap) or None; summed proximity (x, y) of everything else."""
        if centre is None:
            return None, (0.0, 0.0)
        cb, dist = centre
        near = dist <= self.object_reach
        ox = oy = 0.0
        best = 0.0
        otx = oty = 0.0
        for v, a in zip(prox, self.prox_angles):
            if v <= NOISE_FLOOR:
                continue
            dx, dy = math.cos(a) * v, math.sin(a) * v
            if near and abs(wrap(a - cb)) <= HALF_PI + 0.1:
                ox += dx
                oy += dy
                best = max(best, v)
            else:
                otx += dx
                oty += dy
        if not near:
            surface = (cb, dist)
        elif best > 0.0:
            surface = (math.atan2(oy, ox), (1.0 - best) * self.range)
        else:
            surface = (cb, self.range + 0.05)
        return surface, (otx, oty)

    def goal_hidden(self, light, t, x, y, theta, obj):
        contrast = light_contrast(light)
        self.goal_lit = contrast >= 0.06 if self.goal_lit else contrast > 0.1
        dark = len(light) > 0 and not self.goal_lit
        if not dark:
            b = light_bearing(light, self.light_angles)
            if b is not None:
                g = wrap(b + theta)
                self.goal_dir = g
                self.goal_fix.add(x, y, g)
        g = self.goal_direction(x, y)
        # Never seen the goal: a neighbour may be what hides it (Rust's `push_needs_goal`).
        by_object = not (g is None and self.push_needs_goal)
        if g is not None and obj is not None:
            by_object = abs(wrap(obj + theta - g)) <= self.occluder
        hidden = dark and by_object
        if hidden:
            self.visible_since = None
            if self.hidden_since is None:
                self.hidden_since = t
        else:
            self.hidden_since = None
            if self.visible_since is None:
                self.visible_since = t
        long_hidden = self.hidden_since is not None and t - self.hidden_since >= self.hidden_s - 1e-4
        long_visible = (
            self.visible_since is not None and t - self.visible_since >= self.visible_s - 1e-4
        )
        return long_hidden, long_visible

    def avoid_turn(self, other):
        length = math.hypot(*other)
        if length <= self.avoid_threshold or other[0] <= 0.0:
            return 0.0
        side = -1.0 if other[1] > 0.0 else 1.0
        return side * self.max_turn * min(length, 1.0)

    def escape(self, t, x, y):
        self.escape_turn = 1.0 if self.rng.coin() else -1.0
        self.set_state("escape", t, x, y)

    def approach(self, t, target, other):
        avoid = self.avoid_turn(other)
        length = math.hypot(*other)
        if target is not None:
            turn = self.turn_gain * target + avoid
            fwd = 0.0 if abs(target) > 1.2 else self.approach_speed * max(math.cos(target), 0.0)
            if other[0] > self.avoid_threshold:
                fwd = 0.0
            elif length > self.avoid_threshold and other[0] > 0.0:
                fwd *= 0.3
            return self.twist(fwd, turn)
        dt = max(t - self.last_s, 0.0)
        if self.walk_left_s > 0.0:
            self.walk_left_s -= dt
            return self.twist(self.search_speed * 0.3, self.walk_turn + avoid)
        if self.rng.random() < dt / 5.0:
            self.walk_left_s = self.rng.uniform(0.3, 1.5)
            self.walk_turn = 1.5 if self.rng.coin() else -1.5
        fwd = 0.0 if (length > self.avoid_threshold and other[0] > 0.0) else self.search_speed
        return self.twist(fwd, avoid)

    # -- the step --------------------------------------------------------------------------

    def step(self, r):
        x, y, theta = r.pose
        t = r.time_s
        # Positions are noisy: the progress watch uses a smoothed one (as Rust).
        if self.smooth is not None and math.hypot(x - self.smooth[0], y - self.smooth[1]) < 0.2:
            self.smooth = (
                self.smooth[0] + 0.2 * (x - self.smooth[0]),
                self.smooth[1] + 0.2 * (y - self.smooth[1]),
            )
        else:
            self.smooth = (x, y)
        prox = r.proximity
        beacon = r.beacon
        centre = None
        if beacon is not None:
            dx, dy = beacon[0] - x, beacon[1] - y
            centre = (wrap(math.atan2(dy, dx) - theta), math.hypot(dx, dy))
        surface, other = self.perceive(prox, centre)
        obj_dir = centre[0] if centre is not None else None
        hidden, visible = self.goal_hidden(r.light, t, x, y, theta, obj_dir)
        hops = 0
        while True:
            hops += 1
            if hops > 4:
                self.escape(t, x, y)
                act = self.twist(-self.approach_speed, 0.0)
                break
            s = self.state
            if s in ("search", "approach"):
                target = centre[0] if centre is not None else None
                if surface is not None and surface[1] <= self.contact_gap:
                    self.side = 1.0
                    self.reverse_until = -math.inf
                    self.blocked_since = None
                    self.set_state("circle", t, x, y)
                    continue
                self.set_state("approach" if target is not None else "search", t, x, y)
                if self.stuck(t, x, y, self.stuck_s):
                    self.escape(t, x, y)
                    continue
                act = self.approach(t, target, other)
                break
            if s == "circle":
                if surface is None:
                    self.set_state("search", t, x, y)
                    continue
                if centre is not None and centre[1] > self.object_reach:
                    self.set_state("approach", t, x, y)
                    continue
                if hidden:
                    self.set_state("push", t, x, y)
                    continue
                length = math.hypot(*other)
                ahead = length > self.avoid_threshold and other[0] > 0.3 * length
                reversed_ = t < self.reverse_until
                if ahead:
                    if self.blocked_since is None:
                        self.blocked_since = t
                    if t - self.blocked_since >= self.block_s:
                        self.reverse_until = -math.inf if reversed_ else t + self.reverse_s
                        self.blocked_since = None
                else:
                    self.blocked_since = None
                if self.stuck(t, x, y, self.stuck_s):
                    self.escape(t, x, y)
                    continue
                side = -self.side if t < self.reverse_until else self.side
                err = wrap(surface[0] - side * HALF_PI)
                gap_err = min(max(surface[1] - self.circle_gap, -0.1), 0.1)
                turn = self.turn_gain * err + side * self.gap_gain * gap_err
                fwd = self.circle_speed * max(1.0 - abs(err) / PI, 0.2)
                if ahead:
                    turn -= side * self.max_turn * 0.5
                    fwd *= 0.3
                act = self.twist(fwd, turn)
                break
            if s == "push":
                if surface is None:
                    self.set_state("search", t, x, y)
                    continue
                if visible:
                    self.set_state("circle", t, x, y)
                    continue
                if surface[1] > 2.0 * self.contact_gap + 0.05:
                    self.set_state("approach", t, x, y)
                    continue
                if self.stuck(t, x, y, self.push_stuck_s):
                    self.escape(t, x, y)
                    continue
                err = surface[0]
                g = self.goal_direction(x, y)
                if g is not None and self.push_bias > 0.0:
                    to_goal = wrap(g - theta - surface[0])
                    err = wrap(surface[0] + min(max(to_goal, -self.push_bias), self.push_bias))
                fwd = self.push_speed if abs(err) < self.push_align else 0.0
                act = self.twist(fwd, self.turn_gain * err)
                break
            # escape
            since = t - self.since_s
            if since >= self.escape_s:
                self.set_state("approach", t, x, y)
                continue
            if since < self.escape_s * 0.5:
                act = self.twist(-self.approach_speed, 0.0)
            else:
                act = self.twist(0.0, self.escape_turn * self.max_turn * 0.5)
            break
        self.last_s = t
        return act[0], act[1], LED[self.state]


formica.register_controller("py-occlusion", Occlusion)


def _seeds(text: str) -> range:
    a, b = text.split("..")
    return range(int(a), int(b.lstrip("=")) + 1)


def _rate(rows) -> str:
    ok = sum(1 for r in rows if r["outcome"] == "success")
    times = sorted(r["sim_time_s"] for r in rows if r["outcome"] == "success")
    # The mean of the two middle times for an even count, as `formica run` reports it.
    median = statistics.median(times) if times else float("nan")
    return f"{ok}/{len(rows)} succeed ({100.0 * ok / len(rows):.0f} %), median time of successes {median:.1f} s"


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    # The shipped scenario, found from this file, so that the script runs from any folder.
    default = pathlib.Path(__file__).resolve().parents[2] / "scenarios" / "seed-transport.toml"
    ap.add_argument("--scenario", default=str(default))
    ap.add_argument("--seeds", default="1..20", help="A..B inclusive (default 1..20)")
    ap.add_argument("--rust-only", action="store_true", help="run only the built-in Rust controller")
    ap.add_argument("--python-only", action="store_true", help="run only this Python port")
    args = ap.parse_args()
    seeds = _seeds(args.seeds)
    sc = formica.load(args.scenario)
    if not args.python_only:
        t0 = time.perf_counter()
        rust = formica.run(sc, seeds, controller="occlusion", as_frame=False)
        print(f"rust   occlusion: {_rate(rust)} ({time.perf_counter() - t0:.1f} s wall)")
    if not args.rust_only:
        t0 = time.perf_counter()
        py = formica.run(sc, seeds, controller="py-occlusion", as_frame=False)
        print(f"python occlusion: {_rate(py)} ({time.perf_counter() - t0:.1f} s wall)")


if __name__ == "__main__":
    main()
