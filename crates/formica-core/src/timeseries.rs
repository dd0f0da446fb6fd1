//! Quantities over time, sampled from a running world: the object's distance to the goal, its
//! speed, and how many robots are in each controller state. `formica run --out` writes them as
//! `timeseries.csv`, sweeps with trajectories store them, and the viewer plots them.
//!
//! A series is fed after each tick ([`TimeSeries::observe`]) and samples every `every` ticks.
//! With a cap, it never holds more points: when full it keeps every other point and samples half
//! as often, so a run of any length keeps an evenly spaced series.

use crate::world::World;
use serde::Serialize;

/// One sample.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct SeriesPoint {
    /// Simulated time (s).
    pub t_s: f64,
    /// Distance from the target object's centre to the goal (m); `None` without either.
    pub goal_distance_m: Option<f64>,
    /// Speed of the target object's centre of mass (m/s); `None` without an object.
    pub object_speed_m_s: Option<f64>,
    /// Robots in each state, indexed like [`TimeSeries::states`] (missing trailing entries: 0).
    pub robots_in_state: Vec<u32>,
}

/// A series of [`SeriesPoint`]s.
#[derive(Debug, Clone)]
pub struct TimeSeries {
    every: u64,
    cap: usize,
    states: Vec<&'static str>,
    points: Vec<SeriesPoint>,
    last_tick: Option<u64>,
}

impl TimeSeries {
    /// A series sampling every `every_s` simulated seconds (at least every tick) and holding at
    /// most `cap` points (at least 2); samples `world` now.
    pub fn new(world: &World, every_s: f64, cap: usize) -> Self {
        let ticks = (every_s * world.tick_hz).round();
        let every = if ticks.is_finite() && ticks >= 1.0 {
            ticks as u64
        } else {
            1
        };
        let mut s = Self {
            every,
            cap: cap.max(2),
            states: Vec::new(),
            points: Vec::new(),
            last_tick: None,
        };
        s.sample(world);
        s
    }

    /// Called after each tick: samples if the tick is due.
    pub fn observe(&mut self, world: &World) {
        if world.tick.is_multiple_of(self.every) {
            self.sample(world);
        }
    }

    /// Samples `world` now (once per tick: a second call in the same tick does nothing).
    pub fn sample(&mut self, world: &World) {
        if self.last_tick == Some(world.tick) {
            return;
        }
        self.last_tick = Some(world.tick);
        if self.points.len() >= self.cap {
            let mut k = 0;
            self.points.retain(|_| {
                k += 1;
                k % 2 == 1
            });
            self.every = self.every.saturating_mul(2);
        }
        let mut counts = vec![0u32; self.states.len()];
        for r in &world.robots {
            match self.states.iter().position(|s| *s == r.state) {
                Some(i) => counts[i] += 1,
                None => {
                    self.states.push(r.state);
                    counts.push(1);
                }
            }
        }
        let target = world.target;
        let center = target.map(|t| world.object_center(t));
        self.points.push(SeriesPoint {
            t_s: world.time_s,
            goal_distance_m: center
                .zip(world.goal())
                .map(|(c, g)| f64::from((c - g).length())),
            object_speed_m_s: target
                .map(|t| f64::from(world.physics.velocity(world.objects[t].body).length())),
            robots_in_state: counts,
        });
    }

    /// Controller states seen so far, in the order first seen.
    pub fn states(&self) -> &[&'static str] {
        &self.states
    }

    /// The samples, oldest first.
    pub fn points(&self) -> &[SeriesPoint] {
        &self.points
    }

    /// Ticks between samples now.
    pub fn every_ticks(&self) -> u64 {
        self.every
    }

