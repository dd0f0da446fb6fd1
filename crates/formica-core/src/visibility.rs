//! Shortest paths around obstacles on a visibility graph, for the path efficiency of transport
//! around obstacles (issue 14): the optimal path of the object's centre is the shortest path
//! from its start to where it ended that keeps out of every obstacle grown by the object's
//! half-width.
//!
//! Obstacles are convex polygons (grown walls are rectangles). The graph's nodes are the two
//! end points and every obstacle corner inside the usable area (nudged outward by a micrometre
//! so that a path along an edge does not count as crossing it); an edge joins two nodes when
//! the segment between them crosses no obstacle's interior. The shortest path in a plane with
//! polygonal obstacles runs along such edges, so Dijkstra's algorithm on this graph finds it.
//! All arithmetic is in `f64` with additions, multiplications and square roots only (portable:
//! the same bits everywhere).

/// A point (m).
pub type P = [f64; 2];

fn sub(a: P, b: P) -> P {
    [a[0] - b[0], a[1] - b[1]]
}

fn dist(a: P, b: P) -> f64 {
    let d = sub(a, b);
    (d[0] * d[0] + d[1] * d[1]).sqrt()
}

fn cross(a: P, b: P) -> f64 {
    a[0] * b[1] - a[1] * b[0]
}

/// The polygon counter-clockwise.
fn ccw(mut poly: Vec<P>) -> Vec<P> {
    let n = poly.len();
    let area: f64 = (0..n).map(|i| cross(poly[i], poly[(i + 1) % n])).sum();
    if area < 0.0 {
        poly.reverse();
    }
    poly
}

/// Whether `p` is strictly inside the counter-clockwise convex polygon `poly`.
fn inside(poly: &[P], p: P) -> bool {
    let n = poly.len();
    (0..n).all(|i| cross(sub(poly[(i + 1) % n], poly[i]), sub(p, poly[i])) > 0.0)
}

/// Whether the segment `a`-`b` passes through the interior of the counter-clockwise convex
/// polygon `poly` (Cyrus-Beck clipping; touching its boundary does not count).
pub fn crosses(poly: &[P], a: P, b: P) -> bool {
    let d = sub(b, a);
    let (mut t0, mut t1) = (0.0f64, 1.0f64);
    let n = poly.len();
    for i in 0..n {
        let e = sub(poly[(i + 1) % n], poly[i]);
        // Inside: cross(e, x - p_i) > 0, i.e. num + t * den > 0.
        let num = cross(e, sub(a, poly[i]));
        let den = cross(e, d);
        if den == 0.0 {
            if num <= 0.0 {
                return false;
            }
        } else {
            let t = -num / den;
            if den > 0.0 {
                t0 = t0.max(t);
            } else {
                t1 = t1.min(t);
            }
        }
        if t1 - t0 <= 1e-12 {
            return false;
        }
    }
    true
}

/// Length (m) of the shortest path from `from` to `to` that crosses the interior of none of
/// `obstacles` (convex polygons, either orientation) and turns only at corners inside the box
/// `bounds` (min, max corners). An obstacle that contains an end point is ignored for the
/// segments that leave that point (the object ended, or started, against it). The straight
/// distance if nothing is in the way, or if no path exists.
pub fn shortest_path(from: P, to: P, obstacles: &[Vec<P>], bounds: (P, P)) -> f64 {
    path_length(from, to, obstacles, bounds).unwrap_or_else(|| dist(from, to))
}

