//! The server over real loopback sockets: where it binds, what it serves, how it answers bad
//! requests, and that its memory does not grow with clients.

use formica::Scenario;
use formica_serve::{ServeOptions, Server, ServerHandle, MAX_STEP, PATH_CAP};
use std::io::{Read, Write};
use std::net::{SocketAddr, TcpStream};
use std::time::{Duration, Instant};

/// A small world: three robots drive straight into a light box, so the object moves.
const SMALL: &str = r#"
name = "small"
[arena]
size = [4.0, 2.0]
[[lights]]
at = [1.8, 0.0]
height = 0.5
[[objects]]
name = "box"
at = [-0.6, 0.0]
shape = { box = [0.3, 0.3] }
height = 0.2
mass = 0.5
floor_mu = 0.01
[[robots]]
count = 3
controller = "constant"
params = { left = 0.1, right = 0.1, led = "red" }
placement = { poses = [[-1.2, 0.0, 0.0], [-1.2, 0.15, 0.0], [-1.2, -0.15, 0.0]] }
[run]
duration_s = 100000
[stop]
on_goal = false
on_wall = false
"#;

struct Running {
    handle: ServerHandle,
    thread: Option<std::thread::JoinHandle<std::io::Result<()>>>,
}

impl Running {
    fn addr(&self) -> SocketAddr {
        self.handle.addr()
    }
}

impl Drop for Running {
    fn drop(&mut self) {
        self.handle.stop();
        if let Some(t) = self.thread.take() {
            let _ = t.join();
        }
    }
}

fn small() -> Scenario {
    Scenario::parse(SMALL, "small.toml").expect("test scenario parses")
}

fn seed_transport() -> Scenario {
    let p = concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/../../scenarios/seed-transport.toml"
    );
    Scenario::load(p.as_ref()).expect("seed scenario loads")
}

fn start_with(sc: Scenario, f: impl FnOnce(&mut ServeOptions)) -> Running {
    let mut opts = ServeOptions {
        port: 0,
        read_timeout: Duration::from_millis(500),
        ..ServeOptions::default()
    };
    f(&mut opts);
    let server = Server::bind(sc, opts).expect("server binds");
    let handle = server.handle();
    let thread = std::thread::spawn(move || server.run());
    Running {
        handle,
        thread: Some(thread),
    }
}

fn start(sc: Scenario) -> Running {
    start_with(sc, |_| {})
}

/// Sends raw bytes, returns the status code and the body.
fn raw(addr: SocketAddr, bytes: &[u8]) -> (u16, String) {
    let mut s = TcpStream::connect_timeout(&addr, Duration::from_secs(5)).expect("connects");
    s.set_read_timeout(Some(Duration::from_secs(10)))
        .expect("timeout");
    let _ = s.write_all(bytes);
    let mut out = Vec::new();
    let _ = s.read_to_end(&mut out);
    let text = String::from_utf8_lossy(&out).to_string();
    let status = text
        .split(' ')
        .nth(1)
        .and_then(|c| c.parse().ok())
        .unwrap_or(0);
    let body = text
        .split_once("\r\n\r\n")
        .map(|(_, b)| b.to_string())
        .unwrap_or_default();
    (status, body)
}

fn req(addr: SocketAddr, method: &str, target: &str) -> (u16, String) {
    raw(
        addr,
        format!(
            "{method} {target} HTTP/1.1\r\nHost: 127.0.0.1:{}\r\n\r\n",
            addr.port()
        )
        .as_bytes(),
    )
}

fn json(body: &str) -> serde_json::Value {
    serde_json::from_str(body).unwrap_or_else(|e| panic!("not JSON ({e}): {body}"))
}

