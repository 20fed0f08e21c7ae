//! What a model's XML may be before a third-party parser sees it. The MJCF and URDF parsers
//! recurse once per nesting level, so deep nesting overflowed the stack and aborted the whole
//! server (at load, or later when a fork or verify folded the model on a smaller thread stack);
//! entities could expand to such nesting behind a scan's back. Models use neither: MuJoCo's
//! Gymnasium models nest about ten levels, and neither format uses a DTD.

use crate::value::Refusal;

/// The deepest element nesting a model may have (MuJoCo and URDF models in use nest ~10–20).
pub const MAX_XML_DEPTH: usize = 64;

/// Refuses XML nested deeper than [`MAX_XML_DEPTH`] or declaring entities, in one sentence
/// naming `what` (the parameter). A linear scan that never recurses.
pub fn check(xml: &str, what: &str) -> Result<(), Refusal> {
    let b = xml.as_bytes();
    let mut depth = 0usize;
    let mut i = 0;
    let skip_past = |from: usize, end: &[u8]| -> usize {
        b[from..].windows(end.len()).position(|w| w == end).map_or(b.len(), |p| from + p + end.len())
    };
    while i < b.len() {
        if b[i] != b'<' {
            i += 1;
            continue;
        }
        let rest = &b[i..];
        if rest.starts_with(b"<!--") {
            i = skip_past(i + 4, b"-->");
        } else if rest.starts_with(b"<![CDATA[") {
            i = skip_past(i + 9, b"]]>");
        } else if rest.starts_with(b"<!") {
            // A DOCTYPE: a bare one (`<!DOCTYPE robot>`) is harmless. One with a quoted
            // identifier could hide a `>` (and then a comment swallowing the model) from this
            // scan, one with `[` declares entities: models use neither.
            let end = skip_past(i + 2, b">");
            if b[i..end].iter().any(|c| matches!(c, b'"' | b'\'' | b'[')) {
                return Err(format!("{what} has a DOCTYPE with an identifier or declarations (entities), which models do not use"));
            }
            i = end;
        } else if rest.starts_with(b"<?") {
            i = skip_past(i + 2, b"?>");
        } else if rest.starts_with(b"</") {
            depth = depth.saturating_sub(1);
            i = skip_past(i + 2, b">");
        } else {
            // An opening tag: find its end outside quoted attribute values.
            let mut j = i + 1;
            let mut quote = None;
            while j < b.len() {
                match (quote, b[j]) {
                    (None, q @ (b'"' | b'\'')) => quote = Some(q),
                    (Some(q), c) if c == q => quote = None,
                    (None, b'>') => break,
                    _ => {}
                }
                j += 1;
            }
            let self_closing = j > 0 && j < b.len() && b[j - 1] == b'/';
            if !self_closing {
                depth += 1;
                if depth > MAX_XML_DEPTH {
                    return Err(format!("{what} nests elements deeper than {MAX_XML_DEPTH} levels, more than any model needs"));
                }
            }
            i = j + 1;
        }
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::{check, MAX_XML_DEPTH};

    fn nested(n: usize) -> String {
        format!("<mujoco>{}{}</mujoco>", "<body a=\"x>y\">".repeat(n - 1), "</body>".repeat(n - 1))
    }

    #[test]
    fn depth_up_to_the_bound_passes_and_one_more_is_refused() {
        assert!(check(&nested(MAX_XML_DEPTH), "file_path").is_ok());
        let e = check(&nested(MAX_XML_DEPTH + 1), "file_path").unwrap_err();
        assert!(e.starts_with("file_path nests elements deeper than 64"), "{e}");
    }

    #[test]
    fn self_closing_tags_comments_and_declarations_do_not_count() {
        let many = format!("<?xml version=\"1.0\"?><!DOCTYPE robot><robot>{}<!-- <a><a><a> --><![CDATA[<b><b>]]></robot>", "<link name=\"l\"/>".repeat(500));
        assert!(check(&many, "file_path").is_ok());
    }

    #[test]
    fn entities_and_quoted_doctypes_are_refused() {
        let e = check(r#"<?xml version="1.0"?><!DOCTYPE m [<!ENTITY l "lol">]><m>&l;</m>"#, "file_path").unwrap_err();
        assert!(e.contains("entities"), "{e}");
        // A quoted `>` would end the DOCTYPE early for a scan that ignored quotes, and the
        // comment it opens would hide thousands of levels.
        let deep = format!(r#"<!DOCTYPE m SYSTEM "><!--"><m>{}{}<!-- --></m>"#, "<a>".repeat(5000), "</a>".repeat(5000));
        assert!(check(&deep, "file_path").is_err());
    }
}
