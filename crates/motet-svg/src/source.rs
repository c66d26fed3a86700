//! The source document before usvg: every element's location and layer,
//! indexed by id (generated ids where elements have none), so that usvg's
//! nodes can be traced back to the line:column they came from.

use std::collections::HashMap;

use motet_planner::{SourceError, SourceLoc};
use usvg::roxmltree;

use crate::error::{line_col, usvg_error, xml_error};
use crate::{arcs, depth};

/// Prefix of the ids given to elements that have none.
const GENERATED_ID: &str = "motet-svg-";

/// Inkscape's XML namespace (layer labels).
const INKSCAPE_NS: &str = "http://www.inkscape.org/namespaces/inkscape";

/// usvg options: no external files, no images.
fn usvg_options() -> usvg::Options<'static> {
    usvg::Options {
        image_href_resolver: usvg::ImageHrefResolver {
            resolve_data: Box::new(|_, _, _| None),
            resolve_string: Box::new(|_, _| None),
        },
        ..Default::default()
    }
}

/// The document as usvg reads it, with what usvg forgets about its source.
pub(crate) struct Source {
    pub(crate) tree: usvg::Tree,
    /// Elements by id (given or generated).
    pub(crate) index: HashMap<String, ElemInfo>,
    /// Names of the top-level groups (layers).
    pub(crate) layers: Vec<String>,
}

/// Parses `text` (depth-checked, tagged with ids, arcs bounded) into a usvg
/// tree and the index of its elements.
pub(crate) fn read(text: &str) -> Result<Source, SourceError> {
    depth::check_text(text)?;
    let xml_opt = roxmltree::ParsingOptions {
        allow_dtd: true,
        ..Default::default()
    };
    let doc = roxmltree::Document::parse_with_options(text, xml_opt).map_err(xml_error)?;
    depth::check_tree(&doc)?;
    let root_loc = {
        let p = doc.text_pos_at(doc.root_element().range().start);
        SourceLoc {
            line: p.row,
            column: p.col,
        }
    };

    let usvg_opt = usvg_options();
    let (annotated, mut index, layers) = annotate(&doc);
    arcs::check(&index)?;
    let tagged = match &annotated {
        Some(text) => usvg::Tree::from_str(text, &usvg_opt).ok(),
        None => None,
    };
    let tree = match tagged {
        Some(tree) => tree,
        None => {
            if annotated.is_some() {
                // Tagging broke something: parse the original, without
                // the generated ids.
                index.retain(|_, info| !info.generated);
            }
            usvg::Tree::from_xmltree(&doc, &usvg_opt).map_err(|e| usvg_error(e, root_loc))?
        }
    };
    Ok(Source {
        tree,
        index,
        layers,
    })
}

/// Where an element is and what it is.
#[derive(Clone, Debug)]
pub(crate) struct ElemInfo {
    pub(crate) loc: SourceLoc,
    pub(crate) tag: String,
    /// The id was made up by [`annotate`].
    pub(crate) generated: bool,
    /// Path data of a `path` element that has arcs.
    pub(crate) d: Option<String>,
    /// Index of the top-level group (layer) the element is in.
    pub(crate) layer: Option<usize>,
}

