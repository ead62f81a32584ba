//! `clatter query` (being written).
/// Runs the JSON-lines query loop on `input` (a path or `-`).
pub fn run(input: &str) -> anyhow::Result<()> {
    anyhow::bail!("query is not implemented yet ({input})")
}
