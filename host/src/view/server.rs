//! The viewer's HTTP server (tiny_http): listens on 127.0.0.1 only, answers local peers only,
//! and only with the files of its [`Site`] table, by exact path.
//!
//! The rules, each checked by [`respond`] before a file is looked up:
//! - the peer must be a loopback address (the socket is bound to 127.0.0.1, so no other peer
//!   should ever connect; the check holds even if that changed);
//! - the `Host` header must name this server (`127.0.0.1:PORT` or `localhost:PORT`), so a page
//!   of another site cannot reach it through DNS rebinding;
//! - the method must be `GET` or `HEAD`;
//! - the path (before any `?`) must be exactly one of the table's; nothing is decoded and nothing
//!   is read from disk, so `/../Cargo.toml` or `/%2e%2e/` are simply not in the table (404).

use std::io::Cursor;
use std::net::{Ipv4Addr, SocketAddr};
use std::time::{Duration, Instant};

use tiny_http::{Header, Method, Request, Response, Server};

use super::error::ViewError;
use super::files::Site;

/// How often the serving loop looks at its stop conditions.
const POLL: Duration = Duration::from_millis(100);

/// Headers on every answer: no caching (the files change with the command line), no type
/// sniffing, no referrer, a content security policy that allows the page's own scripts and
/// WebAssembly only, and cross-origin isolation, which gives the page's `performance.now()` its
/// fine resolution for the per-frame times.
const HEADERS: &[(&str, &str)] = &[
    ("Cache-Control", "no-store"),
    ("X-Content-Type-Options", "nosniff"),
    ("Referrer-Policy", "no-referrer"),
    (
        "Content-Security-Policy",
        "default-src 'self'; script-src 'self' 'wasm-unsafe-eval'; style-src 'self'; \
         img-src 'self' data:; connect-src 'self'; frame-ancestors 'none'",
    ),
    ("Cross-Origin-Opener-Policy", "same-origin"),
    ("Cross-Origin-Embedder-Policy", "require-corp"),
    ("Cross-Origin-Resource-Policy", "same-origin"),
];

/// An answer: the status, and a file of the table or a one-line text.
#[derive(Debug, PartialEq, Eq)]
pub struct Reply<'a> {
    /// HTTP status code.
    pub status: u16,
    /// `Content-Type`.
    pub content_type: &'static str,
    /// The body (for `HEAD`, tiny_http sends the headers only).
    pub body: &'a [u8],
}

impl Reply<'_> {
    fn text(status: u16, body: &'static str) -> Reply<'static> {
        Reply {
            status,
            content_type: "text/plain; charset=utf-8",
            body: body.as_bytes(),
        }
    }
}

/// The answer to one request, from its method, URL (path and query as sent), peer address and
/// `Host` header; `port` is the server's.
pub fn respond<'a>(
    site: &'a Site,
    method: &Method,
    url: &str,
    peer: Option<SocketAddr>,
    host: Option<&str>,
    port: u16,
) -> Reply<'a> {
    if !peer.is_some_and(|p| p.ip().is_loopback()) {
        return Reply::text(403, "sinew view answers this computer only\n");
    }
    let ours = [format!("127.0.0.1:{port}"), format!("localhost:{port}")];
    if !host.is_some_and(|h| ours.iter().any(|o| o.eq_ignore_ascii_case(h))) {
        return Reply::text(421, "this server is 127.0.0.1 (Host header)\n");
    }
    if !matches!(method, Method::Get | Method::Head) {
        return Reply::text(405, "GET or HEAD only\n");
    }
    let path = url.split(['?', '#']).next().unwrap_or(url);
    match site.get(path) {
        Some(entry) => Reply {
            status: 200,
            content_type: entry.content_type,
            body: &entry.body,
        },
        None => Reply::text(404, "not found\n"),
    }
}

/// A viewer server bound to a port of 127.0.0.1.
pub struct Viewer {
    server: Server,
    site: Site,
    port: u16,
}

impl std::fmt::Debug for Viewer {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Viewer")
            .field("port", &self.port)
            .field("site", &self.site)
            .finish_non_exhaustive()
    }
}

impl Viewer {
    /// Binds 127.0.0.1:`port` (0: any free port).
    pub fn bind(site: Site, port: u16) -> Result<Self, ViewError> {
        let server = Server::http(SocketAddr::from((Ipv4Addr::LOCALHOST, port)))
            .map_err(|source| ViewError::Listen { port, source })?;
        let port = server
            .server_addr()
            .to_ip()
            .map(|a| a.port())
            .ok_or(ViewError::NotIp)?;
        Ok(Self { server, site, port })
    }

    /// The page's address, `http://127.0.0.1:PORT/`.
    pub fn url(&self) -> String {
        format!("http://127.0.0.1:{}/", self.port)
    }

    /// The port it listens on.
    pub fn port(&self) -> u16 {
        self.port
    }

    /// Answers requests until `stop()` says so or `deadline` has passed (checked every 100 ms).
    pub fn serve(
        &self,
        deadline: Option<Instant>,
        stop: impl Fn() -> bool,
    ) -> Result<(), ViewError> {
        loop {
            if stop() || deadline.is_some_and(|d| Instant::now() >= d) {
                return Ok(());
            }
            let Some(request) = self.server.recv_timeout(POLL).map_err(ViewError::Receive)? else {
                continue;
            };
            self.answer(request);
        }
    }

    fn answer(&self, request: Request) {
        let peer = request.remote_addr().copied();
        let host = request
            .headers()
            .iter()
            .find(|h| h.field.equiv("Host"))
            .map(|h| h.value.as_str().to_owned());
        let reply = respond(
            &self.site,
            request.method(),
            request.url(),
            peer,
            host.as_deref(),
            self.port,
        );
        if reply.status != 200 {
            let peer = peer.map_or_else(|| "an unknown peer".to_owned(), |p| p.to_string());
            eprintln!(
                "sinew view: {} {} from {peer}: {}",
                request.method(),
                request.url(),
                reply.status
            );
        }
        let headers: Vec<Header> = HEADERS
            .iter()
            .chain(&[("Content-Type", reply.content_type)])
            .filter_map(|(k, v)| Header::from_bytes(k.as_bytes(), v.as_bytes()).ok())
            .collect();
        let response = Response::new(
            reply.status.into(),
            headers,
            Cursor::new(reply.body),
            Some(reply.body.len()),
            None,
        )
        // Always a Content-Length: every body is in memory, and its size is known.
        .with_chunked_threshold(usize::MAX);
        // A peer that went away mid-answer is no failure of the server.
        let _ = request.respond(response);
    }
}
