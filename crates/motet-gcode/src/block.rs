//! One block (line) as collected words, before it is executed: at most one
//! code per modal group, and the parameter words with where they stand.

use motet_planner::SourceError;

use crate::codes::{Motion, NonModal, Plane, Printer, Spindle, Stop};

/// Arguments of a printer code.
#[derive(Clone, Copy, Debug, Default)]
pub(crate) struct PArgs {
    pub(crate) s: Option<f64>,
    pub(crate) r: Option<f64>,
    pub(crate) p: Option<f64>,
    pub(crate) t: Option<f64>,
}

/// A parameter word: its value (None if the letter had no number) and where.
#[derive(Clone, Copy, Debug)]
pub(crate) struct Param {
    pub(crate) value: Option<f64>,
    pub(crate) at: usize,
}

/// What one line says, before it is executed.
#[derive(Default)]
pub(crate) struct Words {
    pub(crate) motion: Option<(Motion, usize)>,
    pub(crate) nonmodal: Option<(NonModal, usize)>,
    pub(crate) plane: Option<(Plane, usize)>,
    pub(crate) distance: Option<(bool, usize)>,
    pub(crate) arc_distance: Option<(bool, usize)>,
    pub(crate) units: Option<(bool, usize)>,
    /// true: G93 inverse time.
    pub(crate) feed_mode: Option<(bool, usize)>,
    pub(crate) wcs: Option<(usize, usize)>,
    pub(crate) spindle: Option<(Spindle, usize)>,
    pub(crate) coolant: Option<(u8, usize)>,
    pub(crate) stop: Option<(Stop, usize)>,
    pub(crate) extrusion: Option<(bool, usize)>,
    pub(crate) printer: Option<(Printer, u32, usize, PArgs)>,
    pub(crate) axes: [Option<Param>; 7],
    /// I, J, K.
    pub(crate) ijk: [Option<Param>; 3],
    pub(crate) r: Option<Param>,
    pub(crate) f: Option<Param>,
    pub(crate) s: Option<Param>,
    pub(crate) p: Option<Param>,
    pub(crate) l: Option<Param>,
    pub(crate) t: Option<(u8, usize)>,
    /// An unknown code was skipped (allow_unknown): leftover words are its.
    pub(crate) unknown_g: bool,
}

impl Words {
    pub(crate) fn any_axis(&self) -> bool {
        self.axes.iter().any(Option::is_some)
    }

    pub(crate) fn first_axis_at(&self) -> Option<usize> {
        self.axes.iter().flatten().map(|p| p.at).min()
    }
}

/// Puts `v` in a modal group's slot for this line; a second code of the same
/// group on one line is the error `clash` makes from the first.
pub(crate) fn claim<T: Copy>(
    slot: &mut Option<(T, usize)>,
    v: T,
    at: usize,
    clash: impl FnOnce(T) -> SourceError,
) -> Result<(), SourceError> {
    if let Some((other, _)) = *slot {
        return Err(clash(other));
    }
    *slot = Some((v, at));
    Ok(())
}
