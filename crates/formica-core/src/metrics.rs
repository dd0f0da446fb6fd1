//! Filling metrics: robots attached to the object, fill time, convexity of the pseudo object
//! (object plus attached robots), how much of the cavity they cover, how many robot discs fit
//! in the cavity and how many attached robots are in it or outside the object's hull; and the
//! `on_filled` stop rule.
//!
//! The **cavity** is the region between the object and its own convex hull. Areas are measured
//! by sampling a grid over the hull's bounding box: 5 mm, exact to well under 1 % for the seed's
//! shapes and robots, coarser for large objects so that no measurement takes more than about
//! [`MAX_AREA_SAMPLES`] samples. [`cavity_capacity`] packs robot discs into the cavity (see
//! there).

use crate::experiment::{LoopFunctions, Outcome, RunResult};
use crate::geometry::{bounds, convex_hull, Vec2};
use crate::ops;
use crate::scenario::Scenario;
use crate::world::World;
use rapier2d::parry::utils::point_in_convex_poly2d;

/// Finest grid step of the area sampling (m).
pub const AREA_STEP_M: f32 = 0.005;

/// Most grid samples one area measurement takes (the step grows for large objects).
pub const MAX_AREA_SAMPLES: f32 = 250_000.0;

/// Most points of one packing lattice over an object's hull: [`cavity_capacity`] estimates a
/// larger object's capacity from its area instead. Also the most cells or candidates of the
/// reach flood and of [`pack_deepest_first`]'s grid, which coarsen for large objects. (The
/// number of lattice trials is bounded by [`MAX_PACKING_WORK`] since results format 28.)
pub const MAX_PACKING_POINTS: usize = 400_000;

/// Most lattice points the trials of [`pack_discs`] examine together (each a disc test against
/// the object): above this, fewer rotations, offsets and edges are tried, so that a large
/// object's capacity takes seconds, not minutes. Objects up to about 8 m across (a Khepera
/// IV's radius) get every trial.
pub const MAX_PACKING_WORK: usize = 4_000_000;

/// Areas of the pseudo object (object + attached robots).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct FillAreas {
    /// Area of the union of the object and attached robots (m^2).
    pub pseudo: f64,
    /// Area of its convex hull (m^2).
    pub hull: f64,
    /// Area of the hull not covered by the object itself (the cavity) (m^2).
    pub cavity: f64,
    /// Part of the cavity covered by attached robots (m^2).
    pub cavity_covered: f64,
}

impl FillAreas {
    /// Area / hull area.
    pub fn convexity(&self) -> f64 {
        if self.hull > 0.0 {
            (self.pseudo / self.hull).min(1.0)
        } else {
            1.0
        }
    }
    /// Covered part of the cavity (1 when there is no cavity).
    pub fn cavity_filled(&self) -> f64 {
        if self.cavity > 1e-9 {
            self.cavity_covered / self.cavity
        } else {
            1.0
        }
    }
}

/// Robots attached to object `obj`: (centre, radius).
pub fn attached_discs(world: &World, obj: usize) -> Vec<(Vec2, f32)> {
    world
        .robots
        .iter()
        .enumerate()
        .filter(|(_, r)| r.attached.is_some_and(|(_, o)| o == obj))
        .map(|(i, _)| (world.robot_pose(i).position(), world.robot_model(i).radius))
        .collect()
}

