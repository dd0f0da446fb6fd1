//! Files written by `formica run --out DIR`: trajectories as CSV and a picture of the end.

use anyhow::{Context, Result};
use formica::experiment::Trajectories;
use std::io::Write;
use std::path::Path;

/// Writes `object.csv` (t, x, y, theta) and `robots.csv` (t, robot, x, y, theta).
pub fn write_trajectories(dir: &Path, tr: &Trajectories) -> Result<()> {
    let write = |name: &str, header: &str, rows: &mut dyn Iterator<Item = String>| -> Result<()> {
        let path = dir.join(name);
        let f =
            std::fs::File::create(&path).with_context(|| format!("creating {}", path.display()))?;
        let mut w = std::io::BufWriter::new(f);
        writeln!(w, "{header}")?;
        for row in rows {
            writeln!(w, "{row}")?;
        }
        w.flush()
            .with_context(|| format!("writing {}", path.display()))
    };
    write(
        "object.csv",
        "t_s,x_m,y_m,theta_rad",
        &mut tr
            .object
            .iter()
            .map(|s| format!("{:.3},{:.5},{:.5},{:.5}", s.t, s.x, s.y, s.theta)),
    )?;
    write(
        "robots.csv",
        "t_s,robot,x_m,y_m,theta_rad",
        &mut tr.robots.iter().map(|s| {
            format!(
                "{:.3},{},{:.5},{:.5},{:.5}",
                s.t,
                s.id.unwrap_or(0),
                s.x,
                s.y,
                s.theta
            )
        }),
    )
}
