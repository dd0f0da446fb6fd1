//! Benchmark worlds ([`Workload`]): the shipped transport scenarios tiled to any swarm size at
//! their density, and the older random-walk world.
//!
//! - [`Workload::Transport`]: `scenarios/seed-transport.toml` at its density, 20 Khepera IV and
//!   one 50 kg box per 24 m^2 (the seed's 6 m x 4 m arena is one tile; tiles are laid side by
//!   side in one walled arena with no walls between them), the `occlusion` controller with its
//!   real sensors (8 proximity, 8 light with occlusion, positioning, beacon) and the
//!   `"realistic"` noise preset. Robots start at random, as in the seed.
//! - [`Workload::FillTransport`]: `scenarios/fill-transport-*.toml` at their density, 30 Khepera
//!   IV and one 20 kg concave object per 24 m^2 (the U, L, arc, H and plus in turn), running
//!   `fill-transport`.
//! - [`Workload::RandomWalk`]: the benchmark world before issue 12 (0.8 m^2 per robot on a grid,
//!   one 5 kg box, `random-walk`), kept to compare with older figures.
//!
//! In every workload one goal light sits 0.5 m from the east wall, as in the seed, and is
//! brighter in larger arenas ([`light_intensity`]) so that every robot sees it as strongly as a
//! robot in the far corner of the seed's arena does: every robot computes its light (and its
//! occlusion ray) every tick. Each movable object carries a beacon, and robots read the nearest
//! (see [`crate::sensors::Readings::beacon`]).

use crate::geometry::Vec2;
use crate::scenario::{Scenario, ScenarioError};
use rand::{Rng, SeedableRng};
use std::fmt::Write as _;

/// Floor area per robot of the random-walk world (m^2).
pub const AREA_PER_ROBOT_M2: f32 = 0.8;

/// One tile of the transport workloads: the seed's arena (m).
pub const TILE: [f32; 2] = [6.0, 4.0];

/// What a benchmark world runs.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Default)]
pub enum Workload {
    /// Occlusion-based transport of 50 kg boxes (20 robots per box).
    #[default]
    Transport,
    /// Filling then transport of 20 kg concave objects (30 robots per object).
    FillTransport,
    /// Random walk on the older benchmark world (no contacts to speak of).
    RandomWalk,
}

impl Workload {
    /// Every workload, in the order `formica bench` lists them.
    pub const ALL: [Workload; 3] = [
        Workload::Transport,
        Workload::FillTransport,
        Workload::RandomWalk,
    ];

    /// Its name on the command line and in JSON.
    pub fn name(self) -> &'static str {
        match self {
            Workload::Transport => "transport",
            Workload::FillTransport => "fill-transport",
            Workload::RandomWalk => "random-walk",
        }
    }

    /// The workload of a name.
    pub fn from_name(name: &str) -> Option<Workload> {
        Workload::ALL.into_iter().find(|w| w.name() == name)
    }

    /// Robots per tile (per object).
    pub fn robots_per_tile(self) -> usize {
        match self {
            Workload::Transport => 20,
            Workload::FillTransport => 30,
            Workload::RandomWalk => 1,
        }
    }

    /// Most robots a world of this workload can hold: a scenario's limits on robots
    /// ([`crate::limits::MAX_ROBOTS`]) and objects ([`crate::limits::MAX_ITEMS`], one a tile).
    pub fn max_robots(self) -> usize {
        match self {
            Workload::Transport | Workload::FillTransport => {
                (self.robots_per_tile() * crate::limits::MAX_ITEMS).min(crate::limits::MAX_ROBOTS)
            }
            Workload::RandomWalk => crate::limits::MAX_ROBOTS,
        }
    }

    /// The benchmark world for `robots` robots.
    pub fn scenario(self, robots: usize) -> Result<Scenario, ScenarioError> {
        match self {
            Workload::Transport | Workload::FillTransport => tiled(self, robots, true),
            Workload::RandomWalk => random_walk(robots, "random-walk", true),
        }
    }

    /// The same world without its robots (arena, objects and light only), to tell the memory
    /// robots take.
    pub fn empty_scenario(self, robots: usize) -> Result<Scenario, ScenarioError> {
        match self {
            Workload::Transport | Workload::FillTransport => tiled(self, robots, false),
            Workload::RandomWalk => random_walk(robots, "random-walk", false),
        }
    }
}

