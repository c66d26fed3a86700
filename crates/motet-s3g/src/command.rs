//! Host commands: typed for those motet sends and the simulated bot runs,
//! opaque (code and body, length checked) for the other documented ones.

use crate::packet::MAX_PAYLOAD;

/// Command numbers.
pub mod code {
    /// Query: firmware version (u16 host version in, u16 out).
    pub const VERSION: u8 = 0;
    /// Query: free bytes in the action buffer (u32 out).
    pub const GET_BUFFER_SIZE: u8 = 2;
    /// Query: empty the action buffer.
    pub const CLEAR_BUFFER: u8 = 3;
    /// Query: stop at once, empty the buffer.
    pub const ABORT: u8 = 7;
    /// Query: pause or resume the buffer.
    pub const PAUSE: u8 = 8;
    /// Query: ask a tool (tool, sub-command, data).
    pub const TOOL_QUERY: u8 = 10;
    /// Query: whether every queued action has run (u8 out).
    pub const IS_FINISHED: u8 = 11;
    /// Query: position, 5 × i32 steps and u16 end stops out.
    pub const GET_POSITION_EXT: u8 = 21;
    /// Query: advanced version (u16 firmware, u16 internal, u8 variant, u8, u16).
    pub const ADVANCED_VERSION: u8 = 27;
    /// Action: wait, u32 milliseconds.
    pub const DELAY: u8 = 133;
    /// Action: wait for a tool to reach its temperature.
    pub const WAIT_FOR_TOOL: u8 = 135;
    /// Action: tool action (tool, sub-command, length, data).
    pub const TOOL_ACTION: u8 = 136;
    /// Action: enable or disable axes (u8 bits; bit 7 enables).
    pub const ENABLE_AXES: u8 = 137;
    /// Action: set the position, 5 × i32 steps.
    pub const SET_POSITION_EXT: u8 = 140;
    /// Action: wait for the platform to reach its temperature.
    pub const WAIT_FOR_PLATFORM: u8 = 141;
    /// Action: queue a point, 5 × i32 steps, u32 µs, u8 relative axes.
    pub const QUEUE_POINT_NEW: u8 = 142;
    /// Action: queue an accelerated point (Sailfish), 5 × i32 steps, u32
    /// steps/s, u8 relative axes, f32 mm, u16 feed rate × 64.
    pub const QUEUE_POINT_NEW_EXT: u8 = 155;
    /// Action: firmware acceleration on (1) or off (0) for what follows.
    pub const SET_ACCELERATION_TOGGLE: u8 = 156;
}

/// How long a command's body (after its code) is.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum BodyLen {
    /// Always this many bytes.
    Fixed(usize),
    /// Tool action: tool, sub-command, length N, then N bytes.
    ToolAction,
    /// Tool query: tool, sub-command, then data (the packet's length says).
    ToolQuery,
    /// Query with host data of variable length (the packet says).
    Variable,
    /// `head` bytes then text ending with a NUL.
    Text {
        /// Bytes before the text.
        head: usize,
    },
}

