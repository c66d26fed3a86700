//! Graph files: what a validated file holds, and its compilation by stage:
//! `raw` parses the TOML, `resolve` resolves names against
//! the component declarations, `ports` resolves and checks ports and
//! mappings through the node's own builder, [`crate::stage`] and
//! `simulation` read the workflow and simulation sections, and
//! `emit` turns the result into messages.

use crate::emit::Op;
use crate::raw::RawFile;
use crate::source::place;
pub(crate) use crate::source::Source;
use crate::{ports, resolve, simulation};
use motet_node::graph::declare::Declaration;
use motet_node::graph::PortRef;
use motet_wire::message::GraphInputKind;
use motet_wire::HostMessage;
use std::path::Path;

/// A problem in a graph file, with its place (line 0: the whole file, as
/// when it cannot be read).
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
#[error("{}: {message}", place(.file, *.line, *.column))]
pub struct FileError {
    /// The graph file's path as given.
    pub file: String,
    /// 1-based line; 0 when the problem is about the whole file.
    pub line: usize,
    /// 1-based column in characters; 0 with line 0.
    pub column: usize,
    /// The key the problem is about (`components.knob.kind`, `map[2].to`).
    pub key: String,
    /// What is wrong, for the person editing the file.
    pub message: String,
}

/// A place in the graph file.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
pub struct Loc {
    /// 1-based line.
    pub line: usize,
    /// 1-based column, in characters.
    pub column: usize,
}

/// A change to the running graph that names something the graph does not
/// have; nothing is sent to the node.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum LiveError {
    /// No component of that name in the file.
    #[error("no component `{0}` in the graph")]
    UnknownComponent(String),
    /// The component exists but its kind has no live parameter of that name
    /// (construction parameters cannot change while running).
    #[error("component `{component}` ({kind}) has no live parameter `{param}`; it has: {known}")]
    UnknownParam {
        /// The component's name in the file.
        component: String,
        /// Its kind (`encoder`, `channel`, …).
        kind: &'static str,
        /// The parameter asked for.
        param: String,
        /// The kind's live parameters, comma-separated.
        known: String,
    },
    /// No input of that name in the file's `[inputs]`.
    #[error("no input `{0}` in the graph's [inputs]")]
    UnknownInput(String),
}
/// A graph channel's place among the channels and its scale.
#[derive(Clone, Debug, PartialEq)]
pub struct ChannelDef {
    /// Ordinal among the graph's channels (creation order).
    pub ordinal: u8,
    /// `units` world units are `steps` steps.
    pub units: f64,
    /// See `units`; nonzero.
    pub steps: f64,
    /// The machine actuator it drives (simulation), if named.
    pub actuator: Option<String>,
}

/// One component of the file.
#[derive(Clone, Debug)]
pub struct ComponentDef {
    /// Its name in the file (`[components.NAME]`).
    pub name: String,
    /// Its kind's declaration: ports, parameters, defaults, live parameters.
    pub info: &'static Declaration,
    /// Index in the graph (creation order = file order).
    pub index: u8,
    /// Construction values as sent.
    pub params: Vec<f64>,
    /// For a `channel` component, its place and scale; `None` otherwise.
    pub channel: Option<ChannelDef>,
    /// Where its table is in the file, for errors.
    pub loc: Loc,
}

/// An external input named in `[inputs]`.
#[derive(Clone, Debug, PartialEq)]
pub struct InputDef {
    /// The component reading it (also the input's name).
    pub name: String,
    /// Which hardware inputs it reads: encoder, analog, button or stream.
    pub kind: GraphInputKind,
    /// Which of them (`encoder3` is 3), below the node's count of that kind.
    pub index: u8,
    /// The reading component's index in the graph.
    pub component: u8,
}

/// A damped pendulum swinging an input (simulation only):
/// `amplitude · e^(−damping·t) · sin(2π·frequency·t + phase)`.
#[derive(Clone, Debug, PartialEq)]
pub struct Pendulum {
    /// The encoder or analog input it swings (a name in `[inputs]`).
    pub input: String,
    /// Peak value at t = 0, in the input's own units (counts for an
    /// encoder).
    pub amplitude: f64,
    /// Swings per second, Hz; not negative.
    pub frequency: f64,
    /// Decay rate, 1/s; not negative (0 swings for ever).
    pub damping: f64,
    /// Phase at t = 0, radians.
    pub phase: f64,
}

/// Render hints (simulation only): the pen is down while channel
/// `pen_channel`'s position (steps) is below `pen_down_below`.
#[derive(Clone, Debug, PartialEq, Default)]
pub struct RenderDef {
    /// The channel component whose position lifts and lowers the pen;
    /// `None`: the pen is always down.
    pub pen_channel: Option<String>,
    /// Position, in steps, below which the pen is down.
    pub pen_down_below: f64,
}

/// A validated graph file.
#[derive(Clone, Debug)]
pub struct GraphFile {
    /// The file's path as given, for errors.
    pub file: String,
    /// The node's core frame period, µs (`frame_us`, default 40).
    pub frame_us: f64,
    /// The components, in file order (which is the order they run in).
    pub components: Vec<ComponentDef>,
    /// The external inputs named in `[inputs]`.
    pub inputs: Vec<InputDef>,
    /// The staged workflow, in file order; empty when the file has none.
    pub stages: Vec<crate::stage::Stage>,
    /// Simulated inputs (`[[pendulum]]`).
    pub pendulums: Vec<Pendulum>,
    /// How a simulation draws the result (`[render]`).
    pub render: RenderDef,
    pub(crate) ops: Vec<(Op, Loc, String)>,
}

