//! Just enough HTTP/1.1 for the viewer: one request per connection, bounded sizes, strict
//! parsing. Anything malformed gets a 4xx/5xx status, never a panic.

use std::io::{Read, Write};

/// Largest request head (request line and headers) accepted.
pub const MAX_HEAD: usize = 8 * 1024;
/// Largest request body accepted.
pub const MAX_BODY: usize = 4 * 1024;

/// Request methods the server knows.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Method {
    /// GET.
    Get,
    /// HEAD (as GET, without the body).
    Head,
    /// POST.
    Post,
}

/// A parsed request.
#[derive(Debug, Clone)]
pub struct Request {
    /// Method.
    pub method: Method,
    /// Path, exactly as sent (never percent-decoded, never resolved against a folder).
    pub path: String,
    /// Query parameters, percent-decoded.
    pub query: Vec<(String, String)>,
    /// The `Host` header, if any.
    pub host: Option<String>,
    /// The `Origin` header, if any.
    pub origin: Option<String>,
}

/// A response to write.
#[derive(Debug, Clone)]
pub struct Response {
    /// Status code.
    pub status: u16,
    /// Content type.
    pub content_type: &'static str,
    /// Body.
    pub body: Vec<u8>,
    /// Extra headers.
    pub headers: Vec<(&'static str, String)>,
}

impl Response {
    /// A 200 response.
    pub fn ok(content_type: &'static str, body: impl Into<Vec<u8>>) -> Self {
        Self {
            status: 200,
            content_type,
            body: body.into(),
            headers: Vec::new(),
        }
    }

    /// A JSON error `{"error": message}` with `status`.
    pub fn error(status: u16, message: &str) -> Self {
        let body = serde_json::json!({ "error": message, "status": status }).to_string();
        Self {
            status,
            content_type: "application/json",
            body: body.into_bytes(),
            headers: Vec::new(),
        }
    }

    /// 503 with `Retry-After: 1`: the server cannot take this request now, and the client
    /// should send it again.
    pub fn come_back(message: &str) -> Self {
        Self::error(503, message).with_header("Retry-After", "1")
    }

    /// Adds a header.
    pub fn with_header(mut self, name: &'static str, value: impl Into<String>) -> Self {
        self.headers.push((name, value.into()));
        self
    }
}

/// Why a request could not be read.
#[derive(Debug)]
pub enum ReadError {
    /// The client closed or timed out before sending a whole request head; nothing to answer.
    Gone,
    /// A malformed or unacceptable request: answer with this.
    Bad(Response),
}

fn reason(status: u16) -> &'static str {
    match status {
        200 => "OK",
        204 => "No Content",
        400 => "Bad Request",
        403 => "Forbidden",
        404 => "Not Found",
        405 => "Method Not Allowed",
        408 => "Request Timeout",
        411 => "Length Required",
        413 => "Content Too Large",
        417 => "Expectation Failed",
        421 => "Misdirected Request",
        422 => "Unprocessable Content",
        431 => "Request Header Fields Too Large",
        500 => "Internal Server Error",
        501 => "Not Implemented",
        503 => "Service Unavailable",
        505 => "HTTP Version Not Supported",
        _ => "Unknown",
    }
}

/// Where the head ends and the body starts: at the first empty line, its lines ended by CRLF
/// or, as HTTP lets a server accept, by a bare LF.
fn find_head_end(buf: &[u8]) -> Option<(usize, usize)> {
    (0..buf.len()).find_map(|i| {
        if buf[i] != b'\n' {
            return None;
        }
        let head = if i > 0 && buf[i - 1] == b'\r' {
            i - 1
        } else {
            i
        };
        match buf.get(i + 1..) {
            Some([b'\n', ..]) => Some((head, i + 2)),
            Some([b'\r', b'\n', ..]) => Some((head, i + 3)),
            _ => None,
        }
    })
}

fn hex(b: u8) -> Option<u8> {
    match b {
        b'0'..=b'9' => Some(b - b'0'),
        b'a'..=b'f' => Some(b - b'a' + 10),
        b'A'..=b'F' => Some(b - b'A' + 10),
        _ => None,
    }
}

/// Percent-decodes a query component (`+` is a space); `None` if malformed or not UTF-8.
pub fn percent_decode(s: &str) -> Option<String> {
    let b = s.as_bytes();
    let mut out = Vec::with_capacity(b.len());
    let mut i = 0;
    while i < b.len() {
        match b[i] {
            b'%' => {
                let hi = hex(*b.get(i + 1)?)?;
                let lo = hex(*b.get(i + 2)?)?;
                out.push(hi * 16 + lo);
                i += 3;
            }
            b'+' => {
                out.push(b' ');
                i += 1;
            }
            c => {
                out.push(c);
                i += 1;
            }
        }
    }
    String::from_utf8(out).ok()
}

