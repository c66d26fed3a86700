//! Tool commands: what a tool query (10) asks and what a tool action (136)
//! does, for the heaters and fans a print uses.

/// Tool query and action sub-commands (the protocol's tool command table).
pub mod sub {
    /// Query: the tool's temperature, °C (i16).
    pub const GET_TEMP: u8 = 2;
    /// Action: the tool's target temperature, °C (i16).
    pub const SET_TEMP: u8 = 3;
    /// Action: extruder motor on/off and direction (u8 bits).
    pub const TOGGLE_MOTOR_1: u8 = 10;
    /// Action: the heat-sink fan on/off (u8).
    pub const TOGGLE_FAN: u8 = 12;
    /// Action: the "valve" output, the print-cooling fan on Replicator 2s (u8).
    pub const TOGGLE_VALVE: u8 = 13;
    /// Query: whether the tool has reached its target (u8 1/0).
    pub const IS_TOOL_READY: u8 = 22;
    /// Query: the platform's temperature, °C (i16).
    pub const GET_PLATFORM_TEMP: u8 = 30;
    /// Action: the platform's target temperature, °C (i16).
    pub const SET_PLATFORM_TEMP: u8 = 31;
    /// Query: the tool's target temperature, °C (i16).
    pub const GET_SP: u8 = 32;
    /// Query: the platform's target temperature, °C (i16).
    pub const GET_PLATFORM_SP: u8 = 33;
    /// Query: whether the platform has reached its target (u8 1/0).
    pub const IS_PLATFORM_READY: u8 = 35;
}

/// A heater as the protocol addresses it.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub enum Heater {
    /// An extruder's heater, by tool index.
    Tool(u8),
    /// The build platform (addressed through tool 0).
    Platform,
}

impl Heater {
    /// The tool index the packet carries.
    pub fn tool(self) -> u8 {
        match self {
            Heater::Tool(t) => t,
            Heater::Platform => 0,
        }
    }

    /// The query sub-command reading its temperature.
    pub fn get_temp(self) -> u8 {
        match self {
            Heater::Tool(_) => sub::GET_TEMP,
            Heater::Platform => sub::GET_PLATFORM_TEMP,
        }
    }

    /// The action sub-command setting its target.
    pub fn set_temp(self) -> u8 {
        match self {
            Heater::Tool(_) => sub::SET_TEMP,
            Heater::Platform => sub::SET_PLATFORM_TEMP,
        }
    }
}
