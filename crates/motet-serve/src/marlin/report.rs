//! What the device reports as Marlin prints it: temperatures
//! (`T:actual /target B:actual /target @:power B@:power`), the firmware
//! and its capabilities (`M115`), the position (`M114`).

use crate::session::HeaterState;
use motet_planner::AuxChannel;

/// The firmware name a host reads from `M115`; hosts that know Marlin's
/// protocol take the device for one.
pub const FIRMWARE_NAME: &str = "Marlin 2.1.2 (motet)";

/// Capabilities reported by `M115` (`Cap:NAME:0|1`), in Marlin's names.
pub const CAPABILITIES: &[(&str, bool)] = &[
    ("SERIAL_XON_XOFF", false),
    ("BINARY_FILE_TRANSFER", false),
    ("EEPROM", false),
    ("VOLUMETRIC", false),
    ("AUTOREPORT_POS", false),
    ("AUTOREPORT_TEMP", true),
    ("PROGRESS", false),
    ("PRINT_JOB", false),
    ("AUTOLEVEL", false),
    ("RUNOUT", false),
    ("Z_PROBE", false),
    ("LEVELING_DATA", false),
    ("BUILD_PERCENT", false),
    ("SOFTWARE_POWER", false),
    ("TOGGLE_LIGHTS", false),
    ("CASE_LIGHT_BRIGHTNESS", false),
    ("EMERGENCY_PARSER", true),
    ("HOST_ACTION_COMMANDS", false),
    ("PROMPT_SUPPORT", false),
    ("SDCARD", false),
    ("REPEAT", false),
    ("SD_WRITE", false),
    ("AUTOREPORT_SD_STATUS", false),
    ("LONG_FILENAME", false),
    ("EXTENDED_M20", false),
    ("LFN_WRITE", false),
    ("CUSTOM_FIRMWARE_UPLOAD", false),
    ("THERMAL_PROTECTION", false),
    ("MOTION_MODES", false),
    ("ARCS", true),
    ("BABYSTEPPING", false),
    ("CHAMBER_TEMPERATURE", false),
    ("COOLER_TEMPERATURE", false),
    ("MEATPACK", false),
    ("CONFIG_EXPORT", false),
];

/// The `M115` reply's lines (before its `ok`).
pub fn firmware(machine: &str, extruders: usize) -> Vec<String> {
    let mut out = vec![format!(
        "FIRMWARE_NAME:{FIRMWARE_NAME} PROTOCOL_VERSION:1.0 MACHINE_TYPE:{} EXTRUDER_COUNT:{extruders}",
        machine.replace(':', " ")
    )];
    out.extend(
        CAPABILITIES
            .iter()
            .map(|(name, on)| format!("Cap:{name}:{}", u8::from(*on))),
    );
    out
}

/// Temperatures as Marlin prints them after `ok` (M105), alone (auto
/// reports) or during a wait: `T:25.00 /0.00 B:25.00 /0.00 @:0 B@:0`.
/// Empty for a machine without heaters.
pub fn temperatures(heaters: &[HeaterState]) -> String {
    // Marlin's order, whatever the machine file's: hot ends, bed, chamber.
    let mut rows: Vec<(u16, String, String)> = heaters
        .iter()
        .filter_map(|h| {
            let (rank, t, p) = match h.channel {
                AuxChannel::Hotend(0) => (0, "T".to_string(), "@".to_string()),
                AuxChannel::Hotend(i) => (u16::from(i), format!("T{i}"), format!("@{i}")),
                AuxChannel::Bed => (300, "B".into(), "B@".into()),
                AuxChannel::Chamber => (301, "C".into(), "C@".into()),
                _ => return None,
            };
            // Marlin's power scale: 0..=127.
            Some((
                rank,
                format!("{t}:{:.2} /{:.2}", h.temp, h.target),
                format!("{p}:{}", (h.power * 127.0).round() as u32),
            ))
        })
        .collect();
    rows.sort_by_key(|r| r.0);
    let temps = rows.iter().map(|r| r.1.clone());
    let powers = rows.iter().map(|r| r.2.clone());
    temps.chain(powers).collect::<Vec<_>>().join(" ")
}

/// The `M114` reply: `X:… Y:… Z:… E:…` in program coordinates.
pub fn position(letters: &[(char, f64)]) -> String {
    let coords: Vec<String> = letters.iter().map(|(l, v)| format!("{l}:{v:.2}")).collect();
    coords.join(" ")
}
