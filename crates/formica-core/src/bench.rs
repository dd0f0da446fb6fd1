//! The standard benchmark world: a transport-like arena scaled to keep density constant
//! (about 0.8 m^2 per robot), one movable box, one light, every robot sensing (proximity and
//! light with occlusion) and driving every tick.

use crate::scenario::{Scenario, ScenarioError};

/// Floor area per robot (m^2).
pub const AREA_PER_ROBOT_M2: f32 = 0.8;

/// The benchmark scenario for `robots` Khepera IVs running `controller`.
pub fn scenario(robots: usize, controller: &str) -> Result<Scenario, ScenarioError> {
    let side = (AREA_PER_ROBOT_M2 * robots.max(1) as f32).sqrt().max(3.0);
    let cols = (robots.max(1) as f32).sqrt().ceil() as usize;
    let spacing = side / (cols as f32 + 1.0);
    let rows = robots.max(1).div_ceil(cols);
    // Keep grid points off the box at the origin.
    let cx = if cols % 2 == 1 { spacing / 2.0 } else { 0.0 };
    let cy = if rows % 2 == 1 { spacing / 2.0 } else { 0.0 };
    let text = format!(
        r#"
name = "bench-{robots}"
[arena]
size = [{side}, {side}]

[[lights]]
at = [{lx}, 0.0]
height = 0.5
intensity = 10.0

[[objects]]
name = "box"
at = [0.0, 0.0]
shape = {{ box = [0.5, 0.5] }}
mass = 5.0
height = 0.5
floor_mu = 0.1

[[robots]]
model = "khepera4"
count = {robots}
controller = "{controller}"
placement = {{ grid = {{ center = [{cx}, {cy}], spacing = {spacing}, columns = {cols}, heading_deg = 30.0 }} }}
"#,
        lx = side / 2.0 - 0.5,
        spacing = spacing,
    );
    Scenario::parse(&text, &format!("<bench {robots}>"))
}
