//! Plane geometry: poses, angles, shape descriptions and polygon checks.
//!
//! Lengths are metres, angles radians unless a name says `_deg`. The heavy lifting (convex
//! decomposition, hulls, point tests) is done by parry2d; this module only adapts it to the
//! shapes that scenario files describe.

use crate::limits::MIN_SIZE_M;
use crate::ops;
use rapier2d::parry::shape::{Compound, SharedShape, TriMesh};
use rapier2d::parry::transformation::convex_hull as convex_hull2;
use serde::{Deserialize, Serialize};

/// A 2D vector in metres (re-exported from the physics engine's math library).
pub type Vec2 = rapier2d::math::Vector;

/// Position and heading of something on the floor.
#[derive(Debug, Clone, Copy, PartialEq, Default, Serialize, Deserialize)]
pub struct Pose {
    /// x in metres.
    pub x: f32,
    /// y in metres.
    pub y: f32,
    /// Heading in radians, counter-clockwise from +x.
    pub theta: f32,
}

impl Pose {
    /// Builds a pose from a position and heading.
    pub fn new(x: f32, y: f32, theta: f32) -> Self {
        Self { x, y, theta }
    }
    /// The position as a vector.
    pub fn position(&self) -> Vec2 {
        Vec2::new(self.x, self.y)
    }
    /// Transforms a point given in this pose's frame to the world frame.
    pub fn world_from_local(&self, p: Vec2) -> Vec2 {
        let (s, c) = ops::sin_cos(self.theta);
        Vec2::new(self.x + c * p.x - s * p.y, self.y + s * p.x + c * p.y)
    }
    /// Transforms a world point into this pose's frame.
    pub fn local_from_world(&self, p: Vec2) -> Vec2 {
        let (s, c) = ops::sin_cos(self.theta);
        let d = Vec2::new(p.x - self.x, p.y - self.y);
        Vec2::new(c * d.x + s * d.y, -s * d.x + c * d.y)
    }
}

/// Wraps an angle to (-pi, pi].
pub fn wrap_angle(a: f32) -> f32 {
    let two_pi = std::f32::consts::TAU;
    // `a % 2 pi` is `a` itself when |a| < 2 pi (the remainder is exact), which is nearly every
    // call: skipping the division is the same bits, and 2 % of a tick fewer instructions.
    let mut r = if a.abs() < two_pi { a } else { a % two_pi };
    if r > std::f32::consts::PI {
        r -= two_pi;
    } else if r <= -std::f32::consts::PI {
        r += two_pi;
    }
    r
}

/// A primitive shape, in its own frame (centred on its origin).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case", deny_unknown_fields)]
pub enum Primitive {
    /// An axis-aligned box `[width, depth]`, centred.
    Box([f32; 2]),
    /// A disc of the given radius.
    Disc(f32),
    /// A simple polygon (concave allowed), vertices in order, at least 3. A vertex that repeats
    /// the one before it (as the closing vertex of many exported outlines does) or lies on the
    /// straight edge between its neighbours is dropped ([`polygon_vertices`]).
    Polygon(Vec<[f32; 2]>),
    /// A regular polygon: `{ sides = 6, radius = 0.3 }` (circumradius).
    Regular {
        /// Number of sides (3 or more).
        sides: u32,
        /// Distance from centre to each vertex.
        radius: f32,
    },
}

/// One part of a composite shape, placed in the object's frame.
#[derive(Debug, Clone, PartialEq)]
pub struct Part {
    /// The part's shape.
    pub shape: Primitive,
    /// Offset of the part's centre from the object's origin.
    pub at: [f32; 2],
    /// Rotation of the part, in degrees.
    pub yaw_deg: f32,
}

impl Part {
    /// Where the part sits in the object's frame, as the collision engine takes it.
    fn placement(&self) -> rapier2d::math::Pose {
        rapier2d::math::Pose::new(Vec2::new(self.at[0], self.at[1]), self.yaw_deg.to_radians())
    }
}

/// A geometry error, described for humans.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[error("{0}")]
pub struct ShapeError(pub String);

impl Primitive {
    /// Checks the primitive is well formed: sizes of at least [`MIN_SIZE_M`], a simple
    /// polygon (once repeated vertices and vertices on a straight edge are dropped: no
    /// crossing edges, no spike of no width), regular polygons with sides of at least
    /// [`MIN_SIZE_M`].
    pub fn validate(&self) -> Result<(), ShapeError> {
        let min = MIN_SIZE_M;
        match self {
            Primitive::Box([w, h]) => {
                if !(*w >= min && *h >= min && w.is_finite() && h.is_finite()) {
                    return Err(ShapeError(format!(
                        "box size must be two numbers of at least {min} m, got [{w}, {h}]"
                    )));
                }
            }
            Primitive::Disc(r) => {
                if !(*r >= min && r.is_finite()) {
                    return Err(ShapeError(format!(
                        "disc radius must be at least {min} m, got {r}"
                    )));
                }
            }
            Primitive::Polygon(v) => check_simple_polygon(&polygon_vertices(v))?,
            Primitive::Regular { sides, radius } => {
                let side = 2.0 * radius * ops::sin(std::f32::consts::PI / *sides.max(&1) as f32);
                if *sides < 3 || !(*radius >= min && radius.is_finite() && side >= min) {
                    return Err(ShapeError(format!(
                        "regular polygon needs sides >= 3, radius >= {min} m and sides at least \
                         {min} m long, got sides = {sides}, radius = {radius}"
                    )));
                }
            }
        }
        Ok(())
    }

    /// The outline of the primitive as a counter-clockwise polygon (discs approximated with
    /// `disc_segments` vertices).
    pub fn outline(&self, disc_segments: usize) -> Vec<Vec2> {
        match self {
            Primitive::Box([w, h]) => {
                let (a, b) = (w / 2.0, h / 2.0);
                vec![
                    Vec2::new(-a, -b),
                    Vec2::new(a, -b),
                    Vec2::new(a, b),
                    Vec2::new(-a, b),
                ]
            }
            Primitive::Disc(r) => regular_outline(disc_segments, *r),
            Primitive::Polygon(v) => {
                let mut pts = polygon_vertices(v);
                if signed_area(&pts) < 0.0 {
                    pts.reverse();
                }
                pts
            }
            Primitive::Regular { sides, radius } => regular_outline(*sides as usize, *radius),
        }
    }