/// Measures the pseudo object of object `obj` with the given discs attached. The cavity is the
/// part of the object's own convex hull outside the object (it moves with the object); the
/// convexity is measured on the pseudo object and the hull of the pseudo object.
pub fn fill_areas(world: &World, obj: usize, discs: &[(Vec2, f32)]) -> FillAreas {
    let mut pts: Vec<Vec2> = world.object_outlines(obj).into_iter().flatten().collect();
    let object_hull = convex_hull(&pts);
    for (c, r) in discs {
        for k in 0..24 {
            let a = std::f32::consts::TAU * k as f32 / 24.0;
            pts.push(*c + ops::unit(a) * *r);
        }
    }
    let hull = convex_hull(&pts);
    let (lo, hi) = bounds(&hull);
    let body = world.objects[obj].body;
    let extent = (hi - lo).max(Vec2::splat(1e-3));
    let step = AREA_STEP_M.max((extent.x * extent.y / MAX_AREA_SAMPLES).sqrt());
    let cell = f64::from(step) * f64::from(step);
    let nx = ((hi.x - lo.x) / step).ceil() as usize;
    let ny = ((hi.y - lo.y) / step).ceil() as usize;
    let mut a = FillAreas {
        pseudo: 0.0,
        hull: 0.0,
        cavity: 0.0,
        cavity_covered: 0.0,
    };
    for iy in 0..ny {
        for ix in 0..nx {
            let p = Vec2::new(
                lo.x + (ix as f32 + 0.5) * step,
                lo.y + (iy as f32 + 0.5) * step,
            );
            if !point_in_convex_poly2d(p, &hull) {
                continue;
            }
            a.hull += cell;
            let in_obj = world.physics.contains(body, p);
            let in_robot = discs
                .iter()
                .any(|(c, r)| (p - *c).length_squared() <= r * r);
            if in_obj || in_robot {
                a.pseudo += cell;
            }
            if !in_obj && point_in_convex_poly2d(p, &object_hull) {
                a.cavity += cell;
                if in_robot {
                    a.cavity_covered += cell;
                }
            }
        }
    }
    a
}

/// The object's convex hull in the world frame (counter-clockwise).
pub fn object_hull(world: &World, obj: usize) -> Vec<Vec2> {
    let pts: Vec<Vec2> = world.object_outlines(obj).into_iter().flatten().collect();
    convex_hull(&pts)
}

/// Signed distance from `p` to the inside of the convex polygon `hull` (counter-clockwise):
/// positive inside (the distance to the nearest edge line), negative outside.
fn inside_depth(hull: &[Vec2], p: Vec2) -> f32 {
    let n = hull.len();
    if n < 3 {
        return f32::NEG_INFINITY;
    }
    let mut depth = f32::INFINITY;
    for i in 0..n {
        let (a, b) = (hull[i], hull[(i + 1) % n]);
        let e = b - a;
        let len = e.length();
        if len < 1e-9 {
            continue;
        }
        // Left of a counter-clockwise edge is inside.
        let d = (e.x * (p.y - a.y) - e.y * (p.x - a.x)) / len;
        depth = depth.min(d);
    }
    depth
}

/// Slack (m) of [`disc_in_cavity`]: how far a disc may reach past the hull or into the object
/// and still count (the contact solver lets bodies overlap by a millimetre or so).
pub const CAVITY_SLACK_M: f32 = 0.002;

/// Whether a disc of `radius` centred at `p` lies in the cavity of object `obj`: inside the
/// object's hull and not overlapping the object, each within [`CAVITY_SLACK_M`]. The one test
/// of both `cavity_capacity` (lattice discs) and `cavity_robots` (attached robots).
pub fn disc_in_cavity(world: &World, obj: usize, hull: &[Vec2], p: Vec2, radius: f32) -> bool {
    let r = radius - CAVITY_SLACK_M;
    if inside_depth(hull, p) < r {
        return false;
    }
    // An intersection test, not a point projection: a concave polygon is cut into convex
    // pieces, and at a point on a piece's edge (within rounding) the projection can land on
    // a far vertex, letting a disc centred on the object's boundary count as fitting.
    !world.physics.disc_meets(world.objects[obj].body, p, r)
}

