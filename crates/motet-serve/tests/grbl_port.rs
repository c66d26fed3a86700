//! The grbl device on its ports, on a running server: a pseudo-terminal
//! and TCP, each connected to as a sender would, driving the same session.

use motet_serve::device::port::Port;
use motet_serve::{serve_config, Server, ServerConfig, SimNodes};
use std::io::{Read, Write};
use std::sync::mpsc;
use std::time::{Duration, Instant};

fn server(dir: &std::path::Path) -> Server {
    let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../../examples/laser.toml");
    let m = motet_host::Machine::load(&path).unwrap();
    let nodes = Box::new(SimNodes::new(&m, m.start, serve_config()));
    let cfg = ServerConfig {
        listen: "127.0.0.1:0".parse().unwrap(),
        dir: dir.to_path_buf(),
        token: None,
    };
    Server::start(m, nodes, &cfg).unwrap()
}

/// A sender's end: bytes out, text in (read on a thread of its own).
struct Sender {
    out: Box<dyn Write>,
    text: mpsc::Receiver<String>,
    seen: String,
}

impl Sender {
    fn new(out: Box<dyn Write>, mut input: Box<dyn Read + Send>) -> Sender {
        let (tx, text) = mpsc::channel();
        std::thread::spawn(move || {
            let mut buf = [0u8; 4096];
            while let Ok(n) = input.read(&mut buf) {
                if n == 0
                    || tx
                        .send(String::from_utf8_lossy(&buf[..n]).into_owned())
                        .is_err()
                {
                    break;
                }
            }
        });
        Sender {
            out,
            text,
            seen: String::new(),
        }
    }

    /// Sends `bytes` and waits (15 s at most) for `want` in what comes back.
    fn expect(&mut self, bytes: &[u8], want: &str) {
        self.seen.clear();
        self.out.write_all(bytes).unwrap();
        self.out.flush().unwrap();
        let end = Instant::now() + Duration::from_secs(15);
        while !self.seen.contains(want) {
            let left = end.saturating_duration_since(Instant::now());
            match self.text.recv_timeout(left) {
                Ok(t) => self.seen.push_str(&t),
                Err(_) => panic!("no {want:?} after {bytes:?}: got {:?}", self.seen),
            }
        }
    }
}

fn connect(at: &str) -> Sender {
    if let Some(addr) = at.strip_prefix("tcp:") {
        let s = std::net::TcpStream::connect(addr).unwrap();
        Sender::new(Box::new(s.try_clone().unwrap()), Box::new(s))
    } else {
        let f = std::fs::OpenOptions::new()
            .read(true)
            .write(true)
            .open(at)
            .unwrap();
        Sender::new(Box::new(f.try_clone().unwrap()), Box::new(f))
    }
}

#[test]
fn a_sender_drives_the_machine_over_a_pty_and_over_tcp() {
    for port in ["pty", "tcp:127.0.0.1:0"] {
        let dir = tempfile::tempdir().unwrap();
        let srv = server(dir.path());
        let at = srv.grbl(&port.parse::<Port>().unwrap()).unwrap();
        let mut s = connect(&at);
        s.expect(b"\x18", "\r\nGrbl 1.1h ['$' for help]\r\n");
        s.expect(b"$I\n", "[VER:1.1h.motet:]\r\n[OPT:V,128,128]\r\nok\r\n");
        s.expect(b"G21 G90\nG0 X5 Y4\n", "ok\r\nok\r\n");
        // Motion waits for the nodes' clocks to settle (a few seconds).
        let end = Instant::now() + Duration::from_secs(15);
        loop {
            s.expect(b"?", ">\r\n");
            if s.seen.contains("<Idle|MPos:5.000,4.000,0.000|") {
                break;
            }
            assert!(Instant::now() < end, "{port}: not at X5 Y4: {}", s.seen);
            std::thread::sleep(Duration::from_millis(50));
        }
        s.expect(b"$J=G91 X1000 F100\n", "error:15\r\n");
    }
}

#[test]
fn a_bad_port_is_refused_with_what_is_expected() {
    for bad in ["serial", "tcp:", "tcp:localhost", "tcp:1.2.3.4", "pty2"] {
        let e = bad.parse::<Port>().unwrap_err();
        assert!(
            e.contains("pty") && e.contains("tcp:ADDRESS:PORT"),
            "{bad}: {e}"
        );
    }
}