impl GraphFile {
    /// Reads and validates a graph file.
    pub fn load(path: &Path) -> Result<GraphFile, FileError> {
        let text = std::fs::read_to_string(path).map_err(|e| FileError {
            file: path.display().to_string(),
            line: 0,
            column: 0,
            key: String::new(),
            message: format!("cannot read graph file: {e}"),
        })?;
        GraphFile::parse(&text, &path.display().to_string())
    }

    /// Validates a graph file given as text (`file` names it in errors).
    pub fn parse(text: &str, file: &str) -> Result<GraphFile, FileError> {
        let src = Source {
            file: file.to_string(),
            text,
        };
        compile(&src, crate::raw::parse(&src)?)
    }

    /// The component named `name`.
    pub fn component(&self, name: &str) -> Option<&ComponentDef> {
        self.components.iter().find(|c| c.name == name)
    }

    /// The graph channels, in creation order.
    pub fn channels(&self) -> impl Iterator<Item = &ComponentDef> {
        self.components.iter().filter(|c| c.channel.is_some())
    }

    /// The messages that build this graph on a node: `GraphBegin`, one message
    /// per component, ratio and mapping, `GraphCommit`.
    pub fn messages(&self) -> Vec<HostMessage> {
        let mut out = vec![HostMessage::GraphBegin {
            frame_us: self.frame_us,
        }];
        out.extend(self.ops.iter().map(|(op, _, _)| op.message()));
        out.push(HostMessage::GraphCommit);
        out
    }

    /// The component index and parameter id of `component.param`.
    pub fn param_id(&self, component: &str, param: &str) -> Result<(u8, u8), LiveError> {
        let c = self
            .component(component)
            .ok_or_else(|| LiveError::UnknownComponent(component.to_string()))?;
        let id = c
            .info
            .live
            .iter()
            .find(|l| l.name == param)
            .map(|l| l.id)
            .ok_or_else(|| LiveError::UnknownParam {
                component: component.to_string(),
                kind: c.info.name,
                param: param.to_string(),
                known: names(c.info.live.iter().map(|l| l.name)),
            })?;
        Ok((c.index, id))
    }

    /// A live parameter change of the running graph.
    pub fn set(&self, component: &str, param: &str, value: f64) -> Result<HostMessage, LiveError> {
        let (component, param) = self.param_id(component, param)?;
        Ok(HostMessage::GraphParam {
            component,
            param,
            value,
        })
    }

    /// The input named `name` in `[inputs]`.
    pub fn input(&self, name: &str) -> Option<&InputDef> {
        self.inputs.iter().find(|i| i.name == name)
    }

    /// A reading of the input `name`.
    pub fn input_message(&self, name: &str, value: f64) -> Result<HostMessage, LiveError> {
        let i = self
            .input(name)
            .ok_or_else(|| LiveError::UnknownInput(name.to_string()))?;
        Ok(HostMessage::GraphInput {
            kind: i.kind,
            index: i.index,
            value,
        })
    }

    /// `component.port` for messages.
    pub fn port_name(&self, p: PortRef) -> String {
        match self.components.get(p.comp as usize) {
            Some(c) => {
                let port = c
                    .info_ports()
                    .get(p.port as usize)
                    .map_or("?".to_string(), |s| s.to_string());
                format!("{}.{}", c.name, port)
            }
            None => format!("#{}.{}", p.comp, p.port),
        }
    }
}

impl ComponentDef {
    /// Port names in port order.
    pub fn info_ports(&self) -> Vec<&'static str> {
        self.info.ports.iter().map(|p| p.name).collect()
    }
}

pub(crate) fn names<'a>(it: impl Iterator<Item = &'a str>) -> String {
    let v: Vec<&str> = it.collect();
    if v.is_empty() {
        "(none)".to_string()
    } else {
        v.join(", ")
    }
}

/// Compiles a parsed file stage by stage.
fn compile(src: &Source, raw: RawFile) -> Result<GraphFile, FileError> {
    let frame_us = resolve::frame_us(src, &raw)?;
    // Inputs first: the components need their hardware index.
    let input_of = resolve::input_names(src, &raw)?;
    let resolved = resolve::components(src, &raw, &input_of)?;
    let mut ops = resolved.ops;
    ops.extend(ports::mappings(src, &resolved.components, &raw.map)?);
    let mut gf = GraphFile {
        file: src.file.clone(),
        frame_us,
        components: resolved.components,
        inputs: resolved.inputs,
        stages: Vec::new(),
        pendulums: Vec::new(),
        render: RenderDef::default(),
        ops,
    };
    ports::check_build(src, &gf)?;
    gf.stages = crate::stage::compile(src, &gf, &raw.stage)?;
    simulation::pendulums(src, &mut gf, &raw)?;
    simulation::render(src, &mut gf, &raw)?;
    Ok(gf)
}
