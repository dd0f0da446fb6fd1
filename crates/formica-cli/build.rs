//! Records which commit and target the binary is built from, for `formica --version` and the
//! provenance of every result: `FORMICA_GIT_COMMIT` (the commit HEAD points at, with `-dirty`
//! appended when the code (`crates/`, `python/src/`, `Cargo.toml`, `Cargo.lock`) differs from
//! it; `unknown` outside a git checkout of Formica; a packager may set it) and
//! `FORMICA_TARGET`.

use std::path::{Path, PathBuf};
use std::process::Command;

fn git(dir: &Path, args: &[&str]) -> Option<String> {
    let out = Command::new("git")
        .arg("-C")
        .arg(dir)
        .args(args)
        .output()
        .ok()?;
    if !out.status.success() {
        return None;
    }
    let s = String::from_utf8(out.stdout).ok()?.trim().to_string();
    (!s.is_empty()).then_some(s)
}

fn main() {
    println!("cargo:rerun-if-changed=build.rs");
    println!("cargo:rerun-if-env-changed=FORMICA_GIT_COMMIT");
    let target = std::env::var("TARGET").unwrap_or_else(|_| "unknown".into());
    println!("cargo:rustc-env=FORMICA_TARGET={target}");
    let manifest = PathBuf::from(std::env::var("CARGO_MANIFEST_DIR").unwrap_or_default());
    let commit = std::env::var("FORMICA_GIT_COMMIT")
        .ok()
        .filter(|c| !c.trim().is_empty())
        .or_else(|| {
            // Only a checkout of Formica itself counts, not some repository around a copy.
            let top = PathBuf::from(git(&manifest, &["rev-parse", "--show-toplevel"])?);
            if !top.join("crates/formica-cli/Cargo.toml").is_file() {
                return None;
            }
            let commit = git(&manifest, &["rev-parse", "HEAD"])?;
            // Build again when HEAD moves: its file, the branch it names, the packed refs.
            let abs = |p: String| {
                let p = PathBuf::from(p);
                if p.is_absolute() {
                    p
                } else {
                    manifest.join(p)
                }
            };
            // (A path that does not exist would make cargo run this script on every build.)
            let watch = |p: PathBuf| {
                if p.exists() {
                    println!("cargo:rerun-if-changed={}", p.display());
                }
            };
            if let Some(dir) = git(&manifest, &["rev-parse", "--git-dir"]).map(abs) {
                watch(dir.join("HEAD"));
            }
            if let Some(common) = git(&manifest, &["rev-parse", "--git-common-dir"]).map(abs) {
                watch(common.join("packed-refs"));
                if let Some(branch) = git(&manifest, &["symbolic-ref", "-q", "HEAD"]) {
                    watch(common.join(branch));
                }
            }
            // Code that differs from the commit: results made by this build are not that
            // commit's. Build again when any of it changes.
            let code = ["crates", "python/src", "Cargo.toml", "Cargo.lock"];
            for path in code {
                watch(top.join(path));
            }
            let mut status = vec!["status", "--porcelain", "--untracked-files=no", "--"];
            status.extend(code);
            let dirty = git(&top, &status).is_some();
            Some(if dirty {
                format!("{commit}-dirty")
            } else {
                commit
            })
        })
        .unwrap_or_else(|| "unknown".into());
    println!("cargo:rustc-env=FORMICA_GIT_COMMIT={commit}");
}
