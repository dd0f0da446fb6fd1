//! `formica serve` and `formica record` as users call them.

use std::io::{BufRead, BufReader, Read, Write};

use std::process::Stdio;
use std::time::Duration;

mod common;
use common::{formica, input_error, repo};

#[test]
fn record_writes_an_animated_gif() {
    let dir = std::env::temp_dir().join(format!("formica-record-test-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    let out = dir.join("run.gif");
    let o = formica()
        .args(["record", "--duration", "3", "--seed", "2", "--width", "200"])
        .args(["--fps", "10", "--speed", "10", "--occlusion", "--out"])
        .arg(&out)
        .arg(repo("scenarios/seed-transport.toml"))
        .output()
        .expect("runs");
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let text = String::from_utf8_lossy(&o.stdout);
    // 3 s at one frame per simulated second, plus the first frame.
    assert!(text.contains("4 frames"), "{text}");
    let bytes = std::fs::read(&out).expect("GIF written");
    assert!(bytes.starts_with(b"GIF89a"));
    let _ = std::fs::remove_dir_all(&dir);

    for (args, msg) in [
        (vec!["--out", "x.webm"], ".gif or .mp4"),
        (vec!["--out", "x.png"], ".gif or .mp4"),
        (vec!["--out", "x.gif", "--fps", "0"], "--fps"),
        (vec!["--out", "x.gif", "--width", "10"], "--width"),
    ] {
        let o = formica()
            .arg("record")
            .args(&args)
            .arg(repo("scenarios/seed-transport.toml"))
            .output()
            .expect("runs");
        assert_eq!(o.status.code(), Some(2), "{args:?}");
        assert!(String::from_utf8_lossy(&o.stderr).contains(msg), "{args:?}");
    }
}

/// The whole answer to `GET path` from the server at `authority`.
fn get(authority: &str, path: &str) -> Result<String, String> {
    let mut s = std::net::TcpStream::connect(authority).map_err(|e| e.to_string())?;
    s.set_read_timeout(Some(Duration::from_secs(10)))
        .map_err(|e| e.to_string())?;
    write!(s, "GET {path} HTTP/1.1\r\nHost: {authority}\r\n\r\n").map_err(|e| e.to_string())?;
    let mut resp = String::new();
    let _ = s.read_to_string(&mut resp);
    Ok(resp)
}

#[test]
fn serve_listens_on_loopback_and_answers() {
    // `--set` and `--controller` as `run` takes them (the viewer lacked both).
    let mut child = formica()
        .args(["serve", "--port", "0", "--set", "robots.0.count=3"])
        .args(["--controller", "random-walk"])
        .arg(repo("scenarios/seed-transport.toml"))
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .expect("starts");
    let mut line = String::new();
    if let Some(out) = child.stdout.take() {
        let _ = BufReader::new(out).read_line(&mut line);
    }
    let url = line
        .split_whitespace()
        .find(|w| w.starts_with("http://"))
        .map(str::to_string);
    let result = (|| {
        let url = url.ok_or_else(|| format!("no address in `{line}`"))?;
        let authority = url
            .trim_start_matches("http://")
            .trim_end_matches('/')
            .to_string();
        if !authority.starts_with("127.0.0.1:") {
            return Err(format!("listening on {authority}, not loopback"));
        }
        let resp = get(&authority, "/api/state")?;
        if !resp.starts_with("HTTP/1.1 200") || !resp.contains("\"tick\":0") {
            return Err(format!("unexpected answer: {resp:.200}"));
        }
        let resp = get(&authority, "/api/scene")?;
        if !resp.contains("\"robots\":3") {
            return Err(format!("--set robots.0.count=3 not applied: {resp:.300}"));
        }
        let resp = get(&authority, "/api/robot?i=0")?;
        if !resp.contains("\"controller\":\"random-walk\"") {
            return Err(format!("--controller random-walk not applied: {resp:.300}"));
        }
        Ok(())
    })();
    let _ = child.kill();
    let _ = child.wait();
    result.expect("serve answers on loopback");

    // A bad scenario is an input error, as for `formica run`, and so is an unknown controller.
    let o = formica()
        .args(["serve", "no-such-file.toml", "--port", "0"])
        .output()
        .expect("runs");
    assert_eq!(o.status.code(), Some(2));
    let err = input_error(
        formica()
            .args(["serve", "--port", "0", "--controller", "ocluson"])
            .arg(repo("scenarios/seed-transport.toml"))
            .output()
            .expect("runs"),
    );
    assert!(err.contains("ocluson"), "{err}");
}

#[test]
fn serve_refuses_addresses_and_trials_it_cannot_serve() {
    for (args, says) in [
        (&["--host", "localhost"][..], "127.0.0.1 (or ::1)"),
        (&["--host", "224.0.0.1"][..], "multicast or broadcast"),
        (&["--host", "255.255.255.255"][..], "multicast or broadcast"),
    ] {
        let out = formica()
            .arg("serve")
            .arg(repo("scenarios/seed-transport.toml"))
            .args(args)
            .output()
            .unwrap();
        assert_eq!(out.status.code(), Some(2), "{args:?}");
        let err = String::from_utf8_lossy(&out.stderr);
        assert!(err.contains(says), "{args:?}: {err}");
    }
    let dir = std::env::temp_dir();
    for (cmd, trial, says) in [
        ("serve", "1..2", "--trial 1..2` checks many"),
        ("record", "all", "--trial all` checks many"),
        ("serve", "-3", "expected a trial number"),
    ] {
        let mut c = formica();
        c.args([cmd, "--db"]).arg(&dir).args(["--trial", trial]);
        if cmd == "record" {
            c.args(["--out", "x.gif"]);
        }
        let out = c.output().unwrap();
        assert_eq!(out.status.code(), Some(2), "{cmd} {trial}");
        let err = String::from_utf8_lossy(&out.stderr);
        assert!(err.contains(says), "{cmd} {trial}: {err}");
    }
    // A folder named as the store is said to be one.
    let out = formica()
        .args(["serve", "--db"])
        .arg(&dir)
        .args(["--trial", "1"])
        .output()
        .unwrap();
    assert_eq!(out.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&out.stderr).contains("a folder, not a result store"));
}
