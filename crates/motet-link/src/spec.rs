//! Link spec strings: which transport to open, written as one word on a
//! command line or in a config file.
//!
//! | spec | transport |
//! |---|---|
//! | `udp:HOST:PORT` | UDP to a node at HOST:PORT, from an ephemeral port |
//! | `udp-listen:HOST:PORT` | UDP bound to HOST:PORT (a node; port 0 takes any free one), answering its latest sender |
//! | `serial:PATH[@BAUD]` | COBS stream on a serial port, BAUD default 115200 |
//! | `slcan:PATH[@BITRATE]` | CAN-FD through an slcan adapter, BITRATE default 500k (`500000`, `500k`, `1M`) |
//! | `udp-group:GROUP:PORT[@IFACE]` | UDP multicast to the group GROUP:PORT (224.0.0.0/4) on the interface of address IFACE, default 127.0.0.1: every member hears every frame, as on a bus |
//!
//! HOST is a name, an IPv4 address or a bracketed IPv6 address (`[::1]`).

use crate::slcan_port::{bitrate_code, SlcanConfig, SlcanTransport};
use crate::{SerialTransport, Transport, UdpTransport};
use std::io;
use std::net::ToSocketAddrs;

/// Serial baud rate when a spec gives none.
pub const DEFAULT_BAUD: u32 = 115_200;
/// CAN bit rate when an slcan spec gives none.
pub const DEFAULT_BITRATE: u32 = 500_000;

/// A parsed link spec.
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum LinkSpec {
    /// `udp:HOST:PORT`.
    Udp {
        /// The node's host name or address (IPv6 in brackets).
        host: String,
        /// The node's UDP port, 1-65535.
        port: u16,
    },
    /// `udp-listen:HOST:PORT`.
    UdpListen {
        /// The local address to bind (IPv6 in brackets).
        host: String,
        /// The local port; 0 takes any free one.
        port: u16,
    },
    /// `serial:PATH[@BAUD]`.
    Serial {
        /// The serial device (`/dev/ttyACM0`, `COM3`).
        path: String,
        /// Baud rate, [`DEFAULT_BAUD`] if not given.
        baud: u32,
    },
    /// `udp-group:GROUP:PORT[@IFACE]`.
    UdpGroup {
        /// The group's multicast address.
        group: std::net::Ipv4Addr,
        /// The group's port, 1-65535.
        port: u16,
        /// The address of the interface to join it on.
        iface: std::net::Ipv4Addr,
    },
    /// `slcan:PATH[@BITRATE]`.
    Slcan {
        /// The adapter's serial device.
        path: String,
        /// Nominal CAN bit rate, bit/s, one of the slcan rates;
        /// [`DEFAULT_BITRATE`] if not given.
        bitrate: u32,
    },
}

/// Why a spec string was refused.
#[derive(Clone, Debug, PartialEq, Eq, thiserror::Error)]
pub enum SpecError {
    /// Nothing given.
    #[error("empty link spec")]
    Empty,
    /// No `scheme:` before the address (the spec given).
    #[error(
        "link spec {0:?} has no scheme (expected udp:, udp-listen:, udp-group:, serial: or slcan:)"
    )]
    NoScheme(String),
    /// A scheme motet has no transport for.
    #[error("unknown link scheme {0:?} (expected udp, udp-listen, udp-group, serial or slcan)")]
    UnknownScheme(String),
    /// `HOST:PORT` with an empty host.
    #[error("missing host in {0:?} (expected HOST:PORT)")]
    MissingHost(String),
    /// No `:PORT`, or an empty one.
    #[error("missing port in {0:?} (expected HOST:PORT)")]
    MissingPort(String),
    /// A port that is not a number in range (0 only to listen).
    #[error("bad port {0:?} (expected 1-65535, or 0 to listen on any)")]
    BadPort(String),
    /// A host with one bracket, or an IPv6 address without brackets.
    #[error("unbalanced brackets in host {0:?}")]
    BadHost(String),
    /// `serial:` or `slcan:` without a device.
    #[error("missing device path")]
    MissingPath,
    /// `@BAUD` that is not a positive integer.
    #[error("bad baud rate {0:?} (expected a positive integer)")]
    BadBaud(String),
    /// A group that is not an IPv4 multicast address, or an interface that
    /// is not an IPv4 address.
    #[error("bad {what} {given:?} (expected {expected})")]
    BadGroup {
        /// Which part: the group or the interface.
        what: &'static str,
        /// The text given.
        given: String,
        /// What was expected.
        expected: &'static str,
    },
    /// `@BITRATE` that is not one of the rates slcan can select.
    #[error("bad CAN bit rate {0:?} (expected one of 10k 20k 50k 100k 125k 250k 500k 800k 1M)")]
    BadBitrate(String),
}

