//! Live reconfiguration: a watch over the modules of a machine while the
//! host is connected. A module is known by its uid. Every module answers
//! the watch's probe (the head of its description: kind, uid, digest;
//! one broadcast request per link, every [`WatchConfig::probe_us`]), and a
//! module that starts or is plugged in announces its head unasked. So the
//! watch learns of a module that came at once, of one replaced or changed
//! at the next probe (its uid or digest is new: its description is read
//! again, every part asked at once), and of one gone when it has not
//! answered for [`WatchConfig::missing_us`]. Each change re-derives the
//! machine from the modules present (the file's order, a replacement in
//! the old one's place, a newcomer at the workpiece end), re-checks it and
//! the job against it, and says exactly what changed.
//!
//! The watch holds no transport: it says what to send ([`ModuleWatch::probes`])
//! and is given what came ([`ModuleWatch::on_reply`]), so it runs beside a
//! networked run ([`super::run_watch`]) and on its own links alike, on any
//! clock.

use motet_host::module::{bus_check, fits, Difference, Expected, FoundModule, JobNeeds, Place};
use motet_wire::describe::{Assembler, DescribePart, Description, Head};
use motet_wire::frame::BROADCAST;
use motet_wire::service::{ServiceReply, ServiceRequest};

/// How often the watch asks and how long it waits.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct WatchConfig {
    /// Between probes, µs.
    pub probe_us: u64,
    /// A module silent this long is gone, µs.
    pub missing_us: u64,
    /// A part of a description asked for and not come is asked again
    /// after this long, µs.
    pub retry_us: u64,
}

impl Default for WatchConfig {
    /// A probe every 150 ms, gone after 500 ms of silence (three probes
    /// unanswered): a change is noticed within about 0.6 s.
    fn default() -> Self {
        WatchConfig {
            probe_us: 150_000,
            missing_us: 500_000,
            retry_us: 50_000,
        }
    }
}

/// A request for the driver to send: on `link`, to `dst`.
#[derive(Clone, Debug, PartialEq)]
pub struct Probe {
    /// The link.
    pub link: String,
    /// The destination address.
    pub dst: u16,
    /// The request.
    pub request: ServiceRequest,
}

/// What the watch says after a change.
#[derive(Clone, Debug, PartialEq)]
pub struct WatchReport {
    /// When the change was noticed, µs of the watch's clock.
    pub at_us: u64,
    /// Every difference between the bus and the machine file, as text.
    pub differences: Vec<String>,
    /// Why the machine the bus makes now is not viable, or the job does
    /// not fit it; empty when it is and it does.
    pub reasons: Vec<String>,
    /// A running job must stop: the machine is not viable for it, or a
    /// node it drives is gone or replaced.
    pub stop: bool,
    /// The watch checks a job (not only the machine).
    pub job: bool,
}

impl WatchReport {
    /// One paragraph for the person: what changed, then the verdict.
    pub fn text(&self) -> String {
        let mut s = String::from("the modules changed:");
        for d in &self.differences {
            s += &format!("\n  - {d}");
        }
        if self.differences.is_empty() {
            s += "\n  - every module is back as the machine file records it";
        }
        let what = if self.job { " for the job" } else { "" };
        if self.reasons.is_empty() {
            s += &format!("\nthe machine is still viable{what}");
        } else {
            s += &format!("\nthe machine is not viable{what}:");
            for r in &self.reasons {
                s += &format!("\n  - {r}");
            }
        }
        s
    }
}

/// One module the watch knows of.
#[derive(Clone, Debug)]
struct Seen {
    place: Place,
    head: Head,
    /// The description that goes with `head`, once read.
    description: Option<Description>,
    /// When it last answered, µs.
    last: u64,
    /// Reading a new description.
    reading: Option<Reading>,
    /// Gone (not heard for `missing_us`).
    gone: bool,
}

#[derive(Clone, Debug)]
struct Reading {
    parts: Assembler,
    started: u64,
    asked: Option<u64>,
}

