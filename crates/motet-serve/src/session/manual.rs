//! What a person does by hand outside a job: jog, say where the machine
//! is, set a tool, blink a node's LED, pair the nodes.

use super::{ActionError, Activity, Client, Session};
use crate::engine::PairOutcome;
use crate::events::Level;
use motet_host::clamp_move;
use motet_planner::{ranges, Command, Located, Move, MoveKind, SourceLoc};

impl Session {
    /// Moves the named axes by the given amounts (`relative`) or to them,
    /// at `feed` units/s (the machine's drawing feed if none).
    pub fn jog(
        &mut self,
        axes: &[(String, f64)],
        relative: bool,
        feed: Option<f64>,
        client: Client,
    ) -> Result<(), ActionError> {
        self.ready("jog")?;
        self.may_drive(client)?;
        let feed = feed.unwrap_or(self.machine.draw_feed);
        if !(feed > 0.0 && feed.is_finite()) {
            return Err(ActionError::OutOfRange {
                what: "feed",
                value: feed,
                range: "> 0 units/s".into(),
            });
        }
        let mut to = self.rest;
        for (name, v) in axes {
            let i = self.axis(name)?;
            if !v.is_finite() {
                return Err(ActionError::OutOfRange {
                    what: "coordinate",
                    value: *v,
                    range: "a finite number".into(),
                });
            }
            to[i] = if relative { to[i] + v } else { *v };
        }
        clamp_move(&self.machine, &self.rest, &mut to)?;
        let cmd = Command::Move(Move {
            target: to,
            feed,
            kind: MoveKind::Feed,
        });
        self.begin(vec![here(cmd)], Activity::Other("jog"), client);
        Ok(())
    }

    /// Says the machine is at these coordinates (the others stay): no
    /// motion; the nodes take the new position with the next run.
    pub fn set_position(
        &mut self,
        axes: &[(String, f64)],
        client: Client,
    ) -> Result<(), ActionError> {
        self.ready("set the position")?;
        self.may_drive(client)?;
        let mut to = self.rest;
        for (name, v) in axes {
            to[self.axis(name)?] = *v;
        }
        motet_host::check_move(&self.machine, &to, &to)?;
        self.rest = to;
        self.events
            .push(self.now, Level::Info, "position set".into());
        Ok(())
    }

    /// Sets a tool output (pen 1 down / 0 up, laser or spindle power 0..=1).
    pub fn set_tool(&mut self, tool: &str, value: f64, client: Client) -> Result<(), ActionError> {
        self.ready("change a tool")?;
        self.may_drive(client)?;
        let index = self
            .machine
            .tools
            .iter()
            .position(|t| t.name == tool)
            .ok_or_else(|| ActionError::UnknownTool {
                name: tool.to_string(),
                tools: names(self.machine.tools.iter().map(|t| &t.name)),
            })?;
        if !ranges::TOOL_VALUE.contains(value) {
            return Err(ActionError::OutOfRange {
                what: "tool value",
                value,
                range: "0..=1".into(),
            });
        }
        let cmd = Command::Tool {
            tool: index as u8,
            value: value as f32,
        };
        self.begin(vec![here(cmd)], Activity::Other("tool change"), client);
        Ok(())
    }

    pub(super) fn axis(&self, name: &str) -> Result<usize, ActionError> {
        self.machine
            .axis(&name.to_ascii_lowercase())
            .ok_or_else(|| ActionError::UnknownAxis {
                name: name.to_string(),
                axes: names(self.machine.axes.iter().map(|a| &a.name)),
            })
    }

    /// Lights node `name`'s identify LED for `seconds` (any client, any
    /// state: it moves nothing).
    pub fn identify(&mut self, name: &str, seconds: f64) -> Result<(), ActionError> {
        let k = self
            .machine
            .nodes
            .iter()
            .position(|n| n.name == name)
            .ok_or_else(|| ActionError::UnknownNode {
                name: name.to_string(),
                nodes: names(self.machine.nodes.iter().map(|n| &n.name)),
            })?;
        if !(0.0..=60.0).contains(&seconds) {
            return Err(ActionError::OutOfRange {
                what: "seconds",
                value: seconds,
                range: "0..=60".into(),
            });
        }
        let ms = (seconds * 1e3).round() as u32;
        if let Some(p) = self.nodes.run_mut().peer_mut(k) {
            p.send_service(&motet_wire::service::ServiceRequest::Identify { ms });
        }
        self.events.push(
            self.now,
            Level::Info,
            format!("identify node {name} for {seconds} s"),
        );
        Ok(())
    }
}

impl Session {
    /// Pairs the devices on the nodes' links with the machine's nodes and
    /// writes the pairing file beside the machine file, as `motet nodes
    /// pair` does for devices alone on their links. Only at rest (idle or
    /// stopped), only by the client in control (who takes control if none
    /// has it); a refusal changes nothing.
    pub fn pair_nodes(&mut self, client: Client) -> Result<PairOutcome, ActionError> {
        self.ready("pair the nodes")?;
        if let (Some(c), me) = (&self.controller, client) {
            if me != Some(c.as_str()) {
                return Err(ActionError::NotController);
            }
        }
        let done = self.nodes.pair(&self.machine, self.rest)?;
        if let Some(c) = client {
            self.controller = Some(c.to_string());
        }
        for line in &done.lines {
            self.events.push(self.now, Level::Info, line.clone());
        }
        self.events.push(
            self.now,
            Level::Info,
            format!("nodes paired: {} written", done.file.display()),
        );
        Ok(done)
    }
}

fn here(item: Command) -> Located<Command> {
    Located {
        loc: SourceLoc { line: 0, column: 0 },
        item,
    }
}

fn names<'a>(it: impl Iterator<Item = &'a String>) -> String {
    it.map(String::as_str).collect::<Vec<_>>().join(", ")
}
