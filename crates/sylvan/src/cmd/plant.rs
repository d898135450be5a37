//! `sylvan plant`: build a plant from an L-system, a preset or a mesh; print statistics as one
//! JSON object (`--stats`) and/or export a `.glb` (`--out`).

use anyhow::{Context, bail};
use std::path::PathBuf;

/// Flags of `sylvan plant`.
#[derive(clap::Args)]
pub struct PlantArgs {
    /// A `.lsys`, `.glb`, `.gltf` or `.obj` file (or use --preset).
    pub source: Option<PathBuf>,
    /// A built-in plant: pine, prunus, bush, chestnut or beech.
    #[arg(long, value_name = "NAME", conflicts_with = "source")]
    pub preset: Option<String>,
    /// Write the plant as binary glTF (wood and leaves as separate meshes and materials).
    #[arg(long, value_name = "FILE.glb")]
    pub out: Option<PathBuf>,
    /// Print one JSON object: internodes, leaves, triangles, levels, instances, bbox_min, bbox_max, …
    #[arg(long)]
    pub stats: bool,
    /// Metres per file unit for meshes (e.g. 0.01 for an OBJ in centimetres).
    #[arg(long, value_name = "S", default_value_t = 1.0)]
    pub unit_scale: f32,
}

/// Runs `sylvan plant`.
pub fn run(args: PlantArgs) -> anyhow::Result<()> {
    let plant = match (&args.preset, &args.source) {
        (Some(name), _) => sylvan_plant::preset(name)?,
        (None, Some(path)) => sylvan_plant::load_with(path, args.unit_scale)?,
        (None, None) => {
            bail!("no plant given — pass a SOURCE file (.lsys, .glb, .gltf, .obj) or --preset NAME")
        }
    };
    if let Some(out) = &args.out {
        let ext = out
            .extension()
            .and_then(|e| e.to_str())
            .unwrap_or("")
            .to_ascii_lowercase();
        if ext != "glb" {
            bail!(
                "{}: only .glb export is supported — name the output FILE.glb",
                out.display()
            );
        }
        sylvan_plant::export::write_glb(&plant, out)?;
    }
    if args.stats {
        let json = serde_json::to_string(&plant.stats()).context("serialising stats")?;
        println!("{json}");
    } else if args.out.is_none() {
        let s = plant.stats();
        println!(
            "{}: {} internodes, {} leaves, {} triangles, {} levels, {} instances (use --stats for JSON, --out FILE.glb to export)",
            plant.name, s.internodes, s.leaves, s.triangles, s.levels, s.instances
        );
    }
    Ok(())
}
