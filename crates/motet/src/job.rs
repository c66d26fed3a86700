//! Loading a job file into commands for a machine.

use anyhow::{bail, Context, Result};
use motet_host::{check_job, Machine};
use motet_planner::{Command, Located};
use std::io::Read;
use std::path::Path;

pub enum Kind {
    Gcode,
    Svg,
}

/// The job's kind from its name (`.gz` is looked through).
pub fn kind(path: &Path) -> Result<Kind> {
    let name = path
        .file_name()
        .and_then(|n| n.to_str())
        .unwrap_or_default()
        .to_ascii_lowercase();
    let name = name.strip_suffix(".gz").unwrap_or(&name);
    let ext = name.rsplit('.').next().unwrap_or_default();
    Ok(match ext {
        "gcode" | "gco" | "g" | "nc" | "ngc" | "tap" => Kind::Gcode,
        "svg" => Kind::Svg,
        _ => bail!(
            "{}: unknown job type `.{ext}`; expected G-code (.gcode, .nc, .g) or SVG (.svg)",
            path.display()
        ),
    })
}

/// The job's name for output folders: the file name without extensions.
pub fn name(path: &Path) -> String {
    let n = path.file_name().and_then(|n| n.to_str()).unwrap_or("job");
    let n = n.strip_suffix(".gz").unwrap_or(n);
    n.rsplit_once('.').map_or(n, |(a, _)| a).to_string()
}

pub fn read_bytes(path: &Path) -> Result<Vec<u8>> {
    let raw = std::fs::read(path).with_context(|| format!("cannot read job {}", path.display()))?;
    if path.extension().is_some_and(|e| e == "gz") {
        let mut out = Vec::new();
        flate2::read::GzDecoder::new(&raw[..])
            .read_to_end(&mut out)
            .with_context(|| format!("{}: not a valid gzip file", path.display()))?;
        return Ok(out);
    }
    Ok(raw)
}

pub struct Loaded {
    pub commands: Vec<Located<Command>>,
    pub warnings: Vec<String>,
}

/// Reads, parses and checks a job against the machine; errors name file:line:column.
pub fn load(machine: &Machine, path: &Path, allow_unknown: bool) -> Result<Loaded> {
    let kind = kind(path)?;
    let data = read_bytes(path)?;
    let target = machine.job_target();
    let file = path.display();
    let (commands, warnings) = match kind {
        Kind::Gcode => {
            let text = std::str::from_utf8(&data).map_err(|e| {
                let line = data[..e.valid_up_to()]
                    .iter()
                    .filter(|b| **b == b'\n')
                    .count()
                    + 1;
                anyhow::anyhow!("{file}:{line}: G-code is not valid UTF-8 text")
            })?;
            let opts = motet_gcode::GcodeOptions { allow_unknown };
            let parsed = motet_gcode::parse(text, &target, &opts)
                .map_err(|e| anyhow::anyhow!("{file}:{e}"))?;
            (
                parsed.commands,
                parsed
                    .warnings
                    .iter()
                    .map(|w| format!("{file}:{w}"))
                    .collect(),
            )
        }
        Kind::Svg => {
            let opts = motet_svg::SvgOptions::default();
            let commands = motet_svg::parse(&data, &target, &opts)
                .map_err(|e| anyhow::anyhow!("{file}:{e}"))?;
            (commands, vec![])
        }
    };
    check_job(machine, &commands).map_err(|e| anyhow::anyhow!("{file}:{e}"))?;
    Ok(Loaded { commands, warnings })
}