    /// The collision shape of this primitive.
    pub fn shared_shape(&self) -> Result<SharedShape, ShapeError> {
        self.validate()?;
        // The validator should let nothing through that parry cannot take; should it still
        // panic (hull, triangulation, decomposition), the panic becomes an input error.
        no_panic("the shape", || self.shared_shape_unchecked())?
    }

    fn shared_shape_unchecked(&self) -> Result<SharedShape, ShapeError> {
        Ok(match self {
            Primitive::Box([w, h]) => SharedShape::cuboid(w / 2.0, h / 2.0),
            Primitive::Disc(r) => SharedShape::ball(*r),
            Primitive::Regular { .. } => convex_shape(self.outline(0))
                .ok_or_else(|| ShapeError("degenerate regular polygon".into()))?,
            Primitive::Polygon(_) => {
                let pts = self.outline(0);
                if is_convex(&pts) {
                    convex_shape(pts).ok_or_else(|| ShapeError("degenerate polygon".into()))?
                } else {
                    let mesh = TriMesh::from_polygon(pts)
                        .ok_or_else(|| ShapeError("polygon could not be triangulated".into()))?;
                    // parry merges the triangles into convex parts and drops a part's vertices
                    // where its sides turn by less than about 1.5 deg, failing when too few are
                    // left (a gear of 600 teeth): then the triangles themselves are the parts.
                    let compound = Compound::decompose_trimesh(&mesh).unwrap_or_else(|| {
                        Compound::new(
                            mesh.triangles()
                                .map(|t| (Default::default(), SharedShape::new(t)))
                                .collect(),
                        )
                    });
                    SharedShape::new(compound)
                }
            }
        })
    }
}

/// A convex polygon's collision shape from its counter-clockwise outline. parry drops vertices
/// where the sides turn by less than about 1.5 deg and gives up when fewer than three are left
/// (a regular polygon of 240 sides, a triangle 3 mm high on a 0.5 m base); the outline is then
/// taken as it is.
fn convex_shape(pts: Vec<Vec2>) -> Option<SharedShape> {
    SharedShape::convex_polyline(pts.clone())
        .or_else(|| SharedShape::convex_polyline_unmodified(pts))
}

/// A polygon's vertices as the shape uses them: a vertex within [`MIN_SIZE_M`] of the one
/// kept before it is dropped (a repeated vertex, or an outline closed by repeating its first),
/// and so is one that lies on the straight edge between its neighbours (it turns the outline
/// by nothing: within the collinearity test of [`check_simple_polygon`], going on the same
/// way). A vertex that folds the outline back on itself (a spike of no width) is kept, for the
/// check to refuse.
pub fn polygon_vertices(v: &[[f32; 2]]) -> Vec<Vec2> {
    let mut pts: Vec<Vec2> = Vec::with_capacity(v.len());
    for p in v.iter().map(|p| Vec2::new(p[0], p[1])) {
        // (Not `>=`: a non-finite vertex is kept, for the check to refuse.)
        if pts.last().is_none_or(|q| !((p - *q).length() < MIN_SIZE_M)) {
            pts.push(p);
        }
    }
    while pts.len() > 3 && (pts[0] - pts[pts.len() - 1]).length() < MIN_SIZE_M {
        pts.pop();
    }
    let n = pts.len();
    if n < 3 {
        // Fewer than three distinct vertices: as given, for the check to name the ones that
        // coincide.
        return v.iter().map(|p| Vec2::new(p[0], p[1])).collect();
    }
    if n == 3 || pts.iter().any(|p| !p.is_finite()) {
        return pts;
    }
    let straight = |i: usize| {
        let (a, b, c) = (pts[(i + n - 1) % n], pts[i], pts[(i + 1) % n]);
        collinear(a, b, c) && (b - a).dot(c - b) > 0.0
    };
    let kept: Vec<Vec2> = (0..n).filter(|&i| !straight(i)).map(|i| pts[i]).collect();
    // Every vertex on one line: no polygon; leave them for the check to refuse.
    if kept.len() < 3 {
        pts
    } else {
        kept
    }
}

fn regular_outline(n: usize, r: f32) -> Vec<Vec2> {
    (0..n)
        .map(|i| {
            let a = std::f32::consts::TAU * i as f32 / n as f32;
            Vec2::new(r * ops::cos(a), r * ops::sin(a))
        })
        .collect()
}

/// Runs `f`, turning a panic inside it (in parry) into a [`ShapeError`] about `what`.
fn no_panic<T>(what: &str, f: impl FnOnce() -> T) -> Result<T, ShapeError> {
    std::panic::catch_unwind(std::panic::AssertUnwindSafe(f))
        .map_err(|_| ShapeError(format!("{what} is too degenerate for the collision engine")))
}

/// Builds one collision shape from parts placed in a common frame.
pub fn compound_shape(parts: &[Part]) -> Result<SharedShape, ShapeError> {
    no_panic("the object", || compound_shape_unchecked(parts))?
}

fn compound_shape_unchecked(parts: &[Part]) -> Result<SharedShape, ShapeError> {
    if parts.is_empty() {
        return Err(ShapeError("an object needs at least one part".into()));
    }
    if parts.len() == 1 && parts[0].at == [0.0, 0.0] && parts[0].yaw_deg == 0.0 {
        return parts[0].shape.shared_shape();
    }
    let mut shapes = Vec::with_capacity(parts.len());
    for p in parts {
        let s = p.shape.shared_shape()?;
        let pose = p.placement();
        // A compound cannot nest a compound: flatten concave polygons.
        if let Some(c) = s.as_compound() {
            for (sub_pose, sub) in c.shapes() {
                shapes.push((pose * *sub_pose, sub.clone()));
            }
        } else {
            shapes.push((pose, s));
        }
    }
    Ok(SharedShape::compound(shapes))
}

