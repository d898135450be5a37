//! `sylvan compare` (placeholder until the metrics work lands).

/// Flags of `sylvan compare`.
#[derive(clap::Args)]
pub struct CompareArgs {}

/// Runs `sylvan compare`.
pub fn run(_args: CompareArgs) -> anyhow::Result<()> {
    anyhow::bail!("sylvan compare is not implemented yet")
}
