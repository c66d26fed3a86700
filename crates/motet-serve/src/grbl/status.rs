//! The `?` status report: `<State|MPos:…|Bf:…|FS:…|Ov:…|WCO:…>`.

use super::axes::Axes;
use super::realtime::Overrides;
use super::settings::Local;
use crate::session::{Session, State};
use motet_trajectory::Point;

/// grbl's name for what the machine is doing.
pub fn state_name(s: &Session, check_mode: bool, program_paused: bool) -> &'static str {
    match s.state() {
        State::Idle if program_paused => "Hold:0",
        // Lines queued, their run about to start: grbl starts its cycle as
        // soon as a block is queued, and senders wait for Idle to finish.
        State::Idle if s.streaming() => "Run",
        State::Idle if check_mode => "Check",
        State::Idle => "Idle",
        State::Running if s.jogging() => "Jog",
        State::Running => "Run",
        // Braking on the path for a hold, a cancel or a stop.
        State::Holding | State::Stopping => "Hold:1",
        State::Paused => "Hold:0",
        State::Stopped | State::Alarm => "Alarm",
    }
}

/// What a report needs besides the session.
pub struct Report<'a> {
    /// grbl's axes.
    pub axes: &'a Axes,
    /// `$10`, `$13`.
    pub local: &'a Local,
    /// The overrides.
    pub overrides: &'a Overrides,
    /// Work coordinate offset (work = machine − offset), machine axes.
    pub wco: Point,
    /// Tool power 0..=1 in use, for `FS:`'s spindle speed (of `$30`=1000).
    pub tool: f64,
    /// Check mode.
    pub check_mode: bool,
    /// Paused by `M0`.
    pub program_paused: bool,
    /// Receive buffer room, bytes.
    pub rx_free: usize,
}

/// The report line, without its line end.
pub fn report(s: &Session, r: &Report) -> String {
    let st = s.status();
    let mut p = [0.0; motet_trajectory::MAX_AXES];
    p[..st.position.len()].copy_from_slice(&st.position);
    let mpos = r.axes.values(&p);
    let wco = r.axes.values(&r.wco);
    let (key, pos) = if r.local.status_mask & 1 == 1 {
        ("MPos", mpos)
    } else {
        ("WPos", mpos.iter().zip(&wco).map(|(m, o)| m - o).collect())
    };
    let inches = r.local.inches;
    let mut out = format!(
        "<{}|{key}:{}",
        state_name(s, r.check_mode, r.program_paused),
        Axes::format(&pos, inches)
    );
    if r.local.status_mask & 2 == 2 {
        let bf = s.stream_status();
        out.push_str(&format!("|Bf:{},{}", bf.blocks_free, r.rx_free));
    }
    let unit = if inches { 25.4 } else { 1.0 };
    out.push_str(&format!(
        "|FS:{:.0},{:.0}",
        st.speed * 60.0 / unit,
        r.tool * 1000.0
    ));
    let o = r.overrides;
    out.push_str(&format!("|Ov:{},{},{}", o.feed, o.rapid, o.spindle));
    out.push_str(&format!("|WCO:{}>", Axes::format(&wco, inches)));
    out
}
