//! Damped pendulums as inputs: the harmonograph's motion.

use super::{DanceError, InputSource};
use motet_graph::GraphFile;
use motet_wire::message::GraphInputKind;

/// Damped pendulums swinging inputs (the harmonograph): each input reads
/// `amplitude · e^(−damping·t) · sin(2π·frequency·t + phase)`.
#[derive(Clone, Debug)]
pub struct Pendulums {
    /// (input index, amplitude, frequency, damping, phase).
    swings: Vec<(usize, f64, f64, f64, f64)>,
}

impl Pendulums {
    /// The graph file's `[[pendulum]]` entries; without any, two pendulums on
    /// the first two encoder inputs (2000 counts, 1 Hz and 1.5 Hz, damping
    /// 0.02/s, a quarter turn apart).
    pub fn from_graph(graph: &GraphFile) -> Result<Pendulums, DanceError> {
        let mut swings = Vec::new();
        if graph.pendulums.is_empty() {
            let enc: Vec<usize> = graph
                .inputs
                .iter()
                .enumerate()
                .filter(|(_, d)| d.kind == GraphInputKind::Encoder)
                .map(|(i, _)| i)
                .take(2)
                .collect();
            if enc.len() < 2 {
                return Err(DanceError::Setup(
                    "pendulums need two encoder inputs or [[pendulum]] entries".into(),
                ));
            }
            swings.push((enc[0], 2000.0, 1.0, 0.02, std::f64::consts::FRAC_PI_2));
            swings.push((enc[1], 2000.0, 1.5, 0.02, 0.0));
        }
        for p in &graph.pendulums {
            let i = graph
                .inputs
                .iter()
                .position(|d| d.name == p.input)
                .expect("validated");
            swings.push((i, p.amplitude, p.frequency, p.damping, p.phase));
        }
        Ok(Pendulums { swings })
    }
}

impl InputSource for Pendulums {
    fn values(&mut self, t: f64, out: &mut [f64]) {
        out.iter_mut().for_each(|o| *o = 0.0);
        for &(i, a, f, d, ph) in &self.swings {
            out[i] += a * (-d * t).exp() * (std::f64::consts::TAU * f * t + ph).sin();
        }
    }
}
