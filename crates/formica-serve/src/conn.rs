//! Connections: one thread per connection, at most `max` of them, so that idle clients cannot
//! lock others out.
//!
//! - Every connection has a total deadline for its request (head and body), not a timeout per
//!   read, so a client sending a byte at a time cannot hold its slot longer than that.
//! - When all `max` slots are taken, the accept loop evicts the connection that has waited
//!   longest while still sending its request (an idle or slow client), and serves the new one.
//!   Only when every slot is busy answering a request does a new client get 503.
//!
//! So however many idle connections are held open, a client that sends its request at once is
//! answered: at worst it evicts the oldest idle one.

use std::collections::VecDeque;
use std::io::{Read, Write};
use std::net::{Shutdown, TcpStream};
use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::{Arc, Mutex};
use std::time::Instant;

/// A read side whose reads all end by one deadline.
pub struct Deadline<'a> {
    stream: &'a TcpStream,
    deadline: Instant,
}

impl<'a> Deadline<'a> {
    /// Reads from `stream` until `deadline` at the latest.
    pub fn new(stream: &'a TcpStream, deadline: Instant) -> Self {
        Self { stream, deadline }
    }
}

impl Write for Deadline<'_> {
    fn write(&mut self, buf: &[u8]) -> std::io::Result<usize> {
        let mut s = self.stream;
        s.write(buf)
    }

    fn flush(&mut self) -> std::io::Result<()> {
        let mut s = self.stream;
        s.flush()
    }
}

impl Read for Deadline<'_> {
    fn read(&mut self, buf: &mut [u8]) -> std::io::Result<usize> {
        let left = self.deadline.saturating_duration_since(Instant::now());
        if left.is_zero() {
            return Err(std::io::ErrorKind::TimedOut.into());
        }
        self.stream.set_read_timeout(Some(left))?;
        let mut s = self.stream;
        s.read(buf)
    }
}

/// One open connection, as the accept loop sees it (oldest first).
struct Entry {
    id: u64,
    /// Still sending its request (evictable once [`IDLE_BEFORE_EVICTION`] old).
    reading: bool,
    admitted: Instant,
    stream: TcpStream,
}

/// How long a connection must have been reading before a newcomer may evict it: in a burst of
/// clients, one admitted just now may have sent its whole request and only wait for its thread
/// to read it. Without an idle one that old, the newcomer is told to come back (503).
pub const IDLE_BEFORE_EVICTION: std::time::Duration = std::time::Duration::from_millis(250);

/// The open connections, bounded; shared by the accept loop and the connection threads.
pub struct Slots {
    max: usize,
    next: AtomicU64,
    open: Mutex<VecDeque<Entry>>,
    evicted: AtomicU64,
}

/// A connection's slot: marks it answering, and frees it when dropped.
pub struct Slot {
    slots: Arc<Slots>,
    id: u64,
}

impl Slot {
    /// The request has been read: from now on this connection is not evicted.
    pub fn answering(&self) {
        let mut open = self.slots.lock();
        if let Some(e) = open.iter_mut().find(|e| e.id == self.id) {
            e.reading = false;
        }
    }

    /// Whether the slot was taken away (the connection was evicted).
    pub fn evicted(&self) -> bool {
        !self.slots.lock().iter().any(|e| e.id == self.id)
    }
}

impl Drop for Slot {
    fn drop(&mut self) {
        self.slots.lock().retain(|e| e.id != self.id);
    }
}

/// Why a connection got no slot.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Full {
    /// Every slot is answering a request: the client should come back.
    Busy,
}

impl Slots {
    /// At most `max` open connections (at least 1).
    pub fn new(max: usize) -> Arc<Slots> {
        Arc::new(Slots {
            max: max.max(1),
            next: AtomicU64::new(0),
            open: Mutex::new(VecDeque::new()),
            evicted: AtomicU64::new(0),
        })
    }

