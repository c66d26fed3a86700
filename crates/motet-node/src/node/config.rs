//! What a node is set up with at rest: its channels, tool outputs, the
//! encoding of batched segments, and where it stands.

use super::{Node, MAX_STEPS_PER_UNIT};
use crate::channel::Channel;
use crate::tally::StepTally;
use crate::tool::ToolOutput;
use motet_trajectory::Point;
use motet_wire::control::{SampleSource, SensorConfig, ServoConfig, ServoGains, ServoTest};
use motet_wire::{ChannelConfig, Refusal, StreamConfig, ToolConfig};

impl<const Q: usize, const T: usize> Node<Q, T> {
    /// Back to a new node, keeping a kept tally (started again). A node with
    /// committed motion keeps it: a reset would lose its position mid-move
    /// (a second host, or a stray message).
    pub(super) fn reset(&mut self) -> Result<(), Refusal> {
        if self.moving() {
            return Err(Refusal::NotAtRest);
        }
        let tally = self.tally.map(|_| StepTally::default());
        let fixed_time = self.fixed_time;
        // A heater forgotten must not stay on: its output goes off at the
        // next poll.
        let heaters = self.control.heater_drives();
        *self = Self::new();
        self.tally = tally;
        self.fixed_time = fixed_time;
        self.control.switch_off_later(heaters);
        Ok(())
    }

    pub(super) fn configure_channel(&mut self, c: ChannelConfig) -> Result<(), Refusal> {
        // Beyond a million steps per unit the step counter and the poll loop
        // would run away; no real drive comes near it.
        let spu = c.steps_per_unit.abs();
        let valid = spu.is_finite()
            && spu > 0.0
            && spu <= MAX_STEPS_PER_UNIT
            && c.map.is_valid()
            && c.timing_is_valid();
        if !valid || !self.segments.is_empty() || self.control.has_servo(c.channel) {
            return Err(Refusal::BadConfig);
        }
        // At rest where the node is: a new or changed channel takes its step
        // count from the current point instead of stepping there.
        let mut ch = Channel::new(c);
        ch.use_fixed_time(self.fixed_time);
        ch.set_position(&self.queue_end);
        match self
            .channels
            .iter_mut()
            .find(|x| x.config().channel == c.channel)
        {
            Some(existing) => *existing = ch,
            None => self.channels.push(ch).map_err(|_| Refusal::BadConfig)?,
        }
        Ok(())
    }

    pub(super) fn configure_tool(&mut self, t: ToolConfig) -> Result<(), Refusal> {
        let out = ToolOutput::new(t);
        match self.tools.iter_mut().find(|x| x.output() == t.output) {
            Some(existing) => *existing = out,
            None => self.tools.push(out).map_err(|_| Refusal::BadConfig)?,
        }
        Ok(())
    }

    pub(super) fn configure_stream(&mut self, c: StreamConfig) -> Result<(), Refusal> {
        if !c.is_valid() || !self.segments.is_empty() {
            return Err(Refusal::BadConfig);
        }
        self.stream = c;
        self.stream_state.valid = false;
        Ok(())
    }

    pub(super) fn set_position(&mut self, p: &Point) -> Result<(), Refusal> {
        if !p.iter().all(|x| x.is_finite()) {
            return Err(Refusal::Malformed);
        }
        if !self.segments.is_empty() {
            return Err(Refusal::NotAtRest);
        }
        for ch in self.channels.iter_mut() {
            ch.set_position(p);
        }
        self.control.set_position(p);
        self.queue_end = *p;
        self.stopped = false;
        self.pending_events = 0;
        self.events.clear();
        Ok(())
    }
}

impl<const Q: usize, const T: usize> Node<Q, T> {
    /// A servo channel, at rest where the node is; its board channel id
    /// not a step channel's.
    pub(super) fn configure_servo(&mut self, c: ServoConfig) -> Result<(), Refusal> {
        let taken = self
            .channels
            .iter()
            .any(|x| x.config().channel == c.channel)
            || self.control.has_heater_drive(c.channel);
        if !c.is_valid() || taken || !self.segments.is_empty() {
            return Err(Refusal::BadConfig);
        }
        self.control.configure_servo(c, &self.queue_end)
    }

    /// New gains for a servo, moving or not.
    pub(super) fn servo_gains(&mut self, channel: u8, gains: ServoGains) -> Result<(), Refusal> {
        self.control.set_gains(channel, gains)
    }

    /// Samples of a source upstream, one every `every` of its ticks.
    pub(super) fn sampling(&mut self, source: SampleSource, every: u32) -> Result<(), Refusal> {
        self.control.set_sampling(source, every)
    }

    /// A sensor channel.
    pub(super) fn configure_sensor(&mut self, c: SensorConfig) -> Result<(), Refusal> {
        if !motet_wire::control::LOOP_HZ.contains(&c.rate_hz) {
            return Err(Refusal::BadConfig);
        }
        self.control.configure_sensor(c)
    }

    /// A heater channel, off until its track sets a target; at rest.
    pub(super) fn configure_heater(
        &mut self,
        c: motet_wire::heater::HeaterConfig,
    ) -> Result<(), Refusal> {
        if !self.segments.is_empty() {
            return Err(Refusal::BadConfig);
        }
        self.control.configure_heater(c)
    }

    /// A tuning test on a servo, at rest.
    pub(super) fn servo_test(&mut self, channel: u8, test: ServoTest) -> Result<(), Refusal> {
        if !self.segments.is_empty() {
            return Err(Refusal::NotAtRest);
        }
        self.control.start_test(channel, test)
    }
}
