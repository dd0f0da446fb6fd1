//! The range of every number a scenario file can hold, and where in the file a key is written.
//!
//! Every count, size, coordinate, rate and duration is checked against these ranges when the
//! file is read, before anything is allocated for it, and an error names the file, the line and
//! column of the key, the key and the range. The ranges are wide enough for real work (100,000
//! robots, arenas of 1 km, 1 to 1000 ticks/s) and narrow enough that no accepted file can
//! exhaust memory, overflow a float or hang a run: the README's "Limits" section lists them.

use crate::scenario::{PartSpec, Placement, Scenario, ScenarioError, SensorOptions};
use std::ops::Range;
use toml::de::{DeTable, DeValue};
use toml::Spanned;

/// Largest scenario or sweep file (bytes).
pub const MAX_FILE_BYTES: usize = 64 << 20;
/// Reads a text file of at most [`MAX_FILE_BYTES`], without reading more than one byte past
/// that: a larger file, or an endless one (`/dev/zero`), is refused once the limit is passed
/// instead of filling memory.
pub fn read_text(path: &std::path::Path) -> std::io::Result<String> {
    use std::io::Read;
    let mut bytes = Vec::new();
    std::fs::File::open(path)?
        .take(MAX_FILE_BYTES as u64 + 1)
        .read_to_end(&mut bytes)?;
    if bytes.len() > MAX_FILE_BYTES {
        return Err(std::io::Error::other(format!(
            "larger than the {MAX_FILE_BYTES} bytes a file may have"
        )));
    }
    String::from_utf8(bytes).map_err(|e| {
        let bytes = e.as_bytes();
        let at = e.utf8_error().valid_up_to();
        let line = 1 + bytes[..at].iter().filter(|&&b| b == b'\n').count();
        let line_start = bytes[..at]
            .iter()
            .rposition(|&b| b == b'\n')
            .map_or(0, |p| p + 1);
        // Columns count characters; the line's bytes up to `at` are valid UTF-8.
        let column = 1 + String::from_utf8_lossy(&bytes[line_start..at])
            .chars()
            .count();
        std::io::Error::new(
            std::io::ErrorKind::InvalidData,
            NotUtf8 {
                line,
                column,
                byte: bytes[at],
            },
        )
    })
}

/// Where a file that is not UTF-8 text first is not: the error inside [`read_text`]'s
/// `InvalidData` error, so that callers can give the file's line and column.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct NotUtf8 {
    /// 1-based line.
    pub line: usize,
    /// 1-based column (in characters).
    pub column: usize,
    /// The first byte that is not UTF-8 there.
    pub byte: u8,
}

impl std::fmt::Display for NotUtf8 {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(
            f,
            "not UTF-8 text: line {}, column {} has the byte 0x{:02x}",
            self.line, self.column, self.byte
        )
    }
}

impl std::error::Error for NotUtf8 {}

/// [`read_text`]'s error `e` for `file` as a scenario error: at the line and column of the
/// first byte that is not UTF-8, or else the file cannot be read.
pub fn read_error(file: &str, e: &std::io::Error) -> ScenarioError {
    match e.get_ref().and_then(|i| i.downcast_ref::<NotUtf8>()) {
        Some(n) => ScenarioError::Invalid {
            file: file.to_string(),
            line: n.line,
            column: n.column,
            message: format!("not UTF-8 text: the byte 0x{:02x}", n.byte),
        },
        None => ScenarioError::Io {
            file: file.to_string(),
            message: e.to_string(),
        },
    }
}

