//! Simulation-only sections: `[[pendulum]]` and `[render]`.

use crate::file::{FileError, GraphFile, Pendulum, RenderDef};
use crate::raw::RawFile;
use crate::source::Source;
use motet_wire::message::GraphInputKind;

/// The pendulums, each swinging an encoder or analog input of the graph.
pub(crate) fn pendulums(src: &Source, gf: &mut GraphFile, raw: &RawFile) -> Result<(), FileError> {
    for (i, p) in raw.pendulum.iter().enumerate() {
        let r = p.get_ref();
        let ok = gf
            .input(r.input.get_ref())
            .is_some_and(|d| matches!(d.kind, GraphInputKind::Encoder | GraphInputKind::Analog));
        if !ok {
            return Err(src.err(
                r.input.span(),
                format!("pendulum[{i}].input"),
                format!(
                    "`{}` is not an encoder or analog input named in [inputs]",
                    r.input.get_ref()
                ),
            ));
        }
        if ![r.amplitude, r.frequency, r.damping, r.phase]
            .iter()
            .all(|v| v.is_finite())
            || r.frequency < 0.0
            || r.damping < 0.0
        {
            return Err(src.err(
                p.span(),
                format!("pendulum[{i}]"),
                "amplitude and phase must be finite, frequency and damping finite and not negative",
            ));
        }
        gf.pendulums.push(Pendulum {
            input: r.input.get_ref().clone(),
            amplitude: r.amplitude,
            frequency: r.frequency,
            damping: r.damping,
            phase: r.phase,
        });
    }
    Ok(())
}

/// The render hints.
pub(crate) fn render(src: &Source, gf: &mut GraphFile, raw: &RawFile) -> Result<(), FileError> {
    if let Some(r) = &raw.render {
        if let Some(c) = &r.pen_channel {
            if gf
                .component(c.get_ref())
                .and_then(|d| d.channel.as_ref())
                .is_none()
            {
                return Err(src.err(
                    c.span(),
                    "render.pen_channel",
                    format!("`{}` is not a channel of the graph", c.get_ref()),
                ));
            }
        }
        gf.render = RenderDef {
            pen_channel: r.pen_channel.as_ref().map(|c| c.get_ref().clone()),
            pen_down_below: r.pen_down_below,
        };
    }
    Ok(())
}
