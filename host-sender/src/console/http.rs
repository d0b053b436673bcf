//! A minimal HTTP/1.1 server on std's `TcpListener` for the console: one thread per connection,
//! `GET` for the embedded page and its assets, `GET /events` for Server-Sent Events, `POST` with a
//! JSON body (`Content-Length`) for commands. Nothing is fetched from elsewhere: the page, its
//! script and its style are compiled into the binary.
//!
//! Every read is bounded before anything is allocated for it: a header line at most
//! [`LINE_MAX`] bytes, at most [`HEADERS_MAX`] header lines (431 beyond either), a body at most
//! [`BODY_MAX`] bytes (413), so a client that sends an endless header or claims a huge body costs
//! serve a few kilobytes, never its memory.

use std::io::{BufRead, BufReader, Read, Write};
use std::net::TcpStream;

/// The longest request or header line read, bytes (with its CRLF).
pub(crate) const LINE_MAX: usize = 8 << 10;
/// The most header lines a request may have.
pub(crate) const HEADERS_MAX: usize = 100;
/// The largest request body accepted from a client that has not shown the token, and for every
/// command but a program upload.
pub(crate) const BODY_MAX: usize = 1 << 20;
/// The largest program upload (`POST /api/program` with the token): CAM programs of tens of
/// megabytes are common.
pub(crate) const UPLOAD_MAX: usize = 32 << 20;

/// Why a request could not be read.
#[derive(Debug, PartialEq, Eq)]
pub(crate) enum ReadError {
    /// The client closed (or the connection failed) between requests.
    Closed,
    /// Not an HTTP request (400).
    Malformed,
    /// A header line or the header count beyond the bounds (431).
    HeaderTooLarge,
}

/// The head of one request; its body, `content_length` bytes, is read by [`read_body`].
pub(crate) struct Head {
    pub(crate) method: String,
    /// The path without the query.
    pub(crate) path: String,
    /// The query (after `?`), empty when none.
    pub(crate) query: String,
    /// The `Host` header.
    pub(crate) host: String,
    /// The body is `application/json`.
    pub(crate) json: bool,
    /// The `Cookie` header(s), joined with `; `.
    pub(crate) cookie: String,
    /// The `Authorization` header.
    pub(crate) authorization: String,
    pub(crate) content_length: usize,
}

impl Head {
    /// The request names this server in its `Host` header: its own address, or `localhost` with
    /// its port (a name another site resolves to this address, DNS rebinding, is refused).
    pub(crate) fn host_ok(&self, addr: std::net::SocketAddr) -> bool {
        let port = addr.port();
        let h = self.host.to_ascii_lowercase();
        h == addr.to_string()
            || h == format!("localhost:{port}")
            || h == format!("127.0.0.1:{port}")
            || h == format!("[::1]:{port}")
            || (!addr.ip().is_loopback()
                && h.parse::<std::net::SocketAddr>()
                    .is_ok_and(|a| a.port() == port))
    }

    /// The value of cookie `name`, if sent.
    pub(crate) fn cookie(&self, name: &str) -> Option<&str> {
        self.cookie
            .split(';')
            .filter_map(|c| c.trim().split_once('='))
            .find(|(k, _)| *k == name)
            .map(|(_, v)| v)
    }

    /// The value of query parameter `name`, if given.
    pub(crate) fn query_param(&self, name: &str) -> Option<&str> {
        self.query
            .split('&')
            .filter_map(|p| p.split_once('='))
            .find(|(k, _)| *k == name)
            .map(|(_, v)| v)
    }

    /// The token of an `Authorization: Bearer TOKEN` header.
    pub(crate) fn bearer(&self) -> Option<&str> {
        let (scheme, token) = self.authorization.trim().split_once(' ')?;
        scheme.eq_ignore_ascii_case("bearer").then(|| token.trim())
    }
}

/// One line of at most `max` bytes (its CRLF or LF removed); reads no further than its end.
fn read_line(stream: &mut BufReader<TcpStream>, max: usize) -> Result<String, ReadError> {
    let mut line = Vec::new();
    loop {
        let buf = match stream.fill_buf() {
            Ok(b) => b,
            Err(e) if e.kind() == std::io::ErrorKind::Interrupted => continue,
            Err(_) => return Err(ReadError::Closed),
        };
        if buf.is_empty() {
            return Err(if line.is_empty() {
                ReadError::Closed
            } else {
                ReadError::Malformed
            });
        }
        let (take, done) = match buf.iter().position(|&b| b == b'\n') {
            Some(i) => (i + 1, true),
            None => (buf.len(), false),
        };
        if line.len() + take > max {
            return Err(ReadError::HeaderTooLarge);
        }
        line.extend_from_slice(&buf[..take]);
        stream.consume(take);
        if done {
            break;
        }
    }
    while matches!(line.last(), Some(b'\n' | b'\r')) {
        line.pop();
    }
    String::from_utf8(line).map_err(|_| ReadError::Malformed)
}