#[test]
fn binds_loopback_unless_asked() {
    assert!(ServeOptions::default().host.is_loopback());
    let r = start(small());
    assert!(r.addr().ip().is_loopback(), "bound {}", r.addr());
    let (code, body) = req(r.addr(), "GET", "/");
    assert_eq!(code, 200);
    assert!(body.contains("<canvas"));
    // A page elsewhere reaching us through a name of its own (DNS rebinding) is refused.
    let (code, _) = raw(
        r.addr(),
        b"GET /api/state HTTP/1.1\r\nHost: evil.example:8787\r\n\r\n",
    );
    assert_eq!(code, 421);
    // Control requests only from our own origin.
    let port = r.addr().port();
    let cross = format!(
        "POST /api/play HTTP/1.1\r\nHost: 127.0.0.1:{port}\r\nOrigin: http://evil.example\r\nContent-Length: 0\r\n\r\n"
    );
    assert_eq!(raw(r.addr(), cross.as_bytes()).0, 403);
    let same = format!(
        "POST /api/pause HTTP/1.1\r\nHost: 127.0.0.1:{port}\r\nOrigin: http://127.0.0.1:{port}\r\nContent-Length: 0\r\n\r\n"
    );
    assert_eq!(raw(r.addr(), same.as_bytes()).0, 200);
}

#[test]
fn serves_only_its_own_assets() {
    let r = start(small());
    let a = r.addr();
    for (path, kind) in [
        ("/", "<canvas"),
        ("/index.html", "<canvas"),
        ("/viewer.js", "formicaViewer"),
        ("/viewer.css", "#view"),
    ] {
        let (code, body) = req(a, "GET", path);
        assert_eq!(code, 200, "{path}");
        assert!(body.contains(kind), "{path}");
    }
    // The page loads nothing from elsewhere.
    let (_, html) = req(a, "GET", "/");
    let (_, js) = req(a, "GET", "/viewer.js");
    for text in [&html, &js] {
        assert!(!text.contains("http://") && !text.contains("https://"));
    }
    for path in [
        "/..",
        "/../Cargo.toml",
        "/../../Cargo.toml",
        "/%2e%2e/Cargo.toml",
        "/%2E%2E%2FCargo.toml",
        "/viewer.js/../../../Cargo.toml",
        "/..%2f..%2fetc/passwd",
        "//etc/passwd",
        "/assets/index.html",
        "/src/lib.rs",
        "/Cargo.toml",
        "/.git/config",
        "/api",
        "/api/",
        "/api/state/",
        "/favicon.ico",
    ] {
        let (code, body) = req(a, "GET", path);
        assert_eq!(code, 404, "{path}: {body}");
        assert!(!body.contains("[package]") && !body.contains("[workspace]"));
    }
}

/// Drives ahead, then from its third step on with a NaN left wheel (a controller's bug).
struct GoesNan(u32);

impl formica::controller::Controller for GoesNan {
    fn step(
        &mut self,
        _r: &formica::sensors::Readings,
        _rng: &mut formica::controller::RobotRng,
    ) -> formica::controller::Actuation {
        self.0 += 1;
        formica::controller::Actuation {
            left: if self.0 >= 3 { f32::NAN } else { 0.1 },
            right: 0.1,
            ..Default::default()
        }
    }
    fn state(&self) -> &'static str {
        "driving"
    }
}

#[test]
fn a_controller_panic_stops_the_run_not_the_server() {
    // It killed the simulation thread: every later request, restart included, was "busy".
    let mut reg = formica::Registry::builtin();
    reg.controller("goes-nan", |_, _| {
        Ok(formica::controller::ControllerFactory::new(
            formica::sensors::SensorNeeds::default(),
            || Box::new(GoesNan(0)),
        ))
    })
    .unwrap();
    let text = SMALL.replace("controller = \"constant\"", "controller = \"goes-nan\"");
    let text = text.replace("params = { left = 0.1, right = 0.1, led = \"red\" }\n", "");
    let r = start(reg.parse(&text, "nan.toml").expect("parses"));
    let (code, body) = req(r.addr(), "POST", "/api/step?n=10");
    assert_eq!(code, 500, "{body}");
    assert!(
        body.contains("the run stopped") && body.contains("goes-nan") && body.contains("NaN"),
        "{body}"
    );
    // The world stays to be looked at; stepping it again is refused with the reason.
    assert_eq!(req(r.addr(), "GET", "/api/state").0, 200);
    let (code, body) = req(r.addr(), "POST", "/api/step?n=1");
    assert_eq!(code, 500, "{body}");
    assert!(body.contains("restart it"), "{body}");
    // A restart builds a new world, which steps until its controller fails again.
    assert_eq!(req(r.addr(), "POST", "/api/restart?seed=2").0, 200);
    assert_eq!(req(r.addr(), "POST", "/api/step?n=1").0, 200);
}

