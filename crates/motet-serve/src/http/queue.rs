//! The job queue's routes (`/api/queue`): see the session's queue.

use super::api::{client, find};
use super::ApiError;
use crate::server::Shared;
use axum::extract::rejection::JsonRejection;
use axum::extract::{Path, State};
use axum::http::{HeaderMap, StatusCode};
use axum::Json;
use serde::Deserialize;
use serde_json::{json, Value};
use std::sync::Arc;

type Answer = Result<Json<Value>, ApiError>;

pub(super) async fn list(State(sh): State<Arc<Shared>>) -> Json<Value> {
    Json(json!(sh.session().queue()))
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
pub(super) struct AddBody {
    job: u64,
}

pub(super) async fn add(
    State(sh): State<Arc<Shared>>,
    h: HeaderMap,
    body: Result<Json<AddBody>, JsonRejection>,
) -> Answer {
    let Json(b) = body.map_err(|e| ApiError(StatusCode::BAD_REQUEST, e.body_text()))?;
    let job = find(&sh, &b.job.to_string())?;
    let me = client(&h);
    sh.session().enqueue(job, me.as_deref())?;
    sh.save();
    Ok(Json(json!(sh.session().queue())))
}

pub(super) async fn remove(
    State(sh): State<Arc<Shared>>,
    Path(index): Path<String>,
    h: HeaderMap,
) -> Answer {
    let index: usize = index.parse().map_err(|_| {
        ApiError(
            StatusCode::NOT_FOUND,
            format!("no queue entry {index:?}: entries are numbered from 0"),
        )
    })?;
    let me = client(&h);
    sh.session().dequeue(index, me.as_deref())?;
    sh.save();
    Ok(Json(json!(sh.session().queue())))
}

pub(super) async fn start(State(sh): State<Arc<Shared>>, h: HeaderMap) -> Answer {
    let me = client(&h);
    sh.session().start_queue(me.as_deref())?;
    sh.wake();
    sh.save();
    Ok(Json(json!(sh.session().queue())))
}
