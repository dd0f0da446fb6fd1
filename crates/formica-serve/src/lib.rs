//! # formica-serve
//!
//! A live web viewer for Formica runs. [`Server`] holds one simulation, shared by every
//! client: a single simulation thread owns it, steps it while it plays, and answers requests
//! that connection threads pass it through a bounded queue (a [`formica::experiment::Run`] is
//! not `Send`, so it stays on the thread that built it; the queue serialises access as a mutex
//! would). Each connection gets a thread of its own, up to [`ServeOptions::max_connections`];
//! idle clients cannot lock others out (see [`conn`]). Nothing is kept per client. Routes:
//!
//! | route | what |
//! |---|---|
//! | `GET /` (`/index.html`), `/viewer.js`, `/viewer.css` | the page, embedded in the binary |
//! | `GET /api/scene` | arena, walls, lights, object outlines, robot groups (JSON) |
//! | `GET /api/state[?rays=1][&zones=1]` | time, outcome, object, path, robots (JSON); for a replay, whether it ended as stored |
//! | `GET /api/series` | goal distance, object speed and robots per state over time (JSON) |
//! | `GET /api/robot?i=N` | robot N's readings, controller state, wheels and state history (JSON) |
//! | `POST /api/play`, `/api/pause`, `/api/step[?n=N]`, `/api/speed?x=F`, `/api/restart[?seed=N]` | control; answer with the state (a step runs `n` ticks, or as many as 5 s of computing allow; a step while another is under way gets 503) |
//! | `GET /api/stats` | request counters and buffer sizes of the server itself |
//!
//! Nothing else is served: there is no file system behind the routes, so `..` or any other
//! path is a 404. The server binds 127.0.0.1 unless told otherwise, and when bound to
//! loopback it only answers requests whose `Host` names loopback (DNS rebinding), and
//! control requests only from its own origin.

pub mod conn;
pub mod http;
pub mod sim;

pub use sim::{ReplayInfo, Sim, StateQuery, MAX_STEP, PATH_CAP, SPEED_RANGE};

use conn::{Deadline, Slot, Slots};
use http::{Method, ReadError, Request, Response};
use std::net::{IpAddr, Ipv4Addr, SocketAddr, TcpListener, TcpStream};
use std::sync::atomic::{AtomicBool, AtomicU64, AtomicUsize, Ordering};
use std::sync::mpsc::{self, Receiver, SyncSender};
use std::sync::Arc;
use std::time::{Duration, Instant};

const INDEX_HTML: &str = include_str!("../assets/index.html");
const VIEWER_JS: &str = include_str!("../assets/viewer.js");
const VIEWER_CSS: &str = include_str!("../assets/viewer.css");

/// Default port of `formica serve`.
pub const DEFAULT_PORT: u16 = 8787;

/// How a server is set up.
#[derive(Debug, Clone)]
pub struct ServeOptions {
    /// Address to bind (default 127.0.0.1; anything else must be asked for).
    pub host: IpAddr,
    /// Port (0: any free port).
    pub port: u16,
    /// Seed of the first run (default: the scenario's).
    pub seed: Option<u64>,
    /// Simulated time limit (default: the scenario's).
    pub duration_s: Option<f32>,
    /// Most connections open at once (one thread each). When all are taken, a new client
    /// evicts the one that has been sending its request longest; it gets 503 only if every
    /// connection is being answered.
    pub max_connections: usize,
    /// How long a client has to send its whole request (head and body), in all.
    pub read_timeout: Duration,
    /// Start playing at once.
    pub play: bool,
    /// The stored trial this run replays, if any.
    pub replay: Option<ReplayInfo>,
}

impl Default for ServeOptions {
    fn default() -> Self {
        Self {
            host: IpAddr::V4(Ipv4Addr::LOCALHOST),
            port: DEFAULT_PORT,
            seed: None,
            duration_s: None,
            max_connections: 64,
            read_timeout: Duration::from_secs(5),
            play: false,
            replay: None,
        }
    }
}