#[test]
fn bad_requests_get_errors_never_a_crash() {
    let r = start(small());
    let a = r.addr();
    let cases: Vec<(Vec<u8>, u16)> = vec![
        (b"garbage\r\n\r\n".to_vec(), 400),
        (b"GET /\r\n\r\n".to_vec(), 400),
        (b"GET / HTTP/9.9\r\n\r\n".to_vec(), 505),
        (b"DELETE / HTTP/1.1\r\n\r\n".to_vec(), 501),
        (b"GET / HTTP/1.1\r\nbroken header\r\n\r\n".to_vec(), 400),
        (vec![0xff, 0xfe, 0x00, b'\r', b'\n', b'\r', b'\n'], 400),
        (
            format!("GET /{} HTTP/1.1\r\n\r\n", "a".repeat(20_000)).into_bytes(),
            431,
        ),
        (
            b"POST /api/step HTTP/1.1\r\nContent-Length: 100000\r\n\r\n".to_vec(),
            413,
        ),
        (
            b"POST /api/step HTTP/1.1\r\nTransfer-Encoding: chunked\r\n\r\n".to_vec(),
            501,
        ),
        // With its Host, so that the bad query, not the missing Host, is what is refused.
        (
            b"GET /?x=%zz HTTP/1.1\r\nHost: 127.0.0.1\r\n\r\n".to_vec(),
            400,
        ),
        (b"GET /api/state HTTP/1.1\r\n\r\n".to_vec(), 400),
        (
            b"GET /api/state HTTP/1.1\r\nHost: a\r\nHost: b\r\n\r\n".to_vec(),
            400,
        ),
        // Half a request, then the client goes quiet: a timeout, answered.
        (b"GET / HTTP/1.1\r\nHost: 127.0.0.1\r\n".to_vec(), 408),
    ];
    for (bytes, want) in &cases {
        let (code, body) = raw(a, bytes);
        assert_eq!(
            code,
            *want,
            "{:?}: {body}",
            String::from_utf8_lossy(&bytes[..bytes.len().min(40)])
        );
        if *want != 0 {
            assert!(json(&body)["error"].is_string());
        }
    }
    for (method, target, want) in [
        ("POST", "/", 405),
        ("POST", "/api/state", 405),
        ("GET", "/api/step", 405),
        ("GET", "/api/restart", 405),
        ("GET", "/?a=1", 400),
        ("GET", "/api/state?rays=maybe", 400),
        ("GET", "/api/state?bogus=1", 400),
        ("POST", "/api/step?n=0", 400),
        ("POST", "/api/step?n=-3", 400),
        ("POST", "/api/step?n=99999999999999999999999", 400),
        ("POST", "/api/speed", 400),
        ("POST", "/api/speed?x=fast", 400),
        ("POST", "/api/speed?x=NaN", 400),
        ("POST", "/api/speed?x=1e9", 400),
        ("POST", "/api/restart?seed=-1", 400),
        ("POST", "/api/restart?seed=abc", 400),
        ("POST", "/api/restart?seed=18446744073709551615", 400),
        ("POST", "/api/step?n=%2B5", 400),
        ("GET", "/api/robot?i=%2B1", 400),
        ("POST", "/api/step?n=1&n=2", 400),
        ("GET", "/api/state?rays=1&rays=0", 400),
    ] {
        let (code, body) = req(a, method, target);
        assert_eq!(code, want, "{method} {target}: {body}");
        assert!(json(&body)["error"].is_string(), "{method} {target}");
    }
    // A client that connects and leaves without a word gets nothing and costs nothing.
    for _ in 0..5 {
        drop(TcpStream::connect(a).expect("connects"));
    }
    // Still serving, and the simulation is intact.
    let (code, body) = req(a, "GET", "/api/state");
    assert_eq!(code, 200);
    assert_eq!(json(&body)["tick"], 0);
}

