//! The server against clients that misbehave, on raw sockets: a huge declared body, a body or a
//! request head that never comes, a client that reads nothing, `HTTP/2.0`, hundreds of idle
//! connections, oversized and countless headers. Each must cost that client only: the others are
//! served, the server stops when asked, and no descriptor is left behind.
//!
//! The bounds are generous (seconds where the server needs milliseconds) so that a loaded
//! machine does not fail them; the limits are short so that each test ends by itself.

use std::io::{ErrorKind, Read, Write};
use std::net::{Ipv4Addr, SocketAddr, TcpStream};
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::{Arc, Mutex, MutexGuard, mpsc};
use std::time::{Duration, Instant};

use super::{Limits, Viewer, refusal_line};
use crate::view::ViewError;
use crate::view::tests::{data, site};

/// What "promptly" means here: far more than the server needs, on a loaded two-core machine.
const PROMPTLY: Duration = Duration::from_secs(5);

/// These tests open hundreds of sockets and count the process's descriptors, so they run one
/// at a time.
static ONE_AT_A_TIME: Mutex<()> = Mutex::new(());

fn one_at_a_time() -> MutexGuard<'static, ()> {
    ONE_AT_A_TIME.lock().unwrap_or_else(|e| e.into_inner())
}

/// Short limits, so that a test of a timeout ends in a second or two.
fn short() -> Limits {
    Limits {
        connections: 8,
        request_head: Duration::from_secs(1),
        stalled_write: Duration::from_secs(1),
        ..Limits::default()
    }
}

/// A server on a free port of 127.0.0.1, serving on a thread of its own.
struct Running {
    port: u16,
    stop: Arc<AtomicBool>,
    done: mpsc::Receiver<Result<(), ViewError>>,
}

impl Running {
    fn start(limits: Limits) -> Self {
        let viewer = Viewer::bind(site(), 0).unwrap().with_limits(limits);
        let port = viewer.port();
        let stop = Arc::new(AtomicBool::new(false));
        let (send, done) = mpsc::channel();
        let flag = stop.clone();
        // Never joined: a server that does not stop must fail the test, not hang it.
        std::thread::spawn(move || {
            let _ = send.send(viewer.serve(None, || flag.load(Ordering::SeqCst)));
        });
        Self { port, stop, done }
    }

    /// Asks it to stop and requires it to have stopped promptly.
    fn stop(self) {
        self.stop.store(true, Ordering::SeqCst);
        let stopped = self.done.recv_timeout(PROMPTLY);
        assert!(
            matches!(stopped, Ok(Ok(()))),
            "the server did not stop within {PROMPTLY:?}: {stopped:?}"
        );
    }
}

impl Drop for Running {
    fn drop(&mut self) {
        self.stop.store(true, Ordering::SeqCst);
    }
}

fn connect(port: u16) -> TcpStream {
    let stream = TcpStream::connect((Ipv4Addr::LOCALHOST, port)).unwrap();
    stream.set_read_timeout(Some(PROMPTLY)).unwrap();
    stream.set_write_timeout(Some(PROMPTLY)).unwrap();
    stream
}

/// What a client got back.
#[derive(Debug, PartialEq, Eq)]
enum Answer {
    /// An answer's status and body, then the end of the connection.
    Status(u16, usize),
    /// The end of the connection (or a reset) without a whole answer.
    Closed,
    /// Nothing more by the deadline, with the connection still open.
    Silence,
}

/// Reads what `stream` gets until the server closes it, or until `deadline`.
fn answer_by(stream: &mut TcpStream, deadline: Instant) -> Answer {
    let mut got = Vec::new();
    let mut buf = [0; 64 * 1024];
    loop {
        let left = deadline.saturating_duration_since(Instant::now());
        stream
            .set_read_timeout(Some(left.max(Duration::from_millis(10))))
            .unwrap();
        match stream.read(&mut buf) {
            Ok(0) => break,
            Ok(n) => got.extend_from_slice(&buf[..n]),
            Err(e) if matches!(e.kind(), ErrorKind::WouldBlock | ErrorKind::TimedOut) => {
                return Answer::Silence;
            }
            Err(e) if e.kind() == ErrorKind::Interrupted => {}
            Err(_) => break,
        }
        if Instant::now() >= deadline {
            return Answer::Silence;
        }
    }
    let Some(split) = got.windows(4).position(|w| w == b"\r\n\r\n") else {
        return Answer::Closed;
    };
    let head = String::from_utf8_lossy(&got[..split]);
    let status = head
        .split(' ')
        .nth(1)
        .and_then(|s| s.parse().ok())
        .unwrap_or(0);
    Answer::Status(status, got.len() - split - 4)
}