/// Why a server could not start.
#[derive(Debug)]
pub enum ServeError {
    /// The scenario does not build.
    Scenario(formica::ScenarioError),
    /// The address could not be bound.
    Io(std::io::Error),
}

impl std::fmt::Display for ServeError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            ServeError::Scenario(e) => write!(f, "{e}"),
            ServeError::Io(e) => write!(f, "{e}"),
        }
    }
}

impl std::error::Error for ServeError {}

/// Counters of a running server.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct Stats {
    /// Requests answered (including errors).
    pub requests: u64,
    /// Connections turned away with 503 because every connection was being answered.
    pub rejected: u64,
    /// Connections closed unanswered to make room, while still sending their request.
    pub evicted: u64,
    /// Connections accepted and not yet closed.
    pub open_connections: usize,
    /// Most connections that can be open at once.
    pub max_connections: usize,
    /// Points of the object's path held.
    pub path_points: usize,
    /// Simulations held (always one: clients share it).
    pub simulations: usize,
}

/// Counters shared by the threads.
#[derive(Default)]
struct Counters {
    stop: AtomicBool,
    /// A step is queued or running: another is refused (503) rather than queued behind it, so
    /// that clients that send steps and leave cannot stack minutes of work (a step runs even
    /// when its client has gone, for up to [`STEP_BUDGET`]).
    stepping: AtomicBool,
    requests: AtomicU64,
    rejected: AtomicU64,
    path_points: AtomicUsize,
}

/// A control request.
#[derive(Debug, Clone, Copy)]
enum Control {
    Play,
    Pause,
    Step(u64),
    Speed(f64),
    Restart(Option<u64>),
}

/// What connection threads ask the simulation thread.
enum Cmd {
    Scene(SyncSender<String>),
    State(StateQuery, SyncSender<String>),
    Series(SyncSender<String>),
    Robot(usize, SyncSender<Option<String>>),
    Control(Control, StateQuery, SyncSender<Result<String, Response>>),
}

/// How long a connection waits for the simulation thread's answer.
const SIM_WAIT: Duration = Duration::from_secs(30);

/// Most wall time one `/api/step?n=N` computes: it runs `n` ticks or as many as fit (at least
/// one), well within what a request waits ([`SIM_WAIT`]), so the server keeps answering.
const STEP_BUDGET: Duration = Duration::from_secs(5);
/// Stack of a connection thread (it parses and writes; the simulation thread builds answers).
const CONN_STACK: usize = 256 * 1024;

struct Shared {
    counters: Arc<Counters>,
    cmd: SyncSender<Cmd>,
    slots: Arc<Slots>,
    loopback: bool,
    addr: SocketAddr,
}

/// A bound server, not yet running.
pub struct Server {
    listener: TcpListener,
    shared: Arc<Shared>,
    opts: ServeOptions,
    sim_thread: std::thread::JoinHandle<()>,
}

/// A handle to a running server: its address, counters, and a way to stop it.
#[derive(Clone)]
pub struct ServerHandle {
    shared: Arc<Shared>,
}

impl ServerHandle {
    /// The bound address.
    pub fn addr(&self) -> SocketAddr {
        self.shared.addr
    }

    /// Current counters.
    pub fn stats(&self) -> Stats {
        stats(&self.shared)
    }

    /// Asks the server to stop; [`Server::run`] returns soon after.
    pub fn stop(&self) {
        self.shared.counters.stop.store(true, Ordering::SeqCst);
        // Wake the accept loop.
        let mut a = self.shared.addr;
        if a.ip().is_unspecified() {
            a.set_ip(match a.ip() {
                IpAddr::V4(_) => IpAddr::V4(Ipv4Addr::LOCALHOST),
                IpAddr::V6(_) => IpAddr::V6(std::net::Ipv6Addr::LOCALHOST),
            });
        }
        let _ = TcpStream::connect_timeout(&a, Duration::from_secs(1));
    }
}