/// The watch over one machine's modules (see the module documentation).
#[derive(Clone, Debug)]
pub struct ModuleWatch {
    cfg: WatchConfig,
    expected: Vec<Expected>,
    needs: Option<JobNeeds>,
    links: Vec<String>,
    seen: Vec<Seen>,
    next_probe: Option<u64>,
    dirty: bool,
    last: Option<(Vec<String>, Vec<String>)>,
}

impl ModuleWatch {
    /// A watch over `expected` (each recorded module where the session
    /// found it, present as recorded at first), checking the job's `needs`
    /// against each machine the bus makes.
    pub fn new(expected: Vec<Expected>, needs: Option<JobNeeds>, cfg: WatchConfig) -> ModuleWatch {
        let mut links: Vec<String> = Vec::new();
        for e in &expected {
            if !links.contains(&e.place.link) {
                links.push(e.place.link.clone());
            }
        }
        let seen = expected
            .iter()
            .map(|e| Seen {
                place: e.place.clone(),
                head: e.record.description.head(e.record.uid),
                description: Some(e.record.description.clone()),
                last: 0,
                reading: None,
                gone: false,
            })
            .collect();
        ModuleWatch {
            cfg,
            expected,
            needs,
            links,
            seen,
            next_probe: None,
            dirty: false,
            last: None,
        }
    }

    /// Takes a reply that came on `link` from `src`.
    pub fn on_reply(&mut self, link: &str, src: u16, reply: &ServiceReply, now: u64) {
        let ServiceReply::Description { part, data } = reply else {
            return;
        };
        if let DescribePart::Head(h) = data {
            let place = Place {
                link: link.to_string(),
                address: src,
            };
            // Another device at a module's address took its place: that
            // one is gone (two cannot answer at one address). Unpaired
            // modules (address 0) share theirs.
            if src != motet_wire::service::UNPAIRED {
                for s in &mut self.seen {
                    if s.head.uid != h.uid && s.place == place && !s.gone {
                        s.gone = true;
                        self.dirty = true;
                    }
                }
            }
            match self.seen.iter_mut().find(|s| s.head.uid == h.uid) {
                Some(s) => {
                    s.last = now;
                    if s.gone {
                        s.gone = false;
                        self.dirty = true;
                    }
                    if s.place != place {
                        s.place = place;
                        self.dirty = true;
                    }
                    let reading = s.reading.as_ref().map(|r| *r.parts.head());
                    if h.digest != s.head.digest && reading.is_none_or(|r| r.digest != h.digest) {
                        s.reading = Assembler::new(*h).ok().map(|parts| Reading {
                            parts,
                            started: now,
                            asked: None,
                        });
                    }
                }
                None => self.seen.push(Seen {
                    place,
                    head: *h,
                    description: None,
                    last: now,
                    reading: Assembler::new(*h).ok().map(|parts| Reading {
                        parts,
                        started: now,
                        asked: None,
                    }),
                    gone: false,
                }),
            }
            return;
        }
        // A part of a description being read: the one reading at that
        // place (one at a time per place).
        let Some(s) = self
            .seen
            .iter_mut()
            .find(|s| s.reading.is_some() && s.place.link == link && s.place.address == src)
        else {
            return;
        };
        let Some(r) = s.reading.as_mut() else { return };
        if r.parts.take(*part, data.clone()).is_err() {
            return;
        }
        if r.parts.missing().is_none() {
            if let Ok(d) = r.parts.finish() {
                s.head = *r.parts.head();
                s.description = Some(d);
                s.reading = None;
                self.dirty = true;
            }
        }
    }

