//! Coulomb floor friction over an object's footprint, one implicit step at a time (no rapier
//! here; `physics.rs` turns the result into joint settings).
//!
//! The floor presses uniformly on the footprint, sampled at a grid of points that each carry an
//! equal share of the load `mu m g`. A point sliding at velocity `u` is resisted with its share
//! opposite `u` (Coulomb); the object's friction wrench is the sum. That sum, taken over every
//! twist, is the object's limit surface, exactly (up to the sampling), so an off-centre push turns
//! the object as Coulomb friction does. The ellipsoidal approximation of quasi-static pushing
//! (Goyal, Ruina & Papadopoulos 1991; Lynch & Mason 1996) was tried first and rejected: it has the
//! right force and torque at the axes but not the right curvature near pure translation (off by
//! the ratio of the footprint's mean squared distance from the centre to its second moment along
//! the push, 1.76 for a square), so a 0.5 m box pushed 5 cm off centre turned 35 % too slowly.
//!
//! One step of length `h` is implicit (backward Euler with maximal dissipation): with `free` the
//! twist the body would have at the end of the step without friction and `A = diag(m, m, I) / h`,
//! the end twist minimises `1/2 |xi - free|_A^2 + D(xi)`, where `D(xi) = sum_k share |u_k(xi)|` is
//! the dissipation. The minimiser is zero (the body sticks) exactly when the wrench that stops it,
//! `-A free`, lies inside the limit surface; otherwise the friction wrench `A (xi - free)` is on the
//! surface with `xi` along its normal. The problem is convex in three unknowns; it is solved by
//! Newton's method with a line search on `D` smoothed by a creep speed of 1 um/s.

use crate::geometry::Vec2;

/// Aim for about this many sample points in a footprint.
const POINTS: usize = 100;
/// Speed below which a point counts as not sliding (m/s): the smoothing of `|u|`.
const CREEP: f64 = 1.0e-6;
/// A body whose points all move slower than this at the end of the step sticks (m/s).
const STICK_SPEED: f64 = 1.0e-5;
/// Points whose square roots and divisions [`Problem::eval`] computes together.
const LANES: usize = 8;
/// Newton iterations at most.
const MAX_ITERATIONS: usize = 40;

/// Linear (at the centre of mass) and angular velocity of a body.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub(super) struct Twist {
    /// Linear velocity (m/s).
    pub lin: Vec2,
    /// Angular velocity (rad/s).
    pub ang: f32,
}

/// Result of one friction step.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(super) struct Step {
    /// Friction force over the step (N).
    pub force: Vec2,
    /// Friction torque about the centre of mass (N m).
    pub torque: f32,
    /// Twist at the end of the step.
    pub end: Twist,
    /// Whether the body ends the step at rest.
    pub sticks: bool,
}

/// The footprint of an object as friction sees it.
#[derive(Debug, Clone)]
pub(super) struct Footprint {
    /// Sample points relative to their centroid, in the body frame (m).
    points: Vec<[f64; 2]>,
    /// Largest friction force, `mu m g` (N).
    pub f_max: f32,
    /// Largest friction torque about the centre, `f_max` times the mean distance (N m).
    pub tau_max: f32,
    /// Largest distance of a point from the centre (m).
    reach: f64,
}

impl Footprint {
    /// Samples the region `inside` (body frame) within the box `lo`..`hi` on a square grid of
    /// about [`POINTS`] cells of the region, each point carrying `f_max / n`. The points are
    /// centred on their centroid: uniform pressure under the centre of mass.
    pub fn sample(inside: impl Fn(Vec2) -> bool, lo: Vec2, hi: Vec2, f_max: f32) -> Footprint {
        let size = hi - lo;
        // Refine until the region holds enough points (it may fill little of its box).
        let mut cells = (POINTS as f32).sqrt().ceil() as usize;
        let mut points = Vec::new();
        for _ in 0..6 {
            points.clear();
            let cell = size.x.max(size.y) / cells as f32;
            if !(cell > 0.0) {
                break;
            }
            let nx = ((size.x / cell).ceil() as usize).max(1);
            let ny = ((size.y / cell).ceil() as usize).max(1);
            for iy in 0..ny {
                for ix in 0..nx {
                    let p = lo + Vec2::new((ix as f32 + 0.5) * cell, (iy as f32 + 0.5) * cell);
                    if inside(p) {
                        points.push([f64::from(p.x), f64::from(p.y)]);
                    }
                }
            }
            if points.len() >= POINTS / 2 {
                break;
            }
            cells *= 2;
        }
        if points.is_empty() {
            points.push([0.0, 0.0]);
        }
        let n = points.len() as f64;
        let cx = points.iter().map(|p| p[0]).sum::<f64>() / n;
        let cy = points.iter().map(|p| p[1]).sum::<f64>() / n;
        for p in &mut points {
            p[0] -= cx;
            p[1] -= cy;
        }
        let dist = |p: &[f64; 2]| (p[0] * p[0] + p[1] * p[1]).sqrt();
        let mean = points.iter().map(dist).sum::<f64>() / n;
        let reach = points.iter().map(dist).fold(0.0, f64::max);
        Footprint {
            points,
            f_max,
            tau_max: (f64::from(f_max) * mean) as f32,
            reach,
        }
    }

