//! The HTTP side: routes, errors as JSON, the token check, the WebSocket
//! and the page's files.

mod api;
mod assets;
mod graph;
mod queue;
mod ws;

use crate::server::Shared;
use axum::extract::{DefaultBodyLimit, Request, State};
use axum::http::{header, StatusCode};
use axum::middleware::Next;
use axum::response::{IntoResponse, Response};
use axum::routing::{delete, get, post};
use axum::{Json, Router};
use std::sync::Arc;

pub(crate) use ws::push_status;

/// Every API route, method and path, as the schema (`openapi.json`) must
/// list them (a test compares the two).
pub const ROUTES: &[(&str, &str)] = &[
    ("get", "/api/machine"),
    ("get", "/api/status"),
    ("get", "/api/nodes"),
    ("post", "/api/nodes/{name}/identify"),
    ("post", "/api/nodes/pair"),
    ("get", "/api/events"),
    ("get", "/api/history"),
    ("get", "/api/jobs"),
    ("post", "/api/jobs"),
    ("get", "/api/jobs/{id}"),
    ("get", "/api/jobs/{id}/preview"),
    ("post", "/api/jobs/{id}/start"),
    ("get", "/api/graph"),
    ("post", "/api/graph/inputs"),
    ("post", "/api/graph/params"),
    ("get", "/api/queue"),
    ("post", "/api/queue"),
    ("delete", "/api/queue/{index}"),
    ("post", "/api/queue/start"),
    ("post", "/api/pause"),
    ("post", "/api/resume"),
    ("post", "/api/cancel"),
    ("post", "/api/estop"),
    ("post", "/api/unlock"),
    ("post", "/api/control"),
    ("post", "/api/jog"),
    ("post", "/api/position"),
    ("post", "/api/tool"),
    ("get", "/api/ws"),
    ("get", "/api/openapi.json"),
];

pub(crate) fn router(shared: Arc<Shared>) -> Router {
    let api = Router::new()
        .route("/api/machine", get(api::machine))
        .route("/api/status", get(api::status))
        .route("/api/nodes", get(api::nodes))
        .route("/api/nodes/{name}/identify", post(api::identify))
        .route("/api/nodes/pair", post(api::pair))
        .route("/api/events", get(api::events))
        .route("/api/history", get(api::history))
        .route(
            "/api/jobs",
            get(api::jobs)
                .post(api::upload)
                .layer(DefaultBodyLimit::max(crate::jobs::MAX_UPLOAD)),
        )
        .route("/api/jobs/{id}", get(api::job))
        .route("/api/jobs/{id}/preview", get(api::preview))
        .route("/api/jobs/{id}/start", post(api::start))
        .route("/api/graph", get(graph::view))
        .route("/api/graph/inputs", post(graph::set_inputs))
        .route("/api/graph/params", post(graph::set_param))
        .route("/api/queue", get(queue::list).post(queue::add))
        .route("/api/queue/{index}", delete(queue::remove))
        .route("/api/queue/start", post(queue::start))
        .route("/api/pause", post(api::pause))
        .route("/api/resume", post(api::resume))
        .route("/api/cancel", post(api::cancel))
        .route("/api/estop", post(api::estop))
        .route("/api/unlock", post(api::unlock))
        .route("/api/control", post(api::control))
        .route("/api/jog", post(api::jog))
        .route("/api/position", post(api::position))
        .route("/api/tool", post(api::tool))
        .route("/api/ws", get(ws::upgrade))
        .route("/api/openapi.json", get(assets::openapi))
        .route("/", get(assets::index))
        .route("/app.js", get(assets::script))
        .route("/style.css", get(assets::style))
        .fallback(not_found);
    api.layer(axum::middleware::from_fn_with_state(
        shared.clone(),
        authorise,
    ))
    .with_state(shared)
}

/// A refused request: its status and a message for the person.
pub(crate) struct ApiError(pub StatusCode, pub String);