fn answer(stream: &mut TcpStream) -> Answer {
    answer_by(stream, Instant::now() + PROMPTLY)
}

/// A plain `GET` on a connection of its own; its status and body.
fn get(port: u16, path: &str) -> (u16, Vec<u8>) {
    let mut stream = connect(port);
    write!(
        stream,
        "GET {path} HTTP/1.1\r\nHost: 127.0.0.1:{port}\r\nConnection: close\r\n\r\n"
    )
    .unwrap();
    let mut got = Vec::new();
    stream
        .read_to_end(&mut got)
        .unwrap_or_else(|e| panic!("GET {path}: {e} after {} bytes", got.len()));
    let split = got
        .windows(4)
        .position(|w| w == b"\r\n\r\n")
        .unwrap_or_else(|| panic!("GET {path}: no answer"));
    let head = String::from_utf8_lossy(&got[..split]).into_owned();
    let status = head.split(' ').nth(1).and_then(|s| s.parse().ok()).unwrap();
    (status, got[split + 4..].to_vec())
}

/// `GET /` is answered within `PROMPTLY`.
fn served_promptly(port: u16) {
    let start = Instant::now();
    let (status, body) = get(port, "/");
    assert_eq!(status, 200);
    assert!(String::from_utf8_lossy(&body).contains("<canvas"));
    assert!(start.elapsed() < PROMPTLY, "{:?}", start.elapsed());
}

/// The process's open descriptors.
#[cfg(target_os = "linux")]
fn open_fds() -> usize {
    std::fs::read_dir("/proc/self/fd").unwrap().count()
}

/// Waits (within `PROMPTLY`) for the process's descriptors to come back to about `before`;
/// other tests of this binary open files meanwhile, hence the slack (a leak here is one or two
/// descriptors a connection, for tens or hundreds of connections).
#[cfg(target_os = "linux")]
fn fds_come_back_to(before: usize, what: &str) {
    let deadline = Instant::now() + PROMPTLY;
    loop {
        let now = open_fds();
        if now <= before + 16 {
            return;
        }
        assert!(
            Instant::now() < deadline,
            "{before} descriptors open before {what}, still {now} {PROMPTLY:?} after"
        );
        std::thread::sleep(Duration::from_millis(50));
    }
}

#[test]
fn a_huge_declared_body_is_refused_unread() {
    let _one = one_at_a_time();
    let server = Running::start(Limits::default());
    let port = server.port;
    for (method, body, refused) in [
        ("POST", "Content-Length: 1000000000000000", 413),
        ("GET", "Content-Length: 1000000000000000", 413),
        ("POST", "Transfer-Encoding: chunked", 413),
        // A length beyond any body's: hyper refuses the head itself.
        ("PUT", "Content-Length: 18446744073709551615", 431),
    ] {
        let mut stream = connect(port);
        write!(
            stream,
            "{method} / HTTP/1.1\r\nHost: 127.0.0.1:{port}\r\n{body}\r\n\r\n"
        )
        .unwrap();
        let got = answer(&mut stream);
        assert!(
            matches!(got, Answer::Status(s, _) if s == refused) || got == Answer::Closed,
            "{method} with {body}: {got:?}"
        );
    }
    served_promptly(port);
    server.stop();
}

#[test]
fn a_request_that_never_ends_costs_only_its_client() {
    let _one = one_at_a_time();
    let server = Running::start(short());
    let port = server.port;
    // A body declared and never sent: refused at once, without waiting for it.
    let mut no_body = connect(port);
    write!(
        no_body,
        "POST / HTTP/1.1\r\nHost: 127.0.0.1:{port}\r\nContent-Length: 100\r\n\r\nten bytes."
    )
    .unwrap();
    // A request head that never ends, and a connection that says nothing.
    let mut half_head = connect(port);
    write!(half_head, "GET / HTTP/1.1\r\nHost: 127.0.0.1:{port}\r\n").unwrap();
    let mut silent = connect(port);
    served_promptly(port);
    assert!(matches!(answer(&mut no_body), Answer::Status(413, _)));
    // Both are closed once their time to send a request head (a second here) is up.
    for (what, stream) in [("half a head", &mut half_head), ("nothing", &mut silent)] {
        let got = answer(stream);
        assert!(
            matches!(got, Answer::Closed | Answer::Status(408, _)),
            "a client that sent {what}: {got:?}"
        );
    }
    // A new one of each, and the server stops promptly while they hold their connections.
    let mut half_head = connect(port);
    write!(half_head, "GET / HTTP/1.1\r\n").unwrap();
    let _silent = connect(port);
    served_promptly(port);
    server.stop();
}

