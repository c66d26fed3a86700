//! The hand-driven machine's routes (`/api/graph`): see [`crate::graph`].

use super::ApiError;
use crate::graph::GraphRun;
use crate::server::Shared;
use axum::extract::rejection::JsonRejection;
use axum::extract::State;
use axum::http::StatusCode;
use axum::Json;
use serde_json::{json, Map, Value};
use std::sync::Arc;

type Answer = Result<Json<Value>, ApiError>;

fn running(sh: &Shared) -> Result<&GraphRun, ApiError> {
    sh.graph.get().ok_or_else(|| {
        ApiError(
            StatusCode::NOT_FOUND,
            "this server runs no graph (start it with `motet serve MACHINE --graph GRAPH.toml`)"
                .into(),
        )
    })
}

pub(super) async fn view(State(sh): State<Arc<Shared>>) -> Answer {
    Ok(Json(json!(running(&sh)?.view())))
}

pub(super) async fn set_inputs(
    State(sh): State<Arc<Shared>>,
    body: Result<Json<Map<String, Value>>, JsonRejection>,
) -> Answer {
    let g = running(&sh)?;
    let Json(body) = body.map_err(|e| ApiError(StatusCode::BAD_REQUEST, e.body_text()))?;
    let mut given = Vec::with_capacity(body.len());
    for (name, v) in body {
        let Some(x) = v.as_f64() else {
            return Err(ApiError(
                StatusCode::BAD_REQUEST,
                format!("input `{name}`: {v} is not a number"),
            ));
        };
        given.push((name, x));
    }
    g.set_inputs(&given)
        .map_err(|e| ApiError(StatusCode::UNPROCESSABLE_ENTITY, e.to_string()))?;
    Ok(Json(json!(g.view())))
}