/// Deepest nesting of arrays and inline tables in a scenario file.
pub const MAX_NESTING: usize = 32;
/// Most robots in one scenario (all groups together).
pub const MAX_ROBOTS: usize = 100_000;
/// Most robot groups, objects, lights, extra walls, and parts of one object.
pub const MAX_ITEMS: usize = 1_000;
/// Largest arena side (m).
pub const MAX_ARENA_M: f32 = 1_000.0;
/// Largest distance of any position from the origin along either axis (m).
pub const MAX_COORD_M: f32 = 2_000.0;
/// Smallest size of anything: a side, a radius, a thickness, a height, a polygon edge (m).
pub const MIN_SIZE_M: f32 = 0.001;
/// Largest size of a shape, a wall or a grid spacing (m).
pub const MAX_SIZE_M: f32 = 1_000.0;
/// Largest height of a wall, an object or a light (m).
pub const MAX_HEIGHT_M: f32 = 100.0;
/// Most vertices of one polygon.
pub const MAX_POLYGON_VERTICES: usize = 1_000;
/// Most sides of a regular polygon.
pub const MAX_REGULAR_SIDES: u32 = 1_000;
/// Largest rotation (degrees, either sign).
pub const MAX_ANGLE_DEG: f32 = 36_000.0;
/// Largest object mass (kg).
pub const MAX_MASS_KG: f32 = 1.0e6;
/// Largest floor friction coefficient.
pub const MAX_FLOOR_MU: f32 = 100.0;
/// Largest light intensity (ARGoS units).
pub const MAX_INTENSITY: f32 = 1.0e4;
/// Largest noise spread (relative spreads are fractions of the reading; angles in rad).
pub const MAX_SPREAD: f32 = 10.0;
/// Largest relative spread of wheel speeds (`wheels.noise`, `wheels.bias`).
pub const MAX_WHEEL_SPREAD: f32 = 0.5;
/// Largest sensor range: camera, colour scan and the scan's range step (m).
pub const MAX_RANGE_M: f32 = 100.0;
/// Control ticks per second.
pub const TICK_HZ: (f32, f32) = (1.0, 1_000.0);
/// Longest simulated time of one run, and latest release time (s).
pub const MAX_DURATION_S: f32 = 1.0e6;
/// Largest seed: TOML integers are 64-bit signed.
pub const MAX_SEED: u64 = i64::MAX as u64;
/// Most trials (parameter sets times seeds) one `run --seeds` or sweep file may ask for.
pub const MAX_TRIALS: u64 = 10_000_000;
/// Most seeds of one `formica run --seeds` or `formica.run` call: each keeps every result for
/// its closing summary (a sweep stores each trial as it ends and takes [`MAX_TRIALS`]).
pub const MAX_RUN_SEEDS: u64 = 1_000_000;
/// Most parameter sets of one sweep file: each is a scenario built and checked when the sweep
/// loads (about 3 KB and 0.4 ms a set), so that a grid of millions is refused, not allocated.
pub const MAX_SETS: u64 = 100_000;

/// `x` as a short decimal for messages (`1000`, `0.001`, `1e6`).
pub fn show(x: f32) -> String {
    if x != 0.0 && (x.abs() >= 1.0e5 || x.abs() < 1.0e-3) {
        format!("{x:e}")
    } else {
        format!("{x}")
    }
}

/// One step of a key path: a table key or an array index.
#[derive(Debug, Clone, PartialEq, Eq)]
enum Step<'p> {
    Key(&'p str),
    Index(usize),
}

/// Splits `objects[0].shape.polygon[3][1]` into its steps.
fn steps(path: &str) -> Vec<Step<'_>> {
    let mut out = Vec::new();
    for part in path.split('.') {
        let (key, mut rest) = part.split_once('[').map_or((part, ""), |(k, r)| (k, r));
        if !key.is_empty() {
            out.push(Step::Key(key));
        }
        while let Some((i, r)) = rest.split_once(']') {
            if let Ok(i) = i.parse() {
                out.push(Step::Index(i));
            }
            rest = r.strip_prefix('[').unwrap_or(r);
        }
    }
    out
}

