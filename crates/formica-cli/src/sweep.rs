//! Sweep files: a base scenario, the scenario keys to vary, and the seeds. Expands into the
//! ordered list of trials that `formica sweep` runs and `--shard` splits.

use crate::CliError;
use formica::scenario::line_col;
use formica::Scenario;
use serde::Deserialize;
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

/// A sweep (experiment) file: a base scenario, fixed overrides, the keys to vary and the seeds.
#[derive(Debug, Deserialize, schemars::JsonSchema)]
#[serde(deny_unknown_fields)]
pub(crate) struct SweepSpec {
    /// Name of the study (default: the file stem).
    #[serde(default)]
    name: Option<String>,
    /// Base scenario, relative to the sweep file (a case may name its own).
    #[serde(default)]
    scenario: Option<String>,
    /// `"A..B"` (inclusive) or a list of seeds.
    #[schemars(schema_with = "crate::schema::seeds_schema")]
    seeds: toml::Value,
    /// Simulated time limit of every trial (same as `"run.duration_s"` in `[set]`).
    #[serde(default)]
    #[schemars(
        range(max = formica::limits::MAX_DURATION_S),
        extend("exclusiveMinimum" = 0)
    )]
    duration_s: Option<f64>,
    /// Store the object's trajectory of every trial.
    #[serde(default)]
    trajectories: bool,
    /// Fixed overrides applied to every trial: dotted scenario keys (`"objects.0.mass"`) and
    /// their values.
    #[serde(default)]
    #[schemars(schema_with = "crate::schema::set_schema")]
    set: toml::Table,
    /// Explicit parameter sets (each a table of overrides, `scenario` allowed).
    #[serde(default)]
    #[schemars(schema_with = "crate::schema::cases_schema")]
    cases: Vec<toml::Table>,
    /// Keys to vary, each with its list of values: the grid is their product.
    #[serde(default)]
    #[schemars(schema_with = "crate::schema::vary_schema")]
    vary: toml::Table,
}

/// Keys of a case that are not scenario overrides: `scenario` (the base file) and `label` (a
/// name for reports).
pub const NOT_OVERRIDES: &[&str] = &["scenario", "label"];

/// One parameter set: the overrides that distinguish it (the sweep's `cases` and `[vary]` keys,
/// `scenario` included when a case names one), in key order.
pub type Params = BTreeMap<String, toml::Value>;

/// A loaded sweep.
pub struct Sweep {
    /// Study name.
    pub name: String,
    /// The sweep file, as given.
    pub file: PathBuf,
    /// The distinct parameter sets, in grid order.
    pub sets: Vec<ParamSet>,
    /// Seeds, in order.
    pub seeds: Vec<u64>,
    /// Store object trajectories.
    pub trajectories: bool,
    /// The keys that distinguish parameter sets (one result column each).
    pub keys: Vec<String>,
    /// A digest of everything fixed (base scenario texts, `[set]`, `duration_s`): a store made
    /// by a different sweep is refused.
    pub digest: String,
}

/// One parameter set, ready to run.
pub struct ParamSet {
    /// Its parameters.
    pub params: Params,
    /// Canonical JSON of `params`: with the seed, the key of a trial in the store.
    pub key: String,
    /// The scenario with every override applied.
    pub scenario: Scenario,
}

/// One trial of the grid.
#[derive(Debug, Clone, Copy)]
pub struct Trial {
    /// Position in the full grid (parameter sets outer, seeds inner).
    pub index: usize,
    /// Index into [`Sweep::sets`].
    pub set: usize,
    /// Seed.
    pub seed: u64,
}

/// Canonical JSON (sorted keys, no spaces) of a TOML value.
pub fn canonical_json(v: &toml::Value) -> String {
    match v {
        toml::Value::String(s) => serde_json::Value::String(s.clone()).to_string(),
        toml::Value::Integer(i) => i.to_string(),
        toml::Value::Float(f) => {
            serde_json::Number::from_f64(*f).map_or_else(|| format!("\"{f}\""), |n| n.to_string())
        }
        toml::Value::Boolean(b) => b.to_string(),
        toml::Value::Datetime(d) => serde_json::Value::String(d.to_string()).to_string(),
        toml::Value::Array(a) => {
            let items: Vec<String> = a.iter().map(canonical_json).collect();
            format!("[{}]", items.join(","))
        }
        toml::Value::Table(t) => {
            let sorted: BTreeMap<&String, &toml::Value> = t.iter().collect();
            let items: Vec<String> = sorted
                .into_iter()
                .map(|(k, v)| {
                    format!(
                        "{}:{}",
                        serde_json::Value::String(k.clone()),
                        canonical_json(v)
                    )
                })
                .collect();
            format!("{{{}}}", items.join(","))
        }
    }
}

