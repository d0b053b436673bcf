//! A minimal HTTP/1.1 server on std's `TcpListener` for the console: one thread per connection,
//! `GET` for the embedded page and its assets, `GET /events` for Server-Sent Events, `POST` with a
//! JSON body (`Content-Length`, at most [`BODY_MAX`] bytes) for commands. Nothing is fetched from
//! elsewhere: the page, its script and its style are compiled into the binary.

use std::io::{BufRead, BufReader, Read, Write};
use std::net::TcpStream;

/// The largest request body accepted (a program upload).
pub const BODY_MAX: usize = 32 << 20;

/// One request.
pub struct Request {
    pub method: String,
    pub path: String,
    pub body: Vec<u8>,
    /// The `Host` header.
    pub host: String,
    /// The body is `application/json`.
    pub json: bool,
}

impl Request {
    /// The request names this server in its `Host` header: its own address, or `localhost` with
    /// its port (a name another site resolves to this address, DNS rebinding, is refused).
    pub fn host_ok(&self, addr: std::net::SocketAddr) -> bool {
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
}

/// Reads one request from `stream`; `None` when the client closed or sent nonsense.
pub fn read_request(stream: &mut BufReader<TcpStream>) -> Option<Request> {
    let mut first = String::new();
    if stream.read_line(&mut first).ok()? == 0 {
        return None;
    }
    let mut parts = first.split_whitespace();
    let method = parts.next()?.to_owned();
    let path = parts.next()?.to_owned();
    let mut len = 0usize;
    let mut host = String::new();
    let mut json = false;
    loop {
        let mut h = String::new();
        if stream.read_line(&mut h).ok()? == 0 {
            return None;
        }
        let h = h.trim_end();
        if h.is_empty() {
            break;
        }
        if let Some((k, v)) = h.split_once(':') {
            if k.trim().eq_ignore_ascii_case("content-length") {
                len = v.trim().parse().ok()?;
            } else if k.trim().eq_ignore_ascii_case("host") {
                host = v.trim().to_owned();
            } else if k.trim().eq_ignore_ascii_case("content-type") {
                json = v
                    .trim()
                    .to_ascii_lowercase()
                    .starts_with("application/json");
            }
        }
    }
    if len > BODY_MAX {
        return None;
    }
    let mut body = vec![0u8; len];
    stream.read_exact(&mut body).ok()?;
    Some(Request {
        method,
        path,
        body,
        host,
        json,
    })
}

/// Writes a whole response.
pub fn respond(stream: &mut TcpStream, status: &str, content_type: &str, body: &[u8]) -> bool {
    let head = format!(
        "HTTP/1.1 {status}\r\nContent-Type: {content_type}\r\nContent-Length: {}\r\nCache-Control: no-store\r\nX-Content-Type-Options: nosniff\r\n\r\n",
        body.len()
    );
    stream.write_all(head.as_bytes()).is_ok() && stream.write_all(body).is_ok()
}

/// Starts a Server-Sent Events response.
pub fn start_events(stream: &mut TcpStream) -> bool {
    stream
        .write_all(
            b"HTTP/1.1 200 OK\r\nContent-Type: text/event-stream\r\nCache-Control: no-store\r\nConnection: keep-alive\r\n\r\n",
        )
        .is_ok()
}

/// One event, `event: KIND` and its JSON data on one line.
pub fn event_text(kind: &str, data: &str) -> String {
    format!(
        "event: {kind}\ndata: {}\n\n",
        data.replace('\n', "\ndata: ")
    )
}