/// Distance from the seed's goal light (2.5, 0) to the far corners of its arena (m).
const SEED_FARTHEST_M: f32 = 5.852_35;

/// Intensity of a goal light whose farthest robot is `farthest` metres away: the seed's 10,
/// scaled so that the farthest robot reads what the seed's farthest does (in range with the
/// same contrast, whatever the arena).
pub fn light_intensity(farthest: f32) -> f32 {
    10.0 * (farthest / SEED_FARTHEST_M).max(1.0)
}

/// The five concave objects of `scenarios/fill-transport-*.toml`, as TOML keys without `at`
/// (each at the tile's centre plus the offset given with it).
pub const FILL_OBJECTS: [(&str, [f32; 2], &str); 5] = [
    (
        "U",
        [0.0, 0.0],
        "parts = [ { box = [0.5, 0.2], at = [-1.0, 0.4] }, { box = [0.5, 0.2], at = [-1.0, -0.4] }, { box = [0.2, 1.0], at = [-0.75, 0.0] } ]",
    ),
    (
        "L",
        [0.0, 0.0],
        "parts = [ { box = [0.5, 0.2], at = [-1.0, 0.3] }, { box = [0.2, 0.7], at = [-0.65, 0.05] } ]",
    ),
    (
        "arc",
        [0.0, 0.0],
        "parts = [ { box = [0.5, 0.1], at = [-0.65, 0.5], yaw_deg = 60.0 }, { box = [0.5, 0.1], at = [-0.65, -0.5], yaw_deg = -60.0 }, { box = [0.1, 0.61], at = [-0.77, 0.0] } ]",
    ),
    (
        "H",
        [-1.0, 0.0],
        "shape = { polygon = [[-0.35, -0.4], [-0.2, -0.4], [-0.2, -0.075], [0.2, -0.075], [0.2, -0.4], [0.35, -0.4], [0.35, 0.4], [0.2, 0.4], [0.2, 0.075], [-0.2, 0.075], [-0.2, 0.4], [-0.35, 0.4]] }",
    ),
    (
        "plus",
        [-1.0, 0.0],
        "shape = { polygon = [[-0.12, -0.4], [0.12, -0.4], [0.12, -0.12], [0.4, -0.12], [0.4, 0.12], [0.12, 0.12], [0.12, 0.4], [-0.12, 0.4], [-0.12, 0.12], [-0.4, 0.12], [-0.4, -0.12], [-0.12, -0.12]] }",
    ),
];

/// Columns and rows of tiles for `tiles` tiles: the fewest spare tiles, then the squarest
/// arena (aspect ratio within 1:2).
pub fn tile_grid(tiles: usize) -> (usize, usize) {
    let tiles = tiles.max(1);
    let mut best = (tiles, 1, usize::MAX, f32::MAX);
    for cols in 1..=tiles {
        let rows = tiles.div_ceil(cols);
        let aspect = (TILE[0] * cols as f32) / (TILE[1] * rows as f32);
        if !(0.5..=2.0).contains(&aspect) && tiles > 1 {
            continue;
        }
        let spare = cols * rows - tiles;
        let skew = crate::ops::ln(aspect).abs();
        if (spare, skew) < (best.2, best.3) || (spare == best.2 && skew < best.3) {
            best = (cols, rows, spare, skew);
        }
    }
    (best.0, best.1)
}