/// Outlines of every part, in the common frame (discs with `disc_segments` vertices).
pub fn part_outlines(parts: &[Part], disc_segments: usize) -> Vec<Vec<Vec2>> {
    parts
        .iter()
        .map(|p| {
            let pose = Pose::new(p.at[0], p.at[1], p.yaw_deg.to_radians());
            p.shape
                .outline(disc_segments)
                .into_iter()
                .map(|v| pose.world_from_local(v))
                .collect()
        })
        .collect()
}

/// The corners `(min, max)` of the axis-aligned box round `pts` (`(MAX, MIN)` for none).
pub fn bounds<'a>(pts: impl IntoIterator<Item = &'a Vec2>) -> (Vec2, Vec2) {
    pts.into_iter().fold(
        (Vec2::splat(f32::MAX), Vec2::splat(f32::MIN)),
        |(lo, hi), p| (lo.min(*p), hi.max(*p)),
    )
}

/// Convex pieces covering a part, counter-clockwise, in the common frame: a convex primitive
/// is one piece, a concave polygon the convex pieces of the collision engine's decomposition,
/// and a disc the regular polygon of `disc_segments` sides drawn round it (so that the pieces
/// contain the part). Empty for a part that is not well formed.
pub fn convex_pieces(part: &Part, disc_segments: usize) -> Vec<Vec<Vec2>> {
    let pose = Pose::new(part.at[0], part.at[1], part.yaw_deg.to_radians());
    let place = |pts: Vec<Vec2>| -> Vec<Vec2> {
        pts.into_iter().map(|v| pose.world_from_local(v)).collect()
    };
    match &part.shape {
        Primitive::Disc(r) => {
            let n = disc_segments.max(3);
            let out = r / ops::cos(std::f32::consts::PI / n as f32);
            vec![place(regular_outline(n, out))]
        }
        Primitive::Polygon(_) => {
            let Ok(shape) = part.shape.shared_shape() else {
                return Vec::new();
            };
            match shape.as_compound() {
                Some(c) => c
                    .shapes()
                    .iter()
                    .filter_map(|(sub_pose, sub)| {
                        let poly = sub.as_convex_polygon()?;
                        Some(place(
                            poly.points()
                                .iter()
                                .map(|p| sub_pose.transform_point(*p))
                                .collect(),
                        ))
                    })
                    .collect(),
                None => vec![place(part.shape.outline(0))],
            }
        }
        other => vec![place(other.outline(0))],
    }
}

/// The parts of an object grouped into pieces that hold together: two parts belong to one
/// piece when they touch or overlap (closer than `gap` m), directly or through other parts.
/// Each piece lists its parts' indices in order, pieces ordered by their first part; an
/// object whose parts all hold together is one piece. Parts that are not well formed count
/// as pieces of their own.
pub fn part_pieces(parts: &[Part], gap: f32) -> Vec<Vec<usize>> {
    let n = parts.len();
    use rapier2d::parry::bounding_volume::BoundingVolume;
    // Each well-formed part's shape, placement and bounding box (widened by `gap`): only
    // parts whose boxes meet get the exact query.
    let shapes: Vec<Option<(rapier2d::math::Pose, SharedShape, _)>> = parts
        .iter()
        .map(|p| {
            let pose = p.placement();
            p.shape.shared_shape().ok().map(|s| {
                let aabb = s.compute_aabb(&pose).loosened(gap);
                (pose, s, aabb)
            })
        })
        .collect();
    let mut root: Vec<usize> = (0..n).collect();
    fn find(root: &mut [usize], mut i: usize) -> usize {
        while root[i] != i {
            root[i] = root[root[i]];
            i = root[i];
        }
        i
    }
    for i in 0..n {
        for j in (i + 1)..n {
            let (Some((pa, sa, ba)), Some((pb, sb, bb))) = (&shapes[i], &shapes[j]) else {
                continue;
            };
            if !ba.intersects(bb) {
                continue;
            }
            let near = rapier2d::parry::query::distance(pa, sa.as_ref(), pb, sb.as_ref())
                .is_ok_and(|d| d.distance <= gap);
            if near {
                let (a, b) = (find(&mut root, i), find(&mut root, j));
                root[a.max(b)] = a.min(b);
            }
        }
    }
    let mut pieces: Vec<Vec<usize>> = Vec::new();
    let mut piece_of_root = vec![usize::MAX; n];
    for i in 0..n {
        let r = find(&mut root, i);
        if piece_of_root[r] == usize::MAX {
            piece_of_root[r] = pieces.len();
            pieces.push(Vec::new());
        }
        pieces[piece_of_root[r]].push(i);
    }
    pieces
}

/// Area, centre and polar second moment of a region of unit density (m², m, m⁴ about the
/// centre).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct AreaMoments {
    /// Area (m²).
    pub area: f64,
    /// Centre of area.
    pub center: [f64; 2],
    /// Polar second moment about the centre (m⁴): the moment of inertia per unit density.
    pub polar: f64,
}

/// Most disjoint pieces [`overlap_moments`] cuts an object into, and most cuts it makes,
/// before it gives up (an object of hundreds of crossing bars), leaving the collision
/// engine's sum over the parts: bounded work for any file.
pub const MAX_UNION_PIECES: usize = 50_000;
/// See [`MAX_UNION_PIECES`].
pub const MAX_UNION_CLIPS: usize = 2_000_000;

