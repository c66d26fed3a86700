//! A running graph's component parameters as the host knows them: which
//! ones are live (the kind's declaration), what values they take, and the
//! value each was last given (by the graph file, a stage or a client). A
//! node has no message that reads a parameter back, so the host keeps what
//! it sent, as it would for a node on a network.

use motet_graph::GraphFile;
use motet_node::graph::declare::{Declaration, Domain};
use motet_sim::dance::ParamChange;
use serde::Serialize;

/// Why a parameter change was refused. Nothing changed.
#[derive(Debug, thiserror::Error)]
pub enum ParamError {
    /// No component of that name, or its kind has no live parameter of that
    /// name (construction parameters cannot change while the graph runs).
    #[error("{0}")]
    Unknown(#[from] motet_graph::LiveError),
    /// Outside what the parameter takes.
    #[error("{component}.{param}: {value} is outside what it takes ({takes})")]
    OutOfRange {
        /// The component's name.
        component: String,
        /// The parameter's name.
        param: String,
        /// The value given.
        value: f64,
        /// What it takes, in words.
        takes: String,
    },
    /// The node refused it (a value that does not go with the others, such
    /// as a channel's lower limit above its upper one).
    #[error("{component}.{param} = {value}: the node refused it: {reason}")]
    Refused {
        /// The component's name.
        component: String,
        /// The parameter's name.
        param: String,
        /// The value given.
        value: f64,
        /// The node's reason.
        reason: String,
    },
    /// The graph is no longer running (the node refused one of its own
    /// steps), so nothing can be set.
    #[error("the graph no longer runs: {0}")]
    Stopped(String),
}

/// One live parameter as a screen shows it.
#[derive(Clone, Debug, Serialize)]
pub struct ParamView {
    /// Its name (the key in graph files and in `set` stages).
    pub name: String,
    /// Its unit (`""`: none).
    pub unit: &'static str,
    /// The value it was last given; `None` (`null`) for an action with no
    /// value of its own until one is sent (a position generator's `stop`)
    /// and for a limit left unbounded (a channel's `lower`, −∞).
    pub value: Option<f64>,
    /// Least value taken; `null`: no bound below.
    pub min: Option<f64>,
    /// Greatest value taken; `null`: no bound above.
    pub max: Option<f64>,
    /// Whether it takes whole numbers only (flags, choices, indices).
    pub integer: bool,
    /// One line about it (`""`: none).
    pub doc: &'static str,
}

/// One component with live parameters.
#[derive(Clone, Debug, Serialize)]
pub struct ComponentView {
    /// Its name in the graph file.
    pub name: String,
    /// Its kind (`channel`, `scale`, …).
    pub kind: &'static str,
    /// Its live parameters, in the declaration's order.
    pub params: Vec<ParamView>,
}

/// Every live parameter of a graph, with the values last given.
#[derive(Clone, Debug)]
pub struct Params {
    components: Vec<ComponentView>,
    /// Per component in the graph (by index): its place in `components`.
    place: Vec<Option<usize>>,
    /// Per listed component: its declaration.
    decls: Vec<&'static Declaration>,
    /// Changes taken since the graph started.
    pub changes: u64,
}

/// What a parameter's domain takes: its bounds and whether it takes whole
/// numbers only. A live parameter with no construction parameter of its
/// name (an action: `go`, `stop`, `record`) takes any finite number.
fn bounds(d: Domain) -> (Option<f64>, Option<f64>, bool) {
    let finite = |v: f64| v.is_finite().then_some(v);
    match d {
        Domain::Number { min, max } => (finite(min), finite(max), false),
        Domain::Positive => (Some(0.0), None, false),
        Domain::Bound => (None, None, false),
        Domain::Flag => (Some(0.0), Some(1.0), true),
        Domain::Index(n) => (Some(0.0), Some(f64::from(n.max(1) - 1)), true),
        Domain::Choice(names) => (Some(0.0), Some(names.len().max(1) as f64 - 1.0), true),
    }
}

/// The construction parameter a live one sets, if one has its name.
fn domain_of(
    decl: &Declaration,
    live: &str,
) -> Option<(usize, &'static motet_node::graph::declare::Param)> {
    decl.params.iter().enumerate().find(|(_, p)| p.name == live)
}

impl Params {
    /// The live parameters of `graph`, each at the value the file gives
    /// (its construction value or the kind's default).
    pub fn of(graph: &GraphFile) -> Params {
        let mut components = Vec::new();
        let mut decls = Vec::new();
        let mut place = vec![None; graph.components.len()];
        for c in graph.components.iter().filter(|c| !c.info.live.is_empty()) {
            let decl = c.info;
            let params = decl
                .live
                .iter()
                .map(|l| {
                    let found = domain_of(decl, l.name);
                    let (min, max, integer) = bounds(found.map_or(Domain::REAL, |(_, p)| p.domain));
                    let value = found
                        .and_then(|(i, p)| c.params.get(decl.offset() + i).copied().or(p.default))
                        .filter(|v| v.is_finite());
                    ParamView {
                        name: l.name.to_string(),
                        unit: found.map_or("", |(_, p)| p.unit),
                        value,
                        min,
                        max,
                        integer,
                        doc: found.map_or("", |(_, p)| p.doc),
                    }
                })
                .collect();
            if let Some(slot) = place.get_mut(c.index as usize) {
                *slot = Some(components.len());
            }
            components.push(ComponentView {
                name: c.name.clone(),
                kind: decl.name,
                params,
            });
            decls.push(decl);
        }
        Params {
            components,
            place,
            decls,
            changes: 0,
        }
    }