    /// Largest distance of a point from the centre (m).
    pub fn reach(&self) -> f32 {
        self.reach as f32
    }

    /// One implicit friction step for a body of mass `m` and inertia `i` turned by the rotation
    /// `(cos, sin)`, whose twist at the end of a step of `h` s would be `free` without friction.
    /// `guess` is where the search starts (e.g. the last step's end twist).
    pub fn step(&self, rot: (f32, f32), m: f32, i: f32, h: f32, free: Twist, guess: Twist) -> Step {
        let still = Step {
            force: Vec2::ZERO,
            torque: 0.0,
            end: free,
            sticks: false,
        };
        if !(self.f_max > 0.0 && h > 0.0 && m > 0.0 && i > 0.0) {
            return still;
        }
        // The limit set contains the double cone |f| / f_max + |tau| / tau_max <= 1 (the hull of
        // its pure translations and rotations): a stopping wrench inside it sticks for sure.
        let stop = (-free.lin * (m / h), -free.ang * (i / h));
        if stop.0.length() / self.f_max + stop.1.abs() / self.tau_max.max(f32::MIN_POSITIVE) <= 1.0
        {
            return Step {
                force: stop.0,
                torque: stop.1,
                end: Twist::default(),
                sticks: true,
            };
        }
        let h = f64::from(h);
        // The points turned into the world frame once: every evaluation below reads them.
        let (c, s) = (f64::from(rot.0), f64::from(rot.1));
        let turned: Vec<[f64; 2]> = self
            .points
            .iter()
            .map(|p| [c * p[0] - s * p[1], s * p[0] + c * p[1]])
            .collect();
        let prob = Problem {
            pts: &turned,
            share: f64::from(self.f_max) / self.points.len() as f64,
            al: f64::from(m) / h,
            aa: f64::from(i) / h,
            free: [
                f64::from(free.lin.x),
                f64::from(free.lin.y),
                f64::from(free.ang),
            ],
        };
        let scale = self.reach.max(1e-3);
        let mut x = [
            f64::from(guess.lin.x),
            f64::from(guess.lin.y),
            f64::from(guess.ang),
        ];
        let (mut phi, mut g, mut hess) = prob.eval(x);
        for _ in 0..MAX_ITERATIONS {
            let Some(d) = solve3(&hess, [-g[0], -g[1], -g[2]]) else {
                break;
            };
            let slope = g[0] * d[0] + g[1] * d[1] + g[2] * d[2];
            if !(slope < 0.0) {
                break;
            }
            // The full Newton step, evaluated completely: it is usually taken.
            let mut t = 1.0;
            let mut next = [x[0] + d[0], x[1] + d[1], x[2] + d[2]];
            let mut at = prob.eval(next);
            if !(at.0 <= phi + 1e-4 * slope) {
                // Backtrack on the value alone, then evaluate where it stops.
                let mut value = at.0;
                while !(value <= phi + 1e-4 * t * slope) && t > 1e-12 {
                    t *= 0.5;
                    next = [x[0] + t * d[0], x[1] + t * d[1], x[2] + t * d[2]];
                    value = prob.phi(next);
                }
                if !(value <= phi) {
                    break;
                }
                at = prob.eval(next);
            }
            let moved = t * ((d[0] * d[0] + d[1] * d[1]).sqrt() + (d[2] * scale).abs());
            let size = (x[0] * x[0] + x[1] * x[1]).sqrt() + (x[2] * scale).abs();
            x = next;
            (phi, g, hess) = at;
            if moved < 1e-3 * CREEP + 1e-7 * size {
                break;
            }
        }
        // Fastest point at the end of the step.
        let fastest = (x[0] * x[0] + x[1] * x[1]).sqrt() + x[2].abs() * self.reach;
        let sticks = fastest < STICK_SPEED;
        if sticks {
            x = [0.0; 3];
        }
        let force = Vec2::new(
            (prob.al * (x[0] - prob.free[0])) as f32,
            (prob.al * (x[1] - prob.free[1])) as f32,
        );
        let torque = (prob.aa * (x[2] - prob.free[2])) as f32;
        Step {
            force,
            torque,
            end: Twist {
                lin: Vec2::new(x[0] as f32, x[1] as f32),
                ang: x[2] as f32,
            },
            sticks,
        }
    }