/// Where a key path is written in a TOML text: the span of its key (or of the array element),
/// or, if the file does not write it (a default), of the deepest table on the way that it does
/// write, or of the first entry of the file. `None` if the text does not parse.
pub fn span_of(text: &str, path: &str) -> Option<Range<usize>> {
    let doc = DeTable::parse(text).ok()?;
    let mut here: &DeTable<'_> = doc.get_ref();
    let mut best = first_entry(here);
    let mut value: Option<&Spanned<DeValue<'_>>> = None;
    for step in steps(path) {
        let next = match (step, value.map(Spanned::get_ref)) {
            (Step::Key(k), None) => find_key(here, k),
            (Step::Key(k), Some(DeValue::Table(t))) => find_key(t, k),
            (Step::Index(i), Some(DeValue::Array(a))) => a.get(i).map(|v| (v.span(), v)),
            _ => None,
        };
        let Some((span, v)) = next else { break };
        best = Some(span);
        value = Some(v);
        if let DeValue::Table(t) = v.get_ref() {
            here = t;
        }
    }
    best
}

/// The key path written at byte `offset` of a TOML text, as its steps (`["robots", "0",
/// "params"]`): the deepest key or array element whose key or value spans the offset. Empty if
/// none does (or the text does not parse). The inverse of [`span_of`].
pub fn path_at(text: &str, offset: usize) -> Vec<String> {
    fn value_path(v: &Spanned<DeValue<'_>>, offset: usize, out: &mut Vec<String>) -> bool {
        match v.get_ref() {
            DeValue::Table(t) => table_path(t, offset, out),
            DeValue::Array(a) => {
                for (i, item) in a.iter().enumerate() {
                    out.push(i.to_string());
                    if value_path(item, offset, out) || item.span().contains(&offset) {
                        return true;
                    }
                    out.pop();
                }
                false
            }
            _ => false,
        }
    }
    fn table_path(t: &DeTable<'_>, offset: usize, out: &mut Vec<String>) -> bool {
        for (key, value) in t.iter() {
            out.push(key.get_ref().to_string());
            // Inside the value first: the tables of `[[robots]]` headers span their entries.
            if value_path(value, offset, out)
                || key.span().contains(&offset)
                || value.span().contains(&offset)
            {
                return true;
            }
            out.pop();
        }
        false
    }
    let mut out = Vec::new();
    if let Ok(doc) = DeTable::parse(text) {
        table_path(doc.get_ref(), offset, &mut out);
    }
    out
}

/// Keys whose value is a point or size `[x, y]`, and keys whose list items are `[x, y]` or
/// `[a, b, c]`, wherever they stand outside a controller's free-form `params`.
const PAIRS: [&str; 6] = ["at", "size", "center", "min", "max", "box"];
const PAIR_ITEMS: [&str; 1] = ["polygon"];
const TRIPLE_ITEMS: [&str; 2] = ["poses", "path"];

/// The first list of numbers of the wrong length under a key of `PAIRS`, `PAIR_ITEMS` or
/// `TRIPLE_ITEMS` (controllers' `params` tables aside), with what it should be. A list of
/// three where two are meant (`at = [2.5, 0.0, 0.5]`, an ARGoS habit: the third is a height
/// here given apart) would otherwise lose its extra number without a word.
pub fn wrong_length(text: &str) -> Option<(Range<usize>, String)> {
    let doc = DeTable::parse(text).ok()?;
    wrong_length_in(doc.get_ref())
}

fn numbers(v: &DeValue<'_>) -> Option<usize> {
    match v {
        DeValue::Array(a)
            if a.iter()
                .all(|x| !matches!(x.get_ref(), DeValue::Array(_) | DeValue::Table(_))) =>
        {
            Some(a.len())
        }
        _ => None,
    }
}