fn stats(s: &Shared) -> Stats {
    let c = &s.counters;
    Stats {
        requests: c.requests.load(Ordering::SeqCst),
        rejected: c.rejected.load(Ordering::SeqCst),
        evicted: s.slots.evictions(),
        open_connections: s.slots.open(),
        max_connections: s.slots.max(),
        path_points: c.path_points.load(Ordering::SeqCst),
        simulations: 1,
    }
}

impl Server {
    /// Binds the address and builds the simulation (on its own thread).
    pub fn bind(scenario: formica::Scenario, opts: ServeOptions) -> Result<Server, ServeError> {
        let listener =
            TcpListener::bind(SocketAddr::new(opts.host, opts.port)).map_err(ServeError::Io)?;
        let addr = listener.local_addr().map_err(ServeError::Io)?;
        let counters = Arc::new(Counters::default());
        let slots = Slots::new(opts.max_connections);
        // Each connection has at most one command outstanding, so the queue never fills.
        let (cmd_tx, cmd_rx) = mpsc::sync_channel::<Cmd>(slots.max() + 4);
        let (init_tx, init_rx) = mpsc::sync_channel(1);
        let sim_thread = {
            let counters = counters.clone();
            let (seed, duration, play) = (opts.seed, opts.duration_s, opts.play);
            let replay = opts.replay.clone();
            std::thread::Builder::new()
                .name("serve-sim".into())
                .spawn(move || match Sim::new(scenario, seed, duration) {
                    Ok(mut sim) => {
                        if let Some(r) = replay {
                            sim.set_replay(r);
                        }
                        sim.set_playing(play);
                        let _ = init_tx.send(Ok(()));
                        sim_loop(sim, &cmd_rx, &counters);
                    }
                    Err(e) => {
                        let _ = init_tx.send(Err(e));
                    }
                })
                .map_err(ServeError::Io)?
        };
        match init_rx.recv() {
            Ok(Ok(())) => {}
            Ok(Err(e)) => {
                let _ = sim_thread.join();
                return Err(ServeError::Scenario(e));
            }
            Err(_) => {
                let _ = sim_thread.join();
                return Err(ServeError::Io(std::io::Error::other(
                    "the simulation thread stopped while building the world",
                )));
            }
        }
        let shared = Arc::new(Shared {
            counters,
            cmd: cmd_tx,
            slots,
            loopback: addr.ip().is_loopback(),
            addr,
        });
        Ok(Server {
            listener,
            shared,
            opts,
            sim_thread,
        })
    }

    /// The bound address.
    pub fn local_addr(&self) -> SocketAddr {
        self.shared.addr
    }

    /// A handle for stopping the server and reading its counters.
    pub fn handle(&self) -> ServerHandle {
        ServerHandle {
            shared: self.shared.clone(),
        }
    }

    /// Serves until [`ServerHandle::stop`]: this thread accepts connections and gives each a
    /// thread of its own (see [`conn`] for how idle clients are kept from locking others out).
    pub fn run(self) -> std::io::Result<()> {
        let Server {
            listener,
            shared,
            opts,
            sim_thread,
        } = self;
        let counters = &shared.counters;
        for conn in listener.incoming() {
            if counters.stop.load(Ordering::SeqCst) {
                break;
            }
            let stream = match conn {
                Ok(s) => s,
                Err(_) => {
                    // Out of file descriptors, or the like: let connections close.
                    std::thread::sleep(Duration::from_millis(10));
                    continue;
                }
            };
            let Ok(slot) = shared.slots.admit(&stream) else {
                busy(counters, stream);
                continue;
            };
            let mine = shared.clone();
            let timeout = opts.read_timeout;
            let spawned = std::thread::Builder::new()
                .name("serve-conn".into())
                .stack_size(CONN_STACK)
                .spawn(move || handle(&mine, stream, slot, timeout));
            if spawned.is_err() {
                // The slot was freed with the closure; the client hears nothing and retries.
                counters.rejected.fetch_add(1, Ordering::SeqCst);
            }
        }
        counters.stop.store(true, Ordering::SeqCst);
        // Idle connections are closed; those being answered finish (bounded by the timeouts).
        shared.slots.close_reading();
        let t0 = Instant::now();
        while shared.slots.open() > 0 && t0.elapsed() < opts.read_timeout + SIM_WAIT {
            shared.slots.close_reading();
            std::thread::sleep(Duration::from_millis(10));
        }
        drop(shared);
        let _ = sim_thread.join();
        Ok(())
    }
}