    /// The components with live parameters.
    pub fn view(&self) -> &[ComponentView] {
        &self.components
    }

    /// `component.param = value` checked against the parameter's declared
    /// domain, as the change a node is sent.
    pub fn check(
        &self,
        graph: &GraphFile,
        component: &str,
        param: &str,
        value: f64,
    ) -> Result<ParamChange, ParamError> {
        let (index, id) = graph.param_id(component, param)?;
        let c = graph
            .component(component)
            .ok_or_else(|| motet_graph::LiveError::UnknownComponent(component.into()))?;
        let domain = domain_of(c.info, param).map_or(Domain::REAL, |(_, p)| p.domain);
        if !value.is_finite() || !domain.accepts(value) {
            return Err(ParamError::OutOfRange {
                component: component.into(),
                param: param.into(),
                value,
                takes: takes(domain),
            });
        }
        Ok(ParamChange {
            component: index,
            param: id,
            value,
        })
    }

    /// Notes a change the node took.
    pub fn taken(&mut self, change: &ParamChange) {
        self.changes += 1;
        let Some(&Some(k)) = self.place.get(change.component as usize) else {
            return;
        };
        let Some(live) = self.decls[k].live.iter().position(|l| l.id == change.param) else {
            return;
        };
        self.components[k].params[live].value = Some(change.value).filter(|v| v.is_finite());
    }
}

/// What a domain takes, in words.
fn takes(d: Domain) -> String {
    let (lo, hi, integer) = bounds(d);
    let whole = if integer { "whole numbers " } else { "" };
    match (lo, hi, d) {
        (_, _, Domain::Positive) => "a number above 0".into(),
        (Some(lo), Some(hi), _) => format!("{whole}{lo}..={hi}"),
        (Some(lo), None, _) => format!("a number ≥ {lo}"),
        (None, Some(hi), _) => format!("a number ≤ {hi}"),
        (None, None, _) => "a finite number".into(),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn game_controller() -> GraphFile {
        let path = concat!(
            env!("CARGO_MANIFEST_DIR"),
            "/../../examples/dance/game-controller/graph.toml"
        );
        GraphFile::load(std::path::Path::new(path)).unwrap()
    }

    #[test]
    fn live_parameters_start_at_the_files_values_and_follow_the_changes_taken() {
        let g = game_controller();
        let mut p = Params::of(&g);
        let names: Vec<&str> = p.view().iter().map(|c| c.name.as_str()).collect();
        assert_eq!(
            names,
            ["joy_x", "joy_y", "vel_x", "vel_y", "knob_x", "knob_y", "ch_a", "ch_b"]
        );
        let joy = &p.view()[0];
        assert_eq!(joy.params[0].name, "floor_value");
        assert_eq!(joy.params[0].value, Some(-40.0));
        // Its deadband width takes no negative numbers; its average ≥ 1.
        assert_eq!(joy.params[5].min, Some(0.0));
        assert_eq!(joy.params[6].min, Some(1.0));
        let knob = &p.view()[4];
        assert_eq!(
            (knob.params[0].name.as_str(), knob.params[0].value),
            ("invert", Some(0.0))
        );
        assert!(knob.params[0].integer);
        let c = p.check(&g, "knob_x", "invert", 1.0).unwrap();
        p.taken(&c);
        assert_eq!(p.view()[4].params[0].value, Some(1.0));
        assert_eq!(p.changes, 1);
    }

    #[test]
    fn unknown_names_and_values_outside_the_domain_are_refused() {
        let g = game_controller();
        let p = Params::of(&g);
        for (c, k, v, words) in [
            ("nope", "ratio", 1.0, "no component `nope`"),
            ("knob_x", "ratio", 1.0, "no live parameter `ratio`"),
            ("joy_x", "deadband_width", -1.0, "a number ≥ 0"),
            ("joy_x", "average", 0.5, "a number ≥ 1"),
            ("ch_a", "max_pulse_rate", f64::NAN, "outside"),
        ] {
            let e = p.check(&g, c, k, v).unwrap_err().to_string();
            assert!(e.contains(words), "{c}.{k} = {v}: {e}");
        }
    }
}
