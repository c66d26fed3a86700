//! The board's queries, answered from the adapter's state and the
//! session's: motion status bits from the stream, the pen as commanded,
//! the step counters, the pause button.

use super::parse::Line;
use super::reply::{EbbError, Ending};
use super::{Ebb, Step};
use crate::session::{Session, State, STREAM_BLOCKS};

/// `QC`'s reply: the motor current reference and the supply voltage in
/// the board's ADC counts; the supply reads as a healthy 9 V (about 300)
/// so the AxiDraw software raises no low-power warning.
const QC: &str = "0394,0300";

impl Ebb {
    pub(super) fn query(&mut self, l: &Line, s: &mut Session) -> Result<Step, EbbError> {
        let sy = self.syntax;
        let name = l.name.as_str();
        let data = |d: &str, e: Ending, named: bool| Ok(Step::Reply(sy.data(name, d, e, named)));
        match name {
            "QB" => {
                l.arity(0, 0)?;
                let b = std::mem::take(&mut self.button);
                data(if b { "1" } else { "0" }, Ending::NormOk, false)
            }
            "QC" => {
                l.arity(0, 0)?;
                data(QC, Ending::NormOk, false)
            }
            "QE" => {
                l.arity(0, 0)?;
                let m = self.motors.map(|m| if m == 0 { 0 } else { 32 >> m });
                data(&format!("{},{}", m[0], m[1]), Ending::NormOk, false)
            }
            "QG" => {
                l.arity(0, 0)?;
                let g = self.status_byte(s);
                data(&format!("{g:02X}"), Ending::Norm, false)
            }
            "QL" => {
                l.arity(0, 1)?;
                let i = l.int(0, 0, 31)?.unwrap_or(0);
                data(&self.vars[i as usize].to_string(), Ending::NormOk, false)
            }
            "QM" => {
                l.arity(0, 0)?;
                let g = self.status_byte(s);
                let bit = |b: u8| (g >> b) & 1;
                let d = format!("{},{},{},{}", bit(3), bit(2), bit(1), bit(0));
                data(&d, Ending::Rev, true)
            }
            "QP" => {
                l.arity(0, 0)?;
                data(if self.pen_up { "1" } else { "0" }, Ending::RevOk, false)
            }
            "QR" => {
                l.arity(0, 0)?;
                data(
                    if self.servo_power { "1" } else { "0" },
                    Ending::RevOk,
                    false,
                )
            }
            "QS" => {
                l.arity(0, 0)?;
                let [a, b] = self.steps.counters;
                data(&format!("{a},{b}"), Ending::RevOk, false)
            }
            "QT" => {
                l.arity(0, 0)?;
                let n = self.nickname.clone();
                data(&n, Ending::NormOk, false)
            }
            "PI" => {
                l.arity(2, 0)?;
                let port = l.port(0)?;
                let pin = l.req(1, 0, 7)?;
                let v = self.pins.get(&(port, pin)).copied().unwrap_or(0);
                data(&v.to_string(), Ending::Norm, true)
            }
            _ => Err(EbbError::Unknown(l.name.clone())),
        }
    }

    /// `QG`'s bits: 5 button (cleared by reading), 4 pen up, 3 a command
    /// executing, 2 and 1 motors moving, 0 more commands queued behind it.
    fn status_byte(&mut self, s: &Session) -> u8 {
        let queued = STREAM_BLOCKS - s.stream_status().blocks_free;
        let moving =
            s.streaming() && matches!(s.state(), State::Running | State::Holding | State::Stopping);
        let executing = moving || queued > 0 || (s.streaming() && s.state() == State::Paused);
        let mut g = 0u8;
        if std::mem::take(&mut self.button) {
            g |= 1 << 5;
        }
        if self.pen_up {
            g |= 1 << 4;
        }
        if executing {
            g |= 1 << 3;
        }
        if moving {
            g |= 0b110;
        }
        if queued > 1 {
            g |= 1;
        }
        g
    }
}