fn wrong_length_in(t: &DeTable<'_>) -> Option<(Range<usize>, String)> {
    for (key, value) in t.iter() {
        let k = key.get_ref().as_ref();
        if k == "params" {
            continue;
        }
        if PAIRS.contains(&k) {
            if let Some(n) = numbers(value.get_ref()).filter(|&n| n != 2) {
                return Some((
                    value.span(),
                    format!("`{k}`: expected two numbers [x, y], got {n}"),
                ));
            }
        }
        let items = if PAIR_ITEMS.contains(&k) {
            Some((2, "[x, y]"))
        } else if TRIPLE_ITEMS.contains(&k) {
            Some((
                3,
                if k == "poses" {
                    "[x, y, heading_deg]"
                } else {
                    "[t, x, y]"
                },
            ))
        } else {
            None
        };
        if let (Some((want, shape)), DeValue::Array(list)) = (items, value.get_ref()) {
            for item in list.iter() {
                if let Some(n) = numbers(item.get_ref()).filter(|&n| n != want) {
                    return Some((
                        item.span(),
                        format!("`{k}`: each item is {shape}, {want} numbers; got {n}"),
                    ));
                }
            }
        }
        let found = match value.get_ref() {
            DeValue::Table(inner) => wrong_length_in(inner),
            DeValue::Array(list) => list.iter().find_map(|v| match v.get_ref() {
                DeValue::Table(inner) => wrong_length_in(inner),
                _ => None,
            }),
            _ => None,
        };
        if found.is_some() {
            return found;
        }
    }
    None
}

/// The span of key `k` in `t` and its value.
fn find_key<'t, 'i>(
    t: &'t DeTable<'i>,
    k: &str,
) -> Option<(Range<usize>, &'t Spanned<DeValue<'i>>)> {
    t.iter()
        .find(|(key, _)| key.get_ref().as_ref() == k)
        .map(|(key, v)| (key.span(), v))
}

/// The span of the first key written in `t` (by position).
fn first_entry(t: &DeTable<'_>) -> Option<Range<usize>> {
    t.iter().map(|(k, _)| k.span()).min_by_key(|s| s.start)
}

/// Byte offset of the first structural byte of `text` (outside strings and comments) for which
/// `stop` returns true.
fn scan(text: &str, mut stop: impl FnMut(u8) -> bool) -> Option<usize> {
    let b = text.as_bytes();
    let mut i = 0;
    while i < b.len() {
        match b[i] {
            b'#' => {
                while i < b.len() && b[i] != b'\n' {
                    i += 1;
                }
            }
            q @ (b'"' | b'\'') => {
                let triple = b[i..].starts_with(&[q, q, q]);
                let n = if triple { 3 } else { 1 };
                i += n;
                while i < b.len() && !(b[i..].starts_with(&[q, q, q][..n])) {
                    if q == b'"' && b[i] == b'\\' {
                        i += 1;
                    }
                    // A one-line string ends at the line's end, closed or not.
                    if !triple && b.get(i) == Some(&b'\n') {
                        break;
                    }
                    i += 1;
                }
                i += n;
                continue;
            }
            c => {
                if stop(c) {
                    return Some(i);
                }
            }
        }
        i += 1;
    }
    None
}

/// Byte offset of the first `[` or `{` nested deeper than [`MAX_NESTING`] (outside strings and
/// comments): the parser and the deserialiser recurse, so a file of a million `[` would
/// overflow the stack.
pub fn too_deep(text: &str) -> Option<usize> {
    let mut depth = 0usize;
    scan(text, |c| match c {
        b'[' | b'{' => {
            depth += 1;
            depth > MAX_NESTING
        }
        b']' | b'}' => {
            depth = depth.saturating_sub(1);
            false
        }
        _ => false,
    })
}

/// Most values a scenario or sweep file may hold (counted, before parsing, as its `,`, `=`,
/// `[` and `{` outside strings and comments). Parsing keeps a few hundred bytes for each value,
/// so without this a 20 MB file of `[0,0,0,...]` took 2.7 GB; at the limit a file takes about
/// 0.5 GB. 100,000 robots with a pose each need 500,000.
pub const MAX_VALUES: usize = 2_000_000;

/// Byte offset where `text` passes [`MAX_VALUES`] values.
pub fn too_many_values(text: &str) -> Option<usize> {
    let mut n = 0usize;
    scan(text, |c| {
        if matches!(c, b',' | b'=' | b'[' | b'{') {
            n += 1;
        }
        n > MAX_VALUES
    })
}

