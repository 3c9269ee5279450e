//! The number of steps the stepping diagnostics take from their command line.

use anyhow::Context;

/// `text` as a number of steps, 1 or more.
pub fn whole_steps(text: &str) -> anyhow::Result<u64> {
    text.parse()
        .ok()
        .filter(|&n| n > 0)
        .with_context(|| format!("STEPS: {text:?} is not a whole number of steps, 1 or more"))
}