fn bad(status: u16, msg: &str) -> ReadError {
    ReadError::Bad(Response::error(status, msg))
}

/// Reads and parses one request from `stream` (whose read timeout bounds the wait); writes
/// only the interim `100 Continue` that a client sending `Expect: 100-continue` waits for.
pub fn read_request(stream: &mut (impl Read + Write)) -> Result<Request, ReadError> {
    let mut buf: Vec<u8> = Vec::with_capacity(1024);
    let mut chunk = [0u8; 2048];
    let (head_end, body_start) = loop {
        if let Some(p) = find_head_end(&buf) {
            break p;
        }
        if buf.len() > MAX_HEAD {
            return Err(bad(431, "request head too large"));
        }
        match stream.read(&mut chunk) {
            Ok(0) => {
                return if buf.is_empty() {
                    Err(ReadError::Gone)
                } else {
                    Err(bad(400, "incomplete request"))
                };
            }
            Ok(n) => buf.extend_from_slice(&chunk[..n]),
            Err(e) if e.kind() == std::io::ErrorKind::Interrupted => {}
            Err(e)
                if matches!(
                    e.kind(),
                    std::io::ErrorKind::WouldBlock | std::io::ErrorKind::TimedOut
                ) =>
            {
                return if buf.is_empty() {
                    Err(ReadError::Gone)
                } else {
                    Err(bad(408, "request timed out"))
                };
            }
            Err(_) => return Err(ReadError::Gone),
        }
    };
    if head_end > MAX_HEAD {
        return Err(bad(431, "request head too large"));
    }
    let head =
        std::str::from_utf8(&buf[..head_end]).map_err(|_| bad(400, "request head is not UTF-8"))?;
    let mut lines = head.split('\n').map(|l| l.strip_suffix('\r').unwrap_or(l));
    let line = lines.next().unwrap_or_default();
    let mut parts = line.split(' ');
    let (Some(method), Some(target), Some(version), None) =
        (parts.next(), parts.next(), parts.next(), parts.next())
    else {
        return Err(bad(400, "malformed request line"));
    };
    if !(version == "HTTP/1.1" || version == "HTTP/1.0") {
        return Err(bad(505, "only HTTP/1.0 and HTTP/1.1 are spoken here"));
    }
    let method = match method {
        "GET" => Method::Get,
        "HEAD" => Method::Head,
        "POST" => Method::Post,
        m if !m.is_empty() && m.bytes().all(|b| b.is_ascii_uppercase()) => {
            return Err(ReadError::Bad(
                Response::error(501, "method not implemented")
                    .with_header("Allow", "GET, HEAD, POST"),
            ));
        }
        _ => return Err(bad(400, "malformed method")),
    };
    if !target.starts_with('/') || !target.bytes().all(|b| (0x21..=0x7e).contains(&b)) {
        return Err(bad(
            400,
            "the target must be an absolute path of visible ASCII",
        ));
    }
    let mut host = None;
    let mut origin = None;
    let mut content_length: Option<usize> = None;
    let mut expect_continue = false;
    for h in lines {
        let Some((name, value)) = h.split_once(':') else {
            return Err(bad(400, "malformed header line"));
        };
        if name.is_empty() || name.bytes().any(|b| b.is_ascii_whitespace()) {
            return Err(bad(400, "malformed header name"));
        }
        let value = value.trim();
        if name.eq_ignore_ascii_case("host") {
            if host.is_some() {
                return Err(bad(400, "more than one Host header"));
            }
            host = Some(value.to_string());
        } else if name.eq_ignore_ascii_case("origin") {
            if origin.is_some() {
                return Err(bad(400, "more than one Origin header"));
            }
            origin = Some(value.to_string());
        } else if name.eq_ignore_ascii_case("content-length") {
            let n: usize = crate::digits(value)
                .and_then(|n| usize::try_from(n).ok())
                .ok_or_else(|| bad(400, "malformed Content-Length"))?;
            if content_length.is_some_and(|m| m != n) {
                return Err(bad(400, "conflicting Content-Length headers"));
            }
            content_length = Some(n);
        } else if name.eq_ignore_ascii_case("expect") {
            if !value.eq_ignore_ascii_case("100-continue") {
                return Err(bad(417, "only Expect: 100-continue is understood"));
            }
            expect_continue = version == "HTTP/1.1";
        } else if name.eq_ignore_ascii_case("transfer-encoding") {
            return Err(bad(501, "Transfer-Encoding is not supported"));
        }
    }
    // Read (and discard) a small body so the client sees the answer, not a reset.
    let body_len = content_length.unwrap_or(0);
    if body_len > MAX_BODY {
        return Err(bad(413, "request body too large"));
    }
    // RFC 9112, 3.2: an HTTP/1.1 request without Host is answered 400.
    if version == "HTTP/1.1" && host.is_none() {
        return Err(bad(400, "an HTTP/1.1 request needs a Host header"));
    }
    let mut have = buf.len() - body_start;
    if expect_continue && have < body_len {
        // The client waits for this (curl: 1 s) before it sends the body.
        stream
            .write_all(b"HTTP/1.1 100 Continue\r\n\r\n")
            .map_err(|_| ReadError::Gone)?;
    }
    while have < body_len {
        match stream.read(&mut chunk) {
            Ok(0) => return Err(bad(400, "incomplete request body")),
            Ok(n) => have += n,
            Err(e) if e.kind() == std::io::ErrorKind::Interrupted => {}
            Err(_) => return Err(bad(408, "request body timed out")),
        }
    }
    let (path, q) = target.split_once('?').unwrap_or((target, ""));
    let mut query = Vec::new();
    for pair in q.split('&').filter(|p| !p.is_empty()) {
        let (k, v) = pair.split_once('=').unwrap_or((pair, ""));
        let (Some(k), Some(v)) = (percent_decode(k), percent_decode(v)) else {
            return Err(bad(400, "malformed query string"));
        };
        if query.len() >= 16 {
            return Err(bad(400, "too many query parameters"));
        }
        query.push((k, v));
    }
    Ok(Request {
        method,
        path: path.to_string(),
        query,
        host,
        origin,
    })
}

