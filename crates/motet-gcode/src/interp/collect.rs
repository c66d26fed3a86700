//! Collecting a line into [`Words`]: each code into its modal group, each
//! parameter word into its slot; nothing is executed yet.

use motet_planner::SourceError;

use super::diagnostics::WarnKey;
use super::Interp;
use crate::block::{claim, PArgs, Param, Words};
use crate::codes::{
    axis_slot, code_name, ignored_g, ignored_m, printer_code, Motion, NonModal, Plane, Spindle,
    Stop,
};
use crate::lex::{code10, number, Lexer, Word};

impl Interp {
    /// Reads one line into its words and executes it.
    pub(crate) fn line(&mut self, line: &str, line_no: u32) -> Result<(), SourceError> {
        self.line.clear();
        self.line.push_str(line);
        self.line_no = line_no;
        if line.trim() == "%" {
            return Ok(());
        }
        let mut w = Words::default();
        let mut lx = Lexer::new(line);
        while let Some(word) = lx.next_word().map_err(|e| self.lex_err(e))? {
            match word.letter {
                b'G' => {
                    if self.g_word(&mut w, word)? {
                        lx.skip_rest().map_err(|e| self.lex_err(e))?;
                        break;
                    }
                }
                b'M' => {
                    if self.m_word(&mut w, word, &mut lx)? {
                        break;
                    }
                }
                b'T' => match code10(word.text) {
                    Some(c) if c % 10 == 0 && c <= 2550 => {
                        if w.t.is_some() {
                            return Err(self.error(word.at, "T appears twice on this line"));
                        }
                        w.t = Some(((c / 10) as u8, word.at));
                    }
                    _ => {
                        let what = format!("unsupported tool select T{}", word.text);
                        self.unknown(word, what)?;
                    }
                },
                b'N' => {
                    if word.text.is_empty() || !word.text.bytes().all(|c| c.is_ascii_digit()) {
                        return Err(
                            self.error(word.at, format!("bad line number 'N{}'", word.text))
                        );
                    }
                }
                _ => self.param_word(&mut w, word)?,
            }
        }
        self.execute(&w)
    }

    /// A parameter word (axis, I J K R F S P L) into its slot, once per line.
    fn param_word(&mut self, w: &mut Words, word: Word<'_>) -> Result<(), SourceError> {
        let l = word.letter;
        let slot = match l {
            b'I' => &mut w.ijk[0],
            b'J' => &mut w.ijk[1],
            b'K' => &mut w.ijk[2],
            b'R' => &mut w.r,
            b'F' => &mut w.f,
            b'S' => &mut w.s,
            b'P' => &mut w.p,
            b'L' => &mut w.l,
            _ => match axis_slot(l) {
                Some(s) => {
                    if self.letter_axis[s].is_none() {
                        return Err(self.error(
                            word.at,
                            format!(
                                "axis {} is not on this machine (axes: {})",
                                l as char,
                                self.axes_list()
                            ),
                        ));
                    }
                    &mut w.axes[s]
                }
                None => {
                    let what = format!("unsupported word {}{}", l as char, word.text);
                    self.unknown(word, what)?;
                    w.unknown_g = true;
                    return Ok(());
                }
            },
        };
        if slot.is_some() {
            return Err(self.error(word.at, format!("{} appears twice on this line", l as char)));
        }
        let value = if word.text.is_empty() {
            if axis_slot(l).is_none() {
                return Err(self.error(word.at, format!("{} without a number", l as char)));
            }
            None
        } else {
            match number(word.text) {
                Some(v) => Some(v),
                None => {
                    return Err(self.error(
                        word.at,
                        format!("bad number '{}' in {}{}", word.text, l as char, word.text),
                    ))
                }
            }
        };
        *slot = Some(Param { value, at: word.at });
        Ok(())
    }
}