#[test]
fn controls_step_restart_and_play() {
    let r = start(seed_transport());
    let a = r.addr();
    let s0 = json(&req(a, "GET", "/api/state").1);
    assert_eq!(s0["tick"], 0);
    assert_eq!(s0["robots"].as_array().map(Vec::len), Some(20));
    assert_eq!(s0["playing"], false);
    let scene = json(&req(a, "GET", "/api/scene").1);
    assert_eq!(scene["scenario"], "seed-transport");
    assert!(scene["walls"].as_array().is_some_and(|w| w.len() >= 4));

    let (code, body) = req(a, "POST", "/api/step?n=5&rays=1&zones=1");
    assert_eq!(code, 200, "{body}");
    let s1 = json(&body);
    assert_eq!(s1["tick"], 5);
    assert_ne!(s0["robots"], s1["robots"], "robots moved");
    assert!(s1["zones"].as_array().is_some_and(|z| !z.is_empty()));
    assert_eq!(s1["robots"][0]["rays"].as_array().map(Vec::len), Some(8));
    assert!(s1["robots"][0]["sees_goal"].is_boolean());

    let (code, body) = req(a, "POST", "/api/restart?seed=7");
    assert_eq!(code, 200, "{body}");
    let s2 = json(&body);
    assert_eq!(
        (s2["seed"].as_u64(), s2["tick"].as_u64()),
        (Some(7), Some(0))
    );
    assert_eq!(s2["generation"], s0["generation"].as_u64().unwrap_or(0) + 1);
    assert_ne!(
        s2["robots"][0]["x"], s0["robots"][0]["x"],
        "a new seed places robots anew"
    );
    let scene2 = json(&req(a, "GET", "/api/scene").1);
    assert_eq!(scene2["seed"], 7);
    // The next seed after the largest is 0, not one that no command takes.
    let max = formica::limits::MAX_SEED;
    assert_eq!(req(a, "POST", &format!("/api/restart?seed={max}")).0, 200);
    let s3 = json(&req(a, "POST", "/api/restart").1);
    assert_eq!(s3["seed"], 0);

    assert_eq!(req(a, "POST", "/api/speed?x=8").0, 200);
    assert_eq!(req(a, "POST", "/api/play").0, 200);
    let t0 = Instant::now();
    let mut tick = 0;
    while t0.elapsed() < Duration::from_secs(20) && tick < 10 {
        std::thread::sleep(Duration::from_millis(100));
        tick = json(&req(a, "GET", "/api/state").1)["tick"]
            .as_u64()
            .unwrap_or(0);
    }
    assert!(tick >= 10, "playing advances the clock (tick {tick})");
    let paused = json(&req(a, "POST", "/api/pause").1);
    assert_eq!(paused["playing"], false);
    let t = paused["tick"].clone();
    std::thread::sleep(Duration::from_millis(200));
    assert_eq!(
        json(&req(a, "GET", "/api/state").1)["tick"],
        t,
        "paused stays put"
    );
}

fn rss_kib() -> Option<u64> {
    let s = std::fs::read_to_string("/proc/self/status").ok()?;
    let line = s.lines().find(|l| l.starts_with("VmRSS:"))?;
    line.split_whitespace().nth(1)?.parse().ok()
}