/// The area moments of the union of `parts` when they overlap, as parts written as
/// overlapping boxes do (the seed's U: its arms run into its back); `None` when no two parts
/// overlap, where the collision engine's sum over the parts is already the union's. The
/// parts' convex pieces are made disjoint (each piece less every piece before it, by clipping
/// at the earlier piece's edges) and summed exactly; a disc counts as its 64-gon.
pub fn overlap_moments(parts: &[Part]) -> Option<AreaMoments> {
    type P = [f64; 2];
    let cross = |a: P, b: P, p: P| (b[0] - a[0]) * (p[1] - a[1]) - (b[1] - a[1]) * (p[0] - a[0]);
    // The part of convex `poly` on the left of a -> b (`keep_left`) or on its right.
    let clip = |poly: &[P], a: P, b: P, keep_left: bool| -> Vec<P> {
        let side = |p: P| {
            let c = cross(a, b, p);
            if keep_left {
                c
            } else {
                -c
            }
        };
        let mut out = Vec::with_capacity(poly.len() + 1);
        for i in 0..poly.len() {
            let (p, q) = (poly[i], poly[(i + 1) % poly.len()]);
            let (sp, sq) = (side(p), side(q));
            if sp >= 0.0 {
                out.push(p);
            }
            if (sp > 0.0 && sq < 0.0) || (sp < 0.0 && sq > 0.0) {
                let t = sp / (sp - sq);
                out.push([p[0] + (q[0] - p[0]) * t, p[1] + (q[1] - p[1]) * t]);
            }
        }
        out
    };
    // Area, first and polar second moments about the origin of a counter-clockwise polygon.
    let moments = |poly: &[P]| -> (f64, [f64; 2], f64) {
        let (mut a, mut mx, mut my, mut j) = (0.0, 0.0, 0.0, 0.0);
        for i in 0..poly.len() {
            let (p, q) = (poly[i], poly[(i + 1) % poly.len()]);
            let c = p[0] * q[1] - q[0] * p[1];
            a += c;
            mx += c * (p[0] + q[0]);
            my += c * (p[1] + q[1]);
            j += c
                * (p[0] * p[0]
                    + p[0] * q[0]
                    + q[0] * q[0]
                    + p[1] * p[1]
                    + p[1] * q[1]
                    + q[1] * q[1]);
        }
        (a / 2.0, [mx / 6.0, my / 6.0], j / 12.0)
    };
    let mut pieces: Vec<Vec<P>> = Vec::new();
    for part in parts {
        for piece in convex_pieces(part, 64) {
            let mut poly: Vec<P> = piece.iter().map(|v| [v.x as f64, v.y as f64]).collect();
            if moments(&poly).0 < 0.0 {
                poly.reverse();
            }
            pieces.push(poly);
        }
    }
    let whole: f64 = pieces.iter().map(|p| moments(p).0).sum();
    let mut disjoint: Vec<Vec<P>> = Vec::new();
    let mut clips = 0usize;
    for (i, piece) in pieces.iter().enumerate() {
        let mut frags = vec![piece.clone()];
        for earlier in &pieces[..i] {
            let mut next = Vec::new();
            for f in frags {
                let mut rest = f;
                for k in 0..earlier.len() {
                    let (a, b) = (earlier[k], earlier[(k + 1) % earlier.len()]);
                    clips += 1;
                    let outside = clip(&rest, a, b, false);
                    if outside.len() >= 3 && moments(&outside).0 > 0.0 {
                        next.push(outside);
                    }
                    rest = clip(&rest, a, b, true);
                    if rest.len() < 3 {
                        break;
                    }
                }
            }
            frags = next;
            // Bounded work for objects of very many crossing parts: past this many pieces the
            // engine's sum over the parts stands.
            if frags.len() + disjoint.len() > MAX_UNION_PIECES || clips > MAX_UNION_CLIPS {
                return None;
            }
        }
        disjoint.extend(frags);
    }
    let (mut area, mut first, mut polar) = (0.0, [0.0, 0.0], 0.0);
    for f in &disjoint {
        let (a, m, j) = moments(f);
        area += a;
        first = [first[0] + m[0], first[1] + m[1]];
        polar += j;
    }
    if !(area > 0.0) || whole - area <= 1e-6 * whole {
        return None;
    }
    let center = [first[0] / area, first[1] / area];
    let polar = polar - area * (center[0] * center[0] + center[1] * center[1]);
    Some(AreaMoments {
        area,
        center,
        polar,
    })
}

/// The smallest distance between the edges of two sets of closed outlines (0 where edges
/// touch or cross; a ring wholly inside the other is not noticed): edge against edge, by the
/// collision engine's segment distance.
pub fn outlines_gap(a: &[Vec<Vec2>], b: &[Vec<Vec2>]) -> f32 {
    use rapier2d::parry::{query, shape::Segment};
    let edges = |rings: &[Vec<Vec2>]| -> Vec<Segment> {
        rings
            .iter()
            .flat_map(|r| (0..r.len()).map(move |k| Segment::new(r[k], r[(k + 1) % r.len()])))
            .collect()
    };
    let (ea, eb) = (edges(a), edges(b));
    let id = rapier2d::math::Pose::IDENTITY;
    ea.iter()
        .flat_map(|e| eb.iter().map(move |f| (e, f)))
        .map(|(e, f)| query::distance(&id, e, &id, f).map_or(f32::MAX, |d| d.distance))
        .fold(f32::MAX, f32::min)
}

/// Signed area of a polygon (positive when counter-clockwise).
pub fn signed_area(pts: &[Vec2]) -> f32 {
    let n = pts.len();
    let mut a = 0.0f64;
    for i in 0..n {
        let p = pts[i];
        let q = pts[(i + 1) % n];
        a += p.x as f64 * q.y as f64 - q.x as f64 * p.y as f64;
    }
    (a / 2.0) as f32
}

/// Whether a polygon (either orientation) is convex.
pub fn is_convex(pts: &[Vec2]) -> bool {
    let n = pts.len();
    if n < 3 {
        return false;
    }
    let mut sign = 0.0f32;
    for i in 0..n {
        let a = pts[i];
        let b = pts[(i + 1) % n];
        let c = pts[(i + 2) % n];
        let cross = (b - a).perp_dot(c - b);
        if cross.abs() < 1e-9 {
            continue;
        }
        if sign == 0.0 {
            sign = cross.signum();
        } else if cross.signum() != sign {
            return false;
        }
    }
    true
}

fn segments_cross(a: Vec2, b: Vec2, c: Vec2, d: Vec2) -> bool {
    let o = |p: Vec2, q: Vec2, r: Vec2| (q - p).perp_dot(r - p);
    let (d1, d2, d3, d4) = (o(c, d, a), o(c, d, b), o(a, b, c), o(a, b, d));
    if ((d1 > 0.0 && d2 < 0.0) || (d1 < 0.0 && d2 > 0.0))
        && ((d3 > 0.0 && d4 < 0.0) || (d3 < 0.0 && d4 > 0.0))
    {
        return true;
    }
    let on = |p: Vec2, q: Vec2, r: Vec2, o: f32| {
        o == 0.0
            && r.x >= p.x.min(q.x)
            && r.x <= p.x.max(q.x)
            && r.y >= p.y.min(q.y)
            && r.y <= p.y.max(q.y)
    };
    on(c, d, a, d1) || on(c, d, b, d2) || on(a, b, c, d3) || on(a, b, d, d4)
}