/// Turns a client away with 503 when every connection is being answered.
fn busy(counters: &Counters, mut s: TcpStream) {
    counters.rejected.fetch_add(1, Ordering::SeqCst);
    // Take in what the client has sent already (briefly), so that closing does not reset the
    // connection before it reads the answer.
    let _ = s.set_read_timeout(Some(Duration::from_millis(20)));
    let _ = s.set_write_timeout(Some(Duration::from_millis(200)));
    let mut sink = [0u8; 4096];
    let _ = std::io::Read::read(&mut s, &mut sink);
    let _ = http::write_response(
        &mut s,
        &Response::come_back("server busy, try again"),
        false,
    );
    let _ = s.shutdown(std::net::Shutdown::Write);
}

/// One connection: reads its request by the deadline, answers it, closes.
fn handle(shared: &Shared, mut stream: TcpStream, slot: Slot, timeout: Duration) {
    let counters = &shared.counters;
    let _ = stream.set_nodelay(true);
    let _ = stream.set_write_timeout(Some(timeout));
    let read = http::read_request(&mut Deadline::new(&stream, Instant::now() + timeout));
    if slot.evicted() {
        return;
    }
    slot.answering();
    match read {
        Ok(req) => {
            let resp = respond(shared, &req);
            let _ = http::write_response(&mut stream, &resp, req.method == Method::Head);
            counters.requests.fetch_add(1, Ordering::SeqCst);
        }
        Err(ReadError::Bad(resp)) => {
            let _ = http::write_response(&mut stream, &resp, false);
            counters.requests.fetch_add(1, Ordering::SeqCst);
        }
        Err(ReadError::Gone) => {}
    }
    let _ = stream.shutdown(std::net::Shutdown::Write);
    drop(stream);
    drop(slot);
}

/// Runs `f` on the simulation, turning a panic in it (a controller's bug, such as a NaN wheel
/// speed) into its message: the simulation thread must outlive it, or every later request,
/// restart included, would be told the simulation is busy.
fn unpanicked<T>(f: impl FnOnce() -> T) -> Result<T, String> {
    std::panic::catch_unwind(std::panic::AssertUnwindSafe(f)).map_err(|payload| {
        formica::world::panic_message(payload.as_ref()).unwrap_or_else(|| "(no message)".into())
    })
}

