//! What an error message repeats of a caller's input: at most [`MAX_ECHO_BYTES`], so a
//! 500 KB parameter is not sent back in full (DESIGN §10: every error body is bounded).

/// The most bytes of one piece of user input an error message repeats.
pub const MAX_ECHO_BYTES: usize = 200;

/// `text` cut to at most [`MAX_ECHO_BYTES`] bytes (on a character boundary), with `…` and
/// the full length when something was left out.
pub fn clip(text: &str) -> String {
    if text.len() <= MAX_ECHO_BYTES {
        return text.to_owned();
    }
    let mut end = MAX_ECHO_BYTES;
    while !text.is_char_boundary(end) {
        end -= 1;
    }
    format!("{}… ({} bytes)", &text[..end], text.len())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn long_input_is_cut_on_a_character_boundary() {
        assert_eq!(clip("short"), "short");
        let long = "é".repeat(1000);
        let cut = clip(&long);
        assert!(cut.len() < MAX_ECHO_BYTES + 20, "{}", cut.len());
        assert!(cut.ends_with("(2000 bytes)"));
    }
}
