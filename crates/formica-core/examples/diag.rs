// Scratch diagnostics (not committed): diag SCENARIO SEED EVERY_S [key=value ...]
use formica::experiment::{Run, RunOptions};
use formica::Overrides;
use std::collections::BTreeMap;

fn main() {
    let args: Vec<String> = std::env::args().collect();
    let path = std::path::Path::new(&args[1]);
    let seed: u64 = args[2].parse().unwrap();
    let every: f64 = args[3].parse().unwrap();
    let text = std::fs::read_to_string(path).unwrap();
    let sets: Vec<(String, toml::Value)> = args[4..]
        .iter()
        .map(|a| {
            let (k, v) = a.split_once('=').unwrap();
            let t: toml::Table = toml::from_str(&format!("v = {v}")).unwrap();
            (k.to_string(), t["v"].clone())
        })
        .collect();
    let reg = formica::Registry::builtin();
    let sc = reg
        .parse_with_overrides(&text, &args[1], &sets, ("cli", "--set"))
        .unwrap_or_else(|e| panic!("{e}"));
    let opts = RunOptions {
        overrides: Overrides {
            seed: Some(seed),
            ..Default::default()
        },
        ..Default::default()
    };
    let mut run = Run::new(&sc, &opts).unwrap();
    let mut next = 0.0;
    loop {
        let o = run.step();
        let w = &run.world;
        if w.time_s + 1e-9 >= next || o.is_some() {
            next += every;
            let mut st: BTreeMap<&str, usize> = BTreeMap::new();
            let mut relays = Vec::new();
            for (i, r) in w.robots.iter().enumerate() {
                *st.entry(r.state).or_default() += 1;
                if r.state == "relay" {
                    let p = w.robot_pose(i);
                    relays.push(format!("({:.2},{:.2})", p.x, p.y));
                }
            }
            let c = w.target.map(|t| w.object_center(t)).unwrap();
            let g = w.goal().unwrap();
            println!(
                "t={:6.1} obj=({:.2},{:.2}) goal=({:.2},{:.2}) {:?} relays={}",
                w.time_s,
                c.x,
                c.y,
                g.x,
                g.y,
                st,
                relays.join(" ")
            );
        }
        if let Some(o) = o {
            println!("{o:?}");
            break;
        }
    }
}
