//! Lines to stdout that survive a reader who stops reading (`meshflow services | head`).
//! `println!` panics on a closed pipe; here a closed pipe ends the process quietly, as it
//! ends a C tool, and any other write failure ends it with the reason.

use std::io::Write;

/// Prints one line, like `println!`.
macro_rules! out {
    ($($arg:tt)*) => {
        $crate::output::line(format_args!($($arg)*))
    };
}
pub(crate) use out;

pub fn line(text: std::fmt::Arguments) {
    let mut stdout = std::io::stdout().lock();
    let written = stdout.write_fmt(text).and_then(|()| stdout.write_all(b"\n"));
    match written {
        Ok(()) => {}
        Err(e) if e.kind() == std::io::ErrorKind::BrokenPipe => std::process::exit(0),
        Err(e) => {
            let _ = writeln!(std::io::stderr(), "error: writing to stdout: {e}");
            std::process::exit(1)
        }
    }
}