/// The simulation thread: answers commands, and between them steps the world while it plays.
/// A panic while stepping stops the world where it was: it is still shown, stepping and playing
/// are refused with the panic's message (500), and a restart builds a new world.
fn sim_loop(mut sim: Sim, rx: &Receiver<Cmd>, counters: &Counters) {
    let mut failed: Option<String> = None;
    let mut last = Instant::now();
    counters
        .path_points
        .store(sim.path_points(), Ordering::SeqCst);
    while !counters.stop.load(Ordering::SeqCst) {
        match rx.recv_timeout(Duration::from_millis(15)) {
            Ok(Cmd::Scene(reply)) => {
                let _ = reply.try_send(sim.scene_json().to_string());
            }
            Ok(Cmd::State(q, reply)) => {
                let _ = reply.try_send(sim.state_json(q));
            }
            Ok(Cmd::Series(reply)) => {
                let _ = reply.try_send(sim.series_json());
            }
            Ok(Cmd::Robot(i, reply)) => {
                let _ = reply.try_send(sim.robot_json(i));
            }
            Ok(Cmd::Control(c, q, reply)) => {
                let r = match (&failed, c) {
                    (Some(m), Control::Step(_) | Control::Play) => Err(Response::error(
                        500,
                        &format!("the run stopped: {m}; restart it (with another seed, or fixed)"),
                    )),
                    _ => match unpanicked(|| control(&mut sim, c)) {
                        Ok(r) => {
                            if matches!(c, Control::Restart(_)) && r.is_ok() {
                                failed = None;
                            }
                            r.map(|()| sim.state_json(q))
                        }
                        Err(m) => {
                            sim.set_playing(false);
                            let r = Err(Response::error(500, &format!("the run stopped: {m}")));
                            failed = Some(m);
                            r
                        }
                    },
                };
                if matches!(c, Control::Step(_)) {
                    counters.stepping.store(false, Ordering::SeqCst);
                }
                let _ = reply.try_send(r);
            }
            Err(mpsc::RecvTimeoutError::Timeout) => {}
            Err(mpsc::RecvTimeoutError::Disconnected) => return,
        }
        let now = Instant::now();
        let dt = (now - last).as_secs_f64().min(0.25);
        last = now;
        if failed.is_none() {
            if let Err(m) = unpanicked(|| sim.advance(dt, Duration::from_millis(40))) {
                sim.set_playing(false);
                failed = Some(m);
            }
        }
        counters
            .path_points
            .store(sim.path_points(), Ordering::SeqCst);
    }
}

fn control(sim: &mut Sim, c: Control) -> Result<(), Response> {
    match c {
        Control::Play => sim.set_playing(true),
        Control::Pause => sim.set_playing(false),
        Control::Step(n) => {
            sim.set_playing(false);
            sim.step_within(n, Some(STEP_BUDGET));
        }
        Control::Speed(x) => sim
            .set_speed(x)
            .map_err(|m| Response::error(400, &format!("x: {m}")))?,
        Control::Restart(seed) => sim
            .restart(seed)
            .map_err(|e| Response::error(422, &e.to_string()))?,
    }
    Ok(())
}

/// The answer when the simulation thread cannot take or answer a command in time.
fn sim_busy() -> Response {
    Response::come_back("the simulation is busy, try again")
}

/// Sends a command to the simulation thread and waits for its answer.
fn ask<T>(shared: &Shared, make: impl FnOnce(SyncSender<T>) -> Cmd) -> Result<T, Response> {
    answer(send(shared, make)?)
}

/// Queues a command for the simulation thread (503 if its queue is full); its answer comes on
/// the receiver.
fn send<T>(
    shared: &Shared,
    make: impl FnOnce(SyncSender<T>) -> Cmd,
) -> Result<Receiver<T>, Response> {
    let (tx, rx) = mpsc::sync_channel(1);
    shared.cmd.try_send(make(tx)).map_err(|_| sim_busy())?;
    Ok(rx)
}

/// The simulation thread's answer to a queued command, waited for at most [`SIM_WAIT`].
fn answer<T>(rx: Receiver<T>) -> Result<T, Response> {
    rx.recv_timeout(SIM_WAIT).map_err(|_| sim_busy())
}

/// Whether a `Host` or `Origin` authority names this machine's loopback.
fn is_loopback_authority(a: &str) -> bool {
    let host = if let Some(rest) = a.strip_prefix('[') {
        rest.split(']').next().unwrap_or_default()
    } else {
        a.rsplit_once(':').map_or(a, |(h, _)| h)
    };
    host.eq_ignore_ascii_case("localhost")
        || host.parse::<IpAddr>().is_ok_and(|ip| ip.is_loopback())
}

fn flag(v: &str) -> Result<bool, String> {
    match v {
        "1" | "true" | "" => Ok(true),
        "0" | "false" => Ok(false),
        _ => Err(format!("expected 0 or 1, got `{v}`")),
    }
}

/// A whole number written as digits only (no sign, no spaces), as query values and
/// `Content-Length` take them.
pub(crate) fn digits(v: &str) -> Option<u64> {
    if v.is_empty() || !v.bytes().all(|b| b.is_ascii_digit()) {
        return None;
    }
    v.parse().ok()
}