/// The size checks of a file's text before it is parsed: nesting ([`too_deep`]) and the number
/// of values ([`too_many_values`]). Returns the byte offset and what is wrong.
pub fn too_large(text: &str) -> Option<(usize, String)> {
    if let Some(at) = too_deep(text) {
        return Some((
            at,
            format!("arrays and inline tables nested more than {MAX_NESTING} deep"),
        ));
    }
    too_many_values(text).map(|at| {
        (
            at,
            format!("more than {MAX_VALUES} values (numbers, strings, arrays, tables) in one file"),
        )
    })
}

/// Checks every number of `sc`'s file against its range (see the module doc), in file order
/// of the tables, each error at its key.
pub(crate) fn check(sc: &Scenario) -> Result<(), ScenarioError> {
    let c = Check { sc };
    let s = &sc.spec;
    let a = &s.arena;
    for i in 0..2 {
        c.real(a.size[i], MIN_SIZE_M, MAX_ARENA_M, "m", || {
            format!("arena.size[{i}]")
        })?;
        c.real(a.center[i], -MAX_ARENA_M, MAX_ARENA_M, "m", || {
            format!("arena.center[{i}]")
        })?;
    }
    c.real(a.wall_thickness, MIN_SIZE_M, MAX_HEIGHT_M, "m", || {
        "arena.wall_thickness".into()
    })?;
    c.real(a.wall_height, MIN_SIZE_M, MAX_HEIGHT_M, "m", || {
        "arena.wall_height".into()
    })?;
    c.items(s.walls.len(), "walls")?;
    for (i, w) in s.walls.iter().enumerate() {
        let w = w.get_ref();
        c.point(w.at, || format!("walls[{i}].at"))?;
        if let Some(size) = w.size {
            for (k, v) in size.into_iter().enumerate() {
                c.real(v, MIN_SIZE_M, MAX_COORD_M, "m", || {
                    format!("walls[{i}].size[{k}]")
                })?;
            }
        }
        if let Some(p) = &w.shape {
            c.part(p.get_ref(), &format!("walls[{i}].shape"))?;
        }
        c.angle(w.yaw_deg, || format!("walls[{i}].yaw_deg"))?;
        c.real(w.height, MIN_SIZE_M, MAX_HEIGHT_M, "m", || {
            format!("walls[{i}].height")
        })?;
    }
    c.items(s.lights.len(), "lights")?;
    for (i, l) in s.lights.iter().enumerate() {
        let l = l.get_ref();
        c.point(l.at, || format!("lights[{i}].at"))?;
        c.real(l.height, 0.0, MAX_HEIGHT_M, "m", || {
            format!("lights[{i}].height")
        })?;
        c.real(l.intensity, MIN_SIZE_M, MAX_INTENSITY, "", || {
            format!("lights[{i}].intensity")
        })?;
        c.items(l.path.len(), &format!("lights[{i}].path"))?;
        for (k, w) in l.path.iter().enumerate() {
            c.real(w[0], 0.0, MAX_DURATION_S, "s", || {
                format!("lights[{i}].path[{k}][0]")
            })?;
            for (j, v) in w.iter().enumerate().skip(1) {
                c.real(*v, -MAX_COORD_M, MAX_COORD_M, "m", || {
                    format!("lights[{i}].path[{k}][{j}]")
                })?;
            }
        }
    }
    c.items(s.objects.len(), "objects")?;
    for (i, o) in s.objects.iter().enumerate() {
        let o = o.get_ref();
        let p = |k: &str| format!("objects[{i}].{k}");
        c.point(o.at, || p("at"))?;
        c.angle(o.yaw_deg, || p("yaw_deg"))?;
        c.real(o.height, MIN_SIZE_M, MAX_HEIGHT_M, "m", || p("height"))?;
        c.real(o.mass, MIN_SIZE_M, MAX_MASS_KG, "kg", || p("mass"))?;
        c.real(o.floor_mu, 0.0, MAX_FLOOR_MU, "", || p("floor_mu"))?;
        if let Some(shape) = &o.shape {
            c.part(shape.get_ref(), &p("shape"))?;
        }
        c.items(o.parts.len(), &p("parts"))?;
        for (k, part) in o.parts.iter().enumerate() {
            c.part(part.get_ref(), &p(&format!("parts[{k}]")))?;
        }
    }
    c.items(s.robots.len(), "robots")?;
    let mut total = 0usize;
    for (g, grp) in s.robots.iter().enumerate() {
        let gr = grp.get_ref();
        let p = |k: &str| format!("robots[{g}].{k}");
        let n = match (gr.count, gr.placement.get_ref()) {
            (Some(n), _) => n,
            (None, Placement::Poses(v)) => v.len(),
            (None, _) => 1,
        };
        if !(1..=MAX_ROBOTS).contains(&n) {
            return Err(c.at(
                &p("count"),
                format!(
                    "robots[{g}]: count must be at least 1 and at most {MAX_ROBOTS} (all groups \
                     together), got {n}"
                ),
            ));
        }
        total += n;
        if total > MAX_ROBOTS {
            return Err(c.at(
                &p("count"),
                format!(
                    "robots[{g}].count: at most {MAX_ROBOTS} robots in a scenario (all groups \
                     together), got {total} up to this group"
                ),
            ));
        }
        match gr.placement.get_ref() {
            Placement::Random {
                min,
                max,
                heading_deg,
            } => {
                c.point(*min, || p("placement.random.min"))?;
                c.point(*max, || p("placement.random.max"))?;
                if let Some(h) = heading_deg {
                    c.angle(*h, || p("placement.random.heading_deg"))?;
                }
            }
            Placement::Grid {
                center,
                spacing,
                columns,
                heading_deg,
            } => {
                c.point(*center, || p("placement.grid.center"))?;
                c.real(*spacing, MIN_SIZE_M, MAX_SIZE_M, "m", || {
                    p("placement.grid.spacing")
                })?;
                if let Some(k) = columns {
                    if !(1..=MAX_ROBOTS).contains(k) {
                        return Err(c.at(
                            &p("placement.grid.columns"),
                            format!(
                                "robots[{g}].placement.grid.columns: expected 1 to {MAX_ROBOTS}, \
                                 got {k}"
                            ),
                        ));
                    }
                }
                c.angle(*heading_deg, || p("placement.grid.heading_deg"))?;
            }
            Placement::Poses(poses) => {
                for (k, q) in poses.iter().enumerate() {
                    c.point([q[0], q[1]], || p(&format!("placement.poses[{k}]")))?;
                    c.angle(q[2], || p(&format!("placement.poses[{k}][2]")))?;
                }
            }
        }
        c.sensors(&gr.sensors, &p("sensors"))?;
        c.real(gr.wheels.noise, 0.0, MAX_WHEEL_SPREAD, "", || {
            p("wheels.noise")
        })?;
        c.real(gr.wheels.bias, 0.0, MAX_WHEEL_SPREAD, "", || {
            p("wheels.bias")
        })?;
        let r = &gr.release;
        c.real(r.interval_s, 0.0, MAX_DURATION_S, "s", || {
            p("release.interval_s")
        })?;
        c.real(r.start_s, 0.0, MAX_DURATION_S, "s", || p("release.start_s"))?;
    }
    let run = &s.run;
    c.real(run.tick_hz, TICK_HZ.0, TICK_HZ.1, "ticks/s", || {
        "run.tick_hz".into()
    })?;
    if !(run.duration_s > 0.0 && run.duration_s <= MAX_DURATION_S) {
        return Err(c.at(
            "run.duration_s",
            format!(
                "run.duration_s: expected more than 0 and at most {} s, got {}",
                show(MAX_DURATION_S),
                run.duration_s
            ),
        ));
    }
    let stop = &s.stop;
    if let Some(g) = stop.goal_radius {
        c.real(g, 0.0, MAX_COORD_M, "m", || "stop.goal_radius".into())?;
    }
    c.real(stop.goal_size, 0.0, MAX_SIZE_M, "m", || {
        "stop.goal_size".into()
    })?;
    if let Some(f) = stop.on_filled {
        if !(f > 0.0 && f <= 1.0) {
            return Err(c.at(
                "stop.on_filled",
                format!("stop.on_filled: expected a fraction more than 0 and at most 1, got {f}"),
            ));
        }
    }
    Ok(())
}

