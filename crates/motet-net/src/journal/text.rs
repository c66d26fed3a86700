//! The records' text form, written by the writer and by `Journal::to_text`,
//! and the form a record must have when read back.

use super::*;

pub(super) fn fmt_point(p: &Point) -> String {
    p.iter()
        .map(|v| format!("{v:?}"))
        .collect::<Vec<_>>()
        .join(" ")
}

pub(super) fn header_text(h: &JournalHeader) -> String {
    format!(
        "motet-journal {JOURNAL_FORMAT} run={:08x} machine={} job={} t0={:?} min_move_s={:?} start={}",
        h.run,
        h.machine,
        h.job,
        h.t0,
        h.min_move_s,
        fmt_point(&h.start)
    )
}

pub(super) fn segment_text(s: &JournalSegment) -> String {
    format!(
        "seg {} {} {:?} {:?} {} | {}",
        s.index,
        s.command,
        s.t0,
        s.t1,
        fmt_point(&s.start),
        fmt_point(&s.end)
    )
}

pub(super) fn pace_text(p: &JournalPace) -> String {
    format!("pace {} {:?}", p.command, p.min_move_s)
}

pub(super) fn hold_text(h: &JournalHold) -> String {
    format!("hold {} {:?}", h.command, h.seconds)
}

pub(super) fn seal_text(kind: &str, s: &JournalSeal) -> String {
    format!("{kind} {} {} {} {}", s.end, s.tail, s.done, s.time)
}

pub(super) fn stop_text(s: &JournalStop) -> String {
    let lost = if s.lost.is_empty() {
        "-".to_string()
    } else {
        s.lost
            .iter()
            .map(|k| k.to_string())
            .collect::<Vec<_>>()
            .join(",")
    };
    format!("{} {lost}", seal_text("stop", &s.seal))
}

/// The record's line (newline included), its checksum chained after `chain`
/// (then moved on to it).
pub(super) fn signed(chain: &mut u32, text: &str) -> String {
    *chain = record_checksum(*chain, text);
    format!("{text} *{:08x}\n", *chain)
}