/// Whether `b` lies on the line through `a` and `c`: the turn at `b`, relative to the two
/// edges' lengths, is nothing (straight on, or folding back along itself).
fn collinear(a: Vec2, b: Vec2, c: Vec2) -> bool {
    let (e, f) = (b - a, c - b);
    e.perp_dot(f).abs() <= 1e-5 * e.length() * f.length()
}

/// Checks that a polygon is simple: at least three distinct vertices, non-zero area, and no
/// two non-adjacent edges touching.
pub fn check_simple_polygon(pts: &[Vec2]) -> Result<(), ShapeError> {
    let n = pts.len();
    if n < 3 {
        return Err(ShapeError(format!(
            "a polygon needs at least 3 vertices, got {n}"
        )));
    }
    if pts.iter().any(|p| !p.x.is_finite() || !p.y.is_finite()) {
        return Err(ShapeError("polygon vertices must be finite numbers".into()));
    }
    for i in 0..n {
        let (a, b) = (pts[i], pts[(i + 1) % n]);
        if (a - b).length() < MIN_SIZE_M {
            return Err(ShapeError(format!(
                "polygon vertices {} and {} coincide (closer than {MIN_SIZE_M} m)",
                i + 1,
                (i + 1) % n + 1
            )));
        }
    }
    if (0..n).all(|i| collinear(pts[i], pts[(i + 1) % n], pts[(i + 2) % n])) {
        return Err(ShapeError(
            "polygon vertices all lie on one straight line: it has no area".into(),
        ));
    }
    for i in 0..n {
        let (a, b, c) = (pts[i], pts[(i + 1) % n], pts[(i + 2) % n]);
        // A vertex on the line through its neighbours adds nothing (straight on: dropped
        // before this check, by `polygon_vertices`) or folds the outline back on itself (a
        // spike of no width). Named by its place: dropped vertices shift the numbers.
        if collinear(a, b, c) {
            return Err(ShapeError(if (b - a).dot(c - b) <= 0.0 {
                format!(
                    "polygon folds back on itself at vertex ({}, {}): the outline goes out to \
                     it and back along one line (a spike of no width)",
                    b.x, b.y
                )
            } else {
                format!(
                    "polygon vertex ({}, {}) lies on the straight line through its neighbours \
                     ({}, {}) and ({}, {})",
                    b.x, b.y, a.x, a.y, c.x, c.y
                )
            }));
        }
    }
    for i in 0..n {
        for j in (i + 1)..n {
            let adjacent = j == i + 1 || (i == 0 && j == n - 1);
            if adjacent {
                continue;
            }
            let (a, b, c, d) = (pts[i], pts[(i + 1) % n], pts[j], pts[(j + 1) % n]);
            if segments_cross(a, b, c, d) {
                // Edges named by their ends, not by number: vertices dropped before this
                // check (repeated, or straight on) would shift the numbers.
                return Err(ShapeError(format!(
                    "polygon is self-intersecting: the edge from ({}, {}) to ({}, {}) crosses \
                     the edge from ({}, {}) to ({}, {})",
                    a.x, a.y, b.x, b.y, c.x, c.y, d.x, d.y
                )));
            }
        }
    }
    if signed_area(pts).abs() < MIN_SIZE_M * MIN_SIZE_M {
        return Err(ShapeError(format!(
            "polygon has zero area (less than {MIN_SIZE_M} m squared)"
        )));
    }
    Ok(())
}

/// The least width of `points`' convex hull (m): the narrowest slot it passes through,
/// turned as it best fits (rotating calipers over the hull's edges); 0 for fewer than three
/// points or points on a line.
pub fn least_width(points: &[Vec2]) -> f32 {
    let hull = convex_hull(points);
    let n = hull.len();
    if n < 3 {
        return 0.0;
    }
    (0..n)
        .map(|k| {
            let (a, b) = (hull[k], hull[(k + 1) % n]);
            let e = (b - a).normalize_or_zero();
            hull.iter()
                .map(|p| (*p - a).perp_dot(e).abs())
                .fold(0.0, f32::max)
        })
        .fold(f32::INFINITY, f32::min)
}

/// Convex hull of a point set, counter-clockwise. Non-finite points are left out; should
/// parry's hull panic on degenerate input, a monotone-chain hull in `f64` stands in.
pub fn convex_hull(points: &[Vec2]) -> Vec<Vec2> {
    let finite: Vec<Vec2> = points.iter().copied().filter(|p| p.is_finite()).collect();
    let points = &finite[..];
    if points.len() < 3 {
        return points.to_vec();
    }
    let mut hull = no_panic("", || convex_hull2(points)).unwrap_or_else(|_| monotone_hull(points));
    if signed_area(&hull) < 0.0 {
        hull.reverse();
    }
    hull
}