#[test]
fn a_client_that_reads_nothing_costs_only_itself() {
    let _one = one_at_a_time();
    let model = std::fs::read(data("aim-procedural.sinew")).unwrap();
    // Pipelined requests for answers far larger than both sockets' buffers (tens of MB).
    let requests = |port: u16| {
        format!("GET /model.sinew HTTP/1.1\r\nHost: 127.0.0.1:{port}\r\n\r\n").repeat(400)
    };
    // With a long patience for it, the others are served meanwhile, and stopping is prompt.
    let server = Running::start(Limits {
        stalled_write: Duration::from_secs(600),
        ..Limits::default()
    });
    let port = server.port;
    let mut stalled = connect(port);
    stalled.write_all(requests(port).as_bytes()).unwrap();
    // Time for the server to fill the buffers and stall on this client.
    std::thread::sleep(Duration::from_millis(500));
    let start = Instant::now();
    let (status, body) = get(port, "/model.sinew");
    assert_eq!(status, 200);
    assert!(body == model, "{} bytes of {}", body.len(), model.len());
    assert!(start.elapsed() < PROMPTLY, "{:?}", start.elapsed());
    server.stop();
    drop(stalled);
    // With a short patience, the stalled client is dropped before it got every answer.
    let server = Running::start(short());
    let port = server.port;
    let mut stalled = connect(port);
    stalled.write_all(requests(port).as_bytes()).unwrap();
    std::thread::sleep(Duration::from_secs(4));
    let mut got = 0;
    let mut buf = vec![0; 1 << 20];
    let deadline = Instant::now() + PROMPTLY;
    let closed = loop {
        match stalled.read(&mut buf) {
            Ok(0) => break true,
            Ok(n) => got += n,
            Err(e) if e.kind() == ErrorKind::Interrupted => {}
            Err(e) => break !matches!(e.kind(), ErrorKind::WouldBlock | ErrorKind::TimedOut),
        }
        if Instant::now() >= deadline {
            break false;
        }
    };
    assert!(
        closed && got < 400 * model.len(),
        "closed: {closed}, {got} bytes read"
    );
    served_promptly(port);
    server.stop();
}

#[test]
fn http2_is_refused_and_leaves_nothing_open() {
    let _one = one_at_a_time();
    let server = Running::start(Limits::default());
    let port = server.port;
    #[cfg(target_os = "linux")]
    let before = open_fds();
    let mut clients: Vec<TcpStream> = (0..40)
        .map(|i| {
            let mut stream = connect(port);
            let request = if i % 2 == 0 {
                format!("GET / HTTP/2.0\r\nHost: 127.0.0.1:{port}\r\n\r\n")
            } else {
                // The HTTP/2 connection preface.
                "PRI * HTTP/2.0\r\n\r\nSM\r\n\r\n".to_owned()
            };
            // The server may refuse on the request line and close before the rest is written.
            let _ = stream.write_all(request.as_bytes());
            stream
        })
        .collect();
    let deadline = Instant::now() + PROMPTLY;
    for (i, stream) in clients.iter_mut().enumerate() {
        let got = answer_by(stream, deadline);
        assert!(
            matches!(got, Answer::Status(400 | 505, _) | Answer::Closed),
            "client {i}: {got:?}"
        );
    }
    drop(clients);
    #[cfg(target_os = "linux")]
    fds_come_back_to(before, "40 HTTP/2.0 requests");
    served_promptly(port);
    server.stop();
}

/// Whether the server has closed `stream` (read without waiting).
fn closed(mut stream: &TcpStream) -> bool {
    stream.set_nonblocking(true).unwrap();
    let mut byte = [0];
    let closed = match stream.read(&mut byte) {
        Ok(0) => true,
        Ok(_) => false,
        Err(e) => e.kind() != ErrorKind::WouldBlock,
    };
    stream.set_nonblocking(false).unwrap();
    closed
}