/// Checks that every query key is one of `allowed`, and given once.
fn only(req: &Request, allowed: &[&str]) -> Result<(), Response> {
    for (i, (k, _)) in req.query.iter().enumerate() {
        if req.query[..i].iter().any(|(seen, _)| seen == k) {
            return Err(Response::error(
                400,
                &format!("parameter `{k}` given more than once"),
            ));
        }
        if !allowed.contains(&k.as_str()) {
            return Err(Response::error(
                400,
                &format!(
                    "unknown parameter `{k}` for {}; expected {}",
                    req.path,
                    if allowed.is_empty() {
                        "none".to_string()
                    } else {
                        allowed.join(", ")
                    }
                ),
            ));
        }
    }
    Ok(())
}

fn param<'a>(req: &'a Request, key: &str) -> Option<&'a str> {
    req.query
        .iter()
        .find(|(k, _)| k == key)
        .map(|(_, v)| v.as_str())
}

const JSON: &str = "application/json";

fn respond(shared: &Shared, req: &Request) -> Response {
    if shared.loopback {
        // DNS rebinding: a page elsewhere must not reach this server through a name of its
        // own that resolves to 127.0.0.1.
        if let Some(h) = &req.host {
            if !is_loopback_authority(h) {
                return Response::error(421, "this server only answers to a loopback Host");
            }
        }
    }
    let get = matches!(req.method, Method::Get | Method::Head);
    let static_asset = |body: &'static str, ctype: &'static str| -> Response {
        if !get {
            return Response::error(405, "use GET").with_header("Allow", "GET, HEAD");
        }
        if !req.query.is_empty() {
            return Response::error(400, "static files take no parameters");
        }
        Response::ok(ctype, body)
    };
    match req.path.as_str() {
        "/" | "/index.html" => static_asset(INDEX_HTML, "text/html; charset=utf-8"),
        "/viewer.js" => static_asset(VIEWER_JS, "text/javascript; charset=utf-8"),
        "/viewer.css" => static_asset(VIEWER_CSS, "text/css; charset=utf-8"),
        "/api/scene" | "/api/state" | "/api/stats" | "/api/series" | "/api/robot" => {
            if !get {
                return Response::error(405, "use GET").with_header("Allow", "GET, HEAD");
            }
            api_get(shared, req).unwrap_or_else(|e| e)
        }
        "/api/play" | "/api/pause" | "/api/step" | "/api/speed" | "/api/restart" => {
            if req.method != Method::Post {
                return Response::error(405, "use POST").with_header("Allow", "POST");
            }
            if let Some(o) = &req.origin {
                let authority = o
                    .strip_prefix("http://")
                    .filter(|a| !a.contains('/'))
                    .unwrap_or("");
                let same = req
                    .host
                    .as_deref()
                    .is_some_and(|h| h.eq_ignore_ascii_case(authority));
                if !same {
                    return Response::error(403, "control requests must come from this page");
                }
            }
            api_post(shared, req).unwrap_or_else(|e| e)
        }
        _ => Response::error(404, "not found"),
    }
}

fn api_get(shared: &Shared, req: &Request) -> Result<Response, Response> {
    match req.path.as_str() {
        "/api/scene" => {
            only(req, &[])?;
            Ok(Response::ok(JSON, ask(shared, Cmd::Scene)?))
        }
        "/api/series" => {
            only(req, &[])?;
            Ok(Response::ok(JSON, ask(shared, Cmd::Series)?))
        }
        "/api/robot" => {
            only(req, &["i"])?;
            let v = param(req, "i").ok_or_else(|| Response::error(400, "i: missing"))?;
            let i = digits(v)
                .and_then(|i| usize::try_from(i).ok())
                .ok_or_else(|| {
                    Response::error(400, &format!("i: expected a robot number, got `{v}`"))
                })?;
            ask(shared, |tx| Cmd::Robot(i, tx))?
                .map(|body| Response::ok(JSON, body))
                .ok_or_else(|| Response::error(404, &format!("no robot {i}")))
        }
        "/api/stats" => {
            only(req, &[])?;
            let s = stats(shared);
            let body = serde_json::json!({
                "requests": s.requests,
                "rejected": s.rejected,
                "evicted": s.evicted,
                "open_connections": s.open_connections,
                "max_connections": s.max_connections,
                "path_points": s.path_points,
                "path_cap": PATH_CAP,
                "simulations": s.simulations,
            });
            Ok(Response::ok(JSON, body.to_string()))
        }
        _ => {
            only(req, &["rays", "zones"])?;
            let q = state_query(req)?;
            Ok(Response::ok(JSON, ask(shared, |tx| Cmd::State(q, tx))?))
        }
    }
}

