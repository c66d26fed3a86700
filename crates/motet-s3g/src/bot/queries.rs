//! The simulated bot's answers to queries.

use super::Bot;
use crate::command::{code, Command};
use crate::reply::{Reply, ReplyCode};
use crate::tool::{sub, Heater};

/// Firmware version reported (7.6, as a Replicator's Sailfish).
pub const VERSION: u16 = 760;

impl Bot {
    /// Answers a query now.
    pub(super) fn answer(&mut self, cmd: &Command) -> Reply {
        let ok = |body: Vec<u8>| Reply::new(ReplyCode::Success, body);
        match cmd {
            Command::Version(_) => ok(VERSION.to_le_bytes().to_vec()),
            Command::GetBufferSize => ok((self.free() as u32).to_le_bytes().to_vec()),
            Command::ClearBuffer | Command::Abort => {
                self.stop();
                ok(vec![])
            }
            Command::IsFinished => ok(vec![u8::from(self.finished())]),
            Command::GetPositionExt => {
                let mut b: Vec<u8> = self
                    .position_now()
                    .iter()
                    .flat_map(|s| s.to_le_bytes())
                    .collect();
                b.extend_from_slice(&[0, 0]);
                ok(b)
            }
            Command::ToolQuery { tool, sub, .. } => self.tool_query(*tool, *sub),
            Command::Other { code: c, body } => match *c {
                code::ADVANCED_VERSION => {
                    let mut b = VERSION.to_le_bytes().to_vec();
                    // Internal version, variant (0x80: Sailfish), reserved.
                    b.extend_from_slice(&[0, 0, 0x80, 0, 0, 0]);
                    ok(b)
                }
                // Pause: acknowledged, the simulation does not pause.
                code::PAUSE => ok(vec![]),
                // Board status: nothing to report.
                23 => ok(vec![0]),
                // Build name.
                20 => ok(b"motet\0".to_vec()),
                // Read EEPROM (offset u16, count u8): blank, all zeros.
                12 => ok(vec![0; body.get(2).map_or(0, |&n| n as usize).min(31)]),
                _ => Reply::new(ReplyCode::NotSupported, vec![]),
            },
            _ => Reply::new(ReplyCode::NotSupported, vec![]),
        }
    }

    fn tool_query(&mut self, tool: u8, s: u8) -> Reply {
        let temp = |c: f64| {
            let c = c.round() as i16;
            Reply::new(ReplyCode::Success, c.to_le_bytes().to_vec())
        };
        let ready = |r: bool| Reply::new(ReplyCode::Success, vec![u8::from(r)]);
        match s {
            sub::GET_TEMP => temp(self.temperature(Heater::Tool(tool)).0),
            sub::GET_SP => temp(self.temperature(Heater::Tool(tool)).1),
            sub::GET_PLATFORM_TEMP => temp(self.temperature(Heater::Platform).0),
            sub::GET_PLATFORM_SP => temp(self.temperature(Heater::Platform).1),
            sub::IS_TOOL_READY => ready(self.heater(Heater::Tool(tool)).ready()),
            sub::IS_PLATFORM_READY => ready(self.heater(Heater::Platform).ready()),
            _ => Reply::new(ReplyCode::NotSupported, vec![]),
        }
    }
}
