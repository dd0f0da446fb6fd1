//! In-suite fuzzing of scenario files (issue 15): the shipped `scenarios/*.toml`, mutated by a
//! seeded mutator (numbers replaced by hostile values, lines deleted, duplicated, swapped or
//! inserted from a list of hostile snippets, bytes changed, text cut short), go through parse
//! and check; a share of those that load is built into a world and run for a few ticks (stop
//! rules and metrics included). Every case must end without a panic, within a memory bound
//! (a capped global allocator: exceeding it aborts the test binary) and a time bound (a
//! watchdog aborts on a case that takes longer).
//!
//! `FORMICA_FUZZ_CASES` (default 100,000) and `FORMICA_FUZZ_SEED` (default 1) choose the run;
//! `FORMICA_FUZZ_TRACE=1` writes each case to `target/fuzz-case.toml` before running it, to
//! find the one an abort was on. Run on its own: `cargo test --release --test fuzz`.

use cap::Cap;
use formica::experiment::{run, RunOptions};
use formica::{Overrides, Scenario};
use rand::{Rng, SeedableRng};
use std::alloc::System;
use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant};

#[global_allocator]
static ALLOC: Cap<System> = Cap::new(System, usize::MAX);

/// Most memory one case may allocate on top of what is held before it.
const CASE_BYTES: usize = 256 << 20;
/// Longest one case may take.
const CASE_TIME: Duration = Duration::from_secs(20);
/// One case in this many that loads is built and run.
const BUILD_ONE_IN: u32 = 10;

/// Values that broke, or could break, something: overflow, zero, tiny, huge, non-finite.
const NUMBERS: &[&str] = &[
    "0",
    "-0.0",
    "1",
    "-1",
    "2",
    "0.5",
    "1e-23",
    "1e-7",
    "0.0009",
    "0.001",
    "1000",
    "1001",
    "1e5",
    "100000",
    "100001",
    "1e7",
    "3e7",
    "3.4e38",
    "-3e38",
    "3e38",
    "1e39",
    "1e300",
    "4294967296",
    "4000000000",
    "770000000000000000",
    "9223372036854775807",
    "9223372036854775808",
    "18446744073709551615",
    "-9223372036854775808",
    "nan",
    "inf",
    "-inf",
    "0.001e-3",
    "2000",
    "-2000",
    "36001",
];

/// Lines that broke, or could break, something.
const SNIPPETS: &[&str] = &[
    "count = 4294967296",
    "count = 770000000000000000",
    "count = 100000",
    "tick_hz = 0.001",
    "tick_hz = 2",
    "substeps = 1",
    "duration_s = 1e30",
    "seed = 9223372036854775808",
    "wall_thickness = -1.0",
    "wall_thickness = 0",
    "wall_height = 0",
    "shape = { regular = { sides = 4000000000, radius = 0.3 } }",
    "shape = { regular = { sides = 1000, radius = 0.001 } }",
    "shape = { disc = 1e-23 }",
    "shape = { box = [1000.0, 0.5] }",
    "shape = { polygon = [[0, 0], [1, 0], [2, 0]] }",
    "shape = { polygon = [[0, 0], [0, 0], [1, 1]] }",
    "shape = { polygon = [[0, 0], [1, 0], [0.5, 0], [0, 1]] }",
    "parts = [{ disc = 0.2 }, { box = [0.1, 0.1], at = [0.3, 0] }]",
    "at = [3e7, 3e7]",
    "at = [3.4e38, 0]",
    "at = [499.0, 499.0]",
    "size = [1000.0, 1000.0]",
    "size = [1000.0, 0.5]",
    "center = [1000.0, -1000.0]",
    "placement = { random = { min = [-3e38, -3e38], max = [3e38, 3e38] } }",
    "placement = { random = { min = [-499, 0], max = [499, 0.001] } }",
    "placement = { grid = { center = [0, 0], spacing = 0.001 } }",
    "placement = { grid = { center = [0, 0], spacing = 0.2, columns = 100000 } }",
    "placement = { poses = [[0, 0, 0], [0, 0, 0]] }",
    "sensors = { proximity_noise = -1.0, camera_range = -1.0 }",
    "sensors = { camera_range = 1e30 }",
    "release = { interval_s = 1e30 }",
    "interval_s = 0.0001",
    "params = { left = 1e30, right = -1e30 }",
    "on_filled = 0",
    "goal_radius = -1",
    "intensity = 1e38",
    "mass = 1e-30",
    "floor_mu = 1e30",
    "yaw_deg = 1e30",
    "heading_deg = nan",
    "[run]",
    "[arena]",
    "[[robots]]",
    "[[objects]]",
    "[[walls]]",
    "[[lights]]",
    "a = [[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[1]]]]]]]]]]]]]]]]]]]]]]]]]]]]]]]]]]]]]]]]",
    "x = \"\u{0}\u{7f}\"",
];

