//! Staged workflows: a small state machine the host runs by sending
//! parameter changes, instead of imperative code around the graph.
//!
//! ```toml
//! [[stage]]
//! name = "wait"
//! until = { pressed = "rec_button" }      # an input goes from 0 to nonzero
//!
//! [[stage]]
//! name = "record"
//! set = { "rec.record" = 1 }              # parameter changes on entry
//! until = { released = "rec_button" }     # an input goes back to 0
//! after = { "rec.record" = 0 }            # parameter changes on exit
//!
//! [[stage]]
//! name = "replay"
//! set = { "player.play" = 1 }
//! until = { finished = "player" }         # a player, position generator,
//!                                         # homing or recorder is done
//! after = { "z_lift.go_relative" = 0.5 }
//! repeat = 4                              # run the stage 4 times
//! next = "end"                            # default: the following stage
//! ```
//!
//! `until = { seconds = 2.5 }` waits a time; a stage without `until` stays.

use crate::file::{names, FileError, GraphFile, Source};
use motet_node::graph::{Component, HomingState};
use motet_wire::HostMessage;
use serde::Deserialize;
use std::collections::BTreeMap;
use toml::Spanned;

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub(crate) struct RawStage {
    name: Spanned<String>,
    #[serde(default)]
    set: BTreeMap<Spanned<String>, Spanned<f64>>,
    #[serde(default)]
    until: Option<Spanned<RawUntil>>,
    #[serde(default)]
    after: BTreeMap<Spanned<String>, Spanned<f64>>,
    #[serde(default)]
    repeat: Option<Spanned<i64>>,
    #[serde(default)]
    next: Option<Spanned<String>>,
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct RawUntil {
    #[serde(default)]
    pressed: Option<Spanned<String>>,
    #[serde(default)]
    released: Option<Spanned<String>>,
    #[serde(default)]
    seconds: Option<Spanned<f64>>,
    #[serde(default)]
    finished: Option<Spanned<String>>,
}

/// One parameter change.
#[derive(Clone, Debug, PartialEq)]
pub struct Change {
    /// `component.param`.
    pub what: String,
    /// The value it is set to, in the parameter's units.
    pub value: f64,
    /// The `GraphParam` message that makes the change on the node.
    pub message: HostMessage,
}

/// When a stage ends.
#[derive(Clone, Debug, PartialEq)]
pub enum Until {
    /// The input goes from 0 to nonzero.
    Pressed(String),
    /// The input goes from nonzero to 0.
    Released(String),
    /// This long after the stage began.
    Seconds(f64),
    /// The component is done (player stopped, position generator arrived,
    /// homing done, recorder stopped).
    Finished {
        /// The component's name in the file.
        component: String,
        /// Its index in the graph, as the node reports it.
        index: u8,
    },
    /// Never.
    Never,
}

/// One `[[stage]]` of a graph file.
#[derive(Clone, Debug, PartialEq)]
pub struct Stage {
    /// Its name, unique in the file; the log shows it as `name#pass`.
    pub name: String,
    /// Parameter changes sent on entering it (every pass).
    pub set: Vec<Change>,
    /// When it ends.
    pub until: Until,
    /// Parameter changes sent when it ends (every pass).
    pub after: Vec<Change>,
    /// How many passes it runs before going on; at least 1.
    pub repeat: u32,
    /// The stage after the last pass; `None`: the machine stops.
    pub next: Option<usize>,
}

fn changes(
    src: &Source,
    gf: &GraphFile,
    key: &str,
    m: &BTreeMap<Spanned<String>, Spanned<f64>>,
) -> Result<Vec<Change>, FileError> {
    let mut v: Vec<_> = m.iter().collect();
    v.sort_by_key(|(k, _)| k.span().start);
    let mut out = Vec::new();
    for (k, val) in v {
        let what = k.get_ref();
        let Some((c, p)) = what.rsplit_once('.') else {
            return Err(src.err(
                k.span(),
                format!("{key}.{what}"),
                "expected \"component.parameter\"",
            ));
        };
        let message = gf
            .set(c, p, *val.get_ref())
            .map_err(|e| src.err(k.span(), format!("{key}.{what}"), e.to_string()))?;
        out.push(Change {
            what: what.clone(),
            value: *val.get_ref(),
            message,
        });
    }
    Ok(out)
}

pub(crate) fn compile(
    src: &Source,
    gf: &GraphFile,
    raw: &[Spanned<RawStage>],
) -> Result<Vec<Stage>, FileError> {
    let names_list: Vec<&str> = raw
        .iter()
        .map(|s| s.get_ref().name.get_ref().as_str())
        .collect();
    let mut out = Vec::new();
    for (i, s) in raw.iter().enumerate() {
        let r = s.get_ref();
        let key = format!("stage[{i}]");
        if names_list[..i].contains(&r.name.get_ref().as_str()) {
            return Err(src.err(
                r.name.span(),
                format!("{key}.name"),
                format!("a stage `{}` comes before", r.name.get_ref()),
            ));
        }
        let until = until(src, gf, &key, r.until.as_ref())?;
        let repeat = match &r.repeat {
            None => 1,
            Some(n) if *n.get_ref() >= 1 && *n.get_ref() <= u32::MAX as i64 => *n.get_ref() as u32,
            Some(n) => {
                return Err(src.err(n.span(), format!("{key}.repeat"), "expected a count ≥ 1"))
            }
        };
        let next = match &r.next {
            None => (i + 1 < raw.len()).then_some(i + 1),
            Some(n) if n.get_ref() == "end" => None,
            Some(n) => Some(
                names_list
                    .iter()
                    .position(|x| x == n.get_ref())
                    .ok_or_else(|| {
                        src.err(
                            n.span(),
                            format!("{key}.next"),
                            format!(
                                "no stage `{}`; stages: {}, or \"end\"",
                                n.get_ref(),
                                names_list.join(", ")
                            ),
                        )
                    })?,
            ),
        };
        out.push(Stage {
            name: r.name.get_ref().clone(),
            set: changes(src, gf, &format!("{key}.set"), &r.set)?,
            until,
            after: changes(src, gf, &format!("{key}.after"), &r.after)?,
            repeat,
            next,
        });
    }
    Ok(out)
}

/// A stage's `until`.
fn until(
    src: &Source,
    gf: &GraphFile,
    key: &str,
    until: Option<&Spanned<RawUntil>>,
) -> Result<Until, FileError> {
    Ok(match until {
        None => Until::Never,
        Some(u) => {
            let ur = u.get_ref();
            let n = [
                ur.pressed.is_some(),
                ur.released.is_some(),
                ur.seconds.is_some(),
                ur.finished.is_some(),
            ]
            .iter()
            .filter(|b| **b)
            .count();
            if n != 1 {
                return Err(src.err(
                    u.span(),
                    format!("{key}.until"),
                    "give exactly one of pressed, released, seconds, finished",
                ));
            }
            let input = |s: &Spanned<String>, what: &str| {
                if gf.input(s.get_ref()).is_some() {
                    Ok(s.get_ref().clone())
                } else {
                    Err(src.err(
                        s.span(),
                        format!("{key}.until.{what}"),
                        format!(
                            "no input `{}`; inputs: {}",
                            s.get_ref(),
                            names(gf.inputs.iter().map(|i| i.name.as_str()))
                        ),
                    ))
                }
            };
            if let Some(p) = &ur.pressed {
                Until::Pressed(input(p, "pressed")?)
            } else if let Some(p) = &ur.released {
                Until::Released(input(p, "released")?)
            } else if let Some(t) = &ur.seconds {
                if !(t.get_ref().is_finite() && *t.get_ref() >= 0.0) {
                    return Err(src.err(
                        t.span(),
                        format!("{key}.until.seconds"),
                        "expected a time ≥ 0",
                    ));
                }
                Until::Seconds(*t.get_ref())
            } else {
                let f = ur.finished.as_ref().expect("counted");
                let c = gf.component(f.get_ref());
                let ok = c.is_some_and(|c| {
                    matches!(c.info.name, "player" | "position" | "homing" | "recorder")
                });
                if !ok {
                    return Err(src.err(
                        f.span(),
                        format!("{key}.until.finished"),
                        format!(
                            "`{}` is not a player, position generator, homing or recorder of the graph",
                            f.get_ref()
                        ),
                    ));
                }
                Until::Finished {
                    component: f.get_ref().clone(),
                    index: c.expect("checked").index,
                }
            }
        }
    })
}

/// What the stage machine looks at.
pub trait StageView {
    /// The current value of input `name` (as last sent to the node).
    fn input(&self, name: &str) -> f64;
    /// Whether graph component `index` is done (see [`finished`]).
    fn finished(&self, index: u8) -> bool;
}

/// Whether a component is done: a player not playing, a position generator
/// not moving, a homing cycle done (or idle), a recorder not recording; other
/// kinds always are.
pub fn finished(c: &Component) -> bool {
    match c {
        Component::FourTrackPlayer(p) => !p.playing(),
        Component::PositionGenerator(p) => !p.moving(),
        Component::Homing(h) => matches!(h.state(), HomingState::Done | HomingState::Idle),
        Component::FourTrackRecorder(r) => !r.recording(),
        _ => true,
    }
}

/// Runs a graph file's stages.
#[derive(Clone, Debug)]
pub struct StageMachine {
    stages: Vec<Stage>,
    current: Option<usize>,
    pass: u32,
    entered_s: f64,
    prev: f64,
    log: Vec<(f64, String)>,
}

impl StageMachine {
    /// The file's stages, none entered yet (call [`StageMachine::start`]).
    pub fn new(file: &GraphFile) -> StageMachine {
        StageMachine {
            stages: file.stages.clone(),
            current: None,
            pass: 0,
            entered_s: 0.0,
            prev: 0.0,
            log: Vec::new(),
        }
    }

    /// The stage running, if any.
    pub fn current(&self) -> Option<&str> {
        self.current.map(|i| self.stages[i].name.as_str())
    }

    /// Which pass of the current stage runs (1-based).
    pub fn pass(&self) -> u32 {
        self.pass
    }

    /// Stages entered so far: time (s) and `name#pass`.
    pub fn log(&self) -> &[(f64, String)] {
        &self.log
    }

    fn enter(
        &mut self,
        i: usize,
        pass: u32,
        t_s: f64,
        view: &dyn StageView,
        out: &mut Vec<HostMessage>,
    ) {
        self.current = Some(i);
        self.pass = pass;
        self.entered_s = t_s;
        let s = &self.stages[i];
        self.prev = match &s.until {
            Until::Pressed(n) | Until::Released(n) => view.input(n),
            _ => 0.0,
        };
        self.log.push((t_s, format!("{}#{}", s.name, pass)));
        out.extend(s.set.iter().map(|c| c.message.clone()));
    }

    /// Enters the first stage; returns its parameter changes.
    pub fn start(&mut self, t_s: f64, view: &dyn StageView) -> Vec<HostMessage> {
        let mut out = Vec::new();
        if !self.stages.is_empty() {
            self.enter(0, 1, t_s, view, &mut out);
        }
        out
    }

    /// Checks the current stage's exit condition at time `t_s`; on exit,
    /// returns its `after` changes and the next stage's `set` changes.
    pub fn update(&mut self, t_s: f64, view: &dyn StageView) -> Vec<HostMessage> {
        let mut out = Vec::new();
        let Some(i) = self.current else {
            return out;
        };
        let s = &self.stages[i];
        let done = match &s.until {
            Until::Never => false,
            Until::Seconds(d) => t_s - self.entered_s >= *d,
            Until::Finished { index, .. } => view.finished(*index),
            Until::Pressed(n) => {
                let v = view.input(n);
                let edge = self.prev == 0.0 && v != 0.0;
                self.prev = v;
                edge
            }
            Until::Released(n) => {
                let v = view.input(n);
                let edge = self.prev != 0.0 && v == 0.0;
                self.prev = v;
                edge
            }
        };
        if !done {
            return out;
        }
        out.extend(s.after.iter().map(|c| c.message.clone()));
        if self.pass < s.repeat {
            let p = self.pass + 1;
            self.enter(i, p, t_s, view, &mut out);
        } else if let Some(n) = s.next {
            self.enter(n, 1, t_s, view, &mut out);
        } else {
            self.current = None;
            self.log.push((t_s, "end".to_string()));
        }
        out
    }
}
