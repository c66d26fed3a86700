//! The API socket's framing and requests: each message is one JSON object
//! ended by the byte 0x03; a request is `{"id": …, "method": …, "params":
//! {…}}`, its answer `{"id": …, "result": …}` or `{"id": …, "error":
//! {"error": "WebRequestError", "message": …}}` (Klipper's error object).

use serde_json::{json, Map, Value};

/// Ends every message, both ways.
pub const ETX: u8 = 0x03;
/// Longest message taken, bytes: more before an 0x03 is an error, and what
/// follows up to the next 0x03 is dropped.
pub const MAX_MESSAGE: usize = 1 << 20;

/// A message cut from the byte stream.
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum Frame {
    /// The bytes of one message, without its 0x03.
    Message(Vec<u8>),
    /// A message longer than [`MAX_MESSAGE`] (dropped).
    TooLong,
}

/// Cuts the byte stream into messages.
#[derive(Default)]
pub struct Frames {
    buf: Vec<u8>,
    /// Within a message that was too long: bytes are dropped until its end.
    skipping: bool,
}

impl Frames {
    /// Takes `bytes`; returns the messages they complete, in order.
    pub fn push(&mut self, bytes: &[u8]) -> Vec<Frame> {
        let mut done = Vec::new();
        for &b in bytes {
            if b == ETX {
                if self.skipping {
                    self.skipping = false;
                } else {
                    done.push(Frame::Message(std::mem::take(&mut self.buf)));
                }
                continue;
            }
            if self.skipping {
                continue;
            }
            if self.buf.len() == MAX_MESSAGE {
                self.buf = Vec::new();
                self.skipping = true;
                done.push(Frame::TooLong);
                continue;
            }
            self.buf.push(b);
        }
        done
    }

    /// Bytes waiting for their 0x03.
    pub fn pending(&self) -> usize {
        self.buf.len()
    }
}

/// A value as one message: its JSON and 0x03.
pub fn encode(v: &Value) -> Vec<u8> {
    let mut out = serde_json::to_vec(v).unwrap_or_else(|_| b"{}".to_vec());
    out.push(ETX);
    out
}

/// One request.
#[derive(Clone, Debug, PartialEq)]
pub struct Request {
    /// Its id, echoed in the answer; none: no answer is sent.
    pub id: Option<Value>,
    /// The endpoint, e.g. `objects/query`.
    pub method: String,
    /// Its parameters (an object; empty when absent).
    pub params: Map<String, Value>,
}

/// Why a message is not a request; the error answer says this.
#[derive(Clone, Debug, PartialEq, Eq, thiserror::Error)]
pub enum RequestError {
    /// Not JSON.
    #[error("malformed JSON: {0}")]
    Json(String),
    /// JSON, but not an object.
    #[error("a request is a JSON object with `method` and `params`")]
    NotObject,
    /// No `method`, or not a string.
    #[error("the request has no `method` (a string)")]
    NoMethod,
    /// `params` is not an object.
    #[error("Invalid Argument Type [params]: expected an object")]
    Params,
    /// Over [`MAX_MESSAGE`].
    #[error("the message is longer than {MAX_MESSAGE} bytes")]
    TooLong,
}

/// Reads one message as a request. On error, the id (if it could be read)
/// goes with it so the answer reaches the right caller.
pub fn parse(bytes: &[u8]) -> Result<Request, (Option<Value>, RequestError)> {
    let v: Value = serde_json::from_slice(bytes).map_err(|e| {
        (
            None,
            RequestError::Json(format!("line {} column {}: {e}", e.line(), e.column())),
        )
    })?;
    let Value::Object(mut o) = v else {
        return Err((None, RequestError::NotObject));
    };
    let id = o.remove("id").filter(|v| !v.is_null());
    let method = match o.remove("method") {
        Some(Value::String(m)) => m,
        _ => return Err((id, RequestError::NoMethod)),
    };
    let params = match o.remove("params") {
        None | Some(Value::Null) => Map::new(),
        Some(Value::Object(p)) => p,
        Some(_) => return Err((id, RequestError::Params)),
    };
    Ok(Request { id, method, params })
}

/// The answer carrying `result`.
pub fn result(id: &Value, result: Value) -> Value {
    json!({"id": id, "result": result})
}

/// The answer carrying Klipper's error object.
pub fn error(id: Option<&Value>, message: &str) -> Value {
    json!({
        "id": id.cloned().unwrap_or(Value::Null),
        "error": {"error": "WebRequestError", "message": message},
    })
}
