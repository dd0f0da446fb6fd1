//! Which Formica made a result, and from what: every JSON line, `result.json` and store row
//! carries `formica_version`, `git_commit`, `scenario_sha256` and `platform`; a store's `meta`
//! carries the same and the results format ([`formica::experiment::RESULTS_FORMAT`]).
//!
//! `scenario_sha256` is the SHA-256 of the scenario as run: its parsed content after every
//! override (`--set`, sweep keys, `--duration`, `--controller`), written as canonical JSON (keys
//! sorted, no spaces, numbers as the parser read them). The seed is not part of it (it is a
//! field of its own), nor are comments, key order or the file's name, so two files that set up
//! the same world share it.

use formica::experiment::RESULTS_FORMAT;
use formica::{Overrides, RunResult, Scenario};
use serde::{Deserialize, Serialize};
use sha2::{Digest, Sha256};

/// This build's version.
pub const VERSION: &str = env!("CARGO_PKG_VERSION");
/// The commit this build was made from (`-dirty` appended when its code differed from the
/// commit; `unknown` outside a git checkout).
pub const GIT_COMMIT: &str = env!("FORMICA_GIT_COMMIT");
/// The target triple this build runs on.
pub const PLATFORM: &str = env!("FORMICA_TARGET");
/// What `formica --version` prints after the name.
pub const LONG_VERSION: &str = concat!(
    env!("CARGO_PKG_VERSION"),
    " (commit ",
    env!("FORMICA_GIT_COMMIT"),
    ", ",
    env!("FORMICA_TARGET"),
    ")"
);

/// The four provenance fields of a result.
#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize, Default)]
pub struct Provenance {
    /// Formica's version.
    pub formica_version: String,
    /// The commit it was built from.
    pub git_commit: String,
    /// SHA-256 of the canonical scenario (see the module documentation).
    pub scenario_sha256: String,
    /// The target triple it ran on.
    pub platform: String,
}

impl Provenance {
    /// The provenance of a run of `sc` with `ov` by this build.
    pub fn of(sc: &Scenario, ov: &Overrides) -> Provenance {
        Provenance {
            formica_version: VERSION.into(),
            git_commit: GIT_COMMIT.into(),
            scenario_sha256: scenario_sha256(sc, ov),
            platform: PLATFORM.into(),
        }
    }
}

/// A result with its provenance, as JSON lines and `result.json` print it.
#[derive(Serialize)]
pub struct Stamped<'a> {
    /// The result.
    #[serde(flatten)]
    pub result: &'a RunResult,
    /// Its provenance.
    #[serde(flatten)]
    pub provenance: &'a Provenance,
}

/// Who wrote into a result store: one entry of its `meta` key `writers`.
#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize)]
pub struct Writer {
    /// Formica's version.
    pub formica_version: String,
    /// The commit it was built from.
    pub git_commit: String,
    /// The target triple.
    pub platform: String,
    /// Its results format.
    pub results_format: u32,
}

impl Writer {
    /// This build.
    pub fn this() -> Writer {
        Writer {
            formica_version: VERSION.into(),
            git_commit: GIT_COMMIT.into(),
            platform: PLATFORM.into(),
            results_format: RESULTS_FORMAT,
        }
    }

    /// `0.1.0 (commit abc123, x86_64-unknown-linux-gnu, results format 1)`.
    pub fn describe(&self) -> String {
        format!(
            "{} (commit {}, {}, results format {})",
            self.formica_version,
            short(&self.git_commit),
            self.platform,
            self.results_format
        )
    }
}

/// The first 12 hex digits of a commit (or the whole string if it is not one).
pub fn short(commit: &str) -> &str {
    if commit.len() > 12 && commit.bytes().all(|b| b.is_ascii_hexdigit()) {
        &commit[..12]
    } else {
        commit
    }
}