/// Andrew's monotone-chain convex hull (counter-clockwise, collinear points dropped), with
/// cross products in `f64`: cannot panic.
fn monotone_hull(points: &[Vec2]) -> Vec<Vec2> {
    let mut pts = points.to_vec();
    pts.sort_by(|a, b| a.x.total_cmp(&b.x).then(a.y.total_cmp(&b.y)));
    pts.dedup();
    if pts.len() < 3 {
        return pts;
    }
    let cross = |o: Vec2, a: Vec2, b: Vec2| {
        (f64::from(a.x) - f64::from(o.x)) * (f64::from(b.y) - f64::from(o.y))
            - (f64::from(a.y) - f64::from(o.y)) * (f64::from(b.x) - f64::from(o.x))
    };
    let mut hull: Vec<Vec2> = Vec::with_capacity(2 * pts.len());
    for pass in 0..2 {
        let start = hull.len();
        let iter: Box<dyn Iterator<Item = &Vec2>> = if pass == 0 {
            Box::new(pts.iter())
        } else {
            Box::new(pts.iter().rev())
        };
        for &p in iter {
            while hull.len() >= start + 2
                && cross(hull[hull.len() - 2], hull[hull.len() - 1], p) <= 0.0
            {
                hull.pop();
            }
            hull.push(p);
        }
        hull.pop();
    }
    hull
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    /// `wrap_angle` as it was before its fast path: every angle through `%`.
    fn wrap_angle_by_remainder(a: f32) -> f32 {
        let two_pi = std::f32::consts::TAU;
        let mut r = a % two_pi;
        if r > std::f32::consts::PI {
            r -= two_pi;
        } else if r <= -std::f32::consts::PI {
            r += two_pi;
        }
        r
    }

    proptest! {
        #[test]
        fn wrap_angle_gives_the_same_bits_as_the_remainder(a in -100.0f32..100.0) {
            prop_assert_eq!(wrap_angle(a).to_bits(), wrap_angle_by_remainder(a).to_bits());
            let w = wrap_angle(a);
            prop_assert!(w > -std::f32::consts::PI && w <= std::f32::consts::PI, "{a} -> {w}");
        }
    }

    #[test]
    fn wrap_angle_keeps_the_edge_cases_of_the_remainder() {
        let t = std::f32::consts::TAU;
        let edges = [
            0.0,
            -0.0,
            std::f32::consts::PI,
            -std::f32::consts::PI,
            t,
            -t,
            t.next_down(),
            (-t).next_up(),
            f32::MIN_POSITIVE,
            1e30,
            -1e30,
        ];
        for a in edges {
            assert_eq!(
                wrap_angle(a).to_bits(),
                wrap_angle_by_remainder(a).to_bits(),
                "{a}"
            );
        }
        assert!(wrap_angle(f32::NAN).is_nan());
        assert!(wrap_angle(f32::INFINITY).is_nan());
    }

    /// An L of two 0.5 x 0.2 m arms, its inner corner at (0.2, 0.2): area 0.16.
    fn l_shape() -> Primitive {
        Primitive::Polygon(vec![
            [0.0, 0.0],
            [0.5, 0.0],
            [0.5, 0.2],
            [0.2, 0.2],
            [0.2, 0.5],
            [0.0, 0.5],
        ])
    }

    #[test]
    fn parts_that_touch_make_one_piece_and_parts_apart_make_two() {
        let part = |shape: Primitive, x: f32, y: f32| Part {
            shape,
            at: [x, y],
            yaw_deg: 0.0,
        };
        let bx = || Primitive::Box([0.3, 0.3]);
        // Two boxes side by side (touching), a third 0.5 m off, a disc bridging nothing.
        let touching = [part(bx(), 0.0, 0.0), part(bx(), 0.3, 0.0)];
        assert_eq!(part_pieces(&touching, 1e-3), vec![vec![0, 1]]);
        let apart = [part(bx(), -0.4, 0.0), part(bx(), 0.4, 0.0)];
        assert_eq!(part_pieces(&apart, 1e-3), vec![vec![0], vec![1]]);
        // Held together through a third part laid across the gap, listed last.
        let bridged = [
            part(bx(), -0.4, 0.0),
            part(bx(), 0.4, 0.0),
            part(Primitive::Box([1.1, 0.1]), 0.0, 0.2),
        ];
        assert_eq!(part_pieces(&bridged, 1e-3), vec![vec![0, 1, 2]]);
        // A gap of 2 mm is a gap; 0.5 mm is within the tolerance.
        let near = |d: f32| [part(bx(), 0.0, 0.0), part(bx(), 0.3 + d, 0.0)];
        assert_eq!(part_pieces(&near(0.002), 1e-3).len(), 2);
        assert_eq!(part_pieces(&near(0.0005), 1e-3).len(), 1);
        // A disc touching a concave polygon's inner corner.
        let l = l_shape();
        let r = 0.1;
        let corner = 0.2 + r / std::f32::consts::SQRT_2;
        let with_disc = [
            part(l.clone(), 0.0, 0.0),
            part(Primitive::Disc(r), corner, corner),
        ];
        assert_eq!(part_pieces(&with_disc, 1e-3).len(), 1);
        let off = [part(l, 0.0, 0.0), part(Primitive::Disc(r), 0.4, 0.4)];
        assert_eq!(part_pieces(&off, 1e-3).len(), 2);
    }

    #[test]
    fn self_intersecting_bowtie_is_rejected() {
        let bowtie = [[0.0, 0.0], [1.0, 1.0], [1.0, 0.0], [0.0, 1.0]];
        let err = Primitive::Polygon(bowtie.to_vec()).validate().unwrap_err();
        assert!(err.0.contains("self-intersecting"), "{err}");
        // The crossing edges are named by their ends as written, whatever was dropped before
        // the check: here (0, -0.3) lies straight on between its neighbours.
        let z = [
            [-0.3, -0.3],
            [0.0, -0.3],
            [0.3, -0.3],
            [-0.3, 0.3],
            [0.3, 0.3],
        ];
        let err = Primitive::Polygon(z.to_vec()).validate().unwrap_err();
        assert!(
            err.0.contains("the edge from (0.3, -0.3) to (-0.3, 0.3) crosses the edge from (0.3, 0.3) to (-0.3, -0.3)"),
            "{err}"
        );
    }

    #[test]
    fn concave_polygon_decomposes_and_keeps_its_area() {
        // An L: area 0.5*0.2 + 0.2*0.5 = 0.2 minus the overlap 0.04 = 0.16.
        let l = l_shape();
        let shape = l.shared_shape().unwrap();
        let mp = shape.mass_properties(1.0);
        assert!((mp.mass() - 0.16).abs() < 1e-4, "area {}", mp.mass());
        assert!(shape.as_compound().is_some());
    }

    #[test]
    fn hull_of_u_covers_the_cavity() {
        let u = [
            Vec2::new(0.0, 0.0),
            Vec2::new(1.0, 0.0),
            Vec2::new(1.0, 1.0),
            Vec2::new(0.8, 1.0),
            Vec2::new(0.8, 0.2),
            Vec2::new(0.2, 0.2),
            Vec2::new(0.2, 1.0),
            Vec2::new(0.0, 1.0),
        ];
        assert!(!is_convex(&u));
        let hull = convex_hull(&u);
        assert!((signed_area(&hull) - 1.0).abs() < 1e-5);
    }

    #[test]
    fn least_width_of_a_box_an_l_and_a_disc() {
        let b = Primitive::Box([0.6, 0.15]).outline(0);
        assert!((least_width(&b) - 0.15).abs() < 1e-6);
        // An L 0.4 m across with 0.1 m arms goes through a slot diagonally: its hull's width
        // across the corner, (0.4 + 0.1) / sqrt(2) = 0.354 m.
        let l = [
            [0.0, 0.0],
            [0.4, 0.0],
            [0.4, 0.1],
            [0.1, 0.1],
            [0.1, 0.4],
            [0.0, 0.4],
        ];
        let l: Vec<Vec2> = l.iter().map(|&[x, y]| Vec2::new(x, y)).collect();
        assert!(
            (least_width(&l) - 0.5 / 2f32.sqrt()).abs() < 1e-4,
            "{}",
            least_width(&l)
        );
        let d = Primitive::Disc(0.2).outline(64);
        assert!((least_width(&d) - 0.4).abs() < 0.01);
    }

    proptest! {
        #[test]
        fn wrap_angle_stays_in_range(a in -100.0f32..100.0) {
            let w = wrap_angle(a);
            prop_assert!(w > -std::f32::consts::PI - 1e-5 && w <= std::f32::consts::PI + 1e-5);
            prop_assert!(((a - w) / std::f32::consts::TAU - ((a - w) / std::f32::consts::TAU).round()).abs() < 1e-3);
        }

        #[test]
        fn pose_round_trip(x in -5.0f32..5.0, y in -5.0f32..5.0, t in -4.0f32..4.0,
                           px in -5.0f32..5.0, py in -5.0f32..5.0) {
            let pose = Pose::new(x, y, t);
            let p = Vec2::new(px, py);
            let back = pose.world_from_local(pose.local_from_world(p));
            prop_assert!((back - p).length() < 1e-4);
        }

        #[test]
        fn regular_polygons_are_convex_with_hull_equal_to_self(n in 3u32..20, r in 0.05f32..2.0) {
            let pts = Primitive::Regular { sides: n, radius: r }.outline(0);
            prop_assert!(is_convex(&pts));
            prop_assert!(check_simple_polygon(&pts).is_ok());
            let hull = convex_hull(&pts);
            prop_assert!((signed_area(&hull) - signed_area(&pts)).abs() < 1e-4 * r * r + 1e-6);
        }

        /// The least width does not depend on how the shape is turned or moved, and no
        /// direction gives a narrower projection of the points.
        #[test]
        fn least_width_is_the_narrowest_projection_whatever_the_turn(
            pts in proptest::collection::vec((-1.0f32..1.0, -1.0f32..1.0), 3..12),
            turn in -3.2f32..3.2, dx in -5.0f32..5.0,
        ) {
            let pts: Vec<Vec2> = pts.into_iter().map(|(x, y)| Vec2::new(x, y)).collect();
            let w = least_width(&pts);
            let pose = Pose::new(dx, -dx, turn);
            let moved: Vec<Vec2> = pts.iter().map(|p| pose.world_from_local(*p)).collect();
            prop_assert!((least_width(&moved) - w).abs() < 1e-3, "{} {}", least_width(&moved), w);
            for k in 0..90 {
                let d = ops::unit(k as f32 * std::f32::consts::PI / 90.0);
                let (lo, hi) = pts.iter().map(|p| p.dot(d)).fold((f32::INFINITY, f32::NEG_INFINITY), |(a, b), x| (a.min(x), b.max(x)));
                prop_assert!(hi - lo + 1e-4 >= w);
            }
        }

        #[test]
        fn hull_area_is_at_least_polygon_area(
            pts in proptest::collection::vec((-1.0f32..1.0, -1.0f32..1.0), 3..12)
        ) {
            let pts: Vec<Vec2> = pts.into_iter().map(|(x, y)| Vec2::new(x, y)).collect();
            if check_simple_polygon(&pts).is_ok() {
                let hull = convex_hull(&pts);
                prop_assert!(signed_area(&hull) + 1e-5 >= signed_area(&pts).abs());
            }
        }

        /// Dropping repeated and straight-on vertices leaves every polygon the check took
        /// before alone (so no shape that loaded before changes), and what it leaves of any
        /// other is what the shape is built from.
        #[test]
        fn polygon_vertices_change_no_polygon_that_was_valid(
            pts in proptest::collection::vec((-1.0f32..1.0, -1.0f32..1.0), 3..12),
            dup in 0usize..12,
        ) {
            let raw: Vec<[f32; 2]> = pts.iter().map(|&(x, y)| [x, y]).collect();
            let v: Vec<Vec2> = pts.iter().map(|&(x, y)| Vec2::new(x, y)).collect();
            if check_simple_polygon(&v).is_ok() {
                prop_assert_eq!(&polygon_vertices(&raw), &v);
                // Repeating a vertex (or closing the outline with its first) changes nothing.
                let mut with_dup = raw.clone();
                let k = dup % raw.len();
                with_dup.insert(k + 1, raw[k]);
                prop_assert_eq!(&polygon_vertices(&with_dup), &v);
                let p = Primitive::Polygon(with_dup);
                prop_assert!(p.validate().is_ok());
            }
        }
    }

    fn boxes(b: &[([f32; 2], [f32; 2], f32)]) -> Vec<Part> {
        b.iter()
            .map(|&(size, at, yaw_deg)| Part {
                shape: Primitive::Box(size),
                at,
                yaw_deg,
            })
            .collect()
    }

    /// The union of overlapping boxes weighs its area once: two 2 x 1 boxes sharing a 1 x 1
    /// square make the 3 x 1 bar; the seed's U (arms running 0.1 m into its back) has area
    /// 0.36 m² and its centre 0.0083 m deeper than the sum of its parts puts it.
    #[test]
    fn overlapping_parts_count_their_overlap_once() {
        let bar = overlap_moments(&boxes(&[
            ([2.0, 1.0], [1.0, 0.5], 0.0),
            ([2.0, 1.0], [2.0, 0.5], 0.0),
        ]))
        .expect("they overlap");
        assert!((bar.area - 3.0).abs() < 1e-9, "{bar:?}");
        assert!((bar.center[0] - 1.5).abs() < 1e-9 && (bar.center[1] - 0.5).abs() < 1e-9);
        // A 3 x 1 bar about its centre: m (a^2 + b^2) / 12 with m = 3.
        assert!((bar.polar - 3.0 * 10.0 / 12.0).abs() < 1e-9, "{bar:?}");
        let u = overlap_moments(&boxes(&[
            ([0.5, 0.2], [-1.0, 0.4], 0.0),
            ([0.5, 0.2], [-1.0, -0.4], 0.0),
            ([0.2, 1.0], [-0.75, 0.0], 0.0),
        ]))
        .expect("the U's arms overlap its back");
        assert!((u.area - 0.36).abs() < 1e-6, "{u:?}");
        // First moment: two arms of 0.1 m² at x = -1, the back's 0.2 m² at -0.75, less the two
        // 0.02 m² overlaps at -0.8.
        let first = -(2.0 * 0.1 * 1.0 + 0.2 * 0.75 - 2.0 * 0.02 * 0.8);
        assert!((u.center[0] - first / 0.36).abs() < 1e-6 && u.center[1].abs() < 1e-6);
        // Parts that only touch (the L), or lie apart, leave the engine's sum standing.
        let l = boxes(&[
            ([0.5, 0.2], [-1.0, 0.3], 0.0),
            ([0.2, 0.7], [-0.65, 0.05], 0.0),
        ]);
        assert_eq!(overlap_moments(&l), None);
        assert_eq!(
            overlap_moments(&boxes(&[([1.0, 1.0], [0.0, 0.0], 0.0)])),
            None
        );
    }

    #[test]
    fn crossing_bars_weigh_each_crossing_once_and_many_cost_bounded_work() {
        // A # of three bars each way, 3 x 0.2 m: 3.6 m² of bars less nine 0.04 m² crossings.
        let bars = |n: usize| {
            let mut b = Vec::new();
            for k in 0..n {
                let at = k as f32 - (n as f32 - 1.0) / 2.0;
                b.push(([n as f32, 0.2], [0.0, at], 0.0));
                b.push(([0.2, n as f32], [at, 0.0], 0.0));
            }
            boxes(&b)
        };
        let m = overlap_moments(&bars(3)).expect("they cross");
        assert!((m.area - 3.24).abs() < 1e-6, "{m:?}");
        assert!(m.center[0].abs() < 1e-6 && m.center[1].abs() < 1e-6);
        // 300 bars each way (90,000 crossings): past the bounds, the engine's sum stands.
        assert_eq!(overlap_moments(&bars(300)), None);
    }

    #[test]
    fn outlines_gap_is_the_distance_between_edges() {
        let square = |x: f32, y: f32| {
            vec![
                Vec2::new(x, y),
                Vec2::new(x + 1.0, y),
                Vec2::new(x + 1.0, y + 1.0),
                Vec2::new(x, y + 1.0),
            ]
        };
        let gap = |a: Vec<Vec2>, b: Vec<Vec2>| outlines_gap(&[a], &[b]);
        assert!((gap(square(0.0, 0.0), square(1.5, 0.0)) - 0.5).abs() < 1e-6);
        // Corner to corner, diagonally: sqrt(0.3^2 + 0.4^2).
        assert!((gap(square(0.0, 0.0), square(1.3, 1.4)) - 0.5).abs() < 1e-6);
        assert_eq!(gap(square(0.0, 0.0), square(0.5, 0.5)), 0.0);
    }

    proptest! {
        /// The union's area and centre are what sampling the union on a fine grid gives, for
        /// turned boxes overlapping at random.
        #[test]
        fn overlap_moments_match_a_sampled_union(
            b in proptest::collection::vec(
                ((0.1f32..1.0, 0.1f32..1.0), (-0.4f32..0.4, -0.4f32..0.4), -90.0f32..90.0),
                2..5,
            )
        ) {
            let parts = boxes(
                &b.iter().map(|&((w, h), (x, y), yaw)| ([w, h], [x, y], yaw)).collect::<Vec<_>>(),
            );
            let inside = |p: Vec2| {
                parts.iter().any(|part| {
                    let pose = Pose::new(part.at[0], part.at[1], part.yaw_deg.to_radians());
                    let q = pose.local_from_world(p);
                    let Primitive::Box([w, h]) = part.shape else { unreachable!() };
                    q.x.abs() <= w / 2.0 && q.y.abs() <= h / 2.0
                })
            };
            // A window the boxes cannot leave (offsets up to 0.4, half diagonals up to 0.71).
            let n = 480;
            let step = 2.4 / n as f32;
            let (mut area, mut mx, mut my) = (0.0f64, 0.0f64, 0.0f64);
            for i in 0..n {
                for j in 0..n {
                    let p = Vec2::new(-1.2 + (i as f32 + 0.5) * step, -1.2 + (j as f32 + 0.5) * step);
                    if inside(p) {
                        let a = f64::from(step * step);
                        area += a;
                        mx += a * f64::from(p.x);
                        my += a * f64::from(p.y);
                    }
                }
            }
            // The grid misjudges at most the cells an edge crosses: along an edge aligned with
            // the grid the error does not average out, up to half a step times its length
            // (a thin unturned box 0.72 x 0.15 m against a 0.1 m one: 0.0028 m^2 of 0.114).
            let half_perimeters: f64 = b.iter().map(|&((w, h), _, _)| f64::from(w + h)).sum();
            let grid_error = f64::from(step) * half_perimeters;
            if let Some(m) = overlap_moments(&parts) {
                prop_assert!(
                    (m.area - area).abs() < 0.01 * area + grid_error,
                    "{m:?} against {area}"
                );
                prop_assert!((m.center[0] - mx / area).abs() < 0.01, "{m:?}");
                prop_assert!((m.center[1] - my / area).abs() < 0.01, "{m:?}");
            } else {
                let sum: f64 = parts
                    .iter()
                    .map(|p| { let Primitive::Box([w, h]) = p.shape else { unreachable!() }; f64::from(w * h) })
                    .sum();
                prop_assert!(
                    (sum - area).abs() < 0.01 * sum + grid_error,
                    "no overlap found, but the union has {area} of {sum}"
                );
            }
        }
    }
}
