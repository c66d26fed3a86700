//! Code tables: the G and M codes this interpreter knows, by modal group,
//! and the codes it accepts with a warning only.

/// Axis letters in slot order.
pub(crate) const AXIS_LETTERS: [u8; 7] = *b"XYZEABC";

pub(crate) const SLOT_E: usize = 3;

pub(crate) fn axis_slot(letter: u8) -> Option<usize> {
    AXIS_LETTERS.iter().position(|&l| l == letter)
}

pub(crate) fn code_name(letter: u8, code: u32) -> String {
    let l = letter as char;
    if code % 10 == 0 {
        format!("{l}{}", code / 10)
    } else {
        format!("{l}{}.{}", code / 10, code % 10)
    }
}

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum Motion {
    Rapid,
    Linear,
    Cw,
    Ccw,
}

impl Motion {
    pub(crate) fn name(self) -> &'static str {
        match self {
            Motion::Rapid => "G0",
            Motion::Linear => "G1",
            Motion::Cw => "G2",
            Motion::Ccw => "G3",
        }
    }
}

/// Group 0: codes that act once.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum NonModal {
    Dwell,
    /// G10 with or without L (decided by the L word).
    G10,
    Unretract,
    Home,
    SetHome,
    Machine,
    SetPosition,
    ResetPosition,
}

impl NonModal {
    pub(crate) fn name(self) -> &'static str {
        match self {
            NonModal::Dwell => "G4",
            NonModal::G10 => "G10",
            NonModal::Unretract => "G11",
            NonModal::Home => "G28",
            NonModal::SetHome => "G28.1",
            NonModal::Machine => "G53",
            NonModal::SetPosition => "G92",
            NonModal::ResetPosition => "G92.1",
        }
    }
}

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum Plane {
    Xy,
    Zx,
    Yz,
}

impl Plane {
    pub(crate) fn name(self) -> &'static str {
        match self {
            Plane::Xy => "G17",
            Plane::Zx => "G18",
            Plane::Yz => "G19",
        }
    }

    /// Letter slots of the plane's first and second axis.
    pub(crate) fn slots(self) -> (usize, usize) {
        match self {
            Plane::Xy => (0, 1),
            Plane::Zx => (2, 0),
            Plane::Yz => (1, 2),
        }
    }

    /// Centre-offset letters (first axis, second axis, normal axis), as
    /// indices into [I, J, K].
    pub(crate) fn offsets(self) -> (usize, usize, usize) {
        match self {
            Plane::Xy => (0, 1, 2),
            Plane::Zx => (2, 0, 1),
            Plane::Yz => (1, 2, 0),
        }
    }
}

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum Spindle {
    Cw,
    Ccw,
    Off,
}

impl Spindle {
    pub(crate) fn name(self) -> &'static str {
        match self {
            Spindle::Cw => "M3",
            Spindle::Ccw => "M4",
            Spindle::Off => "M5",
        }
    }
}

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum Stop {
    Pause,
    OptionalPause,
    End(u32),
}

impl Stop {
    pub(crate) fn name(self) -> &'static str {
        match self {
            Stop::Pause => "M0",
            Stop::OptionalPause => "M1",
            Stop::End(20) => "M2",
            Stop::End(_) => "M30",
        }
    }
}

/// Printer codes that read the rest of their line as arguments.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum Printer {
    Hotend { wait: bool },
    Bed { wait: bool },
    Chamber { wait: bool },
    FanOn,
    FanOff,
    Sync,
}

/// Why a slicer code is harmless here, or None if it is not one we accept.
pub(crate) fn ignored_m(code: u32) -> Option<&'static str> {
    Some(match code {
        840 => "(disable motors) accepted: motors are always on in simulation",
        170 => "(enable motors) accepted: motors are always on in simulation",
        180 => "(disable motors) accepted: motors are always on in simulation",
        1140 => "(report position) accepted: the position report happens on the machine",
        1050 => "(report temperatures) ignored",
        730 => "(set print progress) ignored",
        1170 => "(display message) ignored",
        1150 => "(report firmware) ignored",
        2010 => "(set max acceleration) ignored: limits come from the machine file",
        2030 => "(set max feed rate) ignored: limits come from the machine file",
        2040 => "(set acceleration) ignored: limits come from the machine file",
        2050 => "(set jerk) ignored: limits come from the machine file",
        2200 => "(set feed rate percentage) ignored",
        2210 => "(set flow percentage) ignored",
        9000 => "(set linear advance) ignored",
        8620..=8629 => "(printer check) ignored",
        _ => return None,
    })
}

pub(crate) fn ignored_g(code: u32) -> Option<&'static str> {
    Some(match code {
        290 => "(bed levelling) ignored: no probe on this machine",
        800 => "(cancel canned cycle) ignored",
        _ => return None,
    })
}

pub(crate) fn printer_code(code: u32) -> Option<Printer> {
    Some(match code {
        1040 => Printer::Hotend { wait: false },
        1090 => Printer::Hotend { wait: true },
        1400 => Printer::Bed { wait: false },
        1900 => Printer::Bed { wait: true },
        1410 => Printer::Chamber { wait: false },
        1910 => Printer::Chamber { wait: true },
        1060 => Printer::FanOn,
        1070 => Printer::FanOff,
        4000 => Printer::Sync,
        _ => return None,
    })
}