/// Every documented command: its body length and name.
pub fn describe(code: u8) -> Option<(BodyLen, &'static str)> {
    use BodyLen::*;
    Some(match code {
        0 => (Fixed(2), "version"),
        1 => (Fixed(0), "init"),
        2 => (Fixed(0), "get buffer size"),
        3 => (Fixed(0), "clear buffer"),
        4 => (Fixed(0), "get position"),
        7 => (Fixed(0), "abort"),
        8 => (Fixed(0), "pause"),
        9 => (Variable, "probe"),
        10 => (ToolQuery, "tool query"),
        11 => (Fixed(0), "is finished"),
        12 => (Fixed(3), "read EEPROM"),
        13 => (Variable, "write EEPROM"),
        14 => (Variable, "capture to file"),
        15 => (Fixed(0), "end capture"),
        16 => (Variable, "playback capture"),
        17 => (Fixed(0), "reset"),
        18 => (Fixed(1), "next filename"),
        19 => (Fixed(1), "get debug register"),
        20 => (Fixed(0), "get build name"),
        21 => (Fixed(0), "get position ext"),
        22 => (Fixed(1), "extended stop"),
        23 => (Fixed(0), "board status"),
        24 => (Fixed(0), "build statistics"),
        27 => (Fixed(2), "advanced version"),
        112 => (Variable, "debug echo"),
        131 => (Fixed(7), "find axes minimums"),
        132 => (Fixed(7), "find axes maximums"),
        133 => (Fixed(4), "delay"),
        134 => (Fixed(1), "change tool"),
        135 => (Fixed(5), "wait for tool"),
        136 => (ToolAction, "tool action"),
        137 => (Fixed(1), "enable axes"),
        139 => (Fixed(24), "queue point ext"),
        140 => (Fixed(20), "set position ext"),
        141 => (Fixed(5), "wait for platform"),
        142 => (Fixed(25), "queue point new"),
        143 => (Fixed(1), "store home positions"),
        144 => (Fixed(1), "recall home positions"),
        145 => (Fixed(2), "set pot value"),
        146 => (Fixed(5), "set RGB LED"),
        147 => (Fixed(5), "set beep"),
        148 => (Fixed(4), "pause for button"),
        149 => (Text { head: 4 }, "display message"),
        150 => (Fixed(2), "build percentage"),
        151 => (Fixed(1), "queue song"),
        152 => (Fixed(1), "reset to factory"),
        153 => (Text { head: 4 }, "build start notification"),
        154 => (Fixed(1), "build end notification"),
        155 => (Fixed(31), "queue point new ext"),
        156 => (Fixed(1), "set acceleration toggle"),
        157 => (Fixed(20), "stream version"),
        158 => (Fixed(4), "pause at Z position"),
        _ => return None,
    })
}

/// Why a payload is not a command.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub enum CommandError {
    /// No command byte.
    #[error("empty command")]
    Empty,
    /// A command number the protocol does not document.
    #[error("unknown S3G command {0}")]
    Unknown(u8),
    /// The body's length does not fit the command.
    #[error("S3G command {code} ({name}): body of {got} bytes, expected {want}")]
    Length {
        /// The command.
        code: u8,
        /// Its name.
        name: &'static str,
        /// Bytes present.
        got: usize,
        /// Bytes it needs (at least, for variable ones).
        want: usize,
    },
    /// Text without its ending NUL.
    #[error("S3G command {0}: text without its ending NUL")]
    Unterminated(u8),
    /// The encoded command would not fit in a packet.
    #[error("S3G command {code}: {len} bytes do not fit in one packet")]
    TooLong {
        /// The command.
        code: u8,
        /// Its encoded length.
        len: usize,
    },
}

/// A queued point with a duration (142).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct PointNew {
    /// Target per axis X Y Z A B, steps.
    pub steps: [i32; 5],
    /// How long the move takes, µs.
    pub us: u32,
    /// Axes whose target is relative (bit per axis).
    pub relative: u8,
}

/// An accelerated point (155): the firmware plans its speed.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PointAccel {
    /// Target per axis X Y Z A B, steps.
    pub steps: [i32; 5],
    /// Step rate of the axis with the most steps, steps/s.
    pub dda_rate: u32,
    /// Axes whose target is relative (bit per axis).
    pub relative: u8,
    /// Path length, mm.
    pub distance: f32,
    /// Feed rate × 64, mm/s.
    pub feedrate_x64: u16,
}

/// A command, host to bot.
#[derive(Debug, Clone, PartialEq)]
pub enum Command {
    /// 0: version; the host's version in, the firmware's out.
    Version(u16),
    /// 2: free bytes in the action buffer.
    GetBufferSize,
    /// 3: empty the action buffer.
    ClearBuffer,
    /// 7: stop at once.
    Abort,
    /// 10: ask a tool.
    ToolQuery {
        /// Tool index.
        tool: u8,
        /// Sub-command ([`crate::tool::sub`]).
        sub: u8,
        /// Its data.
        data: Vec<u8>,
    },
    /// 11: whether everything queued has run.
    IsFinished,
    /// 21: the position in steps.
    GetPositionExt,
    /// 133: wait this many ms.
    Delay(u32),
    /// 135: wait for a tool's temperature.
    WaitForTool {
        /// Tool index.
        tool: u8,
        /// Ms between the firmware's checks.
        ping_ms: u16,
        /// Give up after this many seconds.
        timeout_s: u16,
    },
    /// 136: a tool action.
    ToolAction {
        /// Tool index.
        tool: u8,
        /// Sub-command ([`crate::tool::sub`]).
        sub: u8,
        /// Its data.
        data: Vec<u8>,
    },
    /// 137: enable (bit 7 set) or disable the axes in the low bits.
    EnableAxes(u8),
    /// 140: the position, steps.
    SetPositionExt([i32; 5]),
    /// 141: wait for the platform's temperature.
    WaitForPlatform {
        /// Tool index the platform is on.
        tool: u8,
        /// Ms between the firmware's checks.
        ping_ms: u16,
        /// Give up after this many seconds.
        timeout_s: u16,
    },
    /// 142: a point with a duration.
    PointNew(PointNew),
    /// 155: an accelerated point.
    PointAccel(PointAccel),
    /// 156: firmware acceleration on or off.
    SetAcceleration(bool),
    /// Any other documented command, its body as sent.
    Other {
        /// The command number.
        code: u8,
        /// Everything after it.
        body: Vec<u8>,
    },
}

