//! The first stage: a graph file's TOML as written, every value with its
//! place.

use crate::file::FileError;
use crate::source::Source;
use serde::Deserialize;
use std::collections::BTreeMap;
use toml::Spanned;

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub(crate) struct RawFile {
    #[serde(default)]
    pub(crate) frame_us: Option<Spanned<f64>>,
    #[serde(default)]
    pub(crate) components: BTreeMap<Spanned<String>, Spanned<RawComponent>>,
    #[serde(default)]
    pub(crate) map: Vec<Spanned<RawMap>>,
    #[serde(default)]
    pub(crate) inputs: BTreeMap<Spanned<String>, Spanned<String>>,
    #[serde(default)]
    pub(crate) stage: Vec<Spanned<crate::stage::RawStage>>,
    #[serde(default)]
    pub(crate) pendulum: Vec<Spanned<RawPendulum>>,
    #[serde(default)]
    pub(crate) render: Option<RawRender>,
}

pub(crate) type RawComponent = BTreeMap<Spanned<String>, Spanned<toml::Value>>;

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub(crate) struct RawMap {
    pub(crate) from: Spanned<String>,
    pub(crate) to: Spanned<String>,
    #[serde(default)]
    pub(crate) mode: Option<Spanned<String>>,
    #[serde(default)]
    pub(crate) tap: bool,
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub(crate) struct RawPendulum {
    pub(crate) input: Spanned<String>,
    pub(crate) amplitude: f64,
    pub(crate) frequency: f64,
    #[serde(default)]
    pub(crate) damping: f64,
    #[serde(default)]
    pub(crate) phase: f64,
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub(crate) struct RawRender {
    #[serde(default)]
    pub(crate) pen_channel: Option<Spanned<String>>,
    #[serde(default)]
    pub(crate) pen_down_below: f64,
}

/// Parses the TOML; syntax errors and unknown sections are located.
pub(crate) fn parse(src: &Source) -> Result<RawFile, FileError> {
    toml::from_str(src.text).map_err(|e| {
        let span = e.span().unwrap_or(0..0);
        src.err(span, "", e.message().trim().to_string())
    })
}
