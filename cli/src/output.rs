//! Results written to standard output with every write error reported (a closed pipe, a full
//! disk behind a redirection), where `println!` would panic.

use std::io::Write;

use anyhow::Context;

/// Writes `value` as pretty-printed JSON and a newline to standard output, and flushes it.
///
/// # Errors
/// The serialisation or write error, naming standard output.
pub fn print_json(value: &impl serde::Serialize) -> anyhow::Result<()> {
    let mut out = std::io::stdout().lock();
    serde_json::to_writer_pretty(&mut out, value)
        .map_err(anyhow::Error::from)
        .and_then(|()| out.write_all(b"\n").map_err(anyhow::Error::from))
        .and_then(|()| out.flush().map_err(anyhow::Error::from))
        .context("writing the JSON report to standard output")
}