type Rng64 = rand_pcg::Pcg64Mcg;

/// Byte ranges of the number tokens of `text`.
fn numbers(text: &str) -> Vec<(usize, usize)> {
    let b = text.as_bytes();
    let mut out = Vec::new();
    let mut i = 0;
    while i < b.len() {
        let starts =
            b[i].is_ascii_digit() || (b[i] == b'-' && b.get(i + 1).is_some_and(u8::is_ascii_digit));
        let after_word = i > 0 && (b[i - 1].is_ascii_alphanumeric() || b[i - 1] == b'_');
        if starts && !after_word {
            let s = i;
            i += 1;
            while i < b.len()
                && matches!(b[i], b'0'..=b'9' | b'.' | b'e' | b'E' | b'-' | b'+' | b'_')
            {
                i += 1;
            }
            out.push((s, i));
        } else {
            i += 1;
        }
    }
    out
}

/// Applies one to four mutations to `text`.
fn mutate(text: &str, rng: &mut Rng64) -> String {
    let mut t = text.to_string();
    for _ in 0..rng.random_range(1..=4) {
        match rng.random_range(0..10) {
            0..=3 => {
                let nums = numbers(&t);
                if !nums.is_empty() {
                    let (a, b) = nums[rng.random_range(0..nums.len())];
                    let v = NUMBERS[rng.random_range(0..NUMBERS.len())];
                    t.replace_range(a..b, v);
                }
            }
            4 | 5 => {
                let mut lines: Vec<&str> = t.lines().collect();
                let at = rng.random_range(0..=lines.len());
                lines.insert(at, SNIPPETS[rng.random_range(0..SNIPPETS.len())]);
                t = lines.join("\n");
            }
            6 => {
                let mut lines: Vec<String> = t.lines().map(String::from).collect();
                if !lines.is_empty() {
                    let i = rng.random_range(0..lines.len());
                    match rng.random_range(0..3) {
                        0 => {
                            lines.remove(i);
                        }
                        1 => {
                            let l = lines[i].clone();
                            lines.insert(i, l);
                        }
                        _ => {
                            let j = rng.random_range(0..lines.len());
                            lines.swap(i, j);
                        }
                    }
                }
                t = lines.join("\n");
            }
            7 => {
                // Repeat a whole table (robots, objects, ...) many times.
                if let Some(at) = t.find("[[") {
                    let end = t[at + 2..].find("\n[").map_or(t.len(), |e| at + 2 + e);
                    let block = t[at..end].to_string();
                    for _ in 0..rng.random_range(1..50) {
                        t.push('\n');
                        t.push_str(&block);
                    }
                }
            }
            8 => {
                let cut = rng.random_range(0..=t.len());
                let cut = (0..=cut)
                    .rev()
                    .find(|&c| t.is_char_boundary(c))
                    .unwrap_or(0);
                t.truncate(cut);
            }
            _ => {
                const BYTES: &[u8] = b"[]{}=,.\"'#\n-+_0e ";
                if !t.is_empty() {
                    let i = rng.random_range(0..t.len());
                    let i = (0..=i).rev().find(|&c| t.is_char_boundary(c)).unwrap_or(0);
                    let c = BYTES[rng.random_range(0..BYTES.len())] as char;
                    t.insert(i, c);
                }
            }
        }
    }
    t
}