    /// The series as CSV: `t_s,goal_distance_m,object_speed_m_s`, then one `robots_<state>`
    /// column per state (sorted by name); empty cells for missing values.
    pub fn to_csv(&self) -> String {
        let mut order: Vec<usize> = (0..self.states.len()).collect();
        order.sort_by_key(|&i| self.states[i]);
        let mut out = String::from("t_s,goal_distance_m,object_speed_m_s");
        for &i in &order {
            out.push_str(",robots_");
            out.push_str(self.states[i]);
        }
        out.push('\n');
        let opt = |x: Option<f64>| x.map_or_else(String::new, |v| format!("{v:.5}"));
        for p in &self.points {
            out.push_str(&format!(
                "{:.3},{},{}",
                p.t_s,
                opt(p.goal_distance_m),
                opt(p.object_speed_m_s)
            ));
            for &i in &order {
                out.push_str(&format!(
                    ",{}",
                    p.robots_in_state.get(i).copied().unwrap_or(0)
                ));
            }
            out.push('\n');
        }
        out
    }

    /// The series as JSON: `{"states": [...], "t_s": [...], "goal_distance_m": [...],
    /// "object_speed_m_s": [...], "robots_in_state": [[...], ...]}` (columns, one row per state).
    pub fn to_json(&self) -> serde_json::Value {
        let n = self.states.len();
        let per_state: Vec<Vec<u32>> = (0..n)
            .map(|i| {
                self.points
                    .iter()
                    .map(|p| p.robots_in_state.get(i).copied().unwrap_or(0))
                    .collect()
            })
            .collect();
        serde_json::json!({
            "states": self.states,
            "t_s": self.points.iter().map(|p| p.t_s).collect::<Vec<_>>(),
            "goal_distance_m": self.points.iter().map(|p| p.goal_distance_m).collect::<Vec<_>>(),
            "object_speed_m_s": self.points.iter().map(|p| p.object_speed_m_s).collect::<Vec<_>>(),
            "robots_in_state": per_state,
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::experiment::{Run, RunOptions};
    use crate::Scenario;

    const SCENE: &str = r#"
[arena]
size = [3.0, 2.0]
[[lights]]
at = [1.2, 0.0]
[[objects]]
at = [-0.5, 0.0]
shape = { box = [0.3, 0.3] }
height = 0.3
mass = 0.5
floor_mu = 0.01
[[robots]]
count = 2
controller = "constant"
params = { left = 0.1, right = 0.1 }
placement = { poses = [[-0.9, 0.0, 0.0], [-0.9, 0.5, 0.0]] }
[run]
duration_s = 20
[stop]
on_goal = false
"#;

    #[test]
    fn samples_on_time_and_stays_under_its_cap() {
        let sc = Scenario::parse(SCENE, "t.toml").expect("parses");
        let mut run = Run::new(&sc, &RunOptions::default()).expect("builds");
        let mut s = TimeSeries::new(&run.world, 1.0, 8);
        for _ in 0..50 {
            run.step();
            s.observe(&run.world);
        }
        // Ticks 0, 10, ..., 50 at 10 Hz.
        let t: Vec<f64> = s.points().iter().map(|p| p.t_s).collect();
        assert_eq!(t.len(), 6, "{t:?}");
        assert!((t[5] - 5.0).abs() < 1e-9);
        // Every robot is counted in one state at every sample.
        assert!(!s.states().is_empty());
        for p in s.points() {
            assert_eq!(p.robots_in_state.iter().sum::<u32>(), 2);
        }
        assert!(s.points()[0]
            .goal_distance_m
            .is_some_and(|d| (d - 1.7).abs() < 1e-3));
        for _ in 0..150 {
            run.step();
            s.observe(&run.world);
        }
        assert!(s.points().len() <= 8);
        assert!(s.every_ticks() > 10);
        // The robots pushed the box: it moved at some point.
        assert!(s
            .points()
            .iter()
            .any(|p| p.object_speed_m_s.is_some_and(|v| v > 0.01)));
        let csv = s.to_csv();
        assert!(csv.starts_with("t_s,goal_distance_m,object_speed_m_s,robots_"));
        assert_eq!(csv.lines().count(), s.points().len() + 1);
    }
}
