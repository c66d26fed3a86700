//! The link's answer to each reply code, one scripted bot per case: what
//! it resends, what it waits for, where it stops, and how many times the
//! action went out.

use motet_s3g::command::{Command, PointNew};
use motet_s3g::link::{Link, LinkConfig, LinkError};
use motet_s3g::{encode, ReplyCode};
use std::collections::VecDeque;
use std::io::{ErrorKind, Read, Write};
use std::time::Duration;

/// A bot that answers each packet with the next scripted bytes (none:
/// silence), and counts the packets by command.
struct Script {
    answers: VecDeque<Vec<u8>>,
    rx: Vec<u8>,
    sent: Vec<u8>,
}

impl Write for Script {
    fn write(&mut self, buf: &[u8]) -> std::io::Result<usize> {
        self.sent.push(buf[2]);
        if let Some(a) = self.answers.pop_front() {
            self.rx.extend(a);
        }
        Ok(buf.len())
    }
    fn flush(&mut self) -> std::io::Result<()> {
        Ok(())
    }
}

impl Read for Script {
    fn read(&mut self, buf: &mut [u8]) -> std::io::Result<usize> {
        if self.rx.is_empty() {
            return Err(ErrorKind::TimedOut.into());
        }
        let n = buf.len().min(self.rx.len());
        buf[..n].copy_from_slice(&self.rx[..n]);
        self.rx.drain(..n);
        Ok(n)
    }
}

fn reply(code: u8, body: &[u8]) -> Vec<u8> {
    let mut p = vec![code];
    p.extend_from_slice(body);
    encode(&p).unwrap()
}

fn free(n: u32) -> Vec<u8> {
    reply(0x81, &n.to_le_bytes())
}

fn config() -> LinkConfig {
    LinkConfig {
        reply_timeout: Duration::from_millis(20),
        tries: 5,
        silent_tries: 2,
        poll_interval: Duration::ZERO,
    }
}

/// What a case ends with.
enum End {
    Ok,
    Err(fn(&LinkError) -> bool, &'static str),
}

/// Sends one point to a bot scripted with `answers` (the first answer is
/// to the buffer query made before the point): the end, and how many
/// times the point went out.
fn case(name: &str, answers: Vec<Vec<u8>>, end: End, sends: usize) {
    let mut port = Script {
        answers: answers.into(),
        rx: Vec::new(),
        sent: Vec::new(),
    };
    let point = Command::PointNew(PointNew {
        steps: [1, 2, 3, 4, 5],
        us: 1000,
        relative: 0,
    });
    let r = Link::new(&mut port, config()).action(&point, &mut |_| Ok(()));
    match (end, r) {
        (End::Ok, Ok(())) => {}
        (End::Err(is, words), Err(e)) => {
            assert!(is(&e), "{name}: {e:?}");
            assert!(e.to_string().contains(words), "{name}: {e}");
        }
        (_, r) => panic!("{name}: {r:?}"),
    }
    let n = port.sent.iter().filter(|&&c| c == 142).count();
    assert_eq!(n, sends, "{name}: the point went out {n} times");
}

#[test]
fn each_reply_code() {
    let ok = || reply(0x81, &[]);
    let room = || free(512);
    let refused = |code: ReplyCode| -> fn(&LinkError) -> bool {
        match code {
            ReplyCode::Cancelled => |e| {
                matches!(
                    e,
                    LinkError::Refused {
                        reply: ReplyCode::Cancelled,
                        ..
                    }
                )
            },
            ReplyCode::Overheat => |e| {
                matches!(
                    e,
                    LinkError::Refused {
                        reply: ReplyCode::Overheat,
                        ..
                    }
                )
            },
            _ => |e| {
                matches!(
                    e,
                    LinkError::Refused {
                        reply: ReplyCode::NotSupported,
                        ..
                    }
                )
            },
        }
    };
    case("success", vec![room(), ok()], End::Ok, 1);
    case(
        "generic, resent",
        vec![room(), reply(0x80, &[]), ok()],
        End::Ok,
        2,
    );
    case(
        "crc, resent twice",
        vec![room(), reply(0x83, &[]), reply(0x83, &[]), ok()],
        End::Ok,
        3,
    );
    case(
        "packet timeout, resent",
        vec![room(), reply(0x8C, &[]), ok()],
        End::Ok,
        2,
    );
    // Buffer full: polled until there is room, then sent again.
    case(
        "full, then room",
        vec![
            room(),
            reply(0x82, &[]),
            free(10),
            free(20),
            free(512),
            ok(),
        ],
        End::Ok,
        2,
    );
    // Noise and a false start before the reply.
    let mut noisy = vec![0x00, 0xD5, 0x02, 0x11];
    noisy.extend(ok());
    case("noise", vec![room(), noisy], End::Ok, 1);
    case(
        "cancelled",
        vec![room(), reply(0x89, &[])],
        End::Err(
            refused(ReplyCode::Cancelled),
            "0x89 (build cancelled on the bot)",
        ),
        1,
    );
    case(
        "overheat",
        vec![room(), reply(0x8B, &[])],
        End::Err(refused(ReplyCode::Overheat), "overheating"),
        1,
    );
    case(
        "not supported",
        vec![room(), reply(0x85, &[])],
        End::Err(refused(ReplyCode::NotSupported), "not supported"),
        1,
    );
    case(
        "discarded five times",
        vec![
            room(),
            reply(0x80, &[]),
            reply(0x80, &[]),
            reply(0x83, &[]),
            reply(0x80, &[]),
            reply(0x80, &[]),
        ],
        End::Err(
            |e| matches!(e, LinkError::TooManyRetries { tries: 5, .. }),
            "5 times",
        ),
        5,
    );
    case(
        "silent",
        vec![room()],
        End::Err(
            |e| matches!(e, LinkError::Silent { .. }),
            "stopped answering",
        ),
        1,
    );
    let mut bad = ok();
    *bad.last_mut().unwrap() ^= 1;
    case(
        "acknowledgement corrupted",
        vec![room(), bad],
        End::Err(
            |e| matches!(e, LinkError::LostActionReply { .. }),
            "cannot tell",
        ),
        1,
    );
    // A query met by silence is asked once more, then given up.
    let mut port = Script {
        answers: VecDeque::new(),
        rx: Vec::new(),
        sent: Vec::new(),
    };
    let mut link = Link::new(&mut port, config());
    let e = link.buffer_free().unwrap_err();
    assert!(matches!(e, LinkError::Silent { tries: 2, .. }), "{e:?}");
    assert_eq!(port.sent, vec![2, 2]);
    // A query's corrupted reply is asked again.
    let mut bad_free = free(512);
    *bad_free.last_mut().unwrap() ^= 1;
    case(
        "query reply corrupted",
        vec![bad_free, room(), ok()],
        End::Ok,
        1,
    );
}
