//! Devices: programs that talk to a machine in their own protocol (a grbl
//! sender, the AxiDraw software, a printer host) connect to one on a
//! pseudo-terminal or a TCP port ([`port`]) and drive the server's session
//! through it. A device is a protocol adapter and nothing more: it turns the
//! protocol's bytes into session actions and the session's state into the
//! protocol's replies; it never talks to nodes.
//!
//! To add one: implement [`Device`] in a module of its own (see
//! [`crate::grbl::Grbl`]), open it with [`crate::Server::device`], and give
//! `motet serve` a flag for it.

pub(crate) mod gcode;
pub mod port;
mod pty;
mod unix;

use crate::session::Session;

/// A protocol adapter on one connection. The port's thread calls
/// [`Device::receive`] with the bytes that came in, then [`Device::poll`]
/// (also when nothing came, every couple of milliseconds, so replies that
/// wait on the machine go out when it is ready), with the session locked,
/// and sends what [`Device::take_output`] gives.
pub trait Device: Send + 'static {
    /// The connection opened (a greeting, if the protocol has one).
    fn open(&mut self);
    /// Bytes from the program, in order.
    fn receive(&mut self, bytes: &[u8], s: &mut Session);
    /// Acts on what was received as far as the machine allows now.
    fn poll(&mut self, s: &mut Session);
    /// What to send to the program, taken.
    fn take_output(&mut self) -> Vec<u8>;
    /// Whether the port should read more: false while the device's own
    /// buffer is full, so a program that does not count bytes blocks.
    fn wants_input(&self) -> bool {
        true
    }
}