/// Why [`open`] failed. The messages leave naming the link to the caller
/// (`cannot open link SPEC: …`), so that it is not named twice; the
/// system's error is part of the message, not a separate source.
#[derive(Debug, thiserror::Error)]
pub enum OpenError {
    /// The spec string is malformed.
    #[error(transparent)]
    Spec(#[from] SpecError),
    /// The host name did not resolve to an address.
    #[error("cannot resolve {addr:?}: {error}")]
    Resolve {
        /// `HOST:PORT` as given.
        addr: String,
        /// What the resolver said (or that it found no address).
        error: io::Error,
    },
    /// The socket or device could not be opened (missing device, port in
    /// use, permissions).
    #[error("{error}")]
    Io {
        /// The link with its defaults filled in (`serial:PATH@115200`).
        spec: String,
        /// What the operating system said.
        error: io::Error,
    },
}

/// `any_port` lets port 0 (any free port) through, for binding.
fn host_port(rest: &str, any_port: bool) -> Result<(String, u16), SpecError> {
    let (host, port) = rest
        .rsplit_once(':')
        .ok_or_else(|| SpecError::MissingPort(rest.to_owned()))?;
    if port.is_empty() {
        return Err(SpecError::MissingPort(rest.to_owned()));
    }
    let port = match port.parse::<u16>() {
        Ok(p) if (p > 0 || any_port) && port.bytes().all(|b| b.is_ascii_digit()) => p,
        _ => return Err(SpecError::BadPort(port.to_owned())),
    };
    let bracketed = host.starts_with('[') || host.ends_with(']');
    if bracketed && !(host.len() >= 2 && host.starts_with('[') && host.ends_with(']')) {
        return Err(SpecError::BadHost(host.to_owned()));
    }
    let bare = host.trim_start_matches('[').trim_end_matches(']');
    if bare.is_empty() {
        return Err(SpecError::MissingHost(rest.to_owned()));
    }
    // An unbracketed IPv6 address would be ambiguous with the port.
    if !bracketed && bare.contains(':') {
        return Err(SpecError::BadHost(host.to_owned()));
    }
    Ok((host.to_owned(), port))
}

fn path_and(rest: &str) -> Result<(String, Option<&str>), SpecError> {
    let (path, arg) = match rest.rsplit_once('@') {
        Some((p, a)) => (p, Some(a)),
        None => (rest, None),
    };
    if path.is_empty() {
        return Err(SpecError::MissingPath);
    }
    Ok((path.to_owned(), arg))
}

fn parse_bitrate(s: &str) -> Result<u32, SpecError> {
    let bad = || SpecError::BadBitrate(s.to_owned());
    let (digits, mul) = match s.as_bytes().last() {
        Some(b'k' | b'K') => (&s[..s.len() - 1], 1_000),
        Some(b'M' | b'm') => (&s[..s.len() - 1], 1_000_000),
        _ => (s, 1),
    };
    if digits.is_empty() || !digits.bytes().all(|b| b.is_ascii_digit()) {
        return Err(bad());
    }
    let v = digits
        .parse::<u32>()
        .ok()
        .and_then(|v| v.checked_mul(mul))
        .ok_or_else(bad)?;
    bitrate_code(v).map(|_| v).ok_or_else(bad)
}

impl LinkSpec {
    /// Parses a spec string; never panics.
    pub fn parse(spec: &str) -> Result<LinkSpec, SpecError> {
        let spec = spec.trim();
        if spec.is_empty() {
            return Err(SpecError::Empty);
        }
        let (scheme, rest) = spec
            .split_once(':')
            .ok_or_else(|| SpecError::NoScheme(spec.to_owned()))?;
        match scheme {
            "udp" => host_port(rest, false).map(|(host, port)| LinkSpec::Udp { host, port }),
            "udp-listen" => {
                host_port(rest, true).map(|(host, port)| LinkSpec::UdpListen { host, port })
            }
            "serial" => {
                let (path, arg) = path_and(rest)?;
                let baud = match arg {
                    None => DEFAULT_BAUD,
                    Some(a) => match a.parse::<u32>() {
                        Ok(b) if b > 0 && a.bytes().all(|c| c.is_ascii_digit()) => b,
                        _ => return Err(SpecError::BadBaud(a.to_owned())),
                    },
                };
                Ok(LinkSpec::Serial { path, baud })
            }
            "udp-group" => {
                let (addr, iface) = match rest.rsplit_once('@') {
                    Some((a, i)) => (a, Some(i)),
                    None => (rest, None),
                };
                let (group, port) = host_port(addr, false)?;
                let group = match group.parse::<std::net::Ipv4Addr>() {
                    Ok(g) if g.is_multicast() => g,
                    _ => {
                        return Err(SpecError::BadGroup {
                            what: "multicast group",
                            given: group,
                            expected: "an IPv4 address in 224.0.0.0/4",
                        })
                    }
                };
                let iface = match iface {
                    None => std::net::Ipv4Addr::LOCALHOST,
                    Some(i) => i.parse().map_err(|_| SpecError::BadGroup {
                        what: "interface",
                        given: i.to_owned(),
                        expected: "the IPv4 address of an interface",
                    })?,
                };
                Ok(LinkSpec::UdpGroup { group, port, iface })
            }
            "slcan" => {
                let (path, arg) = path_and(rest)?;
                let bitrate = arg.map_or(Ok(DEFAULT_BITRATE), parse_bitrate)?;
                Ok(LinkSpec::Slcan { path, bitrate })
            }
            _ => Err(SpecError::UnknownScheme(scheme.to_owned())),
        }
    }