    #[cfg(test)]
    /// The friction wrench (force, torque) of the body sliding with twist `xi` and turned by
    /// `(cos, sin)`: each point's share opposite its velocity.
    pub fn wrench(&self, rot: (f32, f32), xi: Twist) -> (Vec2, f32) {
        let (c, s) = (f64::from(rot.0), f64::from(rot.1));
        let share = f64::from(self.f_max) / self.points.len() as f64;
        let (vx, vy, w) = (f64::from(xi.lin.x), f64::from(xi.lin.y), f64::from(xi.ang));
        let (mut fx, mut fy, mut t) = (0.0, 0.0, 0.0);
        for p in &self.points {
            let (x, y) = (c * p[0] - s * p[1], s * p[0] + c * p[1]);
            let (ux, uy) = (vx - w * y, vy + w * x);
            let n = (ux * ux + uy * uy).sqrt();
            if n > 0.0 {
                fx -= share * ux / n;
                fy -= share * uy / n;
                t -= share * (x * uy - y * ux) / n;
            }
        }
        (Vec2::new(fx as f32, fy as f32), t as f32)
    }
}

/// Value, gradient and Hessian (xx, xy, xw, yy, yw, ww) of the step's objective.
type Eval = (f64, [f64; 3], [f64; 6]);

/// The step's minimisation problem (see the module documentation).
struct Problem<'a> {
    /// Points relative to the centre of mass, turned with the body (world frame).
    pts: &'a [[f64; 2]],
    /// Load share of a point (N).
    share: f64,
    /// `m / h`.
    al: f64,
    /// `I / h`.
    aa: f64,
    /// End twist without friction.
    free: [f64; 3],
}

impl Problem<'_> {
    fn phi(&self, x: [f64; 3]) -> f64 {
        let e2 = CREEP * CREEP;
        let mut d = 0.0;
        for &[px, py] in self.pts {
            let (ux, uy) = (x[0] - x[2] * py, x[1] + x[2] * px);
            d += (ux * ux + uy * uy + e2).sqrt();
        }
        self.value(x, d)
    }

    /// The objective at `x`, given `d`, the sum over the points of their smoothed speeds.
    fn value(&self, x: [f64; 3], d: f64) -> f64 {
        let (a, b, c) = (
            x[0] - self.free[0],
            x[1] - self.free[1],
            x[2] - self.free[2],
        );
        0.5 * self.al * (a * a + b * b) + 0.5 * self.aa * c * c + self.share * d
    }

    /// Value, gradient and Hessian at `x` from the sums over the points of their smoothed
    /// speeds (`d`), of those speeds' gradients (`g`) and of their Hessians (`h`).
    fn assemble(&self, x: [f64; 3], d: f64, g: [f64; 3], h: [f64; 6]) -> Eval {
        let (a, b, c) = (
            x[0] - self.free[0],
            x[1] - self.free[1],
            x[2] - self.free[2],
        );
        let k = self.share;
        let grad = [
            self.al * a + k * g[0],
            self.al * b + k * g[1],
            self.aa * c + k * g[2],
        ];
        let hess = [
            self.al + k * h[0],
            k * h[1],
            k * h[2],
            self.al + k * h[3],
            k * h[4],
            self.aa + k * h[5],
        ];
        (self.value(x, d), grad, hess)
    }

    /// Value, gradient and Hessian (xx, xy, xw, yy, yw, ww).
    fn eval(&self, x: [f64; 3]) -> Eval {
        let e2 = CREEP * CREEP;
        let (mut d, mut g, mut h) = (0.0, [0.0; 3], [0.0; 6]);
        // A few points at a time: their square roots and divisions first (independent of each
        // other, so the processor overlaps them), then the sums, in the points' order.
        for block in self.pts.chunks(LANES) {
            let mut u = [[0.0; 3]; LANES];
            for (uk, &[px, py]) in u.iter_mut().zip(block) {
                let (ux, uy) = (x[0] - x[2] * py, x[1] + x[2] * px);
                *uk = [ux, uy, (ux * ux + uy * uy + e2).sqrt()];
            }
            // All the lanes, so that the loop has a fixed length; past a short last block they
            // hold zeros, whose inverses are never read.
            let mut inv = [0.0; LANES];
            for (ik, uk) in inv.iter_mut().zip(&u) {
                *ik = 1.0 / uk[2];
            }
            for ((&p, &[ux, uy, s]), &inv) in block.iter().zip(&u).zip(&inv) {
                add_point(p, [ux, uy], s, inv, &mut d, &mut g, &mut h);
            }
        }
        self.assemble(x, d, g, h)
    }
}

