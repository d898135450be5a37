//! `sylvan plant` (placeholder until the plants work lands).

/// Flags of `sylvan plant`.
#[derive(clap::Args)]
pub struct PlantArgs {}

/// Runs `sylvan plant`.
pub fn run(_args: PlantArgs) -> anyhow::Result<()> {
    anyhow::bail!("sylvan plant is not implemented yet")
}
