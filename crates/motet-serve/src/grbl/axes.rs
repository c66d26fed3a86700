//! grbl's axes (X, Y, Z, then A, B, C) and the machine's, by name: a sender
//! always sees X, Y and Z, reported as 0 where the machine has no such
//! axis, then the machine's other axes in its order.

use motet_host::Machine;
use motet_trajectory::Point;

/// grbl axis k is the machine's axis `map[k]`, if the machine has it.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Axes {
    /// Letter of each grbl axis.
    pub letters: Vec<char>,
    /// The machine axis behind each, if any.
    pub map: Vec<Option<usize>>,
}

impl Axes {
    /// X, Y, Z (present or not), then the machine's other axes.
    pub fn of(machine: &Machine) -> Axes {
        let mut letters = vec!['X', 'Y', 'Z'];
        let mut map: Vec<Option<usize>> = ["x", "y", "z"].iter().map(|n| machine.axis(n)).collect();
        for (i, a) in machine.axes.iter().enumerate() {
            if !map.contains(&Some(i)) {
                letters.push(a.name.chars().next().unwrap_or('?').to_ascii_uppercase());
                map.push(Some(i));
            }
        }
        Axes { letters, map }
    }

    /// The values of `p` on grbl's axes, 0 where the machine has none.
    pub fn values(&self, p: &Point) -> Vec<f64> {
        self.map.iter().map(|m| m.map_or(0.0, |i| p[i])).collect()
    }

    /// `v` as grbl prints a list of coordinates: `1.000,2.000,0.000`, in
    /// inches when `inches`.
    pub fn format(values: &[f64], inches: bool) -> String {
        let (scale, digits) = if inches { (1.0 / 25.4, 4) } else { (1.0, 3) };
        values
            .iter()
            .map(|v| format!("{:.*}", digits, v * scale + 0.0))
            .collect::<Vec<_>>()
            .join(",")
    }
}