/// Give every element without an id a generated one, so that usvg's nodes
/// can be traced back to their source element. Returns the tagged text
/// (`None` if nothing could be tagged), the id index and the names of the
/// top-level groups (layers).
fn annotate(doc: &roxmltree::Document) -> (Option<String>, HashMap<String, ElemInfo>, Vec<String>) {
    let text = doc.input_text();
    let root = doc.root_element();
    let (layers, layer_of) = layers(root);
    let mut index: HashMap<String, ElemInfo> = HashMap::new();

    let prefix = id_prefix(doc);

    // Each element's layer from its parent's, in document order (parents
    // first): linear, where walking up from every element is not.
    let mut layer_by_node: Vec<Option<usize>> = Vec::new();
    let mut layer_at = |node: roxmltree::Node| {
        let layer = match node.parent_element() {
            Some(p) if p == root => layer_of.get(&node.id()).copied(),
            Some(p) => layer_by_node.get(p.id().get_usize()).copied().flatten(),
            None => None,
        };
        let i = node.id().get_usize();
        if layer_by_node.len() <= i {
            layer_by_node.resize(i + 1, None);
        }
        layer_by_node[i] = layer;
        layer
    };
    let root_start = doc.root_element().range().start;
    let mut inserts: Vec<(usize, String)> = Vec::new();
    // Running position, so that locating all elements is linear.
    let (mut cur, mut line, mut col) = (0usize, 1u32, 1u32);
    for node in doc.descendants().filter(|n| n.is_element()) {
        let start = node.range().start;
        let loc = match text.get(cur..start) {
            Some(between) if start >= cur => {
                (line, col) = line_col(between, line, col);
                cur = start;
                SourceLoc { line, column: col }
            }
            _ => {
                let p = doc.text_pos_at(start);
                SourceLoc {
                    line: p.row,
                    column: p.col,
                }
            }
        };
        let info = ElemInfo {
            loc,
            tag: node.tag_name().name().to_string(),
            generated: false,
            d: node
                .attribute("d")
                .filter(|d| node.tag_name().name() == "path" && d.contains(['a', 'A']))
                .map(str::to_string),
            layer: layer_at(node),
        };
        if let Some(id) = node.attribute("id") {
            index.entry(id.to_string()).or_insert(info);
            continue;
        }
        if start < root_start {
            continue;
        }
        let Some(rest) = text.get(start..) else {
            continue;
        };
        let Some(after_lt) = rest.strip_prefix('<') else {
            continue;
        };
        let name_len = after_lt
            .find(|c: char| c.is_whitespace() || c == '/' || c == '>')
            .unwrap_or(after_lt.len());
        let qname = &after_lt[..name_len];
        if name_len == 0 || !qname.ends_with(info.tag.as_str()) {
            continue;
        }
        let at = start + 1 + name_len;
        if inserts.last().is_some_and(|(p, _)| *p >= at) {
            continue;
        }
        let id = format!("{prefix}{}", inserts.len());
        index.insert(
            id.clone(),
            ElemInfo {
                generated: true,
                ..info
            },
        );
        inserts.push((at, id));
    }
    if inserts.is_empty() {
        return (None, index, layers);
    }
    (Some(insert_ids(text, &inserts)), index, layers)
}

/// The names of the top-level groups (`inkscape:label`, else `id`, else
/// `layer N`), and each group's index among them.
fn layers(root: roxmltree::Node) -> (Vec<String>, HashMap<roxmltree::NodeId, usize>) {
    let mut layers: Vec<String> = Vec::new();
    let mut layer_of: HashMap<roxmltree::NodeId, usize> = HashMap::new();
    for g in root
        .children()
        .filter(|n| n.is_element() && n.tag_name().name() == "g")
    {
        let name = g
            .attribute((INKSCAPE_NS, "label"))
            .or_else(|| g.attribute("id"))
            .map_or_else(|| format!("layer {}", layers.len() + 1), str::to_string);
        layer_of.insert(g.id(), layers.len());
        layers.push(name);
    }
    (layers, layer_of)
}

/// A prefix for generated ids that no id in the document starts with.
fn id_prefix(doc: &roxmltree::Document) -> String {
    let existing: Vec<&str> = doc
        .descendants()
        .filter_map(|n| n.attribute("id"))
        .collect();
    let mut prefix = String::from(GENERATED_ID);
    while existing.iter().any(|id| id.starts_with(prefix.as_str())) {
        prefix.push('_');
    }
    prefix
}

/// `text` with ` id="…"` inserted at each byte offset (ascending).
fn insert_ids(text: &str, inserts: &[(usize, String)]) -> String {
    let mut out = String::with_capacity(text.len() + inserts.len() * 24);
    let mut last = 0;
    for (at, id) in inserts {
        out.push_str(&text[last..*at]);
        out.push_str(" id=\"");
        out.push_str(id);
        out.push('"');
        last = *at;
    }
    out.push_str(&text[last..]);
    out
}