/// [`shortest_path`], or `None` if the obstacles and the bounds leave no way from `from` to
/// `to`.
pub fn path_length(from: P, to: P, obstacles: &[Vec<P>], bounds: (P, P)) -> Option<f64> {
    let polys: Vec<Vec<P>> = obstacles.iter().map(|p| ccw(p.clone())).collect();
    let straight = dist(from, to);
    let skip_from: Vec<bool> = polys.iter().map(|p| inside(p, from)).collect();
    let skip_to: Vec<bool> = polys.iter().map(|p| inside(p, to)).collect();
    let free = |a: P, b: P, skip: Option<&[bool]>| {
        polys
            .iter()
            .enumerate()
            .all(|(i, p)| skip.is_some_and(|s| s[i]) || !crosses(p, a, b))
    };
    let both: Vec<bool> = skip_from
        .iter()
        .zip(&skip_to)
        .map(|(a, b)| *a || *b)
        .collect();
    if free(from, to, Some(&both)) {
        return Some(straight);
    }
    // Nodes: 0 = from, 1 = to, then the corners.
    let (lo, hi) = bounds;
    let mut nodes = vec![from, to];
    for p in &polys {
        let n = p.len();
        let c: P = {
            let s = p.iter().fold([0.0, 0.0], |s, q| [s[0] + q[0], s[1] + q[1]]);
            [s[0] / n as f64, s[1] / n as f64]
        };
        for q in p {
            let out = sub(*q, c);
            let l = dist(*q, c).max(1e-12);
            let v = [q[0] + out[0] / l * 1e-6, q[1] + out[1] / l * 1e-6];
            let within = v[0] >= lo[0] && v[0] <= hi[0] && v[1] >= lo[1] && v[1] <= hi[1];
            if within && !polys.iter().any(|o| inside(o, v)) {
                nodes.push(v);
            }
        }
    }
    let n = nodes.len();
    let edge = |i: usize, j: usize| -> Option<f64> {
        let skip = match (i, j) {
            (0, 1) | (1, 0) => Some(both.as_slice()),
            (0, _) | (_, 0) => Some(skip_from.as_slice()),
            (1, _) | (_, 1) => Some(skip_to.as_slice()),
            _ => None,
        };
        free(nodes[i], nodes[j], skip).then(|| dist(nodes[i], nodes[j]))
    };
    // Dijkstra on the dense graph.
    let mut best = vec![f64::INFINITY; n];
    let mut done = vec![false; n];
    best[0] = 0.0;
    while let Some(u) = (0..n)
        .filter(|&i| !done[i] && best[i].is_finite())
        .min_by(|&a, &b| best[a].total_cmp(&best[b]))
    {
        if u == 1 {
            return Some(best[1]);
        }
        done[u] = true;
        for v in 0..n {
            if !done[v] {
                if let Some(w) = edge(u, v) {
                    if best[u] + w < best[v] {
                        best[v] = best[u] + w;
                    }
                }
            }
        }
    }
    None
}

#[cfg(test)]
mod tests {
    use super::*;

    fn rect(cx: f64, cy: f64, w: f64, h: f64) -> Vec<P> {
        vec![
            [cx - w / 2.0, cy - h / 2.0],
            [cx + w / 2.0, cy - h / 2.0],
            [cx + w / 2.0, cy + h / 2.0],
            [cx - w / 2.0, cy + h / 2.0],
        ]
    }

    const BIG: (P, P) = ([-10.0, -10.0], [10.0, 10.0]);

    #[test]
    fn straight_when_nothing_is_in_the_way() {
        let d = shortest_path([0.0, 0.0], [3.0, 4.0], &[rect(5.0, 0.0, 1.0, 1.0)], BIG);
        assert_eq!(d, 5.0);
    }

    #[test]
    fn around_a_wall_through_its_corner() {
        // A wall 2 m tall between (-2, 0) and (2, 0): over its top corners (0, +-1).
        let d = shortest_path([-2.0, 0.0], [2.0, 0.0], &[rect(0.0, 0.0, 0.0001, 2.0)], BIG);
        let want = 2.0 * (4.0f64 + 1.0).sqrt();
        assert!((d - want).abs() < 1e-3, "{d} against {want}");
    }

    #[test]
    fn bounds_close_one_way_around() {
        // The middle map: a 1.5 x 0.5 obstacle, the object at (0, -1), the goal at (0, 1),
        // corners at (+-0.75, +-0.25).
        let ob = rect(0.0, 0.0, 1.5, 0.5);
        let d = shortest_path([0.0, -1.0], [0.0, 1.0], std::slice::from_ref(&ob), BIG);
        let leg = (0.75f64 * 0.75 + 0.75 * 0.75).sqrt();
        assert!((d - (2.0 * leg + 0.5)).abs() < 1e-4, "{d}");
        // A wall from the west arena wall to x = 0.5: around its east end only.
        let wall = rect(-0.5, 0.0, 2.0, 0.5);
        let arena = ([-1.45, -1.45], [1.45, 1.45]);
        let d = shortest_path([-1.0, -1.0], [-1.0, 1.0], &[wall], arena);
        let leg = (1.5f64 * 1.5 + 0.75 * 0.75).sqrt();
        assert!((d - (2.0 * leg + 0.5)).abs() < 1e-4, "{d}");
    }

    #[test]
    fn a_wall_across_the_bounds_leaves_no_way() {
        let arena = ([-1.45, -1.45], [1.45, 1.45]);
        let wall = rect(0.0, 0.0, 3.0, 0.2);
        let no_way = path_length([0.0, -1.0], [0.0, 1.0], std::slice::from_ref(&wall), arena);
        assert_eq!(no_way, None);
        // The metric falls back to the straight distance.
        assert_eq!(shortest_path([0.0, -1.0], [0.0, 1.0], &[wall], arena), 2.0);
    }

    #[test]
    fn an_end_inside_an_obstacle_ignores_it_from_there() {
        let ob = rect(0.0, 0.0, 1.0, 1.0);
        let d = shortest_path([0.4, 0.0], [3.0, 0.0], &[ob], BIG);
        assert!((d - 2.6).abs() < 1e-9);
    }
}