fn many_clients(a: SocketAddr, clients: usize, each: usize) {
    let threads: Vec<_> = (0..clients)
        .map(|c| {
            std::thread::spawn(move || {
                for k in 0..each {
                    let target = match (c + k) % 5 {
                        0 => "/api/state?rays=1&zones=1",
                        1 => "/api/scene",
                        2 => "/",
                        3 => "/viewer.js",
                        _ => "/api/state",
                    };
                    let (code, _) = req(a, "GET", target);
                    assert!(code == 200 || code == 503, "{target}: {code}");
                }
                // Some clients leave half-way through a request.
                if let Ok(mut s) = TcpStream::connect(a) {
                    let _ = s.write_all(b"GET /api/sta");
                }
            })
        })
        .collect();
    for t in threads {
        t.join().expect("client thread");
    }
}

#[test]
fn memory_stays_bounded_with_many_clients() {
    let r = start(small());
    let a = r.addr();
    // The path is thinned, never longer than its cap, however long the run.
    for _ in 0..3 {
        let (code, _) = req(a, "POST", &format!("/api/step?n={MAX_STEP}"));
        assert_eq!(code, 200);
    }
    let st = r.handle.stats();
    assert!(st.path_points <= PATH_CAP, "{} path points", st.path_points);
    let path_len = json(&req(a, "GET", "/api/state").1)["path"]
        .as_array()
        .map_or(0, Vec::len);
    assert!(
        path_len <= PATH_CAP + 1,
        "path of {path_len} points in the state"
    );

    let state_before = req(a, "GET", "/api/state").1;
    // A first round warms up allocator arenas for as many client threads as the second.
    many_clients(a, 16, 15);
    let rss0 = rss_kib();
    many_clients(a, 16, 60);
    let rss1 = rss_kib();

    // Every connection is closed again; nothing is kept per client.
    let t0 = Instant::now();
    while r.handle.stats().open_connections > 0 && t0.elapsed() < Duration::from_secs(10) {
        std::thread::sleep(Duration::from_millis(50));
    }
    let st = r.handle.stats();
    assert_eq!(st.open_connections, 0);
    assert_eq!(st.simulations, 1);
    assert!(st.requests >= 16 * 15 + 16 * 60, "{} requests", st.requests);
    // What a client reads does not depend on how many came before it.
    assert_eq!(req(a, "GET", "/api/state").1, state_before);
    let stats = json(&req(a, "GET", "/api/stats").1);
    assert_eq!(stats["simulations"], 1);
    // Connections are bounded (one thread each), whatever the number of clients.
    assert!(stats["max_connections"].as_u64().is_some_and(|m| m <= 64));
    if let (Some(r0), Some(r1)) = (rss0, rss1) {
        // 960 more requests; a per-request leak of even 10 KiB would show.
        assert!(r1 < r0 + 8 * 1024, "RSS grew from {r0} KiB to {r1} KiB");
    }
}

/// A world heavy enough that stepping it 4,000 ticks takes a second or more: 300 robots wandering.
fn heavy() -> Scenario {
    Scenario::parse(
        r#"
name = "heavy"
[arena]
size = [12.0, 12.0]
[[robots]]
count = 300
controller = "random-walk"
placement = { random = { min = [-5.5, -5.5], max = [5.5, 5.5] } }
[run]
duration_s = 100000
"#,
        "heavy.toml",
    )
    .expect("test scenario parses")
}

