//! The viewer's HTTP server (hyper's HTTP/1 server on a single-threaded tokio runtime): listens
//! on 127.0.0.1 only, answers local peers only, and only with the files of its [`Site`] table,
//! by exact path.
//!
//! The rules, each checked by [`respond`] before a file is looked up:
//! - the peer must be a loopback address (the socket is bound to 127.0.0.1, so no other peer
//!   should ever connect; the check holds even if that changed);
//! - the `Host` header must name this server (`127.0.0.1:PORT` or `localhost:PORT`), so a page
//!   of another site cannot reach it through DNS rebinding;
//! - the method must be `GET` or `HEAD`;
//! - the path (before any `?`) must be exactly one of the table's; nothing is decoded and nothing
//!   is read from disk, so `/../Cargo.toml` or `/%2e%2e/` are simply not in the table (404).
//!
//! Before them, a request that declares a body is refused (413) without reading it. What a
//! client may cost the server (connections at once, time to send a request, time to take an
//! answer, size and count of headers) is bounded by [`Limits`]; hyper refuses a head too large
//! (431), a malformed one or another protocol version (400), and closes the connection.

use std::convert::Infallible;
use std::future::ready;
use std::io::Write as _;
use std::net::{Ipv4Addr, SocketAddr, TcpListener};
use std::pin::Pin;
use std::sync::Arc;
use std::task::{Context, Poll};
use std::time::{Duration, Instant};

use bytes::Bytes;
use http_body_util::Full;
use hyper::body::{Body as _, Incoming};
use hyper::header::{CONNECTION, HOST, HeaderName, HeaderValue};
use hyper::server::conn::http1;
use hyper::service::service_fn;
use hyper::{Method, Request, Response, StatusCode};
use hyper_util::rt::{TokioIo, TokioTimer};
use tokio::io::{AsyncRead, AsyncWrite, ReadBuf};
use tokio::net::TcpStream;
use tokio::sync::Semaphore;
use tokio::time::Sleep;

use super::error::ViewError;
use super::files::Site;

/// How often the serving loop looks at its stop conditions.
const POLL: Duration = Duration::from_millis(100);

/// Headers on every answer: no caching (the files change with the command line), no type
/// sniffing, no referrer, cross-origin isolation, which gives the page's `performance.now()` its
/// fine resolution for the per-frame times, and a content security policy ([`Site::policy`]).
const HEADERS: &[(&str, &str)] = &[
    ("Cache-Control", "no-store"),
    ("X-Content-Type-Options", "nosniff"),
    ("Referrer-Policy", "no-referrer"),
    ("Cross-Origin-Opener-Policy", "same-origin"),
    ("Cross-Origin-Embedder-Policy", "require-corp"),
    ("Cross-Origin-Resource-Policy", "same-origin"),
];

/// An answer: the status, and a file of the table or a one-line text.
#[derive(Debug, PartialEq, Eq)]
pub struct Reply {
    /// HTTP status code.
    pub status: u16,
    /// `Content-Type`.
    pub content_type: &'static str,
    /// The body, shared with the table rather than copied (for `HEAD`, only its length is sent).
    pub body: Bytes,
}

impl Reply {
    fn text(status: u16, body: &'static str) -> Self {
        Self {
            status,
            content_type: "text/plain; charset=utf-8",
            body: Bytes::from_static(body.as_bytes()),
        }
    }
}

/// The answer to one request, from its method, URL (path and query as sent), peer address and
/// `Host` header; `port` is the server's.
pub fn respond(
    site: &Site,
    method: &Method,
    url: &str,
    peer: Option<SocketAddr>,
    host: Option<&str>,
    port: u16,
) -> Reply {
    if !peer.is_some_and(|p| p.ip().is_loopback()) {
        return Reply::text(403, "sinew view answers this computer only\n");
    }
    let ours = [format!("127.0.0.1:{port}"), format!("localhost:{port}")];
    if !host.is_some_and(|h| ours.iter().any(|o| o.eq_ignore_ascii_case(h))) {
        return Reply::text(421, "this server is 127.0.0.1 (Host header)\n");
    }
    if !matches!(*method, Method::GET | Method::HEAD) {
        return Reply::text(405, "GET or HEAD only\n");
    }
    let path = url.split(['?', '#']).next().unwrap_or(url);
    match site.get(path) {
        Some(entry) => Reply {
            status: 200,
            content_type: entry.content_type,
            body: entry.body.clone(),
        },
        None => Reply::text(404, "not found\n"),
    }
}