/// Adds point `[px, py]` to the sums of the objective `d`, its gradient `g` and its Hessian `h`
/// (xx, xy, xw, yy, yw, ww), given its slip `u`, `s = |u|` (with the creep) and `inv = 1 / s`.
#[inline(always)]
fn add_point(
    [px, py]: [f64; 2],
    [ux, uy]: [f64; 2],
    s: f64,
    inv: f64,
    d: &mut f64,
    g: &mut [f64; 3],
    h: &mut [f64; 6],
) {
    *d += s;
    // d|u|/dxi = J^T u / s with J = [[1, 0, -py], [0, 1, px]].
    let (gx, gy) = (ux * inv, uy * inv);
    g[0] += gx;
    g[1] += gy;
    g[2] += px * gy - py * gx;
    // P = (I - u u^T / s^2) / s, then J^T P J.
    let (pxx, pxy, pyy) = ((1.0 - gx * gx) * inv, -gx * gy * inv, (1.0 - gy * gy) * inv);
    h[0] += pxx;
    h[1] += pxy;
    h[2] += -py * pxx + px * pxy;
    h[3] += pyy;
    h[4] += -py * pxy + px * pyy;
    h[5] += py * py * pxx - 2.0 * px * py * pxy + px * px * pyy;
}

/// Solves `H x = b` for a symmetric 3x3 `H` given as (xx, xy, xw, yy, yw, ww).
fn solve3(h: &[f64; 6], b: [f64; 3]) -> Option<[f64; 3]> {
    let [a, bxy, c, d, e, f] = *h;
    // Cofactors of [[a, bxy, c], [bxy, d, e], [c, e, f]].
    let c00 = d * f - e * e;
    let c01 = c * e - bxy * f;
    let c02 = bxy * e - c * d;
    let c11 = a * f - c * c;
    let c12 = bxy * c - a * e;
    let c22 = a * d - bxy * bxy;
    let det = a * c00 + bxy * c01 + c * c02;
    if !(det.abs() > 0.0) || !det.is_finite() {
        return None;
    }
    Some([
        (c00 * b[0] + c01 * b[1] + c02 * b[2]) / det,
        (c01 * b[0] + c11 * b[1] + c12 * b[2]) / det,
        (c02 * b[0] + c12 * b[1] + c22 * b[2]) / det,
    ])
}

/// Caps for holding the point `u` of the unit ball (`|u| <= 1`): along each axis, as far as the
/// ball reaches from `u` along that axis, `sqrt(u_i^2 + 1 - |u|^2)`. A wrench that differs from
/// the one held in one component is then held while it stays inside; the box's corners lie
/// outside, so a wrench that changes in several components at once may be held for one step too
/// many (never let go too early), after which the step sees it.
pub(super) fn hold_box<const N: usize>(u: [f32; N]) -> [f32; N] {
    let slack = (1.0 - u.iter().map(|x| x * x).sum::<f32>()).max(0.0);
    u.map(|x| (x * x + slack).sqrt())
}

#[cfg(test)]
mod tests {
    use super::*;

    fn square(side: f32, f_max: f32) -> Footprint {
        let h = side / 2.0;
        Footprint::sample(
            |p| p.x.abs() <= h && p.y.abs() <= h,
            Vec2::splat(-h),
            Vec2::splat(h),
            f_max,
        )
    }

    #[test]
    fn pure_translation_and_rotation_hit_the_axes() {
        let fp = square(0.5, 10.0);
        let (f, t) = fp.wrench(
            (1.0, 0.0),
            Twist {
                lin: Vec2::new(0.3, -0.4),
                ang: 0.0,
            },
        );
        assert!(
            (f.length() - 10.0).abs() < 1e-4 && t.abs() < 1e-4,
            "{f:?} {t}"
        );
        assert!((f.normalize() + Vec2::new(0.6, -0.8)).length() < 1e-5);
        let (f, t) = fp.wrench(
            (1.0, 0.0),
            Twist {
                lin: Vec2::ZERO,
                ang: 2.0,
            },
        );
        assert!(f.length() < 1e-4 && (t + fp.tau_max).abs() < 1e-4);
        // Mean distance of a square from its centre: side (sqrt 2 + ln(1 + sqrt 2)) / 6.
        let mean = 0.5 * (2f32.sqrt() + crate::ops::ln(1.0 + 2f32.sqrt())) / 6.0;
        assert!(
            (fp.tau_max / 10.0 - mean).abs() / mean < 0.01,
            "{}",
            fp.tau_max
        );
    }

