//! The API's handlers: each takes the lock, acts or reads, and answers in
//! JSON; a refused action answers with its reason and changes nothing.

use super::ApiError;
use crate::jobs::{read_upload, ReadOptions, StoredJob, UploadError};
use crate::server::Shared;
use crate::session::Client;
use axum::body::Bytes;
use axum::extract::rejection::{BytesRejection, JsonRejection, QueryRejection};
use axum::extract::{Path, Query, State};
use axum::http::{HeaderMap, StatusCode};
use axum::Json;
use serde::Deserialize;
use serde_json::{json, Value};
use std::collections::BTreeMap;
use std::sync::Arc;

type Shared_ = State<Arc<Shared>>;
type Answer = Result<Json<Value>, ApiError>;

/// The header a client names itself in (any string it chose), for control.
pub(crate) const CLIENT_HEADER: &str = "x-motet-client";

pub(super) fn client(headers: &HeaderMap) -> Option<String> {
    headers
        .get(CLIENT_HEADER)
        .and_then(|v| v.to_str().ok())
        .map(|s| s.chars().take(64).collect())
}

fn bad_json(e: JsonRejection) -> ApiError {
    ApiError(StatusCode::BAD_REQUEST, e.body_text())
}

fn done() -> Answer {
    Ok(Json(json!({ "ok": true })))
}

pub(super) async fn machine(State(sh): Shared_) -> Json<Value> {
    let m = &sh.machine;
    Json(json!({
        "name": m.name,
        "description": m.description,
        "kinematics": m.kinematics.name(),
        "axes": m.axes.iter().map(|a| json!({
            "name": a.name,
            "travel": a.travel,
            "max_velocity": a.max_velocity,
            "max_acceleration": a.max_acceleration,
            "path": a.path,
        })).collect::<Vec<_>>(),
        "tools": m.tools.iter().map(|t| json!({
            "name": t.name,
            "kind": format!("{:?}", t.kind).to_lowercase(),
        })).collect::<Vec<_>>(),
        "nodes": m.nodes.iter().map(|n| n.name.clone()).collect::<Vec<_>>(),
        "start": m.start[..m.axes.len()].to_vec(),
        "draw_feed": m.draw_feed,
    }))
}

pub(super) async fn status(State(sh): Shared_) -> Json<Value> {
    Json(json!(sh.session().status()))
}

