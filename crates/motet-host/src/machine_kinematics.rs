//! A machine file's kinematics: its name in `[motion] kinematics` and its
//! geometry in `[geometry]`, checked against the kinematics table
//! (`motet_trajectory::kinematics`), so a new kinematics needs nothing here.

use motet_trajectory::KinematicsKind;
use std::collections::BTreeMap;
use std::ops::Range;
use toml::Spanned;

/// The `[geometry]` table as written.
pub type GeometryFile = Spanned<BTreeMap<String, Spanned<f64>>>;

/// The kinematics named `name` with the geometry of `geometry`, or the
/// place in the file and what is wrong there.
pub fn kinematics_from(
    name: &Spanned<String>,
    geometry: Option<&GeometryFile>,
) -> Result<KinematicsKind, (Range<usize>, String)> {
    let Some(params) = KinematicsKind::params_of(name.get_ref()) else {
        return Err((
            name.span(),
            format!(
                "unknown kinematics `{}`; expected one of {}",
                name.get_ref(),
                KinematicsKind::NAMES.join(", ")
            ),
        ));
    };
    let empty = BTreeMap::new();
    let given = geometry.map_or(&empty, |g| g.get_ref());
    let table_span = geometry.map_or(name.span(), |g| g.span());
    if let Some((key, v)) = given
        .iter()
        .find(|(k, _)| !params.iter().any(|p| p.key == k.as_str()))
    {
        let known: Vec<&str> = params.iter().map(|p| p.key).collect();
        return Err((
            v.span(),
            if known.is_empty() {
                format!(
                    "[geometry] {key}: {} kinematics takes no geometry",
                    name.get_ref()
                )
            } else {
                format!(
                    "[geometry] {key}: unknown key for {} kinematics; it takes {}",
                    name.get_ref(),
                    known.join(", ")
                )
            },
        ));
    }
    let mut values = Vec::with_capacity(params.len());
    for p in params {
        match (given.get(p.key), p.default) {
            (Some(v), _) => values.push(*v.get_ref()),
            (None, Some(d)) => values.push(d),
            (None, None) => {
                return Err((
                    table_span,
                    format!(
                        "{} kinematics needs [geometry] {} ({})",
                        name.get_ref(),
                        p.key,
                        p.doc
                    ),
                ))
            }
        }
    }
    let built = KinematicsKind::from_name(name.get_ref(), &values)
        .expect("the name was found in the table above");
    built.map_err(|e| {
        let span = given.get(e.key).map_or(table_span, |v| v.span());
        let doc = params.iter().find(|p| p.key == e.key).map_or("", |p| p.doc);
        (span, format!("[geometry] {}: {} ({doc})", e.key, e.reason))
    })
}