    /// Opens the transport.
    pub fn open(&self) -> Result<Box<dyn Transport + Send>, OpenError> {
        let io_err = |error| OpenError::Io {
            spec: self.to_string(),
            error,
        };
        let resolve = |host: &str, port: u16| {
            let addr = format!("{host}:{port}");
            let mut all = addr.to_socket_addrs().map_err(|error| OpenError::Resolve {
                addr: addr.clone(),
                error,
            })?;
            all.next().ok_or_else(|| OpenError::Resolve {
                addr,
                error: io::Error::new(io::ErrorKind::NotFound, "no address"),
            })
        };
        Ok(match self {
            LinkSpec::Udp { host, port } => {
                Box::new(UdpTransport::connect(resolve(host, *port)?).map_err(io_err)?)
            }
            LinkSpec::UdpListen { host, port } => {
                Box::new(UdpTransport::listen(resolve(host, *port)?).map_err(io_err)?)
            }
            LinkSpec::Serial { path, baud } => {
                Box::new(SerialTransport::open(path, *baud).map_err(io_err)?)
            }
            LinkSpec::UdpGroup { group, port, iface } => {
                let group = std::net::SocketAddrV4::new(*group, *port);
                Box::new(crate::UdpGroup::join(group, *iface).map_err(io_err)?)
            }
            LinkSpec::Slcan { path, bitrate } => {
                let cfg = SlcanConfig {
                    bitrate: *bitrate,
                    ..SlcanConfig::default()
                };
                Box::new(SlcanTransport::open(path, cfg).map_err(io_err)?)
            }
        })
    }
}

impl std::fmt::Display for LinkSpec {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            LinkSpec::Udp { host, port } => write!(f, "udp:{host}:{port}"),
            LinkSpec::UdpListen { host, port } => write!(f, "udp-listen:{host}:{port}"),
            LinkSpec::Serial { path, baud } => write!(f, "serial:{path}@{baud}"),
            LinkSpec::Slcan { path, bitrate } => write!(f, "slcan:{path}@{bitrate}"),
            LinkSpec::UdpGroup { group, port, iface } => {
                write!(f, "udp-group:{group}:{port}@{iface}")
            }
        }
    }
}