#[test]
fn a_full_server_evicts_idle_clients_and_answers_busy_only_when_all_are_answering() {
    let r = start_with(heavy(), |o| {
        o.max_connections = 2;
        o.read_timeout = Duration::from_secs(10);
    });
    let a = r.addr();
    // Silent clients fill both connections; each newcomer evicts the oldest silent one and is
    // answered at once, long before the silent ones' 10 s would run out.
    let mut idle: Vec<TcpStream> = (0..2)
        .map(|_| {
            let s = TcpStream::connect(a).expect("connects");
            std::thread::sleep(Duration::from_millis(50));
            s
        })
        .collect();
    // Silent long enough to be taken for idle, not for a client about to send.
    std::thread::sleep(formica_serve::conn::IDLE_BEFORE_EVICTION);
    let t0 = Instant::now();
    assert_eq!(req(a, "GET", "/api/state").0, 200);
    assert!(t0.elapsed() < Duration::from_secs(2), "{:?}", t0.elapsed());
    assert!(r.handle.stats().evicted >= 1);
    // The oldest silent client was closed, told to come back should it send after all.
    idle[0]
        .set_read_timeout(Some(Duration::from_secs(5)))
        .expect("timeout");
    let mut told = String::new();
    let _ = idle[0].read_to_string(&mut told);
    assert!(
        told.is_empty() || told.starts_with("HTTP/1.1 503"),
        "{told}"
    );

    // While both connections are being answered (a long step, and a request queued behind it
    // for the simulation), a newcomer is turned away with 503; once they are done, it is
    // served again.
    drop(idle.drain(..));
    let patient = |target: &'static str| {
        std::thread::spawn(move || {
            let mut s = TcpStream::connect(a).expect("connects");
            s.set_read_timeout(Some(Duration::from_secs(120)))
                .expect("timeout");
            let port = a.port();
            s.write_all(
                format!(
                    "POST {target} HTTP/1.1\r\nHost: 127.0.0.1:{port}\r\nContent-Length: 0\r\n\r\n"
                )
                .as_bytes(),
            )
            .expect("sends");
            let mut out = String::new();
            let _ = s.read_to_string(&mut out);
            out.split(' ')
                .nth(1)
                .and_then(|c| c.parse::<u16>().ok())
                .unwrap_or(0)
        })
    };
    let t1 = Instant::now();
    let long = patient("/api/step?n=4000");
    std::thread::sleep(Duration::from_millis(100));
    let queued = patient("/api/pause");
    std::thread::sleep(Duration::from_millis(100));
    let mut saw_busy = false;
    while !saw_busy && !long.is_finished() {
        saw_busy = req(a, "GET", "/api/state").0 == 503;
    }
    let codes = [long.join().expect("client"), queued.join().expect("client")];
    eprintln!("the long step was answered after {:?}", t1.elapsed());
    assert_eq!(codes, [200, 200]);
    assert!(saw_busy, "no 503 while both connections were answering");
    assert!(r.handle.stats().rejected >= 1);
    assert_eq!(req(a, "GET", "/api/state").0, 200, "serves again");
}

#[test]
fn steps_do_not_queue_behind_a_step() {
    // Clients that send long steps and leave used to stack them on the simulation thread (each
    // runs up to 5 s, client or not): eight such steps kept every other request waiting.
    let r = start(heavy());
    let a = r.addr();
    let long = std::thread::spawn(move || req(a, "POST", "/api/step?n=4000").0);
    std::thread::sleep(Duration::from_millis(200));
    let mut refused = None;
    while refused.is_none() && !long.is_finished() {
        let (code, body) = req(a, "POST", "/api/step?n=4000");
        if code == 503 {
            refused = Some(body);
        }
    }
    assert_eq!(long.join().expect("client"), 200);
    let body = refused.expect("a second step while the first ran was refused");
    assert!(body.contains("a step is already under way"), "{body}");
    assert_eq!(
        req(a, "POST", "/api/step?n=1").0,
        200,
        "steps again after it"
    );
}