/// How many robot discs of `radius` fit in the cavity of object `obj`: discs inside the
/// object's hull, overlapping neither the object nor each other ([`disc_in_cavity`], the test
/// by which `cavity_robots` counts attached robots, so that the two count the same thing).
/// Computed by lattice packing
/// ([`pack_discs`]): hexagonal and square lattices of spacing `2 radius`, laid at 12 rotations
/// and 16 offsets, and laid along every edge of the object and its hull with the first row
/// touching that edge (fewer rotations, offsets and edges for objects over about 8 m:
/// [`MAX_PACKING_WORK`]), and by a greedy packing deepest in the hull first
/// ([`pack_deepest_first`], which also finds pockets smaller than its grid); the best count is
/// kept. A lower bound of the best packing (the tests
/// check it on cavities counted by hand); a cavity narrower than a robot has capacity 0. Only
/// discs a robot can reach from outside count: room behind a mouth narrower than a robot, or
/// inside a closed ring of parts, holds none (see `Reach`: to within 7 mm for a Khepera IV).
///
/// An object so large that one lattice over its hull would have more than
/// [`MAX_PACKING_POINTS`] points (its cavity would hold some hundred thousand robots) is not
/// packed: its capacity is estimated as the cavity's area over the area each disc takes in a
/// hexagonal packing (`2 sqrt(3) radius^2`), so that the cost stays bounded.
pub fn cavity_capacity(world: &World, obj: usize, radius: f32) -> usize {
    let hull = object_hull(world, obj);
    if !(radius > 0.0) || hull.len() < 3 {
        return 0;
    }
    let (lo, hi) = bounds(&hull);
    let per_axis = f64::from((hi - lo).length() + 4.0 * radius) / f64::from(2.0 * radius) + 1.0;
    if per_axis * per_axis > MAX_PACKING_POINTS as f64 {
        let cavity = fill_areas(world, obj, &[]).cavity;
        let per_disc = 2.0 * 3f64.sqrt() * f64::from(radius) * f64::from(radius);
        return (cavity / per_disc).floor() as usize;
    }
    let reach = Reach::new(world, obj, &hull, radius);
    let fits = |p: Vec2| disc_in_cavity(world, obj, &hull, p, radius) && reach.contains(p);
    let mut edges: Vec<(Vec2, Vec2)> = Vec::new();
    for ring in world
        .object_outlines(obj)
        .iter()
        .chain(std::iter::once(&hull))
    {
        for i in 0..ring.len() {
            edges.push((ring[i], ring[(i + 1) % ring.len()]));
        }
    }
    let body = world.objects[obj].body;
    let clearance = |p: Vec2| world.physics.distance_to(body, p) - (radius - CAVITY_SLACK_M);
    pack_discs(&hull, radius, &edges, fits).max(pack_deepest_first(&hull, radius, clearance, fits))
}

/// Where a robot disc of some radius can go from outside an object's hull without meeting
/// the object: a grid of cells (a tenth of the radius, coarser for large objects: at most about
/// [`MAX_PACKING_POINTS`] cells) over the hull's box and a margin, flooded (4 neighbours) from
/// its border through cells where the disc, less [`CAVITY_SLACK_M`] and the step times
/// `sqrt(1/2)`, is clear of the object. That allowance makes the flood never shut a way that a
/// disc less the slack could take (every cell the way crosses is that close to it), and lets
/// through gaps narrower than the disc by at most the slack plus 0.71 of a step (7 mm for a
/// Khepera IV).
struct Reach {
    lo: Vec2,
    step: f32,
    nx: usize,
    ny: usize,
    open: Vec<bool>,
}