/// What one client may cost the server. Whatever a client does, it holds at most one of
/// `connections` and, for at most these times, a connection's buffers; the others are served
/// meanwhile.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Limits {
    /// Connections served at once; one more is closed as soon as it is accepted.
    pub connections: usize,
    /// Time to send a request's head (request line and headers), counted from the connection's
    /// start or the previous answer: a connection that sends no request for this long, idle
    /// between requests or sending slowly, is closed.
    pub request_head: Duration,
    /// How long an answer waits for a client that takes none of it; then the connection is
    /// closed.
    pub stalled_write: Duration,
    /// Largest request head (request line and headers) in bytes; larger is refused with 431.
    pub head_bytes: usize,
    /// Most header lines in a request; more are refused with 431.
    pub headers: usize,
}

impl Default for Limits {
    /// A page loads with a few connections, a browser's request head takes a kilobyte or two
    /// (more with cookies of other local servers, which browsers send to every port), and
    /// everything is in memory, so an answer on loopback takes milliseconds.
    fn default() -> Self {
        Self {
            connections: 64,
            request_head: Duration::from_secs(10),
            stalled_write: Duration::from_secs(10),
            head_bytes: 16 * 1024,
            headers: 64,
        }
    }
}

/// The line logged for a refused request. Everything the client sent is escaped to printable
/// ASCII (`\u{1b}`, `\r`, `\\`), so a request cannot write terminal escapes or forged lines
/// into the log.
pub fn refusal_line(method: &str, target: &str, peer: Option<SocketAddr>, status: u16) -> String {
    let peer = peer.map_or_else(|| "an unknown peer".to_owned(), |p| p.to_string());
    format!(
        "sinew view: {} {} from {peer}: {status}",
        printable(method),
        printable(target)
    )
}

/// `text` with every character but printable ASCII and the space escaped, and `\` doubled.
fn printable(text: &str) -> String {
    let mut out = String::with_capacity(text.len());
    for c in text.chars() {
        if (c.is_ascii_graphic() && c != '\\') || c == ' ' {
            out.push(c);
        } else {
            out.extend(c.escape_default());
        }
    }
    out
}

/// A line on standard error; a closed or full standard error is no reason to stop serving.
fn log(line: &str) {
    let _ = writeln!(std::io::stderr().lock(), "{line}");
}

/// A viewer server bound to a port of 127.0.0.1.
pub struct Viewer {
    listener: TcpListener,
    site: Arc<Site>,
    port: u16,
    limits: Limits,
}

impl std::fmt::Debug for Viewer {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Viewer")
            .field("port", &self.port)
            .field("site", &self.site)
            .field("limits", &self.limits)
            .finish_non_exhaustive()
    }
}

impl Viewer {
    /// Binds 127.0.0.1:`port` (0: any free port), with the default [`Limits`].
    pub fn bind(site: Site, port: u16) -> Result<Self, ViewError> {
        let listen = |source| ViewError::Listen { port, source };
        let listener = TcpListener::bind((Ipv4Addr::LOCALHOST, port)).map_err(listen)?;
        // The runtime polls it; a blocking accept would hold the serving thread.
        listener.set_nonblocking(true).map_err(listen)?;
        let port = listener.local_addr().map_err(listen)?.port();
        Ok(Self {
            listener,
            site: Arc::new(site),
            port,
            limits: Limits::default(),
        })
    }

    /// The same server with other limits.
    pub fn with_limits(self, limits: Limits) -> Self {
        Self { limits, ..self }
    }

