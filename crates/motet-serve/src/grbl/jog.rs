//! `$J=` jogs: axis words and a feed, with only G20/G21, G90/G91 and G53
//! besides; beyond the machine's travel → `error:15`.

use super::errors::code;
use super::{Grbl, Step, CLIENT};
use crate::session::{ActionError, Session, State};

impl Grbl {
    pub(super) fn jog(&mut self, words: &str, s: &mut Session) -> Step {
        match s.state() {
            State::Running if s.jogging() => return Step::Wait,
            State::Idle if !s.streaming() => {}
            State::Alarm | State::Stopped => return Step::Reply(Err(code::LOCKED)),
            _ => return Step::Reply(Err(code::NOT_IDLE)),
        }
        let modal = self.interp.modal();
        let (mut inches, mut relative, mut machine) = (modal.inches, modal.relative, false);
        let mut feed = None;
        let mut values: Vec<(usize, f64)> = Vec::new();
        let bytes: Vec<char> = words.chars().filter(|c| !c.is_whitespace()).collect();
        let mut i = 0;
        while i < bytes.len() {
            let letter = bytes[i];
            if !letter.is_ascii_alphabetic() {
                return Step::Reply(Err(code::EXPECTED_LETTER));
            }
            let start = i + 1;
            let mut end = start;
            while end < bytes.len() && (bytes[end].is_ascii_digit() || "+-.".contains(bytes[end])) {
                end += 1;
            }
            let text: String = bytes[start..end].iter().collect();
            let Ok(v) = text.parse::<f64>() else {
                return Step::Reply(Err(code::BAD_NUMBER));
            };
            if !v.is_finite() {
                return Step::Reply(Err(code::BAD_NUMBER));
            }
            i = end;
            match letter {
                'G' => match text.as_str() {
                    "20" => inches = true,
                    "21" => inches = false,
                    "90" => relative = false,
                    "91" => relative = true,
                    "53" => machine = true,
                    _ => return Step::Reply(Err(code::BAD_JOG)),
                },
                'F' => feed = Some(v),
                l => {
                    let Some(k) = self.axes.letters.iter().position(|a| *a == l) else {
                        return Step::Reply(Err(code::BAD_JOG));
                    };
                    let Some(axis) = self.axes.map[k] else {
                        // An axis grbl has and this machine does not.
                        return Step::Reply(Err(code::TRAVEL));
                    };
                    if values.iter().any(|(a, _)| *a == axis) {
                        return Step::Reply(Err(code::REPEATED));
                    }
                    values.push((axis, v));
                }
            }
        }
        let Some(f) = feed else {
            return Step::Reply(Err(code::UNDEFINED_FEED));
        };
        if values.is_empty() {
            return Step::Reply(Err(code::NO_AXIS_WORDS));
        }
        let unit = if inches { 25.4 } else { 1.0 };
        if f <= 0.0 {
            return Step::Reply(Err(code::NEGATIVE));
        }
        let rest = s.rest();
        let names: Vec<(String, f64)> = values
            .iter()
            .map(|&(axis, v)| {
                let v = v * unit;
                let to = if relative && !machine {
                    rest[axis] + v
                } else if machine {
                    v
                } else {
                    v + modal.offset[axis]
                };
                (s.machine().axes[axis].name.clone(), to)
            })
            .collect();
        match s.jog(&names, false, Some(f * unit / 60.0), CLIENT) {
            Ok(()) => Step::Reply(Ok(())),
            Err(ActionError::Unreachable(e)) => {
                self.message(&e.to_string());
                Step::Reply(Err(code::TRAVEL))
            }
            Err(e) => {
                self.message(&e.to_string());
                Step::Reply(Err(code::BAD_JOG))
            }
        }
    }
}