#[test]
fn a_hundred_idle_connections_do_not_lock_a_client_out() {
    // The defaults `formica serve` uses: 64 connections, 5 s to send a request.
    let r = start_with(seed_transport(), |o| {
        o.read_timeout = ServeOptions::default().read_timeout;
    });
    let a = r.addr();
    // 100 clients connect and send nothing (a few send half a request), and stay connected.
    let idle: Vec<TcpStream> = (0..100)
        .map(|k| {
            let mut s = TcpStream::connect(a).expect("connects");
            if k % 10 == 0 {
                let _ = s.write_all(b"GET /api/sta");
            }
            s
        })
        .collect();
    // (Those past the 64th found every slot freshly taken, and were told to come back.)
    std::thread::sleep(formica_serve::conn::IDLE_BEFORE_EVICTION + Duration::from_millis(100));
    let st = r.handle.stats();
    assert!(st.open_connections <= st.max_connections, "{st:?}");
    let rejected = st.rejected;
    // A client loads the page and its assets and steps the simulation, in well under 1 s.
    let t0 = Instant::now();
    for path in ["/", "/viewer.js", "/viewer.css", "/api/scene", "/api/state"] {
        assert_eq!(req(a, "GET", path).0, 200, "{path}");
    }
    for k in 1..=5 {
        let (code, body) = req(a, "POST", "/api/step");
        assert_eq!(code, 200, "{body}");
        assert_eq!(json(&body)["tick"], k);
    }
    let took = t0.elapsed();
    eprintln!("with 100 idle connections open: page, scene, state and 5 steps in {took:?}");
    assert!(took < Duration::from_secs(1), "took {took:?}");
    assert_eq!(r.handle.stats().rejected, rejected);
    drop(idle);
}

#[test]
fn a_burst_of_whole_requests_gets_every_one_an_answer() {
    // 300 clients send a whole request at once: each is answered, 200 or 503 to come back;
    // clients admitted a moment before used to be evicted unanswered.
    let r = start(seed_transport());
    let a = r.addr();
    let port = a.port();
    let clients: Vec<TcpStream> = (0..300)
        .map(|_| {
            let mut s = TcpStream::connect(a).expect("connects");
            s.write_all(
                format!("GET /api/stats HTTP/1.1\r\nHost: 127.0.0.1:{port}\r\n\r\n").as_bytes(),
            )
            .expect("sends");
            s
        })
        .collect();
    let mut codes = std::collections::BTreeMap::new();
    for mut s in clients {
        s.set_read_timeout(Some(Duration::from_secs(30)))
            .expect("timeout");
        let mut out = String::new();
        let _ = s.read_to_string(&mut out);
        let code = out.split(' ').nth(1).unwrap_or("none").to_string();
        *codes.entry(code).or_insert(0) += 1;
    }
    assert!(codes.keys().all(|c| c == "200" || c == "503"), "{codes:?}");
}

#[test]
fn robots_can_be_inspected_and_series_grow() {
    let r = start(seed_transport());
    let a = r.addr();
    let (code, body) = req(a, "POST", "/api/step?n=30");
    assert_eq!(code, 200, "{body}");
    let robot = json(&req(a, "GET", "/api/robot?i=3").1);
    assert_eq!(robot["robot"], 3);
    assert_eq!(robot["tick"], 30);
    assert!(robot["state"].as_str().is_some_and(|s| !s.is_empty()));
    assert!(robot["controller"].is_string());
    // The Khepera IV's 8 proximity and 8 light sensors, readings in [0, 1].
    for k in ["proximity", "light"] {
        let v = robot["readings"][k].as_array().expect(k);
        assert_eq!(v.len(), 8, "{k}");
        assert!(v
            .iter()
            .all(|x| x.as_f64().is_some_and(|x| (0.0..=1.0).contains(&x))));
    }
    assert_eq!(robot["proximity_angles"].as_array().map(Vec::len), Some(8));
    assert!(robot["readings"]["blobs"].is_array());
    // State history: at least the state at the start of the window, times within the last minute.
    let h = robot["history"].as_array().expect("history");
    assert!(!h.is_empty());
    assert!(h
        .iter()
        .all(|e| e["t_s"].as_f64().is_some_and(|t| t <= 3.0)));
    for (target, want) in [
        ("/api/robot?i=20", 404),
        ("/api/robot?i=x", 400),
        ("/api/robot", 400),
        ("/api/robot?i=1&j=2", 400),
        ("/api/series?x=1", 400),
    ] {
        assert_eq!(req(a, "GET", target).0, want, "{target}");
    }
    let s1 = json(&req(a, "GET", "/api/series").1);
    let n1 = s1["t_s"].as_array().map_or(0, Vec::len);
    assert_eq!(n1, 7, "t = 0, 0.5, ..., 3 s: {s1}");
    assert!(s1["states"].as_array().is_some_and(|s| !s.is_empty()));
    assert_eq!(
        s1["robots_in_state"].as_array().map(Vec::len),
        s1["states"].as_array().map(Vec::len)
    );
    assert!(s1["goal_distance_m"][0].as_f64().is_some());
    req(a, "POST", "/api/step?n=20");
    let s2 = json(&req(a, "GET", "/api/series").1);
    assert_eq!(s2["t_s"].as_array().map_or(0, Vec::len), n1 + 4);
    // A restart starts a new series.
    req(a, "POST", "/api/restart?seed=3");
    let s3 = json(&req(a, "GET", "/api/series").1);
    assert_eq!(s3["t_s"].as_array().map_or(0, Vec::len), 1);
    assert_eq!(s3["generation"], 2);
}