    /// The page's address, `http://127.0.0.1:PORT/`.
    pub fn url(&self) -> String {
        format!("http://127.0.0.1:{}/", self.port)
    }

    /// The port it listens on.
    pub fn port(&self) -> u16 {
        self.port
    }

    /// Answers requests until `stop()` says so or `deadline` has passed (checked every 100 ms),
    /// then closes every connection still open.
    ///
    /// All connections are served concurrently by one thread: every answer is in memory, so a
    /// connection only ever waits for its client, and a client that stalls holds its own
    /// connection and nothing else.
    pub fn serve(
        &self,
        deadline: Option<Instant>,
        stop: impl Fn() -> bool,
    ) -> Result<(), ViewError> {
        let runtime = tokio::runtime::Builder::new_current_thread()
            .enable_io()
            .enable_time()
            .build()
            .map_err(ViewError::Runtime)?;
        let listener = self.listener.try_clone().map_err(ViewError::Runtime)?;
        // Dropping the runtime on return drops every connection's task, and so its socket.
        runtime.block_on(self.accept(listener, deadline, stop))
    }

    async fn accept(
        &self,
        listener: TcpListener,
        deadline: Option<Instant>,
        stop: impl Fn() -> bool,
    ) -> Result<(), ViewError> {
        let listener = tokio::net::TcpListener::from_std(listener).map_err(ViewError::Runtime)?;
        let limits = self.limits;
        let slots = Arc::new(Semaphore::new(limits.connections));
        let mut http = http1::Builder::new();
        http.timer(TokioTimer::new())
            .header_read_timeout(limits.request_head)
            .max_header_size(limits.head_bytes)
            .max_headers(limits.headers);
        let mut accept_failed = false;
        loop {
            if stop() || deadline.is_some_and(|d| Instant::now() >= d) {
                return Ok(());
            }
            let (stream, peer) = match tokio::time::timeout(POLL, listener.accept()).await {
                Err(_) => continue,
                Ok(Ok(accepted)) => accepted,
                Ok(Err(e)) => {
                    // Out of descriptors, say: the listener stays, and the loop waits a little
                    // rather than spin. Said once, until a connection is accepted again.
                    if !std::mem::replace(&mut accept_failed, true) {
                        log(&format!("sinew view: cannot accept a connection: {e}"));
                    }
                    tokio::time::sleep(POLL).await;
                    continue;
                }
            };
            accept_failed = false;
            let Ok(slot) = slots.clone().try_acquire_owned() else {
                // Over the limit: closed at once, so idle connections cannot pile up.
                drop(stream);
                continue;
            };
            // Each answer is written whole at once; Nagle's delay would only slow the last
            // packet of one.
            let _ = stream.set_nodelay(true);
            let io = TokioIo::new(Patient::new(stream, limits.stalled_write));
            let (site, port) = (self.site.clone(), self.port);
            let service = service_fn(move |request: Request<Incoming>| {
                ready(Ok::<_, Infallible>(answer(&site, port, peer, &request)))
            });
            let connection = http.serve_connection(io, service);
            tokio::spawn(async move {
                if let Err(e) = connection.await {
                    // Timeouts and resets are a client's business; a malformed request is
                    // logged as a refused one is.
                    if e.is_parse() || e.is_parse_too_large() {
                        log(&format!(
                            "sinew view: a malformed request from {peer}: {}",
                            printable(&e.to_string())
                        ));
                    }
                }
                drop(slot);
            });
        }
    }
}