/// `v` with every whole float written as an integer, so that `50` and `50.0` (which set a
/// scenario alike) compare equal in the check for values listed twice.
fn same_number(v: &toml::Value) -> toml::Value {
    match v {
        toml::Value::Float(f) if f.fract() == 0.0 && f.abs() < 9.0e15 => {
            toml::Value::Integer(*f as i64)
        }
        toml::Value::Array(a) => toml::Value::Array(a.iter().map(same_number).collect()),
        toml::Value::Table(t) => {
            toml::Value::Table(t.iter().map(|(k, x)| (k.clone(), same_number(x))).collect())
        }
        other => other.clone(),
    }
}

/// Canonical JSON of a parameter set.
pub fn params_json(p: &Params) -> String {
    let t: toml::Table = p.iter().map(|(k, v)| (k.clone(), v.clone())).collect();
    canonical_json(&toml::Value::Table(t))
}

/// FNV-1a, 64 bits: a stable digest (std's hasher may change between releases).
pub fn fnv64(parts: &[&str]) -> String {
    let mut h: u64 = 0xcbf2_9ce4_8422_2325;
    for p in parts {
        for b in p.bytes().chain(std::iter::once(0xff)) {
            h ^= u64::from(b);
            h = h.wrapping_mul(0x0100_0000_01b3);
        }
    }
    format!("{h:016x}")
}

/// Flattens `[vary]`: nested tables become dotted keys until a list of values is reached.
fn flatten_vary(
    prefix: &str,
    t: &toml::Table,
    out: &mut Vec<(String, Vec<toml::Value>)>,
) -> Result<(), String> {
    for (k, v) in t {
        let key = if prefix.is_empty() {
            k.clone()
        } else {
            format!("{prefix}.{k}")
        };
        match v {
            toml::Value::Array(a) if !a.is_empty() => out.push((key, a.clone())),
            toml::Value::Array(_) => {
                return Err(format!(
                    "[vary] `{key}`: expected a non-empty list of values"
                ))
            }
            toml::Value::Table(inner) => flatten_vary(&key, inner, out)?,
            other => {
                return Err(format!(
                    "[vary] `{key}`: expected a list of values, found {}",
                    formica::scenario::a_toml_type(other)
                ))
            }
        }
    }
    Ok(())
}

/// Where `k` is best pointed at in a sweep file's `text` (byte offset): quoted as a key
/// (`"k"`), or at the start of a line (`k = ...`), else its first mention outside a comment,
/// else its first mention.
fn mention(text: &str, k: &str) -> Option<usize> {
    if k.is_empty() {
        return None;
    }
    let quoted = format!("\"{k}\"");
    let mut offset = 0;
    let mut uncommented = None;
    for line in text.split_inclusive('\n') {
        let code = line.split('#').next().unwrap_or_default();
        if let Some(i) = code.find(&quoted) {
            return Some(offset + i);
        }
        let lead = code.len() - code.trim_start().len();
        if code.trim_start().starts_with(k) {
            return Some(offset + lead);
        }
        if uncommented.is_none() {
            uncommented = code.find(k).map(|i| offset + i);
        }
        offset += line.len();
    }
    uncommented.or_else(|| text.find(k))
}

fn parse_seeds(s: &toml::Value) -> Result<Vec<u64>, String> {
    let expected = "`seeds`: expected \"A..B\" (inclusive, A <= B) or a list of seeds";
    match s {
        toml::Value::Array(items) if !items.is_empty() => {
            let l: Vec<u64> = items
                .iter()
                .map(|v| match v {
                    toml::Value::Integer(i) if *i >= 0 => Ok(*i as u64),
                    _ => Err(format!("{expected}, found {v} in the list")),
                })
                .collect::<Result<_, _>>()?;
            let mut seen = std::collections::BTreeSet::new();
            for x in &l {
                if !seen.insert(*x) {
                    return Err(format!("`seeds`: seed {x} is listed twice"));
                }
            }
            Ok(l)
        }
        toml::Value::String(r) => crate::cmd_run::seed_range(r)
            .map(|s| s.collect())
            .map_err(|m| format!("`seeds`: {m} (or a list of seeds)")),
        other => Err(format!("{expected}, found {other}")),
    }
}