/// Writes `resp` (without the body for HEAD) and asks the client to close.
pub fn write_response(
    stream: &mut impl Write,
    resp: &Response,
    head_only: bool,
) -> std::io::Result<()> {
    let mut out = format!(
        "HTTP/1.1 {} {}\r\nContent-Type: {}\r\nContent-Length: {}\r\nConnection: close\r\nCache-Control: no-store\r\nX-Content-Type-Options: nosniff\r\nReferrer-Policy: no-referrer\r\nContent-Security-Policy: default-src 'self'; img-src 'self' data:; style-src 'self'; script-src 'self'; connect-src 'self'; frame-ancestors 'none'\r\n",
        resp.status,
        reason(resp.status),
        resp.content_type,
        resp.body.len()
    );
    for (k, v) in &resp.headers {
        out.push_str(k);
        out.push_str(": ");
        out.push_str(v);
        out.push_str("\r\n");
    }
    out.push_str("\r\n");
    let mut bytes = out.into_bytes();
    if !head_only {
        bytes.extend_from_slice(&resp.body);
    }
    stream.write_all(&bytes)?;
    stream.flush()
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A client that has sent `input` and reads what the server writes before it answers.
    struct Client<'a> {
        input: &'a [u8],
        output: Vec<u8>,
    }

    impl Read for Client<'_> {
        fn read(&mut self, buf: &mut [u8]) -> std::io::Result<usize> {
            self.input.read(buf)
        }
    }

    impl Write for Client<'_> {
        fn write(&mut self, buf: &[u8]) -> std::io::Result<usize> {
            self.output.write(buf)
        }

        fn flush(&mut self) -> std::io::Result<()> {
            Ok(())
        }
    }

    /// The request parsed and what was written back before the answer.
    fn exchange(s: &str) -> (Result<Request, ReadError>, String) {
        let mut c = Client {
            input: s.as_bytes(),
            output: Vec::new(),
        };
        let r = read_request(&mut c);
        (r, String::from_utf8(c.output).expect("ASCII"))
    }

    fn parse(s: &str) -> Result<Request, ReadError> {
        exchange(s).0
    }

    fn status(s: &str) -> u16 {
        match parse(s) {
            Ok(_) => 200,
            Err(ReadError::Gone) => 0,
            Err(ReadError::Bad(r)) => r.status,
        }
    }

    #[test]
    fn parses_a_plain_get() {
        let r = parse("GET /api/state?rays=1&x=a%20b HTTP/1.1\r\nHost: 127.0.0.1:8\r\n\r\n")
            .expect("parses");
        assert_eq!(r.method, Method::Get);
        assert_eq!(r.path, "/api/state");
        assert_eq!(
            r.query,
            vec![("rays".into(), "1".into()), ("x".into(), "a b".into())]
        );
        assert_eq!(r.host.as_deref(), Some("127.0.0.1:8"));
    }

    #[test]
    fn rejects_malformed_requests() {
        assert_eq!(status(""), 0);
        assert_eq!(status("GET /"), 400);
        assert_eq!(status("GET / HTTP/1.1 extra\r\n\r\n"), 400);
        assert_eq!(status("GET / HTTP/2\r\n\r\n"), 505);
        assert_eq!(status("BREW / HTTP/1.1\r\n\r\n"), 501);
        assert_eq!(status("get / HTTP/1.1\r\n\r\n"), 400);
        assert_eq!(status("GET http://x/ HTTP/1.1\r\n\r\n"), 400);
        assert_eq!(status("GET /a\u{e9} HTTP/1.1\r\n\r\n"), 400);
        assert_eq!(status("GET / HTTP/1.1\r\nNoColon\r\n\r\n"), 400);
        assert_eq!(status("GET /?a=%zz HTTP/1.1\r\nHost: h\r\n\r\n"), 400);
        assert_eq!(status("POST / HTTP/1.1\r\nContent-Length: x\r\n\r\n"), 400);
        assert_eq!(
            status("POST / HTTP/1.1\r\nContent-Length: 99999\r\n\r\n"),
            413
        );
        assert_eq!(
            status("POST / HTTP/1.1\r\nTransfer-Encoding: chunked\r\n\r\n"),
            501
        );
        assert_eq!(
            status("POST / HTTP/1.1\r\nHost: h\r\nContent-Length: 10\r\n\r\nabc"),
            400
        );
        let big = format!("GET / HTTP/1.1\r\nX: {}\r\n\r\n", "a".repeat(MAX_HEAD));
        assert_eq!(status(&big), 431);
        // Digits only; one Origin.
        assert_eq!(status("POST / HTTP/1.1\r\nContent-Length: +0\r\n\r\n"), 400);
        assert_eq!(
            status("POST / HTTP/1.1\r\nOrigin: http://a\r\nOrigin: http://b\r\n\r\n"),
            400
        );
    }

    #[test]
    fn http_1_1_needs_a_host_and_1_0_does_not() {
        match parse("GET / HTTP/1.1\r\n\r\n") {
            Err(ReadError::Bad(r)) => {
                assert_eq!(r.status, 400);
                let body = String::from_utf8_lossy(&r.body);
                assert!(body.contains("needs a Host header"), "{body}");
            }
            _ => panic!("an HTTP/1.1 request without Host was taken"),
        }
        assert_eq!(status("GET / HTTP/1.0\r\n\r\n"), 200);
        assert_eq!(status("GET / HTTP/1.1\r\nHost: h\r\n\r\n"), 200);
    }

    #[test]
    fn expect_100_continue_is_answered_before_the_body_is_read() {
        let post = "POST /api/step HTTP/1.1\r\nHost: h\r\nExpect: 100-continue\r\nContent-Length: 3\r\n\r\n";
        // The body came with the head (or there is none): nothing needs saying.
        let (r, written) = exchange(&format!("{post}abc"));
        assert!(r.is_ok());
        assert_eq!(written, "");
        let (r, written) = exchange(&post.replace("Content-Length: 3", "Content-Length: 0"));
        assert!(r.is_ok());
        assert_eq!(written, "");
        // The client waits with its body: it is told to go on before the body is read.
        let mut c = Client {
            input: post.as_bytes(),
            output: Vec::new(),
        };
        assert!(read_request(&mut c).is_err(), "the body never came");
        assert_eq!(
            String::from_utf8(c.output).unwrap(),
            "HTTP/1.1 100 Continue\r\n\r\n"
        );
        assert_eq!(
            status("POST / HTTP/1.1\r\nHost: h\r\nExpect: 200-ok\r\n\r\n"),
            417
        );
    }

    #[test]
    fn lines_may_end_in_a_bare_line_feed() {
        // Answered at once, where it used to wait for a CRLF pair until it timed out.
        let r = parse("POST /api/step?n=2 HTTP/1.1\nHost: 127.0.0.1\nContent-Length: 3\n\nabc")
            .expect("parses");
        assert_eq!(r.path, "/api/step");
        assert_eq!(r.host.as_deref(), Some("127.0.0.1"));
        let mixed = parse("GET / HTTP/1.1\r\nHost: h\n\r\n").expect("parses");
        assert_eq!(mixed.host.as_deref(), Some("h"));
    }
}