impl Reach {
    fn new(world: &World, obj: usize, hull: &[Vec2], radius: f32) -> Self {
        let (lo, hi) = bounds(hull);
        let step0 = 0.1 * radius;
        let margin = radius + 2.0 * step0;
        let (lo, hi) = (lo - Vec2::splat(margin), hi + Vec2::splat(margin));
        let extent = hi - lo;
        let step = step0
            .max((extent.x * extent.y / MAX_PACKING_POINTS as f32).sqrt())
            .max(1e-6);
        let (nx, ny) = (
            (extent.x / step).ceil() as usize + 1,
            (extent.y / step).ceil() as usize + 1,
        );
        let clear_r = (radius - CAVITY_SLACK_M - step * std::f32::consts::FRAC_1_SQRT_2).max(1e-5);
        let body = world.objects[obj].body;
        let at = |ix: usize, iy: usize| lo + Vec2::new(ix as f32 * step, iy as f32 * step);
        // Free: the centre lies farther outside the hull than the disc reaches (nothing of the
        // object there), or the shrunk disc misses the object.
        let free = |p: Vec2| {
            inside_depth(hull, p) < -(clear_r + 1e-4) || !world.physics.disc_meets(body, p, clear_r)
        };
        let mut open = vec![false; nx * ny];
        let mut seen = vec![false; nx * ny];
        let mut stack: Vec<(usize, usize)> = Vec::new();
        for iy in 0..ny {
            for ix in 0..nx {
                if ix == 0 || iy == 0 || ix + 1 == nx || iy + 1 == ny {
                    seen[iy * nx + ix] = true;
                    stack.push((ix, iy));
                }
            }
        }
        while let Some((ix, iy)) = stack.pop() {
            if !free(at(ix, iy)) {
                continue;
            }
            open[iy * nx + ix] = true;
            let mut visit = |jx: usize, jy: usize| {
                let k = jy * nx + jx;
                if !seen[k] {
                    seen[k] = true;
                    stack.push((jx, jy));
                }
            };
            if ix > 0 {
                visit(ix - 1, iy);
            }
            if ix + 1 < nx {
                visit(ix + 1, iy);
            }
            if iy > 0 {
                visit(ix, iy - 1);
            }
            if iy + 1 < ny {
                visit(ix, iy + 1);
            }
        }
        Self {
            lo,
            step,
            nx,
            ny,
            open,
        }
    }

    /// Whether the cell nearest to `p` is reached (points off the grid are outside the hull:
    /// reached).
    fn contains(&self, p: Vec2) -> bool {
        let g = (p - self.lo) / self.step;
        let (ix, iy) = (g.x.round(), g.y.round());
        if !(ix >= 0.0 && iy >= 0.0 && (ix as usize) < self.nx && (iy as usize) < self.ny) {
            return true;
        }
        self.open[iy as usize * self.nx + ix as usize]
    }
}

