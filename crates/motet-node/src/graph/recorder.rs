//! FourTrackRecorder and FourTrackPlayer, on the tape passed into the frame
//! (format in [`super::record`]). A track's block unit is one recorded step:
//! the ports default to 0.01 world units per step (`set_ratio(0.01, 1)`).

use super::component::{Kind, ParamError, Phase};
use super::declare::{live, Declaration, Domain, Param};
use super::io::Ctx;
use super::port::{Port, PortSpec, Unit};
use super::record::{pack, unpack, StepQuantizer, TRACKS};

/// Records four streams, one byte per frame, after the channels ran. Parameter
/// `RECORD`: nonzero starts a new recording (clearing the tape), zero stops.
/// Recording stops by itself when the tape is full.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct FourTrackRecorder {
    recording: bool,
    start: bool,
    full: bool,
    q: [StepQuantizer; TRACKS],
}

impl FourTrackRecorder {
    /// `set_param` id of `record`: nonzero starts a new recording, zero stops.
    pub const RECORD: u8 = 0;

    /// A recorder, not recording.
    pub fn new() -> FourTrackRecorder {
        FourTrackRecorder::default()
    }

    /// Whether it is recording.
    pub fn recording(&self) -> bool {
        self.recording
    }

    /// The tape ran out during the last recording.
    pub fn full(&self) -> bool {
        self.full
    }
}

impl Kind for FourTrackRecorder {
    const DECL: Declaration = Declaration {
        name: "recorder",
        input: None,
        params: &[],
        live: &[live("record", Self::RECORD)],
        host_keys: &[],
        in_ports: &[],
        ports: Self::PORTS,
        doc: "four-track recorder (0.01 units per recorded step)",
        build: |_| Ok(FourTrackRecorder::new().into()),
    };

    const PORTS: &'static [PortSpec] = &[
        PortSpec::input("track0", Unit::Any),
        PortSpec::input("track1", Unit::Any),
        PortSpec::input("track2", Unit::Any),
        PortSpec::input("track3", Unit::Any),
    ];
    const PHASE: Phase = Phase::Post;

    #[inline]
    fn run<const Q: usize>(&mut self, ports: &mut [Port], ctx: &mut Ctx<'_, '_, Q>) {
        if self.start {
            self.start = false;
            ctx.tape.clear();
            for (q, p) in self.q.iter_mut().zip(ports.iter()) {
                *q = StepQuantizer::start(p.value);
            }
        }
        if !self.recording {
            return;
        }
        let mut steps = [0i8; TRACKS];
        for i in 0..TRACKS {
            steps[i] = self.q[i].step(ports[i].value);
        }
        if !ctx.tape.push(pack(steps)) {
            self.recording = false;
            self.full = true;
        }
    }

    fn set_param(&mut self, _ports: &mut [Port], id: u8, v: f64) -> Result<(), ParamError> {
        match id {
            Self::RECORD => {
                if v.is_nan() {
                    return Err(ParamError::BadValue);
                }
                let on = v != 0.0;
                self.start = on;
                self.recording = on;
                if on {
                    self.full = false;
                }
            }
            _ => return Err(ParamError::Unknown),
        }
        Ok(())
    }
}

/// Replays a tape into four outputs, one byte per frame, in the input phase.
/// Parameter `PLAY`: nonzero plays from the start, zero stops; `LOOP`: nonzero
/// loops.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct FourTrackPlayer {
    playing: bool,
    looping: bool,
    cursor: usize,
}

impl FourTrackPlayer {
    /// `set_param` id of `play`: nonzero plays from the start, zero stops.
    pub const PLAY: u8 = 0;
    /// `set_param` id of `loop`: nonzero loops.
    pub const LOOP: u8 = 1;

    /// A player, stopped, at the start of the tape.
    pub fn new() -> FourTrackPlayer {
        FourTrackPlayer::default()
    }

    /// Whether it is playing.
    pub fn playing(&self) -> bool {
        self.playing
    }

    /// The next sample it plays, an index into the tape.
    pub fn cursor(&self) -> usize {
        self.cursor
    }
}

impl Kind for FourTrackPlayer {
    const DECL: Declaration = Declaration {
        name: "player",
        input: None,
        params: &[Param::new("loop", "", 0.0, Domain::Flag)],
        live: &[live("play", Self::PLAY), live("loop", Self::LOOP)],
        host_keys: &[],
        in_ports: &[],
        ports: Self::PORTS,
        doc: "four-track player of the recorder's tape",
        build: |a| {
            let mut player = FourTrackPlayer::new();
            player.looping = a.flag(0);
            Ok(player.into())
        },
    };

    const PORTS: &'static [PortSpec] = &[
        PortSpec::output("track0", Unit::Any),
        PortSpec::output("track1", Unit::Any),
        PortSpec::output("track2", Unit::Any),
        PortSpec::output("track3", Unit::Any),
    ];
    const PHASE: Phase = Phase::Input;

    #[inline]
    fn run<const Q: usize>(&mut self, ports: &mut [Port], ctx: &mut Ctx<'_, '_, Q>) {
        if !self.playing {
            return;
        }
        if self.cursor >= ctx.tape.len() {
            if self.looping && !ctx.tape.is_empty() {
                self.cursor = 0;
            } else {
                self.playing = false;
                return;
            }
        }
        if let Some(b) = ctx.tape.get(self.cursor) {
            for (p, s) in ports.iter_mut().zip(unpack(b)) {
                p.value += s as f64;
            }
        }
        self.cursor += 1;
    }

    fn set_param(&mut self, _ports: &mut [Port], id: u8, v: f64) -> Result<(), ParamError> {
        if v.is_nan() {
            return Err(ParamError::BadValue);
        }
        match id {
            Self::PLAY => {
                self.playing = v != 0.0;
                self.cursor = 0;
            }
            Self::LOOP => self.looping = v != 0.0,
            _ => return Err(ParamError::Unknown),
        }
        Ok(())
    }
}