pub(super) async fn nodes(State(sh): Shared_) -> Json<Value> {
    let now = sh.now();
    let s = sh.session();
    let figures = s.nodes().figures(now);
    let run = s.nodes().run();
    let m = s.machine();
    let list: Vec<Value> = m
        .nodes
        .iter()
        .enumerate()
        .map(|(k, n)| {
            let f = figures.get(k);
            json!({
                "name": n.name,
                "kind": s.nodes().kind(),
                "link": run.peers().get(k).map(|p| format!("{:?}", p.link_state())),
                "address": s.nodes().link(k),
                "actuators": n.actuators.iter().map(|&a| m.actuators[a].name.clone()).collect::<Vec<_>>(),
                "tools": n.tools.iter().map(|&t| m.tools[t].name.clone()).collect::<Vec<_>>(),
                "firmware": s.nodes().firmware(k),
                "identifying": s.nodes().identifying(k, now),
                "rtt_us": f.map(|f| f.rtt_us),
                "retransmits": f.map(|f| f.retransmits),
                "crc_errors": f.map(|f| f.crc_errors),
                "clock_error_us": f.map(|f| f.sync_error_us),
                "skew_ppm": f.map(|f| f.skew_ppm),
                "bytes_out": f.map(|f| f.bytes_out),
                "bytes_in": f.map(|f| f.bytes_in),
            })
        })
        .collect();
    Json(json!(list))
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
pub(super) struct IdentifyBody {
    #[serde(default = "five")]
    seconds: f64,
}

fn five() -> f64 {
    5.0
}

pub(super) async fn identify(
    State(sh): Shared_,
    Path(name): Path<String>,
    body: Result<Json<IdentifyBody>, JsonRejection>,
) -> Answer {
    let Json(b) = body.map_err(bad_json)?;
    sh.session().identify(&name, b.seconds)?;
    sh.wake();
    done()
}

pub(super) async fn pair(State(sh): Shared_, h: HeaderMap) -> Answer {
    let me = client(&h);
    // Pairing talks to the devices for a second or two; the session is
    // held meanwhile (the machine is at rest, nothing moves).
    let done = tokio::task::spawn_blocking(move || {
        let done = sh.session().pair_nodes(me.as_deref());
        sh.wake();
        done
    })
    .await
    .map_err(|e| ApiError(StatusCode::INTERNAL_SERVER_ERROR, e.to_string()))??;
    Ok(Json(json!({
        "paired": done.lines,
        "file": done.file.display().to_string(),
    })))
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
pub(super) struct Since {
    #[serde(default)]
    since: u64,
}

pub(super) async fn events(State(sh): Shared_, q: Result<Query<Since>, QueryRejection>) -> Answer {
    let q = q.map_err(|e| ApiError(StatusCode::BAD_REQUEST, e.body_text()))?;
    Ok(Json(json!(sh.session().events.since(q.since))))
}

pub(super) async fn history(State(sh): Shared_) -> Json<Value> {
    let s = sh.session();
    Json(json!(s.history().collect::<Vec<_>>()))
}

fn job_json(j: &StoredJob) -> Value {
    let mut v = json!(j);
    v["bounds"] = json!(j.preview.bounds);
    v["preview_points"] = json!(j.preview.points());
    v
}

pub(super) async fn jobs(State(sh): Shared_) -> Json<Value> {
    let list: Vec<Value> = sh.jobs().list().iter().map(|j| job_json(j)).collect();
    Json(json!(list))
}

pub(super) fn find(sh: &Shared, id: &str) -> Result<Arc<StoredJob>, ApiError> {
    let n: u64 = id
        .parse()
        .map_err(|_| ApiError(StatusCode::NOT_FOUND, format!("no job {id:?}")))?;
    sh.jobs()
        .get(n)
        .ok_or_else(|| ApiError(StatusCode::NOT_FOUND, format!("no job {n}")))
}

pub(super) async fn job(State(sh): Shared_, Path(id): Path<String>) -> Answer {
    Ok(Json(job_json(find(&sh, &id)?.as_ref())))
}

pub(super) async fn preview(State(sh): Shared_, Path(id): Path<String>) -> Answer {
    Ok(Json(json!(find(&sh, &id)?.preview)))
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
pub(super) struct UploadQuery {
    /// The file's name: its extension says what kind of job it is.
    name: String,
    #[serde(default)]
    allow_unknown: bool,
    /// Fit the drawing to the travel with this margin, mm.
    fit: Option<f64>,
    /// Scale the drawing by this factor.
    scale: Option<f64>,
    /// Turn the drawing counter-clockwise about its centre, degrees.
    rotate: Option<f64>,
    /// Where the drawing's lower-left corner goes: `X,Y`.
    origin: Option<String>,
}

impl UploadQuery {
    /// The placement the query asks for, checked.
    fn placement(&self) -> Result<motet_api::Placement, ApiError> {
        let bad = |e: motet_api::PlacementError| ApiError(StatusCode::BAD_REQUEST, e.to_string());
        let p = motet_api::Placement {
            fit_margin_mm: self.fit,
            scale: self.scale,
            rotate_deg: self.rotate.unwrap_or(0.0),
            origin: self
                .origin
                .as_deref()
                .map(motet_api::Placement::parse_origin)
                .transpose()
                .map_err(bad)?,
        };
        p.check().map_err(bad)?;
        Ok(p)
    }
}

pub(super) async fn upload(
    State(sh): Shared_,
    q: Result<Query<UploadQuery>, QueryRejection>,
    body: Result<Bytes, BytesRejection>,
) -> Result<(StatusCode, Json<Value>), ApiError> {
    let q = q.map_err(|e| ApiError(StatusCode::BAD_REQUEST, e.body_text()))?;
    // Too large, or the client went away mid-upload: nothing is stored.
    let body = body.map_err(|e| ApiError(e.status(), e.body_text()))?;
    let p = q.placement()?;
    let opts = ReadOptions {
        allow_unknown: q.allow_unknown,
        fit: p.fit_margin_mm,
        scale: p.scale,
        rotate_deg: p.rotate_deg,
        origin: p.origin,
    };
    let (id, dir) = sh.jobs().reserve();
    let machine = sh.machine.clone();
    let read = tokio::task::spawn_blocking(move || {
        read_upload(&machine, &dir.clone(), id, &q.name, &body, &opts)
    })
    .await
    .map_err(|e| ApiError(StatusCode::INTERNAL_SERVER_ERROR, e.to_string()))?;
    let job = read.map_err(|e| {
        let code = match e {
            UploadError::TooLarge { .. } => StatusCode::PAYLOAD_TOO_LARGE,
            UploadError::Io(_) => StatusCode::INTERNAL_SERVER_ERROR,
            UploadError::Job(_) => StatusCode::UNPROCESSABLE_ENTITY,
            UploadError::Name(_) | UploadError::Kind { .. } | UploadError::Empty => {
                StatusCode::BAD_REQUEST
            }
        };
        ApiError(code, e.to_string())
    })?;
    // The job on the machine and those queued stay whatever the uploads.
    let (running, queued) = {
        let s = sh.session();
        (s.job_id(), s.queued_ids())
    };
    let job = sh
        .jobs()
        .insert(job, |id| running == Some(id) || queued.contains(&id));
    sh.save();
    Ok((StatusCode::CREATED, Json(job_json(&job))))
}

pub(super) async fn start(State(sh): Shared_, Path(id): Path<String>, h: HeaderMap) -> Answer {
    let job = find(&sh, &id)?;
    let me = client(&h);
    sh.session().start(job, me.as_deref())?;
    sh.wake();
    done()
}

/// An action that takes only the client.
async fn act(
    sh: Arc<Shared>,
    h: HeaderMap,
    f: impl FnOnce(&mut crate::session::Session, Client) -> Result<(), crate::session::ActionError>,
) -> Answer {
    let me = client(&h);
    f(&mut sh.session(), me.as_deref())?;
    sh.wake();
    done()
}

pub(super) async fn pause(State(sh): Shared_, h: HeaderMap) -> Answer {
    act(sh, h, |s, c| s.pause(c)).await
}

pub(super) async fn resume(State(sh): Shared_, h: HeaderMap) -> Answer {
    act(sh, h, |s, c| s.resume(c)).await
}

pub(super) async fn cancel(State(sh): Shared_, h: HeaderMap) -> Answer {
    act(sh, h, |s, c| s.cancel(c)).await
}

pub(super) async fn estop(State(sh): Shared_, h: HeaderMap) -> Answer {
    act(sh, h, |s, _| {
        s.estop();
        Ok(())
    })
    .await
}

pub(super) async fn unlock(State(sh): Shared_, h: HeaderMap) -> Answer {
    act(sh, h, |s, _| s.unlock()).await
}

pub(super) async fn control(State(sh): Shared_, h: HeaderMap) -> Answer {
    let Some(me) = client(&h) else {
        return Err(ApiError(
            StatusCode::BAD_REQUEST,
            format!("taking control needs the `{CLIENT_HEADER}` header naming the client"),
        ));
    };
    sh.session().take_control(&me);
    done()
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
pub(super) struct JogBody {
    axes: BTreeMap<String, f64>,
    #[serde(default = "yes")]
    relative: bool,
    feed: Option<f64>,
}

fn yes() -> bool {
    true
}

pub(super) async fn jog(
    State(sh): Shared_,
    h: HeaderMap,
    body: Result<Json<JogBody>, JsonRejection>,
) -> Answer {
    let Json(b) = body.map_err(bad_json)?;
    let axes: Vec<(String, f64)> = b.axes.into_iter().collect();
    act(sh, h, move |s, c| s.jog(&axes, b.relative, b.feed, c)).await
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
pub(super) struct PositionBody {
    axes: BTreeMap<String, f64>,
}

pub(super) async fn position(
    State(sh): Shared_,
    h: HeaderMap,
    body: Result<Json<PositionBody>, JsonRejection>,
) -> Answer {
    let Json(b) = body.map_err(bad_json)?;
    let axes: Vec<(String, f64)> = b.axes.into_iter().collect();
    act(sh, h, move |s, c| s.set_position(&axes, c)).await
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
pub(super) struct ToolBody {
    tool: String,
    value: f64,
}

pub(super) async fn tool(
    State(sh): Shared_,
    h: HeaderMap,
    body: Result<Json<ToolBody>, JsonRejection>,
) -> Answer {
    let Json(b) = body.map_err(bad_json)?;
    act(sh, h, move |s, c| s.set_tool(&b.tool, b.value, c)).await
}
