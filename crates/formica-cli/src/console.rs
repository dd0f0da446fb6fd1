//! Printing to stdout. Once the reader of stdout has gone (`formica run ... | head -1`), later
//! lines are dropped instead of panicking as `println!` would, and the command still finishes
//! its work: files it writes (`--out`, a sweep's store) are never lost to a closed pipe.

use std::io::Write;
use std::sync::atomic::{AtomicBool, Ordering};

/// Like `println!`, but a closed stdout drops the line (see the module docs).
macro_rules! outln {
    ($($arg:tt)*) => {
        $crate::console::line(format_args!($($arg)*))
    };
}

/// Like `eprintln!`, but a failed write to stderr (a log file on a full disk) is ignored
/// instead of panicking: what the command writes to its files and its exit code stand.
macro_rules! errln {
    ($($arg:tt)*) => {
        $crate::console::err_line(format_args!($($arg)*))
    };
}

/// Writes one line to stderr, ignoring a failure.
pub fn err_line(args: std::fmt::Arguments) {
    let mut err = std::io::stderr().lock();
    let _ = err.write_fmt(args).and_then(|()| err.write_all(b"\n"));
}

static CLOSED: AtomicBool = AtomicBool::new(false);

/// Why stdout failed, when it was not the reader going away (a full disk): the command's
/// output is then incomplete, and it must not exit 0.
static FAILED: std::sync::Mutex<Option<String>> = std::sync::Mutex::new(None);

/// Forgets an earlier command's closed or failed stdout (commands run in one process from
/// Python).
pub fn reset() {
    CLOSED.store(false, Ordering::Relaxed);
    *FAILED
        .lock()
        .unwrap_or_else(std::sync::PoisonError::into_inner) = None;
}

/// Why stdout failed, other than a closed pipe, if it did.
pub fn failure() -> Option<String> {
    FAILED
        .lock()
        .unwrap_or_else(std::sync::PoisonError::into_inner)
        .clone()
}

fn fail(e: &std::io::Error) {
    let mut f = FAILED
        .lock()
        .unwrap_or_else(std::sync::PoisonError::into_inner);
    if f.is_none() {
        *f = Some(e.to_string());
    }
}

/// Writes one line to stdout, unless the reader has gone.
pub fn line(args: std::fmt::Arguments) {
    if CLOSED.load(Ordering::Relaxed) {
        return;
    }
    let mut out = std::io::stdout().lock();
    let written = out
        .write_fmt(args)
        .and_then(|()| out.write_all(b"\n"))
        .and_then(|()| out.flush());
    if let Err(e) = written {
        if e.kind() != std::io::ErrorKind::BrokenPipe {
            errln!("warning: writing to stdout: {e}; further output dropped");
            fail(&e);
        }
        CLOSED.store(true, Ordering::Relaxed);
    }
}

/// Stdout as a writer for bulk output (`export --csv -`): once the reader has gone, what is
/// written is dropped, as [`line`] drops lines, instead of failing with a broken pipe. Other
/// write errors are returned.
pub struct Stdout;

impl Stdout {
    /// `r`, or `ok` once the pipe is found closed (now or before).
    fn unless_closed<T>(r: impl FnOnce() -> std::io::Result<T>, ok: T) -> std::io::Result<T> {
        if CLOSED.load(Ordering::Relaxed) {
            return Ok(ok);
        }
        match r() {
            Err(e) if e.kind() == std::io::ErrorKind::BrokenPipe => {
                CLOSED.store(true, Ordering::Relaxed);
                Ok(ok)
            }
            Err(e) => {
                fail(&e);
                Err(e)
            }
            r => r,
        }
    }
}

impl Write for Stdout {
    fn write(&mut self, buf: &[u8]) -> std::io::Result<usize> {
        Self::unless_closed(|| std::io::stdout().lock().write(buf), buf.len())
    }

    fn flush(&mut self) -> std::io::Result<()> {
        Self::unless_closed(|| std::io::stdout().lock().flush(), ())
    }
}