    fn lock(&self) -> std::sync::MutexGuard<'_, VecDeque<Entry>> {
        self.open.lock().unwrap_or_else(|e| e.into_inner())
    }

    /// Most open connections.
    pub fn max(&self) -> usize {
        self.max
    }

    /// Open connections now.
    pub fn open(&self) -> usize {
        self.lock().len()
    }

    /// Connections evicted so far.
    pub fn evictions(&self) -> u64 {
        self.evicted.load(Ordering::SeqCst)
    }

    /// A slot for `stream`; if all are taken, evicts the connection that has been sending its
    /// request longest. `Err(Busy)` if every slot is answering.
    pub fn admit(self: &Arc<Self>, stream: &TcpStream) -> Result<Slot, Full> {
        let handle = stream.try_clone().map_err(|_| Full::Busy)?;
        let mut open = self.lock();
        if open.len() >= self.max {
            // Oldest first: entries are kept in the order they were admitted.
            let Some(k) = open
                .iter()
                .position(|e| e.reading && e.admitted.elapsed() >= IDLE_BEFORE_EVICTION)
            else {
                return Err(Full::Busy);
            };
            if let Some(mut old) = open.remove(k) {
                // It is told to come back (should it have sent a request after all), and its
                // thread's next read fails at once.
                let _ = old
                    .stream
                    .set_write_timeout(Some(std::time::Duration::from_millis(20)));
                let _ = crate::http::write_response(
                    &mut old.stream,
                    &crate::http::Response::come_back("server busy, try again"),
                    false,
                );
                let _ = old.stream.shutdown(Shutdown::Both);
                self.evicted.fetch_add(1, Ordering::SeqCst);
            }
        }
        let id = self.next.fetch_add(1, Ordering::SeqCst);
        open.push_back(Entry {
            id,
            reading: true,
            admitted: Instant::now(),
            stream: handle,
        });
        Ok(Slot {
            slots: self.clone(),
            id,
        })
    }

    /// Closes every connection still sending its request (at shutdown).
    pub fn close_reading(&self) {
        for e in self.lock().iter().filter(|e| e.reading) {
            let _ = e.stream.shutdown(Shutdown::Both);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::net::TcpListener;
    use std::time::Duration;

    fn pair(l: &TcpListener) -> (TcpStream, TcpStream) {
        let c = TcpStream::connect(l.local_addr().expect("addr")).expect("connects");
        let (s, _) = l.accept().expect("accepts");
        (c, s)
    }

    #[test]
    fn a_full_set_evicts_the_oldest_reader_and_never_an_answering_one() {
        let l = TcpListener::bind("127.0.0.1:0").expect("binds");
        let slots = Slots::new(2);
        let (_c1, s1) = pair(&l);
        let (_c2, s2) = pair(&l);
        let (_c3, s3) = pair(&l);
        let a = slots.admit(&s1).expect("room");
        a.answering();
        let b = slots.admit(&s2).expect("room");
        assert_eq!(slots.open(), 2);
        // Full, and the reader (b) has just come: it may be about to send its request, so the
        // newcomer is told to come back. Once b has been silent a while, it goes, and the
        // answering one (a) stays.
        assert_eq!(slots.admit(&s3).err(), Some(Full::Busy));
        std::thread::sleep(IDLE_BEFORE_EVICTION);
        let c = slots.admit(&s3).expect("evicts");
        assert!(b.evicted() && !a.evicted() && !c.evicted());
        assert_eq!(slots.evictions(), 1);
        let mut buf = [0u8; 1];
        assert!(matches!((&s2).read(&mut buf), Ok(0) | Err(_)));
        // Both slots answering: a newcomer is turned away.
        c.answering();
        let (_c4, s4) = pair(&l);
        assert_eq!(slots.admit(&s4).err(), Some(Full::Busy));
        drop(a);
        assert_eq!(slots.open(), 1);
        assert!(slots.admit(&s4).is_ok());
    }

    #[test]
    fn a_deadline_bounds_the_whole_request() {
        let l = TcpListener::bind("127.0.0.1:0").expect("binds");
        let (_c, s) = pair(&l);
        let t0 = Instant::now();
        let mut r = Deadline::new(&s, t0 + Duration::from_millis(150));
        let mut buf = [0u8; 8];
        assert!(r.read(&mut buf).is_err());
        assert!(r.read(&mut buf).is_err());
        assert!(t0.elapsed() < Duration::from_millis(1000));
    }
}
