//! The machine's simulated heaters (a printer's hot end and bed): each a
//! first-order lag toward its target ([`motet_host::heater`]), advanced on
//! the session's clock. Targets come from the temperature commands of what
//! the machine runs (M104/M109, M140/M190, M141/M191 in a job or a stream)
//! as the machine reaches them, or from a protocol adapter at once
//! ([`Session::set_heater_target`]), which also reads whether a heater is
//! ready ([`Session::heater_ready`]) to hold a wait.
//!
//! Which heaters a machine has: its machine file's `[heaters.NAME]`
//! ([`motet_host::Heater`]); without that section, a machine with an
//! extruder axis `e` has a hot end and a bed, others none.
//!
//! The simulation does not hold motion for a waiting command (M109 in a
//! job sets the target where the machine reaches it; the machine does not
//! wait there): a protocol adapter holds its own wait before streaming on.

use super::{Activity, Session};
use crate::events::Level;
use crate::session::ActionError;
use motet_host::heater::Heater;
use motet_planner::{AuxChannel, Command, Located};
use serde::Serialize;
use std::collections::VecDeque;

/// One heater as a screen or a protocol reports it.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct HeaterState {
    /// Its name (`hotend`, `bed`).
    pub name: String,
    /// Which temperature commands set it.
    #[serde(serialize_with = "channel_name")]
    pub channel: AuxChannel,
    /// Temperature now, °C.
    pub temp: f64,
    /// Target, °C; 0 is off.
    pub target: f64,
    /// Share of full power, 0..=1.
    pub power: f64,
    /// Highest target it takes, °C.
    pub max: f64,
}

fn channel_name<S: serde::Serializer>(c: &AuxChannel, s: S) -> Result<S::Ok, S::Error> {
    s.serialize_str(&channel_label(*c))
}

/// A channel as the status and errors name it: `hotend0`, `bed`, `chamber`.
fn channel_label(c: AuxChannel) -> String {
    match c {
        AuxChannel::Hotend(i) => format!("hotend{i}"),
        AuxChannel::Bed => "bed".into(),
        AuxChannel::Chamber => "chamber".into(),
        AuxChannel::Fan(i) => format!("fan{i}"),
        AuxChannel::Coolant => "coolant".into(),
    }
}

/// The heaters and the temperature commands of the current run not yet
/// reached.
#[derive(Default)]
pub(crate) struct Heaters {
    states: Vec<HeaterState>,
    models: Vec<Heater>,
    /// When the heaters were last advanced, µs.
    at_us: u64,
    /// (run command index, channel, target) in run order.
    pending: VecDeque<(usize, AuxChannel, f32)>,
}

impl Heaters {
    /// The heaters of `machine` (see the module documentation), cold.
    pub(crate) fn of(machine: &motet_host::Machine) -> Heaters {
        let mut h = Heaters::default();
        for spec in &machine.heaters {
            h.add(&spec.name, spec.channel, spec.max_c, spec.tau_s);
        }
        h
    }

    fn add(&mut self, name: &str, channel: AuxChannel, max: f64, tau_s: f64) {
        let m = Heater::new(tau_s);
        self.states.push(HeaterState {
            name: name.into(),
            channel,
            temp: m.temp,
            target: m.target,
            power: 0.0,
            max,
        });
        self.models.push(m);
    }

    fn index(&self, channel: AuxChannel) -> Option<usize> {
        self.states.iter().position(|h| h.channel == channel)
    }

    /// A new run of `commands`: its temperature commands wait to be reached.
    pub(crate) fn track(&mut self, commands: &[Located<Command>], first_index: usize) {
        for (i, c) in commands.iter().enumerate() {
            if let Command::Aux { channel, value, .. } = c.item {
                if self.index(channel).is_some() {
                    self.pending.push_back((first_index + i, channel, value));
                }
            }
        }
    }

    fn advance(&mut self, now: u64) {
        let dt = now.saturating_sub(self.at_us) as f64 * 1e-6;
        self.at_us = self.at_us.max(now);
        for (m, s) in self.models.iter_mut().zip(&mut self.states) {
            m.advance(dt);
            s.temp = m.temp;
            s.power = m.power(s.max);
        }
    }

    fn set(&mut self, k: usize, target: f64) {
        self.models[k].target = target;
        self.states[k].target = target;
        self.states[k].power = self.models[k].power(self.states[k].max);
    }
}

impl Session {
    /// Server time the session was last ticked to, µs: the clock heaters
    /// and protocol keep-alives run on.
    pub fn now_us(&self) -> u64 {
        self.now
    }

    /// The machine's heaters now.
    pub fn heaters(&self) -> &[HeaterState] {
        &self.heaters.states
    }

    /// Sets the target of the heater on `channel` now, °C (0 is off):
    /// refused, changing nothing, when the machine has no such heater or
    /// the target is above the heater's maximum or below 0.
    pub fn set_heater_target(
        &mut self,
        channel: AuxChannel,
        target: f64,
    ) -> Result<(), ActionError> {
        let k = self
            .heaters
            .index(channel)
            .ok_or_else(|| ActionError::UnknownHeater {
                channel: channel_label(channel),
                heaters: self
                    .heaters
                    .states
                    .iter()
                    .map(|h| h.name.as_str())
                    .collect::<Vec<_>>()
                    .join(", "),
            })?;
        let max = self.heaters.states[k].max;
        if !(0.0..=max).contains(&target) {
            return Err(ActionError::OutOfRange {
                what: "heater target °C",
                value: target,
                range: format!("0 to {max}"),
            });
        }
        self.heaters.advance(self.now);
        self.heaters.set(k, target);
        Ok(())
    }

    /// Whether the heater on `channel` is within its ready band of its
    /// target (or off); `None` if the machine has no such heater.
    pub fn heater_ready(&self, channel: AuxChannel) -> Option<bool> {
        let k = self.heaters.index(channel)?;
        Some(self.heaters.models[k].ready())
    }

    /// Every heater off (an emergency stop).
    pub(super) fn heaters_off(&mut self) {
        self.heaters.pending.clear();
        for k in 0..self.heaters.states.len() {
            self.heaters.set(k, 0.0);
        }
    }

    /// The run stopped on its path: what it had not reached does not run.
    pub(super) fn heaters_run_stopped(&mut self) {
        self.heaters.pending.clear();
    }

    /// A run begins with `commands`.
    pub(super) fn heaters_track_run(&mut self, commands: &[Located<Command>]) {
        self.heaters.pending.clear();
        self.heaters.track(commands, 0);
    }

    /// `commands` join the current run at `first_index`.
    pub(super) fn heaters_track_more(&mut self, commands: &[Located<Command>], first_index: usize) {
        self.heaters.track(commands, first_index);
    }

    /// On the clock: the heaters advance; temperature commands the run has
    /// reached (those before the command it moves on; all of them once it
    /// is done) set their targets.
    pub(super) fn heaters_tick(&mut self, run_done: bool) {
        self.heaters.advance(self.now);
        if self.heaters.pending.is_empty() {
            return;
        }
        let running = !matches!(self.activity, Activity::None) || run_done;
        let reached = if run_done {
            usize::MAX
        } else if running {
            self.nodes.run().command_at(self.now as f64).unwrap_or(0)
        } else {
            0
        };
        while let Some(&(i, channel, value)) = self.heaters.pending.front() {
            if i >= reached {
                break;
            }
            self.heaters.pending.pop_front();
            if let Err(e) = self.set_heater_target(channel, f64::from(value)) {
                self.events
                    .push(self.now, Level::Warn, format!("temperature not set: {e}"));
            }
        }
    }
}