fn state_query(req: &Request) -> Result<StateQuery, Response> {
    let get = |k: &str| -> Result<bool, Response> {
        param(req, k)
            .map_or(Ok(false), flag)
            .map_err(|m| Response::error(400, &format!("{k}: {m}")))
    };
    Ok(StateQuery {
        rays: get("rays")?,
        zones: get("zones")?,
    })
}

fn api_post(shared: &Shared, req: &Request) -> Result<Response, Response> {
    let extra: &[&str] = match req.path.as_str() {
        "/api/step" => &["n", "rays", "zones"],
        "/api/speed" => &["x", "rays", "zones"],
        "/api/restart" => &["seed", "rays", "zones"],
        _ => &["rays", "zones"],
    };
    only(req, extra)?;
    let q = state_query(req)?;
    let c = match req.path.as_str() {
        "/api/play" => Control::Play,
        "/api/pause" => Control::Pause,
        "/api/step" => Control::Step(match param(req, "n") {
            None => 1,
            Some(v) => digits(v)
                .filter(|n| (1..=MAX_STEP).contains(n))
                .ok_or_else(|| {
                    Response::error(400, &format!("n: expected 1 to {MAX_STEP}, got `{v}`"))
                })?,
        }),
        "/api/speed" => {
            let v = param(req, "x").ok_or_else(|| Response::error(400, "x: missing"))?;
            let x: f64 = v
                .parse()
                .map_err(|_| Response::error(400, &format!("x: expected a number, got `{v}`")))?;
            let (lo, hi) = SPEED_RANGE;
            if !(x >= lo && x <= hi) {
                return Err(Response::error(
                    400,
                    &format!("x: speed must be between {lo} and {hi}, got {v}"),
                ));
            }
            Control::Speed(x)
        }
        _ => Control::Restart(match param(req, "seed") {
            None | Some("") => None,
            Some(v) => Some(
                digits(v)
                    .filter(|s| *s <= formica::limits::MAX_SEED)
                    .ok_or_else(|| {
                        Response::error(
                            400,
                            &format!(
                                "seed: expected a whole number from 0 to {} (as `formica run \
                                 --seed` takes), got `{v}`",
                                formica::limits::MAX_SEED
                            ),
                        )
                    })?,
            ),
        }),
    };
    let step = matches!(c, Control::Step(_));
    if step && shared.counters.stepping.swap(true, Ordering::SeqCst) {
        return Err(Response::come_back(
            "a step is already under way, try again",
        ));
    }
    let rx = send(shared, |tx| Cmd::Control(c, q, tx)).inspect_err(|_| {
        // Never queued: the simulation thread will not clear the flag.
        if step {
            shared.counters.stepping.store(false, Ordering::SeqCst);
        }
    })?;
    let body = answer(rx)??;
    Ok(Response::ok(JSON, body))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn loopback_authorities() {
        for ok in [
            "127.0.0.1:80",
            "localhost",
            "LOCALHOST:1",
            "[::1]:8",
            "127.1.2.3",
        ] {
            assert!(is_loopback_authority(ok), "{ok}");
        }
        for bad in [
            "evil.example:80",
            "10.0.0.1",
            "[::2]:8",
            "",
            "localhost.evil",
        ] {
            assert!(!is_loopback_authority(bad), "{bad}");
        }
    }
}