/// Greedy packing of discs of `radius` into the convex region `hull`, where `fits` says
/// whether a disc centred at a point is allowed: candidate centres on a grid of a quarter
/// radius (coarser for large regions, at most about [`MAX_PACKING_POINTS`] candidates), taken
/// deepest inside `hull` first, each kept when it fits and is clear of those kept. Where the
/// cavity is a ring of separate pockets (between a star's points) no lattice puts a disc in
/// each; this does, deepest first, as robots fill them.
///
/// `clearance` says how far a disc centred at a point is from meeting what it must not (for a
/// cavity, the centre's distance to the object less the disc's radius): at least 0 where the
/// disc fits, and changing by no more than the distance moved, or an upper bound of such a
/// function. Where no grid point of a cell fits, the cell is searched by halving (down to a
/// quarter of a millimetre), skipping every part where the clearance, or the depth inside
/// `hull`, shows nothing can fit: a pocket whose room for a centre is smaller than the grid,
/// which a robot creeping into it finds, is found too. The count is the larger of the packings
/// with and without these points.
pub fn pack_deepest_first(
    hull: &[Vec2],
    radius: f32,
    clearance: impl Fn(Vec2) -> f32,
    fits: impl Fn(Vec2) -> bool,
) -> usize {
    if hull.len() < 3 || !(radius > 0.0) {
        return 0;
    }
    let (lo, hi) = bounds(hull);
    let extent = hi - lo;
    let step = (0.25 * radius)
        .max((extent.x * extent.y / MAX_PACKING_POINTS as f32).sqrt())
        .max(1e-6);
    let (nx, ny) = (
        (extent.x / step).ceil() as usize + 1,
        (extent.y / step).ceil() as usize + 1,
    );
    let need = radius - CAVITY_SLACK_M;
    let ok = |p: Vec2| inside_depth(hull, p) >= need && fits(p);
    // How far a disc at `p` is from fitting; far outside the hull, the hull alone (an upper
    // bound, and cheap).
    let margin = |p: Vec2| {
        let d = inside_depth(hull, p) - need;
        if d < -radius {
            d
        } else {
            d.min(clearance(p))
        }
    };
    let mut on_grid: Vec<(f32, Vec2)> = Vec::new();
    let mut found: Vec<(f32, Vec2)> = Vec::new();
    for iy in 0..ny {
        for ix in 0..nx {
            let p = lo + Vec2::new(ix as f32 * step, iy as f32 * step);
            let depth = inside_depth(hull, p);
            if depth >= need && fits(p) {
                on_grid.push((depth, p));
            } else if let Some(q) = room_in_cell(p, 0.5 * step, &margin, &ok) {
                found.push((inside_depth(hull, q), q));
            }
        }
    }
    let greedy = |mut candidates: Vec<(f32, Vec2)>| {
        // Deepest first; ties in grid order (the sort is stable).
        candidates.sort_by(|a, b| b.0.total_cmp(&a.0));
        let gap = 2.0 * radius * (1.0 + 1e-4);
        // Kept discs by cell of side `gap`: a disc nearer than `gap` lies in one of the nine
        // cells around (a large cavity keeps thousands; comparing each candidate with every
        // one kept took minutes).
        let cell = |p: Vec2| ((p.x / gap).floor() as i64, (p.y / gap).floor() as i64);
        let mut kept: std::collections::HashMap<(i64, i64), Vec<Vec2>> = Default::default();
        let mut count = 0;
        for (_, p) in candidates {
            let (cx, cy) = cell(p);
            let clear = (cx - 1..=cx + 1).all(|x| {
                (cy - 1..=cy + 1).all(|y| {
                    kept.get(&(x, y))
                        .is_none_or(|qs| qs.iter().all(|q| (p - *q).length() >= gap))
                })
            });
            if clear {
                kept.entry((cx, cy)).or_default().push(p);
                count += 1;
            }
        }
        count
    };
    if found.is_empty() {
        return greedy(on_grid);
    }
    let plain = greedy(on_grid.clone());
    on_grid.extend(found);
    plain.max(greedy(on_grid))
}

/// Smallest half-side (m) of a cell that [`room_in_cell`] splits.
const ROOM_CELL_M: f32 = 2.5e-4;

/// A point of the square of half-side `half` around `c` where a disc fits (`fits`), searched
/// by splitting the square in four, depth first; a square whose centre's `margin` is below
/// `-half sqrt 2` holds none (`margin` changes by no more than the distance moved).
fn room_in_cell(
    c: Vec2,
    half: f32,
    margin: &impl Fn(Vec2) -> f32,
    fits: &impl Fn(Vec2) -> bool,
) -> Option<Vec2> {
    let m = margin(c);
    if !(m >= -half * std::f32::consts::SQRT_2) {
        return None;
    }
    if m >= 0.0 && fits(c) {
        return Some(c);
    }
    if half < ROOM_CELL_M {
        return None;
    }
    let q = 0.5 * half;
    [(-q, -q), (q, -q), (-q, q), (q, q)]
        .into_iter()
        .find_map(|(dx, dy)| room_in_cell(c + Vec2::new(dx, dy), q, margin, fits))
}

