//! `[heaters.NAME]`: each simulated heater's channel, highest target and
//! time constant; without the section, a printer's hot end and bed when
//! the machine has an extruder axis `e`.

use super::Source;
use crate::machine::{Axis, Heater, MachineError};
use crate::machine_file::MachineFile;
use motet_planner::ranges::ValueRange;
use motet_planner::AuxChannel;

/// Highest target a heater may take, °C.
const MAX_C: ValueRange = ValueRange::new(30.0, 1000.0, "°C");
/// Time constant, s.
const TAU_S: ValueRange = ValueRange::new(0.1, 3600.0, "s");

/// The machine's heaters, in the file's (sorted) order.
pub(super) fn heaters(
    src: &Source,
    raw: &MachineFile,
    axes: &[Axis],
) -> Result<Vec<Heater>, MachineError> {
    if raw.heaters.is_empty() {
        return Ok(if axes.iter().any(|a| a.name == "e") {
            Heater::default_printer()
        } else {
            Vec::new()
        });
    }
    let mut out: Vec<Heater> = Vec::new();
    for (name, h) in &raw.heaters {
        let h = h.get_ref();
        let index = match &h.index {
            None => 0,
            Some(i) => u8::try_from(*i.get_ref())
                .map_err(|_| src.err(i.span(), format!("heater {name}: index from 0 to 255")))?,
        };
        let channel = match h.channel.get_ref().as_str() {
            "hotend" => AuxChannel::Hotend(index),
            "bed" => AuxChannel::Bed,
            "chamber" => AuxChannel::Chamber,
            other => {
                return Err(src.err(
                    h.channel.span(),
                    format!(
                        "heater {name}: unknown channel `{other}`; expected hotend, bed or chamber"
                    ),
                ))
            }
        };
        if let Some(twin) = out.iter().find(|o| o.channel == channel) {
            return Err(src.err(
                h.channel.span(),
                format!("heater {name}: {} already has this channel", twin.name),
            ));
        }
        let max_c = src.value(&h.max, MAX_C, format_args!("heater {name}: max"))?;
        let tau_s = src.value(
            &h.time_constant,
            TAU_S,
            format_args!("heater {name}: time_constant"),
        )?;
        out.push(Heater {
            name: name.clone(),
            channel,
            max_c,
            tau_s,
        });
    }
    Ok(out)
}
