//! Input values quoted in error messages, cut to a readable length.
//!
//! An error that repeats what it found helps a producer fix a file, but repeated whole it
//! can be megabytes (a 6 MB token in one OBJ line once gave 16.8 MB on stderr and in the
//! service's logs). Every reader quotes input through these helpers: at most
//! [`QUOTE_CHARS`] characters, then `…` and the full length in bytes.

/// Characters of an input value kept in a message.
pub const QUOTE_CHARS: usize = 48;

/// Longest free-text message from a parser kept whole (its long words are cut first).
pub const MESSAGE_CHARS: usize = 400;

/// `text` as a Rust string literal (`"abc"`), or its first [`QUOTE_CHARS`] characters
/// followed by `…` and the length: `"abcd…" (6000000 bytes)`.
pub fn quote(text: &str) -> String {
    match cut(text, QUOTE_CHARS) {
        None => format!("{text:?}"),
        Some(head) => format!("{head:?}… ({} bytes)", text.len()),
    }
}

/// Like [`quote`] for values shown as they are (numbers, JSON). A value already in
/// double quotes (a JSON string, a `{:?}`) keeps them around what is left.
pub fn clip(text: &str) -> String {
    if let Some(inner) = text.strip_prefix('"').and_then(|t| t.strip_suffix('"')) {
        if let Some(head) = cut(inner, QUOTE_CHARS) {
            return format!("\"{head}\"… ({} bytes)", inner.len());
        }
    }
    match cut(text, QUOTE_CHARS) {
        None => text.to_string(),
        Some(head) => format!("{head}… ({} bytes)", text.len()),
    }
}

/// A parser's message (TOML, JSON) that may repeat input: every word longer than
/// [`QUOTE_CHARS`] is clipped, then the whole is cut at [`MESSAGE_CHARS`].
pub fn clip_message(message: &str) -> String {
    let mut out = String::new();
    let mut word = String::new();
    for c in message.chars() {
        if c.is_whitespace() {
            out.push_str(&clip(&word));
            out.push(c);
            word.clear();
        } else {
            word.push(c);
        }
        if out.len() > 4 * MESSAGE_CHARS {
            word.clear();
            break;
        }
    }
    out.push_str(&clip(&word));
    match cut(&out, MESSAGE_CHARS) {
        None => out,
        Some(head) => format!("{head}… ({} bytes)", message.len()),
    }
}

/// The first `chars` characters of `text`, or `None` when it is no longer than that.
fn cut(text: &str, chars: usize) -> Option<&str> {
    text.char_indices().nth(chars).map(|(end, _)| &text[..end])
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn short_values_are_quoted_whole() {
        assert_eq!(quote("x"), "\"x\"");
        assert_eq!(quote("tab\there"), "\"tab\\there\"");
        assert_eq!(clip("1e400"), "1e400");
        assert_eq!(
            clip(&format!("{:?}", "y".repeat(60))),
            format!("\"{}\"… (60 bytes)", "y".repeat(48))
        );
        assert_eq!(clip_message("unknown field `x`"), "unknown field `x`");
    }

    #[test]
    fn a_six_megabyte_token_is_cut_with_its_length() {
        let token = "é".repeat(3_000_000);
        let quoted = quote(&token);
        assert!(quoted.ends_with("é\"… (6000000 bytes)"), "{quoted}");
        assert_eq!(quoted.chars().filter(|&c| c == 'é').count(), QUOTE_CHARS);
        let clipped = clip(&token);
        assert_eq!(clipped, format!("{}… (6000000 bytes)", "é".repeat(QUOTE_CHARS)));

        let message = format!("unknown field `{}`, expected `scale`", "a".repeat(6_000_000));
        let clipped = clip_message(&message);
        assert!(clipped.len() < MESSAGE_CHARS + 40, "{} bytes", clipped.len());
        assert!(clipped.starts_with("unknown field `aaaa"), "{clipped}");
        assert!(
            clipped.contains("… (6000003 bytes) expected `scale`"),
            "{clipped}"
        );

        let many_words = "word ".repeat(1_000_000);
        let clipped = clip_message(&many_words);
        assert!(clipped.len() < MESSAGE_CHARS + 40, "{} bytes", clipped.len());
        assert!(clipped.ends_with("… (5000000 bytes)"), "{clipped}");
    }
}