/// Little-endian reading from a body whose length is already checked.
struct Le<'a>(&'a [u8]);

impl Le<'_> {
    fn u8(&mut self) -> u8 {
        let v = self.0[0];
        self.0 = &self.0[1..];
        v
    }
    fn u16(&mut self) -> u16 {
        u16::from_le_bytes([self.u8(), self.u8()])
    }
    fn u32(&mut self) -> u32 {
        u32::from_le_bytes([self.u8(), self.u8(), self.u8(), self.u8()])
    }
    fn i32(&mut self) -> i32 {
        self.u32() as i32
    }
    fn steps(&mut self) -> [i32; 5] {
        [self.i32(), self.i32(), self.i32(), self.i32(), self.i32()]
    }
}

impl Command {
    /// Its command number.
    pub fn code(&self) -> u8 {
        use Command::*;
        match self {
            Version(_) => code::VERSION,
            GetBufferSize => code::GET_BUFFER_SIZE,
            ClearBuffer => code::CLEAR_BUFFER,
            Abort => code::ABORT,
            ToolQuery { .. } => code::TOOL_QUERY,
            IsFinished => code::IS_FINISHED,
            GetPositionExt => code::GET_POSITION_EXT,
            Delay(_) => code::DELAY,
            WaitForTool { .. } => code::WAIT_FOR_TOOL,
            ToolAction { .. } => code::TOOL_ACTION,
            EnableAxes(_) => code::ENABLE_AXES,
            SetPositionExt(_) => code::SET_POSITION_EXT,
            WaitForPlatform { .. } => code::WAIT_FOR_PLATFORM,
            PointNew(_) => code::QUEUE_POINT_NEW,
            PointAccel(_) => code::QUEUE_POINT_NEW_EXT,
            SetAcceleration(_) => code::SET_ACCELERATION_TOGGLE,
            Other { code, .. } => *code,
        }
    }

    /// Whether the bot queues it (an action) rather than answering it now.
    pub fn is_action(&self) -> bool {
        self.code() >= 128
    }

    /// The payload: command number and body.
    pub fn encode(&self) -> Result<Vec<u8>, CommandError> {
        use Command::*;
        let mut p = vec![self.code()];
        let steps = |p: &mut Vec<u8>, s: &[i32; 5]| {
            for v in s {
                p.extend_from_slice(&v.to_le_bytes());
            }
        };
        match self {
            GetBufferSize | ClearBuffer | Abort | IsFinished | GetPositionExt => {}
            Version(v) => p.extend_from_slice(&v.to_le_bytes()),
            ToolQuery { tool, sub, data } => {
                p.extend_from_slice(&[*tool, *sub]);
                p.extend_from_slice(data);
            }
            ToolAction { tool, sub, data } => {
                p.extend_from_slice(&[*tool, *sub, data.len().min(255) as u8]);
                p.extend_from_slice(data);
            }
            Delay(ms) => p.extend_from_slice(&ms.to_le_bytes()),
            WaitForTool {
                tool,
                ping_ms,
                timeout_s,
            }
            | WaitForPlatform {
                tool,
                ping_ms,
                timeout_s,
            } => {
                p.push(*tool);
                p.extend_from_slice(&ping_ms.to_le_bytes());
                p.extend_from_slice(&timeout_s.to_le_bytes());
            }
            EnableAxes(bits) => p.push(*bits),
            SetPositionExt(s) => steps(&mut p, s),
            PointNew(pt) => {
                steps(&mut p, &pt.steps);
                p.extend_from_slice(&pt.us.to_le_bytes());
                p.push(pt.relative);
            }
            PointAccel(pt) => {
                steps(&mut p, &pt.steps);
                p.extend_from_slice(&pt.dda_rate.to_le_bytes());
                p.push(pt.relative);
                p.extend_from_slice(&pt.distance.to_le_bytes());
                p.extend_from_slice(&pt.feedrate_x64.to_le_bytes());
            }
            SetAcceleration(on) => p.push(u8::from(*on)),
            Other { body, .. } => p.extend_from_slice(body),
        }
        if p.len() > MAX_PAYLOAD {
            return Err(CommandError::TooLong {
                code: p[0],
                len: p.len(),
            });
        }
        // What is sent must read back: the same checks as a bot makes.
        Command::decode(&p)?;
        Ok(p)
    }