/// Canonical JSON: object keys sorted, no spaces.
fn canonical(v: &serde_json::Value, out: &mut String) {
    match v {
        serde_json::Value::Object(m) => {
            let mut keys: Vec<&String> = m.keys().collect();
            keys.sort();
            out.push('{');
            for (i, k) in keys.into_iter().enumerate() {
                if i > 0 {
                    out.push(',');
                }
                out.push_str(&serde_json::Value::String(k.clone()).to_string());
                out.push(':');
                canonical(&m[k], out);
            }
            out.push('}');
        }
        serde_json::Value::Array(a) => {
            out.push('[');
            for (i, x) in a.iter().enumerate() {
                if i > 0 {
                    out.push(',');
                }
                canonical(x, out);
            }
            out.push(']');
        }
        other => out.push_str(&other.to_string()),
    }
}

/// The canonical JSON of the scenario as run with `ov` (without its seed).
pub fn canonical_scenario(sc: &Scenario, ov: &Overrides) -> String {
    let mut spec = sc.spec.clone();
    if let Some(d) = ov.duration_s {
        spec.run.duration_s = d;
    }
    let mut v = serde_json::to_value(&spec).unwrap_or(serde_json::Value::Null);
    if let Some(run) = v.get_mut("run").and_then(|r| r.as_object_mut()) {
        run.remove("seed");
    }
    if let Some(c) = &ov.controller {
        if let Some(groups) = v.get_mut("robots").and_then(|r| r.as_array_mut()) {
            for g in groups.iter_mut().filter_map(|g| g.as_object_mut()) {
                g.insert("controller".into(), serde_json::Value::String(c.clone()));
            }
        }
    }
    let mut out = String::new();
    canonical(&v, &mut out);
    out
}

/// Lower-case hex SHA-256 of `bytes`.
pub fn sha256_hex(bytes: &[u8]) -> String {
    Sha256::digest(bytes)
        .iter()
        .map(|b| format!("{b:02x}"))
        .collect()
}

/// SHA-256 of [`canonical_scenario`].
pub fn scenario_sha256(sc: &Scenario, ov: &Overrides) -> String {
    sha256_hex(canonical_scenario(sc, ov).as_bytes())
}

#[cfg(test)]
mod tests {
    use super::*;

    const A: &str = "[arena]\nsize = [2.0, 2.0]\n[run]\nseed = 3\nduration_s = 10\n";

    #[test]
    fn the_digest_ignores_layout_and_seed_but_not_content() {
        let a = Scenario::parse(A, "a.toml").expect("parses");
        let b = Scenario::parse(
            "# the same world\n[run]\nduration_s = 10.0\nseed = 99\n\n[arena]\nsize = [2, 2]\n",
            "b.toml",
        )
        .expect("parses");
        let none = Overrides::default();
        assert_eq!(scenario_sha256(&a, &none), scenario_sha256(&b, &none));
        assert_eq!(scenario_sha256(&a, &none).len(), 64);
        let longer = Overrides {
            duration_s: Some(11.0),
            ..Overrides::default()
        };
        assert_ne!(scenario_sha256(&a, &none), scenario_sha256(&a, &longer));
        let c = Scenario::parse(&A.replace("2.0, 2.0", "2.0, 2.5"), "a.toml").expect("parses");
        assert_ne!(scenario_sha256(&a, &none), scenario_sha256(&c, &none));
        // The known SHA-256 of the empty string.
        assert_eq!(
            sha256_hex(b""),
            "e3b0c44298fc1c149afbf4c8996fb92427ae41e4649b934ca495991b7852b855"
        );
    }

    #[test]
    fn a_stamped_result_carries_the_four_fields() {
        let r = RunResult::default();
        let p = Provenance {
            formica_version: "v".into(),
            git_commit: "c".into(),
            scenario_sha256: "s".into(),
            platform: "p".into(),
        };
        let v = serde_json::to_value(Stamped {
            result: &r,
            provenance: &p,
        })
        .expect("encodes");
        for k in [
            "formica_version",
            "git_commit",
            "scenario_sha256",
            "platform",
            "seed",
        ] {
            assert!(v.get(k).is_some(), "{k} missing from {v}");
        }
    }
}