/// Lattice packing of discs of `radius` into the convex region `hull`, where `fits` says
/// whether a disc centred at a point is allowed: the best of lattices at general rotations and
/// offsets and of lattices whose rows run along one of `edges`, the first row `radius` from it.
/// Bounded cost: trials thin out so that no more than about [`MAX_PACKING_WORK`] lattice
/// points are examined in all (or, for the largest lattices, the fewest trials: two general
/// lattices and four edges).
pub fn pack_discs(
    hull: &[Vec2],
    radius: f32,
    edges: &[(Vec2, Vec2)],
    fits: impl Fn(Vec2) -> bool,
) -> usize {
    if hull.len() < 3 || !(radius > 0.0) {
        return 0;
    }
    let (lo, hi) = bounds(hull);
    let centre = (lo + hi) * 0.5;
    let half_diag = (hi - lo).length() * 0.5 + 2.0 * radius;
    let d = 2.0 * radius * (1.0 + 1e-4);
    let per_axis = (2.0 * half_diag / d).ceil() as i64 + 1;
    let points = (per_axis * per_axis) as usize;
    // 2 lattices x (12 rotations x 16 offsets, and 16 slides either side of up to 64 edges);
    // fewer if the lattice is large.
    // The fewest trials run whatever the work, so that every object gets a packing.
    let all_edges = edges.len().min(64);
    let fewest = (1, 1, edges.len().min(4), 2);
    let (rotations, offsets, edge_count, along) = [(12, 4, all_edges, 16), (6, 2, all_edges, 16)]
        .into_iter()
        .find(|&(r, o, e, a)| points * 2 * (r * o * o + 2 * e * a) <= MAX_PACKING_WORK)
        .unwrap_or(fewest);
    let count = |hex: bool, t: f32, o: Vec2| {
        let (skew, row) = if hex {
            (0.5 * d, d * 0.866_025_4)
        } else {
            (0.0, d)
        };
        let (u, v) = (ops::unit(t), ops::unit(t + std::f32::consts::FRAC_PI_2));
        // Lattice rows through `o`, covering the hull's bounding circle.
        let shift_o = o - centre;
        let (j0, i0) = (
            (shift_o.dot(v) / row).round() as i64,
            (shift_o.dot(u) / d).round() as i64,
        );
        let mut n = 0;
        for j in -per_axis / 2 - 1..=per_axis / 2 + 1 {
            let shift = if j.rem_euclid(2) == 1 { skew } else { 0.0 };
            for i in -per_axis / 2 - 1..=per_axis / 2 + 1 {
                let p = o + u * (d * (i - i0) as f32 + shift) + v * (row * (j - j0) as f32);
                if (p - centre).length() <= half_diag && fits(p) {
                    n += 1;
                }
            }
        }
        n
    };
    let mut best = 0;
    for hex in [true, false] {
        let sector = if hex {
            std::f32::consts::FRAC_PI_3
        } else {
            std::f32::consts::FRAC_PI_2
        };
        let row = if hex { d * 0.866_025_4 } else { d };
        for k in 0..rotations {
            let t = sector * k as f32 / rotations as f32;
            let (u, v) = (ops::unit(t), ops::unit(t + std::f32::consts::FRAC_PI_2));
            for ox in 0..offsets {
                for oy in 0..offsets {
                    let o = centre
                        + u * (d * ox as f32 / offsets as f32)
                        + v * (row * oy as f32 / offsets as f32);
                    best = best.max(count(hex, t, o));
                }
            }
        }
        // Rows along an edge, the first `radius` inside it (either side), slid along it.
        for &(a, b) in edges.iter().take(edge_count) {
            let e = b - a;
            if e.length() < 1e-6 {
                continue;
            }
            let t = ops::angle_of(e);
            let (u, v) = (ops::unit(t), ops::unit(t + std::f32::consts::FRAC_PI_2));
            for side in [1.0f32, -1.0] {
                for k in 0..along {
                    let o = a + v * (side * radius) + u * (d * k as f32 / along as f32);
                    best = best.max(count(hex, t, o));
                }
            }
        }
    }
    best
}

