//! The hand-driven machine's routes (`/api/graph`): see [`crate::graph`].

use super::ApiError;
use crate::graph::{GraphRun, ParamError};
use crate::server::Shared;
use axum::extract::rejection::JsonRejection;
use axum::extract::State;
use axum::http::StatusCode;
use axum::Json;
use serde::Deserialize;
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
    Ok(Json(json!(running(&sh)?.view_with_params())))
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
    Ok(Json(json!(g.view_with_params())))
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
pub(super) struct ParamBody {
    component: String,
    param: String,
    value: f64,
}

pub(super) async fn set_param(
    State(sh): State<Arc<Shared>>,
    body: Result<Json<ParamBody>, JsonRejection>,
) -> Answer {
    running(&sh)?;
    let Json(b) = body.map_err(|e| ApiError(StatusCode::BAD_REQUEST, e.body_text()))?;
    // The answer waits for the graph's thread to send the change to the
    // node: off the async workers.
    let done = tokio::task::spawn_blocking(move || {
        let g = running(&sh)?;
        g.set_param(&b.component, &b.param, b.value)
            .map_err(|e| {
                let code = match e {
                    ParamError::Stopped(_) => StatusCode::CONFLICT,
                    _ => StatusCode::UNPROCESSABLE_ENTITY,
                };
                ApiError(code, e.to_string())
            })
            .map(|()| g.view_with_params())
    })
    .await
    .map_err(|e| ApiError(StatusCode::INTERNAL_SERVER_ERROR, e.to_string()))??;
    Ok(Json(json!(done)))
}