impl Sweep {
    /// Reads a sweep file, expands its grid and validates every parameter set.
    pub fn load(path: &Path) -> Result<Sweep, CliError> {
        let file = path.display().to_string();
        let text = formica::limits::read_text(path)
            .map_err(|e| CliError::from(formica::limits::read_error(&file, &e)))?;
        if let Some((at, m)) = formica::limits::too_large(&text) {
            let (line, col) = line_col(&text, at);
            return Err(CliError::Input(format!("{file}:{line}:{col}: {m}")));
        }
        let spec: SweepSpec = toml::from_str(&text).map_err(|e| {
            if crate::file_kind(path) == Some(crate::FileKind::Scenario) {
                return CliError::Input(format!(
                    "{file}: a scenario file (it has an arena), not a sweep file; run it with \
                     `formica run {file}`, or write a sweep file whose `scenario` names it"
                ));
            }
            let (line, col) = line_col(&text, e.span().map_or(0, |s| s.start));
            CliError::Input(format!("{file}:{line}:{col}: {}", e.message().trim()))
        })?;
        let input = |m: String| {
            // Point at what the message quotes, if any: where it stands as a key, else its
            // first mention outside a comment, else its first mention.
            let pos = m
                .split('`')
                .nth(1)
                .and_then(|k| mention(&text, k))
                .unwrap_or(0);
            let (line, col) = line_col(&text, pos);
            CliError::Input(format!("{file}:{line}:{col}: {m}"))
        };
        if let Some(n) = &spec.name {
            if n.trim().is_empty() || n.chars().any(char::is_control) {
                return Err(input(format!(
                    "`name`: expected a one-line text naming the study in reports, got {n:?}"
                )));
            }
        }
        let seeds = parse_seeds(&spec.seeds).map_err(input)?;
        let mut vary = Vec::new();
        flatten_vary("", &spec.vary, &mut vary).map_err(input)?;
        // The grid's order: keys sorted (whatever order the TOML map keeps), values as listed.
        vary.sort_by(|a, b| a.0.cmp(&b.0));
        // The `[[cases]]` headers (not those in comments or strings), to point at a case.
        let case_error = |case: usize, m: String| {
            let at = text
                .match_indices("[[cases]]")
                .filter(|(i, _)| {
                    text[..*i]
                        .rsplit('\n')
                        .next()
                        .is_some_and(|p| p.trim().is_empty())
                })
                .nth(case)
                .map(|(i, _)| i);
            match at {
                Some(i) => {
                    let (line, col) = line_col(&text, i);
                    CliError::Input(format!("{file}:{line}:{col}: {m}"))
                }
                None => input(m),
            }
        };
        let mut labels = std::collections::BTreeSet::new();
        for (k, case) in spec.cases.iter().enumerate() {
            let label = match case.get("label") {
                None => continue,
                Some(toml::Value::String(l))
                    if !l.trim().is_empty() && !l.chars().any(char::is_control) =>
                {
                    l
                }
                Some(other) => {
                    return Err(input(format!(
                        "`label`: expected a one-line text naming the case in reports, got {other}"
                    )))
                }
            };
            // Reports name a case by its label: two cases under one name would share a row
            // label and a plot's bar.
            if !labels.insert(label.as_str()) {
                return Err(case_error(
                    k,
                    format!(
                        "this case's label {label:?} names an earlier case too: each label must \
                         be its own"
                    ),
                ));
            }
        }
        let mut cases = spec.cases.clone();
        if cases.is_empty() {
            cases.push(toml::Table::new());
        }
        let dir = path.parent().unwrap_or(Path::new("."));
        let mut fixed: Vec<(String, toml::Value)> = spec
            .set
            .iter()
            .map(|(k, v)| (k.clone(), v.clone()))
            .collect();
        fixed.sort_by(|a, b| a.0.cmp(&b.0));
        if let Some(d) = spec.duration_s {
            let max = formica::limits::MAX_DURATION_S as f64;
            if !(d > 0.0 && d <= max) {
                return Err(input(format!(
                    "`duration_s`: expected more than 0 and at most {} seconds, got {d}",
                    formica::limits::show(max as f32)
                )));
            }
            if fixed.iter().any(|(k, _)| k == "run.duration_s") {
                return Err(input(
                    "`duration_s` and [set] \"run.duration_s\" both give the duration: keep one"
                        .to_string(),
                ));
            }
            fixed.push(("run.duration_s".into(), toml::Value::Float(d)));
        }
        // Each trial's seed is the sweep's: a seed set, varied or given by a case would be
        // overridden by it, and two "parameter sets" would run the same trials.
        let sets_seed = fixed.iter().any(|(k, _)| k == "run.seed")
            || vary.iter().any(|(k, _)| k == "run.seed")
            || cases.iter().any(|c| c.contains_key("run.seed"));
        if sets_seed {
            return Err(input(
                "`run.seed`: the sweep's `seeds` gives every trial its seed; list the seeds \
                 there instead"
                    .to_string(),
            ));
        }
        for (k, values) in &vary {
            // By the value as TOML writes it: a set, not a comparison of every pair (a list
            // may hold up to `MAX_SETS` values).
            let mut seen = std::collections::HashSet::with_capacity(values.len());
            if let Some((i, v)) = values
                .iter()
                .enumerate()
                .find(|(_, v)| !seen.insert(canonical_json(&same_number(v))))
            {
                return Err(input(format!(
                    "`{k}`: the value {v} is listed twice (item {} of the list); each value \
                     makes parameter sets of its own",
                    i + 1
                )));
            }
            if NOT_OVERRIDES.contains(&k.as_str()) {
                continue;
            }
            if fixed.iter().any(|(f, _)| f == k) {
                return Err(input(format!(
                    "`{k}` is both set and varied: keep it in one place"
                )));
            }
        }
        // The grid's size is known before it is built (cases times the product of the vary
        // lists): a grid too large is refused at the key that makes it so, not allocated.
        let too_large = |sets: u64| {
            if sets > formica::limits::MAX_SETS {
                Some(format!(
                    "the grid has more than {} parameter sets; split the sweep (or vary fewer \
                     values at once)",
                    formica::limits::MAX_SETS
                ))
            } else if sets.saturating_mul(seeds.len() as u64) > formica::limits::MAX_TRIALS {
                Some(format!(
                    "the grid has more than {} trials (parameter sets times seeds); split the \
                     sweep",
                    formica::limits::MAX_TRIALS
                ))
            } else {
                None
            }
        };
        let mut size = cases.len() as u64;
        if let Some(m) = too_large(size) {
            return Err(input(m));
        }
        for (k, values) in &vary {
            size = size.saturating_mul(values.len() as u64);
            if let Some(m) = too_large(size) {
                return Err(input(format!("`{k}`: {m}")));
            }
        }
        // Grid: cases (outer) x product of vary lists (last key fastest).
        let mut grid: Vec<Params> = Vec::with_capacity(size as usize);
        for case in &cases {
            let mut combos: Vec<Params> =
                vec![case.iter().map(|(k, v)| (k.clone(), v.clone())).collect()];
            for (k, values) in &vary {
                let mut next = Vec::with_capacity(combos.len() * values.len());
                for c in &combos {
                    for v in values {
                        let mut c = c.clone();
                        c.insert(k.clone(), v.clone());
                        next.push(c);
                    }
                }
                combos = next;
            }
            grid.extend(combos);
        }
        let mut keys: Vec<String> = Vec::new();
        for p in &grid {
            for k in p.keys() {
                if !keys.contains(k) {
                    keys.push(k.clone());
                }
            }
        }
        keys.sort();
        // Load each base scenario once.
        let mut texts: BTreeMap<String, (String, String)> = BTreeMap::new();
        let mut load_base = |rel: &str| -> Result<(String, String), CliError> {
            if let Some(t) = texts.get(rel) {
                return Ok(t.clone());
            }
            let p = dir.join(rel);
            let name = p.display().to_string();
            let t = formica::limits::read_text(&p)
                .map_err(|e| input(format!("`{rel}`: cannot read {name}: {e}")))?;
            texts.insert(rel.to_string(), (name.clone(), t.clone()));
            Ok((name, t))
        };
        let per_case = grid.len() / cases.len().max(1);
        let mut sets = Vec::with_capacity(grid.len());
        let mut seen = std::collections::BTreeSet::new();
        for (index, params) in grid.into_iter().enumerate() {
            let base_rel = match params.get("scenario") {
                Some(toml::Value::String(s)) => s.clone(),
                Some(other) => {
                    return Err(input(format!(
                        "`scenario`: expected a file name, found {}",
                        formica::scenario::a_toml_type(other)
                    )))
                }
                None => spec.scenario.clone().ok_or_else(|| {
                    input("expected `scenario = \"path/to/base.toml\"` (relative to this file), at the top or in every case".into())
                })?,
            };
            let (base_name, base_text) = load_base(&base_rel)?;
            let mut ov = fixed.clone();
            ov.extend(
                params
                    .iter()
                    .filter(|(k, _)| !NOT_OVERRIDES.contains(&k.as_str()))
                    .map(|(k, v)| (k.clone(), v.clone())),
            );
            let scenario =
                Scenario::parse_with_overrides(&base_text, &base_name, &ov, (&file, &text))?;
            let key = params_json(&params);
            if !seen.insert(key.clone()) {
                let m = format!("the parameter set {key} appears twice: every case must differ");
                // At the case that repeats an earlier one: its `[[cases]]` header.
                return Err(case_error(index / per_case.max(1), m));
            }
            sets.push(ParamSet {
                params,
                key,
                scenario,
            });
        }
        let mut digest_parts: Vec<String> = Vec::new();
        if let Some(s) = &spec.scenario {
            digest_parts.push(s.clone());
        }
        for (rel, (_, t)) in &texts {
            digest_parts.push(rel.clone());
            digest_parts.push(t.clone());
        }
        for (k, v) in &fixed {
            digest_parts.push(format!("{k}={}", canonical_json(v)));
        }
        let refs: Vec<&str> = digest_parts.iter().map(String::as_str).collect();
        let name = spec.name.clone().unwrap_or_else(|| {
            path.file_stem()
                .map_or_else(|| file.clone(), |s| s.to_string_lossy().into_owned())
        });
        Ok(Sweep {
            name,
            file: path.to_path_buf(),
            sets,
            seeds,
            trajectories: spec.trajectories,
            keys,
            digest: fnv64(&refs),
        })
    }