    /// Reads a payload, checking its command number and length.
    pub fn decode(payload: &[u8]) -> Result<Command, CommandError> {
        let (&c, body) = payload.split_first().ok_or(CommandError::Empty)?;
        let want = check_len(c, body)?;
        if want != body.len() {
            let name = describe(c).map_or("?", |d| d.1);
            return Err(CommandError::Length {
                code: c,
                name,
                got: body.len(),
                want,
            });
        }
        Ok(typed(c, body))
    }
}

/// The body length a command needs given the bytes present; errors when
/// the command is unknown or the bytes cannot make it.
pub fn check_len(c: u8, body: &[u8]) -> Result<usize, CommandError> {
    let (len, name) = describe(c).ok_or(CommandError::Unknown(c))?;
    let short = |want| CommandError::Length {
        code: c,
        name,
        got: body.len(),
        want,
    };
    match len {
        BodyLen::Fixed(n) => Ok(n),
        BodyLen::Variable => Ok(body.len()),
        BodyLen::ToolQuery if body.len() < 2 => Err(short(2)),
        BodyLen::ToolQuery => Ok(body.len()),
        BodyLen::ToolAction if body.len() < 3 => Err(short(3)),
        BodyLen::ToolAction => Ok(3 + body[2] as usize),
        BodyLen::Text { head } if body.len() <= head => Err(short(head + 1)),
        BodyLen::Text { head } => body[head..]
            .iter()
            .position(|&b| b == 0)
            .map(|i| head + i + 1)
            .ok_or(CommandError::Unterminated(c)),
    }
}

/// The typed form of a command whose length is checked.
fn typed(c: u8, body: &[u8]) -> Command {
    let mut r = Le(body);
    match c {
        code::VERSION => Command::Version(r.u16()),
        code::GET_BUFFER_SIZE => Command::GetBufferSize,
        code::CLEAR_BUFFER => Command::ClearBuffer,
        code::ABORT => Command::Abort,
        code::IS_FINISHED => Command::IsFinished,
        code::GET_POSITION_EXT => Command::GetPositionExt,
        code::TOOL_QUERY => Command::ToolQuery {
            tool: body[0],
            sub: body[1],
            data: body[2..].to_vec(),
        },
        code::TOOL_ACTION => Command::ToolAction {
            tool: body[0],
            sub: body[1],
            data: body[3..].to_vec(),
        },
        code::DELAY => Command::Delay(r.u32()),
        code::WAIT_FOR_TOOL => Command::WaitForTool {
            tool: r.u8(),
            ping_ms: r.u16(),
            timeout_s: r.u16(),
        },
        code::WAIT_FOR_PLATFORM => Command::WaitForPlatform {
            tool: r.u8(),
            ping_ms: r.u16(),
            timeout_s: r.u16(),
        },
        code::ENABLE_AXES => Command::EnableAxes(r.u8()),
        code::SET_POSITION_EXT => Command::SetPositionExt(r.steps()),
        code::QUEUE_POINT_NEW => Command::PointNew(PointNew {
            steps: r.steps(),
            us: r.u32(),
            relative: r.u8(),
        }),
        code::QUEUE_POINT_NEW_EXT => Command::PointAccel(PointAccel {
            steps: r.steps(),
            dda_rate: r.u32(),
            relative: r.u8(),
            distance: f32::from_bits(r.u32()),
            feedrate_x64: r.u16(),
        }),
        code::SET_ACCELERATION_TOGGLE => Command::SetAcceleration(r.u8() != 0),
        _ => Command::Other {
            code: c,
            body: body.to_vec(),
        },
    }
}