struct Check<'a> {
    sc: &'a Scenario,
}

impl Check<'_> {
    /// An error at the key `path`.
    fn at(&self, path: &str, message: String) -> ScenarioError {
        self.sc.error_at_key(path, message)
    }

    /// `v` in `lo..=hi` (NaN is not).
    fn real(
        &self,
        v: f32,
        lo: f32,
        hi: f32,
        unit: &str,
        path: impl FnOnce() -> String,
    ) -> Result<(), ScenarioError> {
        if v >= lo && v <= hi {
            return Ok(());
        }
        let path = path();
        let unit = if unit.is_empty() {
            String::new()
        } else {
            format!(" {unit}")
        };
        Err(self.at(
            &path,
            format!(
                "{path}: expected {} to {}{unit}, got {}",
                show(lo),
                show(hi),
                show(v)
            ),
        ))
    }

    /// A position: both coordinates within [`MAX_COORD_M`].
    fn point(&self, p: [f32; 2], path: impl Fn() -> String) -> Result<(), ScenarioError> {
        for (k, v) in p.into_iter().enumerate() {
            self.real(v, -MAX_COORD_M, MAX_COORD_M, "m", || {
                format!("{}[{k}]", path())
            })?;
        }
        Ok(())
    }

    /// An angle in degrees within [`MAX_ANGLE_DEG`].
    fn angle(&self, v: f32, path: impl FnOnce() -> String) -> Result<(), ScenarioError> {
        self.real(v, -MAX_ANGLE_DEG, MAX_ANGLE_DEG, "degrees", path)
    }

    /// At most [`MAX_ITEMS`] entries in the list at `path`.
    fn items(&self, n: usize, path: &str) -> Result<(), ScenarioError> {
        if n <= MAX_ITEMS {
            return Ok(());
        }
        Err(self.at(
            &format!("{path}[{MAX_ITEMS}]"),
            format!("{path}: at most {MAX_ITEMS} entries, got {n}"),
        ))
    }

    /// Noise spreads, ranges and the ambient level of a group's `sensors` table.
    fn sensors(&self, so: &SensorOptions, path: &str) -> Result<(), ScenarioError> {
        let spreads = [
            ("proximity_noise", so.proximity_noise),
            ("proximity_floor", so.proximity_floor),
            ("light_noise", so.light_noise),
            ("light_floor", so.light_floor),
            ("heading_noise", so.heading_noise),
            ("camera_noise", so.camera_noise),
            ("camera_distance_noise", so.camera_distance_noise),
            ("scan_noise", so.scan_noise),
        ];
        for (k, v) in spreads {
            if let Some(v) = v {
                self.real(v, 0.0, MAX_SPREAD, "", || format!("{path}.{k}"))?;
            }
        }
        for (k, v, lo, hi) in [
            ("position_noise", so.position_noise, 0.0, MAX_SIZE_M),
            ("beacon_noise", so.beacon_noise, 0.0, MAX_SIZE_M),
            ("ambient_light", so.ambient_light, 0.0, 0.999),
            ("camera_range", so.camera_range, MIN_SIZE_M, MAX_RANGE_M),
            ("scan_range", so.scan_range, MIN_SIZE_M, MAX_RANGE_M),
            ("scan_step", so.scan_step, 0.0, MAX_RANGE_M),
            (
                "beacon_range",
                so.beacon_range,
                MIN_SIZE_M,
                2.0 * MAX_COORD_M,
            ),
        ] {
            if let Some(v) = v {
                self.real(
                    v,
                    lo,
                    hi,
                    if k == "ambient_light" { "" } else { "m" },
                    || format!("{path}.{k}"),
                )?;
            }
        }
        Ok(())
    }

    /// The sizes of one shape (the shape's own checks follow in [`PartSpec::to_part`]).
    fn part(&self, p: &PartSpec, path: &str) -> Result<(), ScenarioError> {
        let size =
            |v: f32, key: &dyn Fn() -> String| self.real(v, MIN_SIZE_M, MAX_SIZE_M, "m", key);
        let offset =
            |v: f32, key: &dyn Fn() -> String| self.real(v, -MAX_SIZE_M, MAX_SIZE_M, "m", key);
        for (k, v) in p.at.into_iter().enumerate() {
            offset(v, &|| format!("{path}.at[{k}]"))?;
        }
        self.angle(p.yaw_deg, || format!("{path}.yaw_deg"))?;
        if let Some(b) = p.box_ {
            for (k, v) in b.into_iter().enumerate() {
                size(v, &|| format!("{path}.box[{k}]"))?;
            }
        }
        if let Some(r) = p.disc {
            size(r, &|| format!("{path}.disc"))?;
        }
        if let Some(v) = &p.polygon {
            if !(3..=MAX_POLYGON_VERTICES).contains(&v.len()) {
                let key = format!("{path}.polygon");
                return Err(self.at(
                    &key,
                    format!(
                        "{key}: expected 3 to {MAX_POLYGON_VERTICES} vertices, got {}",
                        v.len()
                    ),
                ));
            }
            for (i, q) in v.iter().enumerate() {
                for (k, x) in q.iter().enumerate() {
                    offset(*x, &|| format!("{path}.polygon[{i}][{k}]"))?;
                }
            }
        }
        if let Some(r) = &p.regular {
            if !(3..=MAX_REGULAR_SIDES).contains(&r.sides) {
                let key = format!("{path}.regular.sides");
                return Err(self.at(
                    &key,
                    format!(
                        "{key}: expected 3 to {MAX_REGULAR_SIDES} sides, got {}",
                        r.sides
                    ),
                ));
            }
            size(r.radius, &|| format!("{path}.regular.radius"))?;
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const TEXT: &str = "# c\nname = \"x\"\n[arena]\nsize = [6.0, 4.0]\n\n[[objects]]\nat = [1.0,\n  2.0]\n[[objects]]\nshape = { disc = 0.2 }\n[run]\ntick_hz = 0.5\n";

    fn at(path: &str) -> (usize, usize) {
        let s = span_of(TEXT, path).unwrap();
        crate::scenario::line_col(TEXT, s.start)
    }

    #[test]
    fn paths_resolve_to_their_key_or_the_nearest_written_table() {
        assert_eq!(at("run.tick_hz"), (12, 1));
        assert_eq!(at("arena.size[1]"), (4, 14));
        assert_eq!(at("objects[0].at[1]"), (8, 3));
        assert_eq!(at("objects[1].shape.disc"), (10, 11));
        // Defaulted: the table that is written; a missing table: the first entry of the file.
        assert_eq!(at("run.duration_s"), (11, 2));
        assert_eq!(at("stop.goal_size"), (2, 1));
        assert_eq!(at("objects[7].at"), (6, 3));
    }

    #[test]
    fn nesting_is_bounded_outside_strings_and_comments() {
        assert_eq!(too_deep("a = [[1], {b = [2]}]"), None);
        let deep = format!("a = {}", "[".repeat(MAX_NESTING + 1));
        assert_eq!(too_deep(&deep), Some(4 + MAX_NESTING));
        let quoted = format!("a = \"{}\" # {}", "[".repeat(99), "{".repeat(99));
        assert_eq!(too_deep(&quoted), None);
        let triple = format!("a = '''\n{}\n'''", "[".repeat(99));
        assert_eq!(too_deep(&triple), None);
    }
}
