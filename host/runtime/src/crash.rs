//! What a user reads when a plugin crashes: the plugin's own words first (a Rust panic's
//! message, which it prints to stderr before trapping), then the trap, then the wasm stack.
//! Advice the sandbox makes impossible to follow (`RUST_BACKTRACE=1`: plugins get no
//! environment) is dropped.

use wasmtime::WasmBacktrace;

/// The most of the plugin's stderr kept in a message (its end, where the panic is).
const STDERR_SHOWN_BYTES: usize = 2000;

/// The message of a crashed run: `stderr` is what the plugin printed.
pub(crate) fn crash_message(error: &wasmtime::Error, stderr: &str) -> String {
    let said: Vec<&str> = stderr
        .lines()
        .filter(|line| !line.starts_with("note: run with `RUST_BACKTRACE=1`"))
        .filter(|line| !line.trim().is_empty())
        .collect();
    let said = said.join("\n");
    let mut message = String::new();
    if !said.is_empty() {
        message.push_str(tail(&said, STDERR_SHOWN_BYTES));
        message.push('\n');
    }
    message.push_str(&error.root_cause().to_string());
    if let Some(stack) = error.downcast_ref::<WasmBacktrace>() {
        message.push_str("\nwasm stack:\n");
        message.push_str(stack.to_string().trim_end());
    }
    message
}

fn tail(text: &str, max: usize) -> &str {
    let start = text.len().saturating_sub(max);
    let start = (start..text.len()).find(|&i| text.is_char_boundary(i)).unwrap_or(text.len());
    &text[start..]
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_panic_comes_first_and_the_backtrace_advice_goes() {
        let stderr = "\nthread '<unnamed>' panicked at src/lib.rs:27:5:\nno mesh today\n\
                      note: run with `RUST_BACKTRACE=1` environment variable to display a backtrace\n";
        let error = wasmtime::Error::msg("wasm trap: wasm `unreachable` instruction executed");
        let message = crash_message(&error, stderr);
        assert!(
            message.starts_with("thread '<unnamed>' panicked at src/lib.rs:27:5:\nno mesh today\n"),
            "{message}"
        );
        assert!(message.ends_with("unreachable` instruction executed"), "{message}");
        assert!(!message.contains("RUST_BACKTRACE"), "{message}");
    }
}
