//! What the page's API answers with ([`Reply`]), and reading a request's JSON body.

use serde_json::{json, Value};

/// An HTTP reply: status, content type, body.
#[derive(Debug, Clone, PartialEq)]
pub struct Reply {
    pub status: u16,
    pub content_type: &'static str,
    pub body: Vec<u8>,
}

impl Reply {
    pub fn json(status: u16, v: &Value) -> Reply {
        Reply {
            status,
            content_type: "application/json",
            body: v.to_string().into_bytes(),
        }
    }

    /// `{"error": msg}` with `status`.
    pub fn error(status: u16, msg: impl Into<String>) -> Reply {
        Reply::json(status, &json!({ "error": msg.into() }))
    }
}

/// The JSON request `body`, or a 400 reply saying it is malformed and to send `shape`.
pub fn json_body<T: serde::de::DeserializeOwned>(
    body: &[u8],
    shape: &str,
) -> std::result::Result<T, Reply> {
    serde_json::from_slice(body)
        .map_err(|e| Reply::error(400, format!("malformed body: {e}; send {shape}")))
}