    #[test]
    fn a_push_inside_the_surface_sticks_and_outside_slides() {
        let fp = square(0.5, 10.0);
        let (m, i, h) = (5.0, 5.0 * 0.25 / 6.0, 0.01);
        // A push of 9.9 N for one step from rest: sticks.
        let free = Twist {
            lin: Vec2::new(9.9 * h / m, 0.0),
            ang: 0.0,
        };
        let s = fp.step((1.0, 0.0), m, i, h, free, Twist::default());
        assert!(s.sticks && (s.force.x + 9.9).abs() < 1e-3, "{s:?}");
        // 10.1 N: slides, with exactly f_max against it and no torque.
        let free = Twist {
            lin: Vec2::new(10.1 * h / m, 0.0),
            ang: 0.0,
        };
        let s = fp.step((1.0, 0.0), m, i, h, free, Twist::default());
        assert!(
            !s.sticks && (s.force.x + 10.0).abs() < 1e-3 && s.torque.abs() < 1e-3,
            "{s:?}"
        );
        assert!((s.end.lin.x - 0.1 * h / m).abs() < 1e-6);
    }

    #[test]
    fn the_step_is_the_maximally_dissipative_wrench() {
        // A spinning, sliding box: the wrench matches the surface at the end twist.
        let fp = square(0.5, 10.0);
        let (m, i, h) = (5.0, 5.0 * 0.25 / 6.0, 0.01);
        let free = Twist {
            lin: Vec2::new(0.2, 0.1),
            ang: 1.5,
        };
        let s = fp.step((0.8, 0.6), m, i, h, free, Twist::default());
        assert!(!s.sticks);
        let (f, t) = fp.wrench((0.8, 0.6), s.end);
        assert!(
            (f - s.force).length() < 1e-3 && (t - s.torque).abs() < 1e-3,
            "{s:?} {f:?} {t}"
        );
    }

    /// [`Problem::eval`] with its sums taken as before it took the points in blocks: one point
    /// at a time.
    fn eval_point_by_point(prob: &Problem, x: [f64; 3]) -> Eval {
        let e2 = CREEP * CREEP;
        let (mut d, mut g, mut h) = (0.0, [0.0; 3], [0.0; 6]);
        for &[px, py] in prob.pts {
            let (ux, uy) = (x[0] - x[2] * py, x[1] + x[2] * px);
            let s = (ux * ux + uy * uy + e2).sqrt();
            add_point([px, py], [ux, uy], s, 1.0 / s, &mut d, &mut g, &mut h);
        }
        prob.assemble(x, d, g, h)
    }

    proptest::proptest! {
        /// Taking the points in blocks changes the order of no sum: the bits are those of the
        /// point-by-point loop, for any number of points (full and short blocks) and twist.
        #[test]
        fn blocked_evaluation_has_the_bits_of_the_point_by_point_loop(
            pts in proptest::collection::vec((-1.0f64..1.0, -1.0f64..1.0), 1..40),
            x in (-1.0f64..1.0, -1.0f64..1.0, -5.0f64..5.0),
            free in (-1.0f64..1.0, -1.0f64..1.0, -5.0f64..5.0),
        ) {
            let pts: Vec<[f64; 2]> = pts.into_iter().map(|(a, b)| [a, b]).collect();
            let prob = Problem {
                pts: &pts,
                share: 0.3,
                al: 500.0,
                aa: 20.0,
                free: [free.0, free.1, free.2],
            };
            let x = [x.0, x.1, x.2];
            let (v, g, h) = prob.eval(x);
            let (rv, rg, rh) = eval_point_by_point(&prob, x);
            proptest::prop_assert_eq!(v.to_bits(), rv.to_bits());
            proptest::prop_assert_eq!(g.map(f64::to_bits), rg.map(f64::to_bits));
            proptest::prop_assert_eq!(h.map(f64::to_bits), rh.map(f64::to_bits));
        }
    }

    #[test]
    fn hold_box_reaches_the_ball_along_each_axis() {
        let c = hold_box([0.6, 0.0, 0.0]);
        assert!((c[0] - 1.0).abs() < 1e-6 && (c[1] - 0.8).abs() < 1e-6);
        let c = hold_box([0.0, 0.0]);
        assert_eq!(c, [1.0, 1.0]);
    }
}