/// Reads the head of one request from `stream`.
pub(crate) fn read_head(stream: &mut BufReader<TcpStream>) -> Result<Head, ReadError> {
    let first = read_line(stream, LINE_MAX)?;
    let mut parts = first.split_whitespace();
    let method = parts.next().ok_or(ReadError::Malformed)?.to_owned();
    let target = parts.next().ok_or(ReadError::Malformed)?;
    let (path, query) = target.split_once('?').unwrap_or((target, ""));
    let mut head = Head {
        method,
        path: path.to_owned(),
        query: query.to_owned(),
        host: String::new(),
        json: false,
        cookie: String::new(),
        authorization: String::new(),
        content_length: 0,
    };
    let mut count = 0;
    loop {
        let h = read_line(stream, LINE_MAX).map_err(|e| match e {
            ReadError::Closed => ReadError::Malformed,
            e => e,
        })?;
        if h.is_empty() {
            break;
        }
        count += 1;
        if count > HEADERS_MAX {
            return Err(ReadError::HeaderTooLarge);
        }
        let Some((k, v)) = h.split_once(':') else {
            return Err(ReadError::Malformed);
        };
        let (k, v) = (k.trim(), v.trim());
        if k.eq_ignore_ascii_case("content-length") {
            head.content_length = v.parse().map_err(|_| ReadError::Malformed)?;
        } else if k.eq_ignore_ascii_case("transfer-encoding") {
            // Chunked bodies are not taken: a command is small and has a length.
            return Err(ReadError::Malformed);
        } else if k.eq_ignore_ascii_case("host") {
            head.host = v.to_owned();
        } else if k.eq_ignore_ascii_case("content-type") {
            head.json = v.to_ascii_lowercase().starts_with("application/json");
        } else if k.eq_ignore_ascii_case("cookie") {
            if !head.cookie.is_empty() {
                head.cookie.push_str("; ");
            }
            head.cookie.push_str(v);
        } else if k.eq_ignore_ascii_case("authorization") {
            head.authorization = v.to_owned();
        }
    }
    Ok(head)
}

/// Reads a body of `len` bytes (the caller has bounded `len`).
pub(crate) fn read_body(stream: &mut BufReader<TcpStream>, len: usize) -> Option<Vec<u8>> {
    let mut body = vec![0u8; len];
    stream.read_exact(&mut body).ok()?;
    Some(body)
}

/// Writes a whole response, with `extra` header lines (each ending in CRLF).
pub(crate) fn respond_with(
    stream: &mut TcpStream,
    status: &str,
    content_type: &str,
    extra: &str,
    body: &[u8],
) -> bool {
    let head = format!(
        "HTTP/1.1 {status}\r\nContent-Type: {content_type}\r\nContent-Length: {}\r\nCache-Control: no-store\r\nX-Content-Type-Options: nosniff\r\n{extra}\r\n",
        body.len()
    );
    stream.write_all(head.as_bytes()).is_ok() && stream.write_all(body).is_ok()
}

/// Writes a whole response.
pub(crate) fn respond(
    stream: &mut TcpStream,
    status: &str,
    content_type: &str,
    body: &[u8],
) -> bool {
    respond_with(stream, status, content_type, "", body)
}

/// Answers a request that is refused before its body was read, then closes: the client's
/// unread bytes are drained for a moment (at most [`BODY_MAX`], 2 s), so that the answer is
/// not lost to a reset, but never stored.
pub(crate) fn refuse_and_close(stream: &mut TcpStream, status: &str, text: &str) {
    let _ = respond_with(
        stream,
        status,
        "text/plain",
        "Connection: close\r\n",
        text.as_bytes(),
    );
    let _ = stream.flush();
    let _ = stream.shutdown(std::net::Shutdown::Write);
    let _ = stream.set_read_timeout(Some(std::time::Duration::from_secs(2)));
    let mut sink = [0u8; 4096];
    let mut drained = 0;
    while drained < BODY_MAX {
        match stream.read(&mut sink) {
            Ok(0) | Err(_) => break,
            Ok(n) => drained += n,
        }
    }
}

/// Starts a Server-Sent Events response.
pub(crate) fn start_events(stream: &mut TcpStream) -> bool {
    stream
        .write_all(
            b"HTTP/1.1 200 OK\r\nContent-Type: text/event-stream\r\nCache-Control: no-store\r\nConnection: keep-alive\r\n\r\n",
        )
        .is_ok()
}

/// One event, `event: KIND` and its JSON data on one line.
pub(crate) fn event_text(kind: &str, data: &str) -> String {
    format!(
        "event: {kind}\ndata: {}\n\n",
        data.replace('\n', "\ndata: ")
    )
}
