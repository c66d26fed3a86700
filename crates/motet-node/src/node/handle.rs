//! Messages from the host: each is decoded, checked and acted on whole, or
//! refused with nothing changed. The acting lives with what it acts on (the
//! configuration, the queues, the window, the hosted graph); here each
//! message finds it.

use super::Node;
use motet_wire::{decode, HostMessage, NodeMessage, Refusal};

impl<const Q: usize, const T: usize> Node<Q, T> {
    /// Acts on one message received as bytes. Returns a reply when there is one
    /// to send: a status on request, or a refusal, in which case nothing changed.
    pub fn handle(&mut self, bytes: &[u8]) -> Option<NodeMessage> {
        let reply = match decode(bytes) {
            Ok(msg) => self.act(msg),
            Err(_) => Err(Refusal::Malformed),
        };
        reply.unwrap_or_else(|reason| Some(NodeMessage::Refused { reason }))
    }

    /// A seal for every node at once (a group seal, with this node's end):
    /// what [`HostMessage::Seal`] does (the endpoint confirms it with a
    /// heartbeat, and sends a refusal through the link).
    pub fn group_seal(&mut self, next_seq: u32) -> Result<(), Refusal> {
        self.seal(next_seq)
    }

    /// Acts on a decoded message, family by family; `Ok` holds the reply, if
    /// the message has one besides a refusal.
    fn act(&mut self, msg: HostMessage) -> Result<Option<NodeMessage>, Refusal> {
        let done = match msg {
            // Questions: answered, nothing changes.
            HostMessage::Status => return Ok(Some(self.status_message())),
            HostMessage::Where => return Ok(Some(self.position())),
            HostMessage::TallyGet => {
                return self
                    .tally
                    .as_ref()
                    .map(|t| Some(t.message()))
                    .ok_or(Refusal::BadConfig)
            }
            // Configuration, at rest.
            HostMessage::Reset => self.reset(),
            HostMessage::ConfigureChannel(c) => self.configure_channel(c),
            HostMessage::ConfigureTool(t) => self.configure_tool(t),
            HostMessage::ConfigureStream(c) => self.configure_stream(c),
            HostMessage::SetPosition { position } => self.set_position(&position).inspect(|_| {
                // At rest: the next batched segment carries its start.
                self.stream_state.valid = false;
            }),
            // The trajectory: segments and tool events.
            HostMessage::Segment(s) => self.push_segment(&s).inspect(|_| {
                // A batch after a plain segment carries its start.
                self.stream_state.valid = false;
            }),
            HostMessage::Segments(b) => self.push_batch(&b),
            HostMessage::Event { track, time, value } => self.push_event(track, time, value, 0.0),
            HostMessage::EventPerSpeed {
                track,
                time,
                value,
                feed,
            } => self.push_event_per_speed(track, time, value, feed),
            // Windows.
            HostMessage::Windowed { run } => self.open_window(run),
            // No reply: the link's acknowledgement confirms a seal (a
            // status would cost the node a frame and the host its ack).
            HostMessage::Seal { next_seq } => self.seal(next_seq),
            HostMessage::SegmentsSealed(b) => {
                // Refused whole when no seal can follow.
                self.takes_seals()?;
                self.push_batch(&b)?;
                self.seal(self.next_seq)
            }
            // The hosted graph.
            HostMessage::GraphBegin { frame_us } => self.begin_graph(frame_us),
            HostMessage::GraphAdd { kind, params } => self.add_component(kind, &params),
            HostMessage::GraphRatio { port, world, block } => {
                self.set_port_ratio(port, world, block)
            }
            HostMessage::GraphMap {
                from,
                to,
                mode,
                tap,
            } => self.map_ports(from, to, mode, tap),
            HostMessage::GraphCommit => self.commit_graph(),
            HostMessage::GraphParam {
                component,
                param,
                value,
            } => self.set_graph_param(component, param, value),
            HostMessage::GraphInput { kind, index, value } => self.set_input(kind, index, value),
            HostMessage::GraphClear => {
                self.clear_graph();
                Ok(())
            }
            // Closed loops.
            HostMessage::ConfigureServo(c) => self.configure_servo(c),
            HostMessage::ServoGains { channel, gains } => self.servo_gains(channel, gains),
            HostMessage::Sampling { source, every } => self.sampling(source, every),
            HostMessage::ConfigureSensor(c) => self.configure_sensor(c),
            HostMessage::ServoTest { channel, test } => self.servo_test(channel, test),
            HostMessage::ConfigureHeater(c) => self.configure_heater(c),
        };
        done.map(|()| None)
    }
}