/// A transport workload's world: tiles of the seed's arena, each with its object at the
/// seed's place, robots at random (their start poses drawn here, so that placement costs no
/// rejection sampling over the whole swarm).
fn tiled(workload: Workload, robots: usize, with_robots: bool) -> Result<Scenario, ScenarioError> {
    let robots = robots.max(1);
    let per = workload.robots_per_tile();
    let tiles = robots.div_ceil(per);
    let (cols, rows) = tile_grid(tiles);
    let (w, h) = (TILE[0] * cols as f32, TILE[1] * rows as f32);
    let light = [w / 2.0 - 0.5, 0.0];
    let farthest = Vec2::new(light[0] + w / 2.0, h / 2.0).length();
    let (controller, mass, floor_mu, height) = match workload {
        Workload::FillTransport => ("fill-transport", 20.0, 0.015, 0.3),
        _ => ("occlusion", 50.0, 0.006, 0.5),
    };
    let mut text = format!(
        "name = \"bench-{name}-{robots}\"\n\
         [arena]\nsize = [{w}, {h}]\nwall_thickness = 0.1\n\n\
         [[lights]]\nat = [{lx}, {ly}]\nheight = 0.5\nintensity = {i}\ngoal = true\n",
        name = workload.name(),
        lx = light[0],
        ly = light[1],
        i = light_intensity(farthest),
    );
    // Tile centres, and the object's outline as seen from the tile's centre (for placement).
    let mut centres = Vec::with_capacity(tiles);
    for k in 0..tiles {
        let (c, r) = (k % cols, k / cols);
        centres.push([
            -w / 2.0 + TILE[0] * (c as f32 + 0.5),
            -h / 2.0 + TILE[1] * (r as f32 + 0.5),
        ]);
    }
    for (k, c) in centres.iter().enumerate() {
        let _ = write!(text, "\n[[objects]]\nname = \"o{k}\"\n");
        match workload {
            Workload::FillTransport => {
                let (name, off, keys) = FILL_OBJECTS[k % FILL_OBJECTS.len()];
                let _ = write!(
                    text,
                    "# {name}\nat = [{}, {}]\n{keys}\n",
                    c[0] + off[0],
                    c[1] + off[1]
                );
            }
            _ => {
                let _ = write!(
                    text,
                    "at = [{}, {}]\nshape = {{ box = [0.5, 0.5] }}\n",
                    c[0] - 1.0,
                    c[1]
                );
            }
        }
        let _ = write!(
            text,
            "height = {height}\nmass = {mass}\nfloor_mu = {floor_mu}\nmovable = true\ncolor = \"green\"\n"
        );
    }
    text.push_str(
        "\n[run]\ntick_hz = 10\nduration_s = 1e6\n\n[stop]\non_goal = false\non_wall = false\n",
    );
    let name = format!("<bench {} {robots}>", workload.name());
    let sc = Scenario::parse(&text, &name)?;
    if !with_robots {
        return Ok(sc);
    }
    // Start poses: each tile's robots at random in the seed's start region of the tile
    // (x within 2 m of its centre, y anywhere), clear of the object, the walls and each other.
    let world = crate::world::World::new(&sc, &Default::default())?;
    let radius = crate::robot::RobotModel::khepera4().radius;
    let mut rng = rand_pcg::Pcg64Mcg::seed_from_u64(12);
    let mut poses: Vec<[f32; 3]> = Vec::with_capacity(robots);
    let (lo_y, hi_y) = (
        -TILE[1] / 2.0 + radius + 0.06,
        TILE[1] / 2.0 - radius - 0.06,
    );
    for (k, c) in centres.iter().enumerate() {
        let n = per.min(robots - k * per);
        let first = poses.len();
        let mut tries = 0;
        while poses.len() < first + n {
            tries += 1;
            if tries > 100_000 {
                return Err(sc.error_at(0..0, format!("no room for {n} robots in tile {k}")));
            }
            let p = [
                c[0] + rng.random_range(-2.0..2.0),
                c[1] + rng.random_range(lo_y..hi_y),
            ];
            let clear = world
                .physics
                .disc_overlaps(p.into(), radius + 0.01)
                .is_none()
                && poses[first..].iter().all(|q| {
                    let (dx, dy) = (q[0] - p[0], q[1] - p[1]);
                    dx * dx + dy * dy > (2.0 * radius + 0.01) * (2.0 * radius + 0.01)
                });
            if clear {
                let heading = rng.random_range(-180.0..180.0f32);
                poses.push([p[0], p[1], heading]);
            }
        }
    }
    let _ = write!(
        text,
        "\n[[robots]]\nmodel = \"khepera4\"\ncontroller = \"{controller}\"\nsensors = {{ noise = \"realistic\" }}\nplacement = {{ poses = ["
    );
    for (i, p) in poses.iter().enumerate() {
        let sep = if i == 0 { "" } else { ", " };
        let _ = write!(text, "{sep}[{:.4}, {:.4}, {:.2}]", p[0], p[1], p[2]);
    }
    text.push_str("] }\n");
    Scenario::parse(&text, &name)
}

