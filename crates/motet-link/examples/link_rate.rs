//! Messages per second through a reliable `Link` pair, one way and round
//! trip, over a pseudo-terminal and over UDP loopback, with segment-sized
//! payloads.
//!
//! `cargo run --release -p motet-link --example link_rate`
//!
//! Host and node each run in their own thread on the wall clock. One way:
//! the host keeps the window full and the node counts deliveries. Round
//! trip: the host sends one message and waits for the node's answer of the
//! same size before sending the next.

use motet_link::{SerialTransport, Transport, UdpTransport};
use motet_wire::frame::MAX_FRAME;
use motet_wire::link::{Config, Link};
use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};
use std::sync::Arc;
use std::thread;
use std::time::{Duration, Instant};

type Boxed = Box<dyn Transport + Send>;
/// Makes a connected (host, node) pair.
type Maker = fn() -> (Boxed, Boxed);

fn pump(link: &mut Link, t: &mut dyn Transport, now: u64) {
    let mut out = [0u8; MAX_FRAME];
    while let Some(f) = link.poll(now, &mut out) {
        t.send(f).unwrap();
    }
}

fn wait(link: &Link, now: u64) -> Duration {
    let us = link
        .next_timeout()
        .map_or(1_000, |t| t.saturating_sub(now).min(1_000));
    Duration::from_micros(us.max(1))
}

/// The node: delivers, counts, answers with the same payload if `echo`.
fn node(
    mut t: Boxed,
    echo: bool,
    count: Arc<AtomicU64>,
    stop: Arc<AtomicBool>,
) -> thread::JoinHandle<()> {
    thread::spawn(move || {
        let t0 = Instant::now();
        let mut link = Link::new(Config {
            isn: 7,
            ..Config::new(2, 1, false)
        });
        let now = || t0.elapsed().as_micros() as u64;
        while !stop.load(Ordering::Relaxed) {
            let n = now();
            if let Some(f) = t.recv(Some(wait(&link, n))).unwrap() {
                let n = now();
                let mut answers = Vec::new();
                let mut d = link.on_frame(&f, n).map(|d| d.payload.to_vec());
                while let Some(p) = d {
                    count.fetch_add(1, Ordering::Relaxed);
                    answers.push(p);
                    d = link.recv().map(|d| d.payload.to_vec());
                }
                if echo {
                    for p in answers {
                        // One message in flight at a time: there is room.
                        link.send(&p, n).unwrap();
                    }
                }
            }
            pump(&mut link, t.as_mut(), now());
        }
    })
}

/// Returns messages per second.
fn measure(mut host_t: Boxed, node_t: Boxed, size: usize, n: u64, round_trip: bool) -> f64 {
    let count = Arc::new(AtomicU64::new(0));
    let stop = Arc::new(AtomicBool::new(false));
    let nd = node(node_t, round_trip, count.clone(), stop.clone());
    let t0 = Instant::now();
    let now = || t0.elapsed().as_micros() as u64;
    let mut link = Link::new(Config {
        isn: 1000,
        ..Config::new(1, 2, true)
    });
    let payload: Vec<u8> = (0..size).map(|i| i as u8).collect();
    let (mut sent, mut answered) = (0u64, 0u64);
    let mut start = None;
    let done = |sent: u64, answered: u64| {
        if round_trip {
            answered >= n
        } else {
            count.load(Ordering::Relaxed) >= n && sent >= n
        }
    };
    while !done(sent, answered) {
        let t = now();
        while sent < n && (!round_trip || sent == answered) {
            if link.send(&payload, t).is_err() {
                break;
            }
            // Timed from the first message queued.
            start.get_or_insert_with(Instant::now);
            sent += 1;
        }
        pump(&mut link, host_t.as_mut(), t);
        if let Some(f) = host_t.recv(Some(wait(&link, now()))).unwrap() {
            let mut d = link.on_frame(&f, now()).is_some();
            while d {
                answered += 1;
                d = link.recv().is_some();
            }
        }
        pump(&mut link, host_t.as_mut(), now());
    }
    let secs = start.map_or(0.0, |s| s.elapsed().as_secs_f64());
    stop.store(true, Ordering::Relaxed);
    nd.join().unwrap();
    n as f64 / secs
}

/// A pty pair: (master, slave opened by path through `serialport`).
fn pty() -> (Boxed, Boxed) {
    use std::os::fd::FromRawFd;
    let (mut m, mut s) = (-1, -1);
    // SAFETY: openpty fills the two descriptors; null pointers are allowed.
    let r = unsafe {
        libc::openpty(
            &mut m,
            &mut s,
            std::ptr::null_mut(),
            std::ptr::null(),
            std::ptr::null(),
        )
    };
    assert_eq!(r, 0, "openpty: {}", std::io::Error::last_os_error());
    let mut name = [0 as libc::c_char; 256];
    // SAFETY: a writable buffer of the given length.
    assert_eq!(
        unsafe { libc::ttyname_r(s, name.as_mut_ptr(), name.len()) },
        0
    );
    // SAFETY: ttyname_r wrote a NUL-terminated string.
    let path = unsafe { std::ffi::CStr::from_ptr(name.as_ptr()) }
        .to_str()
        .unwrap()
        .to_owned();
    let slave = SerialTransport::open(&path, 115_200).unwrap();
    // SAFETY: our descriptor; the port opened by path keeps the device open.
    unsafe { libc::close(s) };
    // SAFETY: an open descriptor we own from here on.
    let master = unsafe { serialport::TTYPort::from_raw_fd(m) };
    (
        Box::new(SerialTransport::from_port(
            "pty-master".into(),
            Box::new(master),
        )),
        Box::new(slave),
    )
}

fn udp() -> (Boxed, Boxed) {
    let (a, b) = UdpTransport::loopback_pair().unwrap();
    (Box::new(a), Box::new(b))
}

fn main() {
    let n = 20_000;
    let rt_n = 5_000;
    println!(
        "messages/s through a reliable Link pair (window 8), {n} one way, {rt_n} round trips:"
    );
    println!("transport | payload B | one way msg/s | round trip /s | round trip µs");
    let carriers: [(&str, Maker); 2] = [("pty", pty), ("udp", udp)];
    for (name, make) in carriers {
        for size in [60usize, 120, 190] {
            let (h, nd) = make();
            let one = measure(h, nd, size, n, false);
            let (h, nd) = make();
            let rt = measure(h, nd, size, rt_n, true);
            println!(
                "{name:>9} | {size:>9} | {one:>13.0} | {rt:>13.0} | {:>13.1}",
                1e6 / rt
            );
        }
    }
}