#[test]
fn idle_connections_beyond_the_limit_are_closed_at_once() {
    let _one = one_at_a_time();
    let limits = Limits {
        connections: 8,
        request_head: Duration::from_secs(600),
        ..Limits::default()
    };
    let server = Running::start(limits);
    let port = server.port;
    #[cfg(target_os = "linux")]
    let before = open_fds();
    let idle: Vec<TcpStream> = (0..300).map(|_| connect(port)).collect();
    // All but the first 8 are closed as they are accepted; those 8 are kept.
    let deadline = Instant::now() + PROMPTLY;
    let mut open = idle.len();
    while open > limits.connections && Instant::now() < deadline {
        std::thread::sleep(Duration::from_millis(50));
        open = idle.iter().filter(|s| !closed(s)).count();
    }
    assert_eq!(
        open,
        limits.connections,
        "of {} idle connections",
        idle.len()
    );
    // The server holds at most its 8 beside the 300 client sockets of this process.
    #[cfg(target_os = "linux")]
    {
        let now = open_fds();
        assert!(
            now <= before + idle.len() + limits.connections + 16,
            "{before} descriptors before, {now} with {} idle connections",
            idle.len()
        );
    }
    // Once the idle ones go, new clients are served.
    drop(idle);
    let deadline = Instant::now() + PROMPTLY;
    loop {
        let mut stream = connect(port);
        write!(
            stream,
            "GET / HTTP/1.1\r\nHost: 127.0.0.1:{port}\r\nConnection: close\r\n\r\n"
        )
        .unwrap();
        match answer(&mut stream) {
            Answer::Status(200, _) => break,
            got => assert!(Instant::now() < deadline, "{got:?}"),
        }
        std::thread::sleep(Duration::from_millis(50));
    }
    #[cfg(target_os = "linux")]
    fds_come_back_to(before, "300 idle connections");
    server.stop();
}

/// Sends `head` (ignoring a write the server cut short) and reads the answer.
fn send_head(port: u16, head: &str) -> Answer {
    let mut stream = connect(port);
    let _ = stream.write_all(head.as_bytes());
    answer(&mut stream)
}

#[test]
fn oversized_and_countless_headers_are_refused() {
    let _one = one_at_a_time();
    let server = Running::start(Limits::default());
    let port = server.port;
    let start = format!("GET / HTTP/1.1\r\nHost: 127.0.0.1:{port}\r\nConnection: close\r\n");
    let huge = format!("{start}X-Huge: {}\r\n\r\n", "a".repeat(4 << 20));
    let got = send_head(port, &huge);
    assert!(
        matches!(got, Answer::Status(431, _) | Answer::Closed),
        "a 4 MiB header: {got:?}"
    );
    let many: String = (0..1000).map(|i| format!("X-{i}: {i}\r\n")).collect();
    let got = send_head(port, &format!("{start}{many}\r\n"));
    assert!(
        matches!(got, Answer::Status(431, _) | Answer::Closed),
        "1000 headers: {got:?}"
    );
    let long_url = format!(
        "GET /{} HTTP/1.1\r\nHost: 127.0.0.1:{port}\r\nConnection: close\r\n\r\n",
        "a".repeat(1 << 20)
    );
    let got = send_head(port, &long_url);
    assert!(
        matches!(got, Answer::Status(414 | 431, _) | Answer::Closed),
        "a 1 MiB path: {got:?}"
    );
    // A browser's request, with a few kilobytes of cookies, is well within the limits.
    let browser: String = (0..20)
        .map(|i| format!("X-Browser-{i}: {}\r\n", "b".repeat(40)))
        .collect();
    let cookies = format!("Cookie: {}\r\n", "c=1; ".repeat(800));
    let got = send_head(port, &format!("{start}{browser}{cookies}\r\n"));
    assert!(matches!(got, Answer::Status(200, _)), "{got:?}");
    served_promptly(port);
    server.stop();
}

#[test]
fn refusals_are_logged_in_printable_ascii() {
    let peer = Some(SocketAddr::from((Ipv4Addr::LOCALHOST, 50000)));
    assert_eq!(
        refusal_line("GET", "/x?y=1", peer, 404),
        "sinew view: GET /x?y=1 from 127.0.0.1:50000: 404"
    );
    assert_eq!(
        refusal_line("GET", "/", None, 403),
        "sinew view: GET / from an unknown peer: 403"
    );
    // A terminal escape, a forged second line, a bell, DEL, a right-to-left override, a
    // backslash: all escaped, so the log shows what was sent and nothing else.
    let line = refusal_line(
        "G\u{7}ET",
        "/\u{1b}[2J\r\nsinew view: ok\u{7f}\u{202e}\\",
        peer,
        404,
    );
    assert!(
        line.chars().all(|c| c == ' ' || c.is_ascii_graphic()),
        "{line:?}"
    );
    assert_eq!(
        line,
        "sinew view: G\\u{7}ET /\\u{1b}[2J\\r\\nsinew view: ok\\u{7f}\\u{202e}\\\\ from 127.0.0.1:50000: 404"
    );
}