#[test]
fn a_replay_is_checked_against_its_stored_result() {
    use formica::experiment::{run, RunOptions};
    use formica::Overrides;
    let sc = small();
    let stored = run(
        &sc,
        &RunOptions {
            overrides: Overrides {
                seed: Some(4),
                duration_s: Some(3.0),
                controller: None,
            },
            ..RunOptions::default()
        },
    )
    .expect("runs")
    .0;
    for tamper in [false, true] {
        let mut stored = stored.clone();
        if tamper {
            stored.object_path_m = stored.object_path_m.map(|p| p + 1.0);
        }
        let r = start_with(small(), |o| {
            o.seed = Some(4);
            o.duration_s = Some(3.0);
            o.replay = Some(formica_serve::ReplayInfo {
                label: "trial 7 of test.db".into(),
                seed: 4,
                stored: stored.clone(),
                columns: stored.extra.keys().cloned().collect(),
                params: vec![("robots.0.count".into(), "3".into())],
            });
        });
        let a = r.addr();
        let scene = json(&req(a, "GET", "/api/scene").1);
        assert_eq!(scene["replay"]["label"], "trial 7 of test.db");
        assert_eq!(scene["replay"]["stored_outcome"], "timeout");
        let s = json(&req(a, "GET", "/api/state").1);
        assert_eq!(s["replay"]["active"], true);
        assert_eq!(s["replay"]["ended"], false);
        assert!(s["replay"]["matches"].is_null());
        let s = json(&req(a, "POST", "/api/step?n=100").1);
        assert_eq!(s["tick"], 30);
        assert_eq!(s["replay"]["ended"], true);
        assert_eq!(s["replay"]["matches"], !tamper, "{s}");
        let diffs = s["replay"]["differences"].as_array().expect("list");
        assert_eq!(diffs.len(), usize::from(tamper), "{diffs:?}");
        if tamper {
            assert!(diffs[0]
                .as_str()
                .is_some_and(|d| d.starts_with("object_path_m")));
        }
        // Another seed is not the trial.
        let s = json(&req(a, "POST", "/api/restart?seed=5").1);
        assert_eq!(s["replay"]["active"], false);
    }
}

#[test]
fn a_step_stops_at_its_time_budget_and_runs_at_least_one_tick() {
    // What keeps `/api/step?n=10000` of a 100,000-robot world from holding the server for
    // half an hour: the step ends when its budget is spent.
    let mut sim = formica_serve::Sim::new(small(), None, None).expect("the small world builds");
    assert_eq!(sim.step_within(10_000, Some(Duration::ZERO)), 1);
    assert_eq!(sim.tick(), 1);
    assert_eq!(sim.step_within(7, Some(Duration::from_secs(600))), 7);
    assert_eq!(sim.step(3), 3);
    assert_eq!(sim.tick(), 11);
}