    /// Every trial of the grid, in order.
    pub fn trials(&self) -> Vec<Trial> {
        let mut out = Vec::with_capacity(self.sets.len() * self.seeds.len());
        for set in 0..self.sets.len() {
            for &seed in &self.seeds {
                out.push(Trial {
                    index: out.len(),
                    set,
                    seed,
                });
            }
        }
        out
    }
}

/// Parses `K/N` (0 <= K < N).
pub fn parse_shard(s: &str) -> Result<(usize, usize), CliError> {
    let bad = || CliError::Input(format!("--shard: expected K/N with 0 <= K < N, got `{s}`"));
    let (k, n) = s.split_once('/').ok_or_else(bad)?;
    let k: usize = k.trim().parse().map_err(|_| bad())?;
    let n: usize = n.trim().parse().map_err(|_| bad())?;
    if n == 0 || k >= n {
        return Err(bad());
    }
    Ok((k, n))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn errors_point_at_the_key_not_at_a_comment_that_names_it() {
        let text = "duration_s = 300   # same as \"run.duration_s\" in [set]\n\n[vary]\n\"run.duration_s\" = [1, 2]\n";
        let at = |k: &str| mention(text, k).map(|i| line_col(text, i));
        assert_eq!(at("run.duration_s"), Some((4, 1)));
        assert_eq!(at("duration_s"), Some((1, 1)));
        assert_eq!(at("nowhere"), None);
        // Only in a comment: pointed at all the same.
        assert_eq!(mention("a = 1 # seeds\n", "seeds"), Some(8));
    }

    #[test]
    fn canonical_json_sorts_keys() {
        let t: toml::Table = toml::from_str("b = 1\na = { z = [1, 2.5], y = \"s\" }").unwrap();
        assert_eq!(
            canonical_json(&toml::Value::Table(t)),
            r#"{"a":{"y":"s","z":[1,2.5]},"b":1}"#
        );
    }

    #[test]
    fn shard_and_seeds_parse() {
        assert_eq!(parse_shard("1/4").ok(), Some((1, 4)));
        assert!(parse_shard("4/4").is_err());
        assert_eq!(
            parse_seeds(&toml::Value::String("3..5".into())).unwrap(),
            vec![3, 4, 5]
        );
        let twice = toml::Value::Array(vec![toml::Value::Integer(1), toml::Value::Integer(1)]);
        assert!(parse_seeds(&twice).is_err());
        assert!(parse_seeds(&toml::Value::Integer(5)).is_err());
        // One seed written as a range's string: `"7"` is `"7..7"`.
        assert_eq!(
            parse_seeds(&toml::Value::String("7".into())).unwrap(),
            vec![7]
        );
        assert!(parse_seeds(&toml::Value::String("x".into())).is_err());
        assert!(parse_seeds(&toml::Value::String("".into())).is_err());
    }
}
