//! Input traces: a CSV file of input values over time.

use super::{DanceError, InputSource};
use motet_graph::GraphFile;
use motet_wire::message::GraphInputKind;
use std::path::Path;

/// A CSV trace: a header `time_s,<input>,<input>...` naming inputs of the
/// graph, then rows of numbers with increasing times. Encoders and analog
/// inputs are interpolated linearly, buttons hold their value until the next
/// row. Inputs without a column stay 0; before the first row the first row's
/// values hold, after the last the last's.
#[derive(Clone, Debug)]
pub struct CsvTrace {
    /// For each graph input, its column (or none).
    columns: Vec<Option<usize>>,
    step: Vec<bool>,
    times: Vec<f64>,
    rows: Vec<Vec<f64>>,
    cursor: usize,
}

impl CsvTrace {
    /// Reads and parses the trace at `path` for `graph` (see
    /// [`CsvTrace::parse`]).
    pub fn load(path: &Path, graph: &GraphFile) -> Result<CsvTrace, DanceError> {
        let text = std::fs::read_to_string(path).map_err(|e| DanceError::Trace {
            file: path.display().to_string(),
            line: 0,
            column: 0,
            message: format!("cannot read: {e}"),
        })?;
        CsvTrace::parse(&text, &path.display().to_string(), graph)
    }

    /// Parses `text`, named `file` in errors; an error says where
    /// (`file:line:column`, 1-based) what is wrong: a header whose first
    /// column is not `time_s` or that names a column that is not an input of
    /// `graph` (or one twice), a row with a field count unlike the header's,
    /// a field that is not a finite number, a time that does not increase, or
    /// no rows at all.
    pub fn parse(text: &str, file: &str, graph: &GraphFile) -> Result<CsvTrace, DanceError> {
        let err = |line: usize, column: usize, message: String| DanceError::Trace {
            file: file.to_string(),
            line,
            column,
            message,
        };
        let mut lines = text
            .lines()
            .enumerate()
            .filter(|(_, l)| !l.trim().is_empty() && !l.trim_start().starts_with('#'));
        let Some((hl, header)) = lines.next() else {
            return Err(err(
                1,
                1,
                "empty trace: expected a header `time_s,...`".into(),
            ));
        };
        // Fields with their 1-based columns.
        let fields = |l: &str| {
            let mut col = 1;
            l.split(',')
                .map(|f| {
                    let c = col + (f.len() - f.trim_start().len());
                    col += f.chars().count() + 1;
                    (c, f.trim().to_string())
                })
                .collect::<Vec<_>>()
        };
        let head = fields(header);
        if head[0].1 != "time_s" {
            return Err(err(
                hl + 1,
                head[0].0,
                format!("the first column must be `time_s`, not `{}`", head[0].1),
            ));
        }
        let mut columns = vec![None; graph.inputs.len()];
        for (k, (c, name)) in head.iter().enumerate().skip(1) {
            let Some(i) = graph.inputs.iter().position(|d| &d.name == name) else {
                return Err(err(
                    hl + 1,
                    *c,
                    format!(
                        "`{name}` is not an input of the graph; its inputs: {}",
                        graph
                            .inputs
                            .iter()
                            .map(|d| d.name.as_str())
                            .collect::<Vec<_>>()
                            .join(", ")
                    ),
                ));
            };
            if columns[i].is_some() {
                return Err(err(hl + 1, *c, format!("`{name}` appears twice")));
            }
            columns[i] = Some(k - 1);
        }
        let mut times: Vec<f64> = Vec::new();
        let mut rows = Vec::new();
        for (ln, l) in lines {
            let f = fields(l);
            if f.len() != head.len() {
                return Err(err(
                    ln + 1,
                    f.last().map_or(1, |x| x.0),
                    format!("expected {} fields, found {}", head.len(), f.len()),
                ));
            }
            let mut row = Vec::with_capacity(f.len());
            for (c, v) in &f {
                let x: f64 = v
                    .parse()
                    .ok()
                    .filter(|x: &f64| x.is_finite())
                    .ok_or_else(|| err(ln + 1, *c, format!("`{v}` is not a number")))?;
                row.push(x);
            }
            let t = row.remove(0);
            if times.last().is_some_and(|&p| t <= p) {
                return Err(err(ln + 1, f[0].0, format!("time {t} does not increase")));
            }
            times.push(t);
            rows.push(row);
        }
        if rows.is_empty() {
            return Err(err(hl + 1, 1, "the trace has no rows".into()));
        }
        let step = graph
            .inputs
            .iter()
            .map(|d| d.kind == GraphInputKind::Digital)
            .collect();
        Ok(CsvTrace {
            columns,
            step,
            times,
            rows,
            cursor: 0,
        })
    }

    /// Time of the last row, s.
    pub fn end(&self) -> f64 {
        *self.times.last().unwrap_or(&0.0)
    }
}

impl InputSource for CsvTrace {
    fn values(&mut self, t: f64, out: &mut [f64]) {
        if self.cursor > 0 && self.times[self.cursor] > t {
            self.cursor = 0;
        }
        while self.cursor + 1 < self.times.len() && self.times[self.cursor + 1] <= t {
            self.cursor += 1;
        }
        let k = self.cursor;
        for (i, o) in out.iter_mut().enumerate() {
            let Some(c) = self.columns.get(i).copied().flatten() else {
                *o = 0.0;
                continue;
            };
            let a = self.rows[k][c];
            *o = if self.step[i] || k + 1 >= self.times.len() || t <= self.times[k] {
                a
            } else {
                let b = self.rows[k + 1][c];
                let u = (t - self.times[k]) / (self.times[k + 1] - self.times[k]);
                a + (b - a) * u
            };
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn malformed_traces_name_the_place() {
        let g = GraphFile::load(
            &Path::new(env!("CARGO_MANIFEST_DIR")).join("../../examples/dance/wheelbot/graph.toml"),
        )
        .unwrap();
        let cases = [
            ("time,pedal\n0,1\n", "t.csv:1:1:"),
            ("time_s,pedal,nope\n0,1,2\n", "t.csv:1:14:"),
            ("time_s,pedal\n0,1\n1,x\n", "t.csv:3:3:"),
            ("time_s,pedal\n0,1\n0,2\n", "t.csv:3:1:"),
            ("time_s,pedal\n0,1,3\n", "t.csv:2:5:"),
        ];
        for (text, at) in cases {
            let e = CsvTrace::parse(text, "t.csv", &g).unwrap_err().to_string();
            assert!(e.starts_with(at), "{text:?}: {e}");
        }
        let mut t = CsvTrace::parse("time_s,pedal\n0,0\n1,100\n", "t.csv", &g).unwrap();
        let mut v = [0.0; 2];
        t.values(0.25, &mut v);
        assert_eq!(v, [25.0, 0.0]);
    }
}