/// The answer to `request` from `peer`: [`respond`]'s, or 413 for a request that declares a
/// body (none is ever read: a `GET` or `HEAD` has none, and other methods are refused anyway).
fn answer(
    site: &Site,
    port: u16,
    peer: SocketAddr,
    request: &Request<Incoming>,
) -> Response<Full<Bytes>> {
    let target = request.uri().to_string();
    let has_body = !request.body().is_end_stream();
    let reply = if has_body {
        Reply::text(413, "no request bodies here\n")
    } else {
        let host = request.headers().get(HOST).and_then(|h| h.to_str().ok());
        respond(site, request.method(), &target, Some(peer), host, port)
    };
    if reply.status != 200 {
        log(&refusal_line(
            request.method().as_str(),
            &target,
            Some(peer),
            reply.status,
        ));
    }
    let mut response = Response::new(Full::new(reply.body));
    *response.status_mut() =
        StatusCode::from_u16(reply.status).unwrap_or(StatusCode::INTERNAL_SERVER_ERROR);
    let headers = response.headers_mut();
    for (name, value) in HEADERS.iter().chain(&[
        ("Content-Security-Policy", site.policy()),
        ("Content-Type", reply.content_type),
    ]) {
        if let (Ok(name), Ok(value)) = (
            HeaderName::from_bytes(name.as_bytes()),
            HeaderValue::from_str(value),
        ) {
            headers.insert(name, value);
        }
    }
    if has_body {
        // The unread body ends the connection; say so.
        headers.insert(CONNECTION, HeaderValue::from_static("close"));
    }
    response
}

/// A client's socket whose writes give up once the client has taken nothing for `patience`, so
/// that an answer to a client that does not read ends its connection instead of holding it.
#[derive(Debug)]
struct Patient {
    stream: TcpStream,
    patience: Duration,
    /// Since the first write that could not go on, while none could.
    stalled: Option<Pin<Box<Sleep>>>,
}

impl Patient {
    fn new(stream: TcpStream, patience: Duration) -> Self {
        Self {
            stream,
            patience,
            stalled: None,
        }
    }

    /// `poll` of a write, or a timeout once writes have been pending for `patience`.
    fn watch<T>(
        &mut self,
        cx: &mut Context<'_>,
        poll: Poll<std::io::Result<T>>,
    ) -> Poll<std::io::Result<T>> {
        if poll.is_ready() {
            self.stalled = None;
            return poll;
        }
        let patience = self.patience;
        let stalled = self
            .stalled
            .get_or_insert_with(|| Box::pin(tokio::time::sleep(patience)));
        match stalled.as_mut().poll(cx) {
            Poll::Ready(()) => Poll::Ready(Err(std::io::Error::new(
                std::io::ErrorKind::TimedOut,
                "the client took none of the answer",
            ))),
            Poll::Pending => Poll::Pending,
        }
    }
}

impl AsyncRead for Patient {
    fn poll_read(
        self: Pin<&mut Self>,
        cx: &mut Context<'_>,
        buf: &mut ReadBuf<'_>,
    ) -> Poll<std::io::Result<()>> {
        // Reading is bounded by the request head's timeout.
        Pin::new(&mut self.get_mut().stream).poll_read(cx, buf)
    }
}

impl AsyncWrite for Patient {
    fn poll_write(
        self: Pin<&mut Self>,
        cx: &mut Context<'_>,
        buf: &[u8],
    ) -> Poll<std::io::Result<usize>> {
        let this = self.get_mut();
        let poll = Pin::new(&mut this.stream).poll_write(cx, buf);
        this.watch(cx, poll)
    }

    fn poll_write_vectored(
        self: Pin<&mut Self>,
        cx: &mut Context<'_>,
        bufs: &[std::io::IoSlice<'_>],
    ) -> Poll<std::io::Result<usize>> {
        let this = self.get_mut();
        let poll = Pin::new(&mut this.stream).poll_write_vectored(cx, bufs);
        this.watch(cx, poll)
    }

    fn is_write_vectored(&self) -> bool {
        self.stream.is_write_vectored()
    }

    fn poll_flush(self: Pin<&mut Self>, cx: &mut Context<'_>) -> Poll<std::io::Result<()>> {
        let this = self.get_mut();
        let poll = Pin::new(&mut this.stream).poll_flush(cx);
        this.watch(cx, poll)
    }

    fn poll_shutdown(self: Pin<&mut Self>, cx: &mut Context<'_>) -> Poll<std::io::Result<()>> {
        Pin::new(&mut self.get_mut().stream).poll_shutdown(cx)
    }
}

#[cfg(test)]
mod tests;