impl std::str::FromStr for LinkSpec {
    type Err = SpecError;
    fn from_str(s: &str) -> Result<LinkSpec, SpecError> {
        LinkSpec::parse(s)
    }
}

/// Opens the transport a spec string names.
pub fn open(spec: &str) -> Result<Box<dyn Transport + Send>, OpenError> {
    LinkSpec::parse(spec)?.open()
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;
    use std::time::Duration;

    #[test]
    fn good_specs() {
        let s = |x: &str| x.to_owned();
        let cases = [
            (
                "udp:192.168.1.20:4000",
                LinkSpec::Udp {
                    host: s("192.168.1.20"),
                    port: 4000,
                },
            ),
            (
                "udp:node-3.local:9",
                LinkSpec::Udp {
                    host: s("node-3.local"),
                    port: 9,
                },
            ),
            (
                "udp:[::1]:4000",
                LinkSpec::Udp {
                    host: s("[::1]"),
                    port: 4000,
                },
            ),
            (
                "udp-group:239.255.77.1:47100",
                LinkSpec::UdpGroup {
                    group: std::net::Ipv4Addr::new(239, 255, 77, 1),
                    port: 47100,
                    iface: std::net::Ipv4Addr::LOCALHOST,
                },
            ),
            (
                "udp-group:239.255.77.1:47100@192.168.1.10",
                LinkSpec::UdpGroup {
                    group: std::net::Ipv4Addr::new(239, 255, 77, 1),
                    port: 47100,
                    iface: std::net::Ipv4Addr::new(192, 168, 1, 10),
                },
            ),
            (
                " udp-listen:0.0.0.0:4000 ",
                LinkSpec::UdpListen {
                    host: s("0.0.0.0"),
                    port: 4000,
                },
            ),
            (
                "serial:/dev/ttyACM0",
                LinkSpec::Serial {
                    path: s("/dev/ttyACM0"),
                    baud: 115_200,
                },
            ),
            (
                "serial:/dev/ttyUSB1@921600",
                LinkSpec::Serial {
                    path: s("/dev/ttyUSB1"),
                    baud: 921_600,
                },
            ),
            (
                "slcan:/dev/ttyACM1",
                LinkSpec::Slcan {
                    path: s("/dev/ttyACM1"),
                    bitrate: 500_000,
                },
            ),
            (
                "slcan:/dev/ttyACM1@1M",
                LinkSpec::Slcan {
                    path: s("/dev/ttyACM1"),
                    bitrate: 1_000_000,
                },
            ),
            (
                "slcan:/dev/ttyACM1@125000",
                LinkSpec::Slcan {
                    path: s("/dev/ttyACM1"),
                    bitrate: 125_000,
                },
            ),
            (
                "slcan:/dev/ttyACM1@250k",
                LinkSpec::Slcan {
                    path: s("/dev/ttyACM1"),
                    bitrate: 250_000,
                },
            ),
        ];
        for (text, want) in cases {
            let got = LinkSpec::parse(text).unwrap_or_else(|e| panic!("{text:?}: {e}"));
            assert_eq!(got, want, "{text:?}");
            // Display gives a spec that parses back to the same thing.
            assert_eq!(LinkSpec::parse(&got.to_string()), Ok(got));
        }
    }

    #[test]
    fn bad_specs() {
        let s = |x: &str| x.to_owned();
        let cases = [
            ("", SpecError::Empty),
            ("   ", SpecError::Empty),
            ("/dev/ttyACM0", SpecError::NoScheme(s("/dev/ttyACM0"))),
            ("tcp:1.2.3.4:5", SpecError::UnknownScheme(s("tcp"))),
            ("UDP:1.2.3.4:5", SpecError::UnknownScheme(s("UDP"))),
            ("udp:1.2.3.4", SpecError::MissingPort(s("1.2.3.4"))),
            ("udp:localhost", SpecError::MissingPort(s("localhost"))),
            ("udp:1.2.3.4:", SpecError::MissingPort(s("1.2.3.4:"))),
            ("udp::4000", SpecError::MissingHost(s(":4000"))),
            ("udp:[]:4000", SpecError::MissingHost(s("[]:4000"))),
            ("udp:h:0", SpecError::BadPort(s("0"))),
            ("udp:h:65536", SpecError::BadPort(s("65536"))),
            ("udp:h:+80", SpecError::BadPort(s("+80"))),
            ("udp:::1:4000", SpecError::BadHost(s("::1"))),
            ("udp:[::1:4000", SpecError::BadHost(s("[::1"))),
            ("udp-listen:h:x", SpecError::BadPort(s("x"))),
            (
                "udp-group:10.0.0.1:4000",
                SpecError::BadGroup {
                    what: "multicast group",
                    given: s("10.0.0.1"),
                    expected: "an IPv4 address in 224.0.0.0/4",
                },
            ),
            (
                "udp-group:239.1.2.3:4000@lo",
                SpecError::BadGroup {
                    what: "interface",
                    given: s("lo"),
                    expected: "the IPv4 address of an interface",
                },
            ),
            ("udp-group:239.1.2.3:0", SpecError::BadPort(s("0"))),
            ("serial:", SpecError::MissingPath),
            ("serial:@9600", SpecError::MissingPath),
            ("serial:/dev/x@", SpecError::BadBaud(s(""))),
            ("serial:/dev/x@0", SpecError::BadBaud(s("0"))),
            ("serial:/dev/x@fast", SpecError::BadBaud(s("fast"))),
            ("slcan:", SpecError::MissingPath),
            ("slcan:/dev/x@", SpecError::BadBitrate(s(""))),
            ("slcan:/dev/x@k", SpecError::BadBitrate(s("k"))),
            ("slcan:/dev/x@300k", SpecError::BadBitrate(s("300k"))),
            ("slcan:/dev/x@5000M", SpecError::BadBitrate(s("5000M"))),
            ("slcan:/dev/x@1.5M", SpecError::BadBitrate(s("1.5M"))),
        ];
        for (text, want) in cases {
            assert_eq!(LinkSpec::parse(text), Err(want), "{text:?}");
        }
        // Errors carry a readable message.
        let e = open("tcp:1.2.3.4:5").err().unwrap();
        assert!(e.to_string().contains("unknown link scheme"), "{e}");
    }

    #[test]
    fn open_udp_pair_and_missing_device() {
        let mut node = open("udp-listen:127.0.0.1:0").unwrap();
        assert!(node.name().starts_with("udp-listen:127.0.0.1:"));
        // Find the bound port through the name: the spec asked for any.
        let port: u16 = node.name().rsplit(':').next().unwrap().parse().unwrap();
        let mut host = open(&format!("udp:127.0.0.1:{port}")).unwrap();
        host.send(&[1, 2, 0]).unwrap();
        let wait = Some(Duration::from_secs(5));
        assert_eq!(node.recv(wait).unwrap(), Some(vec![1, 2, 0]));
        node.send(&[3, 0]).unwrap();
        assert_eq!(host.recv(wait).unwrap(), Some(vec![3, 0]));
        for spec in [
            "serial:/dev/motet-no-such-tty",
            "slcan:/dev/motet-no-such-tty@1M",
        ] {
            match open(spec) {
                Err(OpenError::Io { spec: s, .. }) => assert!(s.contains("motet-no-such-tty")),
                other => panic!("{spec}: {:?}", other.map(|t| t.name().to_owned())),
            }
        }
    }

    proptest! {
        #[test]
        fn parse_never_panics(s in ".{0,40}") {
            let _ = LinkSpec::parse(&s);
        }

        #[test]
        fn parse_never_panics_near_valid(
            scheme in prop::sample::select(vec!["udp", "udp-listen", "udp-group", "serial", "slcan", "x"]),
            rest in "[\\[\\]:@a-zA-Z0-9./kM+-]{0,24}",
        ) {
            if let Ok(spec) = LinkSpec::parse(&format!("{scheme}:{rest}")) {
                // Whatever parses prints back to itself.
                prop_assert_eq!(LinkSpec::parse(&spec.to_string()), Ok(spec));
            }
        }
    }
}