/// Where the attached robots of an object lie against its cavity.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct AttachedPlaces {
    /// Robots whose discs lie in the cavity (inside the hull, by the test [`disc_in_cavity`]
    /// that `cavity_capacity` packs with): `cavity_robots`.
    pub inside: usize,
    /// Robots whose centre lies in the cavity (inside the hull, outside the object):
    /// `cavity_centres`, `cavity_robots` as issue 11 first defined it. A robot astride the
    /// cavity's mouth counts, so this can exceed `cavity_capacity`.
    pub centred: usize,
    /// Robots outside the hull (false stops): more than half outside, their centre beyond the
    /// hull by more than half their radius. A robot touching the outside of the hull (the
    /// seed's false stop against a U's back wall) is one; a robot astride the mouth of a
    /// cavity is not.
    pub outside: usize,
}

/// Counts the attached robots of object `obj` by where they lie (see [`AttachedPlaces`]).
pub fn classify_attached(world: &World, obj: usize) -> AttachedPlaces {
    let hull = object_hull(world, obj);
    let body = world.objects[obj].body;
    let mut out = AttachedPlaces::default();
    for (c, r) in attached_discs(world, obj) {
        let depth = inside_depth(&hull, c);
        if depth > 0.0 && !world.physics.contains(body, c) {
            out.centred += 1;
        }
        if disc_in_cavity(world, obj, &hull, c, r) {
            out.inside += 1;
        } else if depth < -0.5 * r {
            out.outside += 1;
        }
    }
    out
}

/// Filling metrics and the `on_filled` stop rule.
pub struct FillHooks {
    on_filled: Option<f32>,
    before: Option<f64>,
    concave: bool,
    /// Robot discs that fit in the cavity at the start (the object is rigid: it stays so).
    capacity: Option<usize>,
}

impl FillHooks {
    /// Hooks for a world built from `sc`; measures the object's convexity at the start.
    pub fn new(sc: &Scenario, world: &World) -> Self {
        let before = world.target.map(|t| fill_areas(world, t, &[]).convexity());
        let concave = before.is_some_and(|c| c < 0.995);
        // The smallest robot of the scenario: its discs fit best.
        let radius = world
            .groups
            .iter()
            .map(|g| g.model.radius)
            .fold(f32::INFINITY, f32::min);
        let capacity = match world.target {
            Some(t) if concave && radius.is_finite() => Some(cavity_capacity(world, t, radius)),
            Some(_) => Some(0),
            None => None,
        };
        Self {
            on_filled: sc.spec.stop.on_filled,
            before,
            concave,
            capacity,
        }
    }

    /// Robots attached to object `obj` (the pseudo object's robots).
    fn attached(world: &World, obj: usize) -> usize {
        world
            .robots
            .iter()
            .filter(|r| r.attached.is_some_and(|(_, o)| o == obj))
            .count()
    }
}

impl LoopFunctions for FillHooks {
    fn is_finished(&self, world: &World) -> Option<Outcome> {
        let frac = self.on_filled?;
        let t = world.target?;
        let all_released = world.released() == world.robots.len();
        let n = world.robots.len().max(1) as f32;
        (all_released && Self::attached(world, t) as f32 / n >= frac).then_some(Outcome::Success)
    }

    fn finish(&self, world: &World, r: &mut RunResult) {
        let Some(t) = world.target else { return };
        let attached = Self::attached(world, t);
        if !self.concave && attached == 0 && self.on_filled.is_none() {
            return;
        }
        let discs = attached_discs(world, t);
        let after = fill_areas(world, t, &discs);
        r.object_robots = Some(attached);
        r.fill_time_s = world
            .robots
            .iter()
            .filter(|r| r.attached.is_some_and(|(_, o)| o == t))
            .filter_map(|r| r.attached_at_s)
            .fold(None, |m: Option<f32>, x| Some(m.map_or(x, |m| m.max(x))))
            .map(f64::from);
        r.convexity_before = self.before;
        r.convexity_after = Some(after.convexity());
        r.cavity_filled = Some(after.cavity_filled());
        let places = classify_attached(world, t);
        r.cavity_capacity = self.capacity;
        r.cavity_robots = Some(places.inside);
        r.false_stops = Some(places.outside);
        r.extra.insert(
            "cavity_centres".into(),
            serde_json::Value::from(places.centred),
        );
    }
}