impl IntoResponse for ApiError {
    fn into_response(self) -> Response {
        let body = Json(serde_json::json!({ "error": self.1 }));
        (self.0, body).into_response()
    }
}

impl From<crate::session::ActionError> for ApiError {
    fn from(e: crate::session::ActionError) -> ApiError {
        use crate::session::ActionError as E;
        let code = match e {
            E::WrongState { .. }
            | E::NotController
            | E::QueueFull(_)
            | E::QueueEmpty
            | E::HandDriven { .. } => StatusCode::CONFLICT,
            E::UnknownJob(_) | E::UnknownNode { .. } | E::NoSuchEntry { .. } => {
                StatusCode::NOT_FOUND
            }
            E::Pair(ref p) => pair_status(p),
            E::UnknownAxis { .. }
            | E::UnknownTool { .. }
            | E::UnknownHeater { .. }
            | E::OutOfRange { .. }
            | E::Unreachable(_) => StatusCode::UNPROCESSABLE_ENTITY,
        };
        ApiError(code, e.to_string())
    }
}

/// A pairing refused by what the nodes are (409), or failed on the
/// devices (502) or the file (500).
fn pair_status(p: &crate::engine::PairRefusal) -> StatusCode {
    use crate::engine::PairRefusal as P;
    match p {
        P::Simulated | P::NoFile => StatusCode::CONFLICT,
        P::Pair(_) | P::Reach(_) => StatusCode::BAD_GATEWAY,
        P::File(_) => StatusCode::INTERNAL_SERVER_ERROR,
    }
}

async fn not_found(req: Request) -> ApiError {
    ApiError(
        StatusCode::NOT_FOUND,
        format!("no such route: {} {}", req.method(), req.uri().path()),
    )
}

/// Every request carries the token when the server has one: in an
/// `Authorization: Bearer` header, or as `?token=` (the page's own load and
/// its WebSocket, which cannot set headers).
async fn authorise(State(shared): State<Arc<Shared>>, req: Request, next: Next) -> Response {
    let Some(token) = shared.token.as_deref() else {
        return next.run(req).await;
    };
    // The page's own files are the same for everyone and hold nothing of
    // the machine: the page loads, then asks for the token's use on /api.
    if matches!(req.uri().path(), "/" | "/app.js" | "/style.css") {
        return next.run(req).await;
    }
    let header = req
        .headers()
        .get(header::AUTHORIZATION)
        .and_then(|h| h.to_str().ok())
        .and_then(|h| h.strip_prefix("Bearer "));
    let query = req
        .uri()
        .query()
        .and_then(|q| q.split('&').find_map(|kv| kv.strip_prefix("token=")));
    let given = header.or(query);
    match given {
        Some(g) if crate::auth::token_matches(token, g) => next.run(req).await,
        Some(_) => ApiError(StatusCode::UNAUTHORIZED, "wrong token".into()).into_response(),
        None => ApiError(
            StatusCode::UNAUTHORIZED,
            "this server needs its token: `Authorization: Bearer TOKEN` or `?token=TOKEN`".into(),
        )
        .into_response(),
    }
}

#[cfg(test)]
mod tests {
    use super::ROUTES;
    use std::collections::BTreeSet;

    /// The schema lists exactly the routes the router serves.
    #[test]
    fn the_schema_lists_every_route_and_no_other() {
        let spec: serde_json::Value = serde_json::from_str(super::assets::OPENAPI).unwrap();
        let mut listed = BTreeSet::new();
        for (path, item) in spec["paths"].as_object().unwrap() {
            for method in item.as_object().unwrap().keys() {
                listed.insert((method.clone(), path.clone()));
            }
        }
        let served: BTreeSet<(String, String)> = ROUTES
            .iter()
            .map(|(m, p)| (m.to_string(), p.to_string()))
            .collect();
        assert_eq!(listed, served);
    }
}
