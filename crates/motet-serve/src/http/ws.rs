//! The WebSocket: the machine's status pushed to every client as it moves
//! (one message every [`PUSH_INTERVAL_US`]), and at once when an event
//! happens (a stop, a state change), so a screen shows an emergency stop
//! without waiting for the next tick. A slow client skips status messages
//! instead of holding the others up.

use crate::server::{Shared, PUSH_INTERVAL_US};
use axum::extract::ws::{Message, WebSocket, WebSocketUpgrade};
use axum::extract::State;
use axum::response::Response;
use serde_json::json;
use std::sync::Arc;
use std::time::{Duration, SystemTime, UNIX_EPOCH};
use tokio::sync::broadcast::error::RecvError;

pub(super) async fn upgrade(State(sh): State<Arc<Shared>>, ws: WebSocketUpgrade) -> Response {
    let rx = sh.updates.subscribe();
    let first = push_message(&sh, 0).0;
    ws.on_upgrade(move |socket| serve_client(socket, rx, first))
}

async fn serve_client(
    mut socket: WebSocket,
    mut rx: tokio::sync::broadcast::Receiver<Arc<str>>,
    first: String,
) {
    if socket.send(Message::Text(first.into())).await.is_err() {
        return;
    }
    loop {
        tokio::select! {
            got = rx.recv() => match got {
                Ok(text) => {
                    if socket.send(Message::Text(text.as_ref().into())).await.is_err() {
                        return;
                    }
                }
                Err(RecvError::Lagged(_)) => continue,
                Err(RecvError::Closed) => return,
            },
            incoming = socket.recv() => match incoming {
                // Clients only listen; anything but a close is ignored.
                Some(Ok(Message::Close(_))) | None | Some(Err(_)) => return,
                Some(Ok(_)) => {}
            },
        }
    }
}

/// One push: the status, the events after `seen`, and the wall clock in ms
/// (so a client on the same computer measures how old the status is).
fn push_message(sh: &Shared, seen: u64) -> (String, u64) {
    let s = sh.session();
    let status = s.status();
    let events = s.events.since(seen);
    let last = s.events.last_seq();
    drop(s);
    let wall_ms = SystemTime::now()
        .duration_since(UNIX_EPOCH)
        .map_or(0.0, |d| d.as_secs_f64() * 1e3);
    let mut msg = json!({
        "type": "status",
        "wall_ms": wall_ms,
        "status": status,
        "events": events,
    });
    if let Some(g) = sh.graph.get() {
        msg["graph"] = json!(g.view());
    }
    (msg.to_string(), last)
}

/// Pushes the status to every WebSocket client, while there are any.
pub(crate) async fn push_status(sh: Arc<Shared>) {
    let mut tick = tokio::time::interval(Duration::from_micros(PUSH_INTERVAL_US));
    tick.set_missed_tick_behavior(tokio::time::MissedTickBehavior::Skip);
    let mut seen = 0;
    loop {
        tokio::select! {
            _ = tick.tick() => {}
            () = sh.changed.notified() => {}
        }
        if sh.updates.receiver_count() == 0 {
            // Nobody listens: note where the events are, nothing more (the
            // clock thread ticks the session).
            seen = sh
                .session
                .lock()
                .unwrap_or_else(|e| e.into_inner())
                .events
                .last_seq();
            continue;
        }
        let (msg, last) = push_message(&sh, seen);
        seen = last;
        let _ = sh.updates.send(msg.into());
    }
}
