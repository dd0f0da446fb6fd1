//! The repository as a whole: nothing in it names a path of the machine it was made on (no
//! checkout, temporary or home folder: a report that says where it was made, a comment with
//! someone's scratch file; every tracked file is searched, binary ones included), and the README
//! is a front page: under 150 lines, every relative link resolving to a file.

use std::path::{Path, PathBuf};
use std::process::Command;

fn root() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../..")
}

/// The files git tracks, or, outside a git checkout, every file but build output.
fn files(root: &Path) -> Vec<PathBuf> {
    if let Ok(out) = Command::new("git")
        .arg("-C")
        .arg(root)
        .args(["ls-files", "-z"])
        .output()
    {
        if out.status.success() && !out.stdout.is_empty() {
            return out
                .stdout
                .split(|&b| b == 0)
                .filter(|p| !p.is_empty())
                .map(|p| root.join(String::from_utf8_lossy(p).as_ref()))
                .collect();
        }
    }
    let mut out = Vec::new();
    let mut stack = vec![root.to_path_buf()];
    while let Some(dir) = stack.pop() {
        for e in std::fs::read_dir(&dir).unwrap() {
            let p = e.unwrap().path();
            let name = p.file_name().unwrap().to_string_lossy().into_owned();
            if p.is_dir() {
                if ![
                    ".git",
                    "target",
                    "node_modules",
                    "book",
                    "out",
                    "__pycache__",
                ]
                .contains(&name.as_str())
                {
                    stack.push(p);
                }
            } else if !name.ends_with(".db") {
                out.push(p);
            }
        }
    }
    out
}

#[test]
fn no_file_names_a_path_of_the_machine_it_was_made_on() {
    // Written in pieces so that this file does not name them itself.
    let patterns: Vec<String> = [
        ["/", "work/"],
        ["/", "tmp/"],
        ["/", "root/"],
        ["/", "home/"],
        ["/", "Users/"],
        ["C:\\", "Users\\"],
        ["/", "var/folders/"],
    ]
    .iter()
    .map(|p| p.concat())
    .collect();
    let root = root();
    let mut found = Vec::new();
    let files = files(&root);
    assert!(files.len() > 50, "only {} files found", files.len());
    for path in files {
        let Ok(bytes) = std::fs::read(&path) else {
            continue; // deleted in the work tree, not yet in the index
        };
        for pat in &patterns {
            if let Some(at) = bytes.windows(pat.len()).position(|w| w == pat.as_bytes()) {
                let line = bytes[..at].iter().filter(|&&b| b == b'\n').count() + 1;
                let rel = path
                    .strip_prefix(&root)
                    .unwrap_or(&path)
                    .display()
                    .to_string();
                found.push(format!("{rel}:{line}: names `{pat}`"));
            }
        }
    }
    assert!(
        found.is_empty(),
        "machine paths in the repository (write a relative path, or a placeholder such as \
         `DIR`):\n{}",
        found.join("\n")
    );
}

#[test]
fn the_readme_is_a_short_front_page_whose_links_resolve() {
    let root = root();
    let text = std::fs::read_to_string(root.join("README.md")).unwrap();
    let lines = text.lines().count();
    assert!(
        lines < 150,
        "README.md has {lines} lines; the guide (docs/) takes the rest"
    );
    // The CI's test command, exactly.
    assert!(text.contains("\ncargo test --release --workspace\n"));
    let mut bad = Vec::new();
    for (i, line) in text.lines().enumerate() {
        let mut rest = line;
        while let Some(at) = rest.find("](") {
            let tail = &rest[at + 2..];
            let end = tail.find(')').unwrap_or(tail.len());
            let target = &tail[..end];
            rest = &tail[end..];
            if target.contains("://") || target.starts_with('#') || target.starts_with("mailto:") {
                continue;
            }
            let file = target.split('#').next().unwrap();
            if !root.join(file).exists() {
                bad.push(format!("README.md:{}: {target}", i + 1));
            }
        }
    }
    assert!(
        bad.is_empty(),
        "links to missing files:\n{}",
        bad.join("\n")
    );
}