/// The random-walk benchmark world for `robots` Khepera IVs running `controller`: about
/// 0.8 m^2 per robot on a grid, one 5 kg box, one light every robot is in range of.
pub fn scenario(robots: usize, controller: &str) -> Result<Scenario, ScenarioError> {
    random_walk(robots, controller, true)
}

fn random_walk(
    robots: usize,
    controller: &str,
    with_robots: bool,
) -> Result<Scenario, ScenarioError> {
    let side = (AREA_PER_ROBOT_M2 * robots.max(1) as f32).sqrt().max(3.0);
    let cols = (robots.max(1) as f32).sqrt().ceil() as usize;
    let spacing = side / (cols as f32 + 1.0);
    let rows = robots.max(1).div_ceil(cols);
    // Keep grid points off the box at the origin.
    let cx = if cols % 2 == 1 { spacing / 2.0 } else { 0.0 };
    let cy = if rows % 2 == 1 { spacing / 2.0 } else { 0.0 };
    let lx = side / 2.0 - 0.5;
    let farthest = Vec2::new(lx + side / 2.0, side / 2.0).length();
    let text = format!(
        r#"
name = "bench-{robots}"
[arena]
size = [{side}, {side}]

[[lights]]
at = [{lx}, 0.0]
height = 0.5
intensity = {intensity}

[[objects]]
name = "box"
at = [0.0, 0.0]
shape = {{ box = [0.5, 0.5] }}
mass = 5.0
height = 0.5
floor_mu = 0.1
"#,
        intensity = light_intensity(farthest),
    );
    let text = if with_robots {
        format!(
            r#"{text}
[[robots]]
model = "khepera4"
count = {robots}
controller = "{controller}"
placement = {{ grid = {{ center = [{cx}, {cy}], spacing = {spacing}, columns = {cols}, heading_deg = 30.0 }} }}
"#
        )
    } else {
        text
    };
    Scenario::parse(&text, &format!("<bench {robots}>"))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn tiles_are_square_and_spare_few() {
        assert_eq!(tile_grid(1), (1, 1));
        assert_eq!(tile_grid(5), (2, 3));
        let (c, r) = tile_grid(50);
        assert!(c * r >= 50 && c * r <= 52, "{c} x {r}");
    }

    #[test]
    fn fill_objects_match_the_shipped_scenarios() {
        let dir = concat!(env!("CARGO_MANIFEST_DIR"), "/../../scenarios");
        for (name, off, _) in FILL_OBJECTS {
            let file = format!("{dir}/fill-transport-{}.toml", name.to_lowercase());
            let shipped = Scenario::load(file.as_ref()).unwrap();
            let sc = Workload::FillTransport.scenario(150).unwrap();
            let k = FILL_OBJECTS.iter().position(|o| o.0 == name).unwrap();
            let at = shipped.spec.objects[0].get_ref().at;
            assert_eq!([at[0], at[1]], off, "{name}");
            assert_eq!(
                sc.object_parts(k).unwrap(),
                shipped.object_parts(0).unwrap(),
                "{name}"
            );
            let (a, b) = (
                sc.spec.objects[k].get_ref(),
                shipped.spec.objects[0].get_ref(),
            );
            assert_eq!(
                (a.mass, a.floor_mu, a.height),
                (b.mass, b.floor_mu, b.height)
            );
        }
    }

    #[test]
    fn one_tile_is_the_seed_transport_set_up() {
        let sc = Workload::Transport.scenario(20).unwrap();
        let seed = Scenario::load(
            concat!(
                env!("CARGO_MANIFEST_DIR"),
                "/../../scenarios/seed-transport.toml"
            )
            .as_ref(),
        )
        .unwrap();
        assert_eq!(sc.spec.arena.size, seed.spec.arena.size);
        let (a, b) = (sc.spec.objects[0].get_ref(), seed.spec.objects[0].get_ref());
        assert_eq!(
            (a.at, a.mass, a.floor_mu, a.height),
            (b.at, b.mass, b.floor_mu, b.height)
        );
        let (l, m) = (sc.spec.lights[0].get_ref(), seed.spec.lights[0].get_ref());
        assert_eq!((l.at, l.height, l.intensity), (m.at, m.height, m.intensity));
        assert_eq!(sc.robot_count(), 20);
    }
}