impl Interp {
    /// Record a G word. Returns true if the rest of the line is its arguments
    /// and should be skipped.
    fn g_word(&mut self, w: &mut Words, word: Word<'_>) -> Result<bool, SourceError> {
        let Some(code) = code10(word.text) else {
            let what = format!("unsupported G-code G{}", word.text);
            self.unknown(word, what)?;
            w.unknown_g = true;
            return Ok(false);
        };
        let at = word.at;
        let name = || code_name(b'G', code);
        match code {
            0 | 10 | 20 | 30 => {
                let m = match code {
                    0 => Motion::Rapid,
                    10 => Motion::Linear,
                    20 => Motion::Cw,
                    _ => Motion::Ccw,
                };
                claim(&mut w.motion, m, at, |o| {
                    self.same_group(at, &name(), o.name())
                })?;
            }
            40 | 100 | 110 | 280 | 281 | 530 | 920 | 921 => {
                let n = match code {
                    40 => NonModal::Dwell,
                    100 => NonModal::G10,
                    110 => NonModal::Unretract,
                    280 => NonModal::Home,
                    281 => NonModal::SetHome,
                    530 => NonModal::Machine,
                    920 => NonModal::SetPosition,
                    _ => NonModal::ResetPosition,
                };
                claim(&mut w.nonmodal, n, at, |o| {
                    self.same_group(at, &name(), o.name())
                })?;
            }
            170 | 180 | 190 => {
                let p = match code {
                    170 => Plane::Xy,
                    180 => Plane::Zx,
                    _ => Plane::Yz,
                };
                claim(&mut w.plane, p, at, |o| {
                    self.same_group(at, &name(), o.name())
                })?;
            }
            930 | 940 => {
                claim(&mut w.feed_mode, code == 930, at, |inv| {
                    self.same_group(at, &name(), if inv { "G93" } else { "G94" })
                })?;
            }
            200 | 210 => {
                claim(&mut w.units, code == 200, at, |inch| {
                    self.same_group(at, &name(), if inch { "G20" } else { "G21" })
                })?;
            }
            900 | 910 => {
                claim(&mut w.distance, code == 910, at, |rel| {
                    self.same_group(at, &name(), if rel { "G91" } else { "G90" })
                })?;
            }
            901 | 911 => {
                claim(&mut w.arc_distance, code == 911, at, |rel| {
                    self.same_group(at, &name(), if rel { "G91.1" } else { "G90.1" })
                })?;
            }
            540 | 550 | 560 | 570 | 580 | 590 => {
                claim(&mut w.wcs, (code / 10 - 54) as usize, at, |o| {
                    self.same_group(at, &name(), &format!("G{}", 54 + o))
                })?;
            }
            _ => {
                if let Some(why) = ignored_g(code) {
                    self.warn(WarnKey(b'G', code), at, || format!("{} {why}", name()));
                    return Ok(true);
                }
                let what = format!("unsupported G-code {}", name());
                self.unknown(word, what)?;
                w.unknown_g = true;
            }
        }
        Ok(false)
    }

    /// Record an M word. Returns true if the rest of the line was consumed.
    fn m_word(
        &mut self,
        w: &mut Words,
        word: Word<'_>,
        lx: &mut Lexer<'_>,
    ) -> Result<bool, SourceError> {
        let at = word.at;
        let Some(c) = code10(word.text) else {
            self.unknown(word, format!("unsupported M-code M{}", word.text))?;
            lx.skip_rest().map_err(|e| self.lex_err(e))?;
            return Ok(true);
        };
        let name = || code_name(b'M', c);
        match c {
            0 | 10 | 20 | 300 => {
                let s = match c {
                    0 => Stop::Pause,
                    10 => Stop::OptionalPause,
                    _ => Stop::End(c),
                };
                claim(&mut w.stop, s, at, |o| {
                    self.same_group(at, &name(), o.name())
                })?;
            }
            30 | 40 | 50 => {
                let s = match c {
                    30 => Spindle::Cw,
                    40 => Spindle::Ccw,
                    _ => Spindle::Off,
                };
                claim(&mut w.spindle, s, at, |o| {
                    self.same_group(at, &name(), o.name())
                })?;
            }
            70 | 80 | 90 => {
                let v = match c {
                    70 => 1,
                    80 => 2,
                    _ => 0,
                };
                claim(&mut w.coolant, v, at, |o| {
                    self.same_group(at, &name(), ["M9", "M7", "M8"][usize::from(o)])
                })?;
            }
            820 | 830 => {
                claim(&mut w.extrusion, c == 830, at, |rel| {
                    self.same_group(at, &name(), if rel { "M83" } else { "M82" })
                })?;
            }
            _ => {
                if let Some(pc) = printer_code(c) {
                    let args = self.printer_args(lx)?;
                    w.printer = Some((pc, c, at, args));
                    return Ok(true);
                }
                if let Some(why) = ignored_m(c) {
                    self.warn(WarnKey(b'M', c), at, || format!("{} {why}", name()));
                } else {
                    self.unknown(word, format!("unsupported M-code {}", name()))?;
                }
                lx.skip_rest().map_err(|e| self.lex_err(e))?;
                return Ok(true);
            }
        }
        Ok(false)
    }

    /// The rest of a printer code's line: S R P T numbers; other letters
    /// (firmware extras such as M104 B/F or M106 I) are ignored.
    fn printer_args(&mut self, lx: &mut Lexer<'_>) -> Result<PArgs, SourceError> {
        let mut a = PArgs::default();
        while let Some(word) = lx.next_word().map_err(|e| self.lex_err(e))? {
            let slot = match word.letter {
                b'S' => &mut a.s,
                b'R' => &mut a.r,
                b'P' => &mut a.p,
                b'T' => &mut a.t,
                _ => continue,
            };
            let l = word.letter as char;
            if slot.is_some() {
                return Err(self.error(word.at, format!("{l} appears twice on this line")));
            }
            match number(word.text) {
                Some(v) => *slot = Some(v),
                None if word.text.is_empty() => {
                    return Err(self.error(word.at, format!("{l} without a number")))
                }
                None => {
                    return Err(self.error(
                        word.at,
                        format!("bad number '{}' in {l}{}", word.text, word.text),
                    ))
                }
            }
        }
        Ok(a)
    }
}