/// Parse, check and, if `build`, a run of a few ticks; returns whether the file loaded.
fn case(text: &str, build: bool) -> bool {
    let Ok(sc) = Scenario::parse(text, "fuzz.toml") else {
        return false;
    };
    if build {
        let ticks = 3.0;
        let opts = RunOptions {
            overrides: Overrides {
                duration_s: Some(ticks / sc.spec.run.tick_hz),
                ..Default::default()
            },
            ..Default::default()
        };
        let _ = run(&sc, &opts);
    }
    true
}

#[test]
fn mutated_scenarios_never_panic_exhaust_memory_or_hang() {
    let env = |k: &str, d: u64| {
        std::env::var(k)
            .ok()
            .and_then(|v| v.parse().ok())
            .unwrap_or(d)
    };
    let cases = env("FORMICA_FUZZ_CASES", 100_000);
    let seed = env("FORMICA_FUZZ_SEED", 1);
    let trace = std::env::var("FORMICA_FUZZ_TRACE").is_ok_and(|v| v == "1");
    let dir = format!("{}/../../scenarios", env!("CARGO_MANIFEST_DIR"));
    let mut files: Vec<_> = std::fs::read_dir(&dir)
        .unwrap()
        .map(|e| e.unwrap().path())
        .filter(|p| p.extension().is_some_and(|e| e == "toml"))
        .collect();
    files.sort();
    let texts: Vec<String> = files
        .iter()
        .map(|p| std::fs::read_to_string(p).unwrap())
        .collect();
    assert!(texts.len() >= 10, "expected the shipped scenarios in {dir}");

    // The watchdog: aborts, naming the case, if one takes longer than CASE_TIME.
    let current: Arc<Mutex<(Instant, u64)>> = Arc::new(Mutex::new((Instant::now(), 0)));
    let done = Arc::new(std::sync::atomic::AtomicBool::new(false));
    let watchdog = {
        let (current, done) = (current.clone(), done.clone());
        std::thread::spawn(move || {
            while !done.load(std::sync::atomic::Ordering::Relaxed) {
                std::thread::sleep(Duration::from_millis(200));
                let (since, k) = *current.lock().unwrap();
                if since.elapsed() > CASE_TIME {
                    eprintln!(
                        "fuzz case {k} (FORMICA_FUZZ_SEED={seed}) took more than {CASE_TIME:?}; \
                         rerun with FORMICA_FUZZ_TRACE=1 to get its text"
                    );
                    std::process::abort();
                }
            }
        })
    };

    let start = Instant::now();
    let mut rng = Rng64::seed_from_u64(seed);
    let (mut loaded, mut built, mut slowest) = (0u64, 0u64, Duration::ZERO);
    let trace_path = format!("{}/../../target/fuzz-case.toml", env!("CARGO_MANIFEST_DIR"));
    for k in 0..cases {
        let base = &texts[rng.random_range(0..texts.len())];
        let text = mutate(base, &mut rng);
        let build = rng.random_ratio(1, BUILD_ONE_IN);
        if trace {
            std::fs::write(&trace_path, &text).unwrap();
        }
        *current.lock().unwrap() = (Instant::now(), k);
        let held = ALLOC.allocated();
        ALLOC.set_limit(held + CASE_BYTES).unwrap();
        let t0 = Instant::now();
        let outcome = std::panic::catch_unwind(|| case(&text, build));
        let took = t0.elapsed();
        ALLOC.set_limit(usize::MAX).unwrap();
        slowest = slowest.max(took);
        match outcome {
            Ok(true) => {
                loaded += 1;
                built += u64::from(build);
            }
            Ok(false) => {}
            Err(_) => panic!("fuzz case {k} (seed {seed}) panicked on:\n{text}"),
        }
    }
    done.store(true, std::sync::atomic::Ordering::Relaxed);
    watchdog.join().unwrap();
    eprintln!(
        "fuzz: {cases} cases in {:.1} s ({loaded} loaded, {built} built and run), slowest \
         {:.0} ms, peak memory held {} MiB",
        start.elapsed().as_secs_f64(),
        slowest.as_secs_f64() * 1e3,
        ALLOC.max_allocated() >> 20
    );
    assert!(
        loaded > cases / 20,
        "too few mutants load ({loaded}): the mutator is too rough"
    );
}
