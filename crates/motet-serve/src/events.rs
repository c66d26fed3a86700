//! What happened on the machine, for the person: a bounded log with
//! sequence numbers, so a screen that reconnects asks only for what it
//! missed.

use serde::Serialize;
use std::collections::VecDeque;

/// Events kept; older ones are forgotten (a server runs for days).
pub const KEPT: usize = 256;

/// How much an event matters.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize)]
#[serde(rename_all = "lowercase")]
pub enum Level {
    /// Something the person may want to know.
    Info,
    /// Something the person should look at.
    Warn,
    /// Something went wrong.
    Error,
}

/// One event.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct Event {
    /// Its number, counting from 1.
    pub seq: u64,
    /// Server time, µs.
    pub t_us: u64,
    /// How much it matters.
    pub level: Level,
    /// What happened.
    pub message: String,
}

/// The newest [`KEPT`] events.
#[derive(Debug, Default)]
pub struct EventLog {
    events: VecDeque<Event>,
    seq: u64,
}

impl EventLog {
    /// Records an event.
    pub fn push(&mut self, t_us: u64, level: Level, message: String) {
        self.seq += 1;
        if self.events.len() == KEPT {
            self.events.pop_front();
        }
        self.events.push_back(Event {
            seq: self.seq,
            t_us,
            level,
            message,
        });
    }

    /// Number of the newest event (0: none yet).
    pub fn last_seq(&self) -> u64 {
        self.seq
    }

    /// The events after `seq` that are still kept, oldest first.
    pub fn since(&self, seq: u64) -> Vec<Event> {
        self.events
            .iter()
            .filter(|e| e.seq > seq)
            .cloned()
            .collect()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn keeps_the_newest_and_numbers_them() {
        let mut log = EventLog::default();
        for i in 0..(KEPT as u64 + 10) {
            log.push(i, Level::Info, format!("e{i}"));
        }
        let all = log.since(0);
        assert_eq!(all.len(), KEPT);
        assert_eq!(all[0].seq, 11);
        assert_eq!(log.last_seq(), KEPT as u64 + 10);
        assert_eq!(log.since(log.last_seq() - 2).len(), 2);
    }
}
