//! Text surgery on the animator's own Spine JSON ([`super::spine_rig`]): an entry added to one of
//! its top-level objects, every other byte of their file as it was.

use serde_json::value::RawValue;
use std::collections::HashMap;

/// Byte offset of `inner` (a slice of `outer`) in `outer`.
fn offset_in(outer: &str, inner: &str) -> usize {
    inner.as_ptr() as usize - outer.as_ptr() as usize
}

/// `text` (a JSON object) with `key: value` (both JSON text) as the first entry of its top-level
/// object `object`, or with `"object": {key: value}` added last when it has none. An entry of
/// that key already there is replaced when `replace`, else left as it is (`text` unchanged).
/// Every other byte of `text` stays.
pub(crate) fn splice(
    text: &str,
    object: &str,
    key: &str,
    value: &str,
    replace: bool,
) -> std::result::Result<String, String> {
    let top: HashMap<String, &RawValue> =
        serde_json::from_str(text).map_err(|e| format!("not a JSON object: {e}"))?;
    let name: String = serde_json::from_str(key).map_err(|e| e.to_string())?;
    let not_object = || format!("`{object}` is not an object");
    let Some(raw) = top.get(object) else {
        // Before the top object's closing brace.
        let close = text.rfind('}').ok_or("does not end in '}'")?;
        let body = text[..close].trim_end();
        let sep = if body.ends_with('{') { "" } else { "," };
        return Ok(format!(
            "{body}{sep}{}:{{{key}:{value}}}{}",
            serde_json::to_string(object).map_err(|e| e.to_string())?,
            &text[body.len()..]
        ));
    };
    let anims_text = raw.get();
    let at = offset_in(text, anims_text);
    let entries: HashMap<String, &RawValue> =
        serde_json::from_str(anims_text).map_err(|_| not_object())?;
    if let Some(old) = entries.get(&name) {
        if !replace {
            return Ok(text.to_owned());
        }
        let (s, e) = (offset_in(text, old.get()), old.get().len());
        return Ok(format!("{}{value}{}", &text[..s], &text[s + e..]));
    }
    // Just after the opening brace.
    let brace = at + anims_text.find('{').ok_or_else(not_object)? + 1;
    let sep = if entries.is_empty() { "" } else { "," };
    Ok(format!(
        "{}{key}:{value}{sep}{}",
        &text[..brace],
        &text[brace..]
    ))
}

#[cfg(test)]
mod tests {
    use super::*;
    use serde_json::Value;

    #[test]
    fn splice_keeps_every_other_byte() {
        let text =
            "{\n  \"bones\": [{\"name\": \"a\"}],\n  \"animations\": {\n    \"idle\": {}\n  }\n}\n";
        let out = splice(text, "animations", "\"mocap\"", "{\"bones\":{}}", true).unwrap();
        assert_eq!(
            out,
            "{\n  \"bones\": [{\"name\": \"a\"}],\n  \"animations\": {\"mocap\":{\"bones\":{}},\n    \"idle\": {}\n  }\n}\n"
        );
        // The same name again: replaced, not added.
        let again = splice(&out, "animations", "\"mocap\"", "{}", true).unwrap();
        assert_eq!(again, out.replace("{\"bones\":{}}", "{}"));
        // No animations: added last.
        let out = splice("{\"bones\": []}\n", "animations", "\"m\"", "{}", true).unwrap();
        assert_eq!(out, "{\"bones\": [],\"animations\":{\"m\":{}}}\n");
        let v: Value = serde_json::from_str(&out).unwrap();
        assert!(v["animations"]["m"].is_object());
        // Empty animations.
        let out = splice("{\"animations\": { }}", "animations", "\"m\"", "1", true).unwrap();
        assert_eq!(out, "{\"animations\": {\"m\":1 }}");
        // Not replacing: an entry already there stays, byte for byte; others go first.
        let events = "{\"events\": {\"step\": {\"int\": 3}}}";
        assert_eq!(
            splice(events, "events", "\"step\"", "{}", false).unwrap(),
            events
        );
        assert_eq!(
            splice(events, "events", "\"land\"", "{}", false).unwrap(),
            "{\"events\": {\"land\":{},\"step\": {\"int\": 3}}}"
        );
    }
}