    /// What to send now: the probes when due, and the parts of the
    /// descriptions being read that have not come.
    pub fn probes(&mut self, now: u64) -> Vec<Probe> {
        let mut out = Vec::new();
        let due = *self.next_probe.get_or_insert(now);
        if now >= due {
            for link in &self.links {
                out.push(Probe {
                    link: link.clone(),
                    dst: BROADCAST,
                    request: ServiceRequest::Describe { uid: None, part: 0 },
                });
            }
            self.next_probe = Some(now + self.cfg.probe_us);
            if self.seen.iter().all(|s| s.last == 0) {
                // Until the first probe went out, nothing was silent.
                for s in &mut self.seen {
                    s.last = now;
                }
            }
        }
        let mut busy: Vec<(String, u16)> = Vec::new();
        for s in &mut self.seen {
            let Some(r) = s.reading.as_mut() else {
                continue;
            };
            let key = (s.place.link.clone(), s.place.address);
            if busy.contains(&key) {
                continue;
            }
            busy.push(key);
            if r.asked.is_some_and(|t| now < t + self.cfg.retry_us) {
                continue;
            }
            r.asked = Some(now);
            let uid = r.parts.head().uid;
            // Every part still missing, at once.
            for part in (1..r.parts.head().parts).filter(|&i| !r.parts.has(i)) {
                out.push(Probe {
                    link: s.place.link.clone(),
                    dst: BROADCAST,
                    request: ServiceRequest::Describe {
                        uid: Some(uid),
                        part,
                    },
                });
            }
        }
        out
    }

    /// Notes who went silent and, after a change, re-derives the machine
    /// and checks it and the job: the report when the verdict or the
    /// differences changed.
    pub fn poll(&mut self, now: u64) -> Option<WatchReport> {
        for s in &mut self.seen {
            if !s.gone && s.last > 0 && now > s.last + self.cfg.missing_us {
                s.gone = true;
                self.dirty = true;
            }
            // A description that never comes whole: read as unreadable.
            let stale = s
                .reading
                .as_ref()
                .filter(|r| now > r.started + self.cfg.missing_us)
                .map(|r| *r.parts.head());
            if let Some(head) = stale {
                s.reading = None;
                s.description = None;
                s.head = head;
                self.dirty = true;
            }
        }
        if !self.dirty || self.seen.iter().any(|s| s.reading.is_some() && !s.gone) {
            return None;
        }
        self.dirty = false;
        let found: Vec<FoundModule> = self
            .seen
            .iter()
            .filter(|s| !s.gone)
            .map(|s| FoundModule {
                place: s.place.clone(),
                uid: s.head.uid,
                firmware: None,
                description: s
                    .description
                    .clone()
                    .ok_or_else(|| "its description did not come whole".to_string()),
            })
            .collect();
        let check = bus_check(&self.expected, &found);
        let differences: Vec<String> = check.differences.iter().map(|d| d.to_string()).collect();
        let mut reasons: Vec<String> = match &check.viability {
            Ok(()) => Vec::new(),
            Err(e) => e.reasons.iter().map(|r| r.to_string()).collect(),
        };
        if let (Some(needs), Ok(())) = (&self.needs, &check.viability) {
            if let Err(e) = fits(&check.now, needs) {
                reasons.extend(e.reasons.iter().map(|r| r.to_string()));
            }
        }
        // A node of the run gone or replaced takes its share of the
        // trajectory with it: the run cannot go on without it.
        let lost = check.differences.iter().any(|d| {
            matches!(
                d,
                Difference::Missing { .. }
                    | Difference::Replaced { .. }
                    | Difference::Unreadable { .. }
            )
        });
        let changed = !check.same_machine && reasons.is_empty();
        if changed && !lost {
            reasons.push("the modules make another machine than the one the job runs on: compose it again (`motet machine from-scan`)".into());
        }
        let stop = lost || !reasons.is_empty();
        let key = (differences.clone(), reasons.clone());
        if self.last.as_ref() == Some(&key) {
            return None;
        }
        self.last = Some(key);
        Some(WatchReport {
            at_us: now,
            differences,
            reasons,
            stop,
            job: self.needs.is_some(),
        })
    }

    /// The links the watch probes.
    pub fn links(&self) -> &[String] {
        &self.links
    }
}
