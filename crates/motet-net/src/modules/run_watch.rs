//! Driving a [`ModuleWatch`]: beside a networked run, through the run's
//! own links (its probes go out as datagrams between the run's frames, and
//! a change that leaves the machine unfit for the job stops the run on its
//! contingency tail), or on links of its own while nothing runs.

use super::watch::{ModuleWatch, WatchReport};
use crate::medium::Medium;
use crate::peer::datagram;
use crate::run::NetRun;
use motet_link::Transport;
use motet_wire::decode;
use motet_wire::frame::{self, Flags, MAX_RAW};
use motet_wire::service::{ServiceReply, HOST_ADDRESS};

/// One turn of `watch` beside `run`, whose node `k` is reached on
/// `links[k]` (as the watch's places name links), at `now` (the run's
/// clock): replies taken, probes sent, and, when a change leaves the
/// machine unfit for the job, the run stopped saying why. The report, when
/// there is one.
pub fn watch_run(
    watch: &mut ModuleWatch,
    run: &mut NetRun,
    links: &[String],
    medium: Option<&Medium>,
    now: u64,
) -> Option<WatchReport> {
    for (k, r) in run.take_service_replies() {
        if let (Some(link), Some(p)) = (links.get(k), run.peers().get(k)) {
            watch.on_reply(link, p.address, &r, now);
        }
    }
    for (k, link) in links.iter().enumerate() {
        if let Some(p) = run.peer_mut(k) {
            for (src, r) in p.take_strangers() {
                watch.on_reply(link, src, &r, now);
            }
        }
    }
    if let Some(m) = medium {
        // A shared medium is one link: the first node's.
        if let Some(link) = links.first() {
            for (src, r) in m.take_strangers() {
                watch.on_reply(link, src, &r, now);
            }
        }
    }
    for p in watch.probes(now) {
        if let Some(k) = links.iter().position(|l| *l == p.link) {
            if let Some(peer) = run.peer_mut(k) {
                // A lost datagram is asked again at the next probe.
                let _ = peer.datagram_to(p.dst, &p.request);
            }
        }
    }
    let report = watch.poll(now)?;
    if report.stop {
        run.stop(&stop_reason(&report), now);
    }
    Some(report)
}

/// The run's stop reason for a report: what changed and why it cannot go on.
pub fn stop_reason(r: &WatchReport) -> String {
    let mut s = format!("the modules changed ({})", r.differences.join("; "));
    if !r.reasons.is_empty() {
        s += &format!(": {}", r.reasons.join("; "));
    }
    s
}

/// A watch on links of its own, while no run holds them (`motet machine
/// watch`).
pub struct IdleWatch {
    /// The watch.
    pub watch: ModuleWatch,
    transports: Vec<(String, Box<dyn Transport + Send>)>,
}

impl IdleWatch {
    /// `watch` over `transports`, each named by the link its places use.
    pub fn new(
        watch: ModuleWatch,
        transports: Vec<(String, Box<dyn Transport + Send>)>,
    ) -> IdleWatch {
        IdleWatch { watch, transports }
    }

    /// One turn at `now`: what came, then the probes due; the report when
    /// something changed.
    pub fn turn(&mut self, now: u64) -> std::io::Result<Option<WatchReport>> {
        let mut raw = [0u8; MAX_RAW];
        for (link, t) in &mut self.transports {
            while let Some(bytes) = t.recv(None)? {
                let Ok(f) = frame::decode(&bytes, &mut raw) else {
                    continue;
                };
                if f.header.dst != HOST_ADDRESS || f.header.flags != Flags::NONE {
                    continue;
                }
                if let Ok(r) = decode::<ServiceReply>(f.payload) {
                    self.watch.on_reply(link, f.header.src, &r, now);
                }
            }
        }
        for p in self.watch.probes(now) {
            if let Some((_, t)) = self.transports.iter_mut().find(|(l, _)| *l == p.link) {
                t.send(&datagram(p.dst, &p.request))?;
            }
        }
        Ok(self.watch.poll(now))
    }
}
