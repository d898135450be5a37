//! `sylvan bake`: bake one plant's asset for a technique into the cache (or `--out FILE`), with
//! a progress bar; prints what was baked as one JSON object with `--json`.

use super::common::{BakeArgs, BakeBar};
use anyhow::{Context, bail};
use serde::Serialize;
use std::path::PathBuf;
use sylvan_render::TechniqueKind;
use sylvan_render::bake::{self, CachePolicy};
use sylvan_render::technique::boxtree::BoxTree;
use sylvan_render::technique::hbt::Hbt;

/// Flags of `sylvan bake`.
#[derive(clap::Args)]
pub struct BakeCmdArgs {
    /// A `.lsys`, `.glb`, `.gltf` or `.obj` file (or use --preset).
    pub source: Option<PathBuf>,
    /// A built-in plant: pine, prunus or bush.
    #[arg(long, value_name = "NAME", conflicts_with = "source")]
    pub preset: Option<String>,
    /// The technique to bake for (techniques without a bake have nothing to do).
    #[arg(long, default_value = "boxtree")]
    pub technique: String,
    /// Write the baked asset to this file instead of the cache folder.
    #[arg(long, value_name = "FILE")]
    pub out: Option<PathBuf>,
    /// Print one JSON object describing the bake.
    #[arg(long)]
    pub json: bool,
    /// Metres per file unit for meshes.
    #[arg(long, value_name = "S", default_value_t = 1.0)]
    pub unit_scale: f32,
    #[command(flatten)]
    pub bake: BakeArgs,
}

#[derive(Serialize)]
struct BakeSummary {
    plant: String,
    technique: &'static str,
    from_cache: bool,
    bake_ms: f64,
    file: Option<String>,
    file_bytes: u64,
    /// GPU texture bytes of the images (all mips).
    image_bytes: u64,
    boxes: usize,
    images: usize,
    tile: u32,
    planes: &'static str,
    #[serde(skip_serializing_if = "Option::is_none")]
    rebaked_because: Option<String>,
}

/// Runs `sylvan bake`.
pub fn run(args: BakeCmdArgs) -> anyhow::Result<()> {
    let plant = match (&args.preset, &args.source) {
        (Some(name), _) => sylvan_plant::preset(name)?,
        (None, Some(path)) => sylvan_plant::load_with(path, args.unit_scale)?,
        (None, None) => {
            bail!("no plant given — pass a SOURCE file (.lsys, .glb, .gltf, .obj) or --preset NAME")
        }
    };
    let technique = TechniqueKind::parse(&args.technique)?;
    if technique == TechniqueKind::Hbt {
        return run_hbt(&args, &plant);
    }
    if technique != TechniqueKind::BoxTree {
        bail!(
            "--technique {}: nothing to bake (only boxtree and hbt bake so far) — use --technique boxtree",
            args.technique
        );
    }
    let params = args.bake.boxtree()?;
    let policy = match &args.out {
        Some(f) => CachePolicy::File(f.clone()),
        None => args.bake.cache(),
    };
    let gpu = sylvan_gpu::Gpu::new()?;
    let bar = BakeBar::new();
    let (baked, report) =
        bake::load_or_bake::<BoxTree>(&gpu, &plant, &params, &policy, &mut |d, t| {
            bar.update(&plant.name, d, t)
        })
        .with_context(|| format!("baking {}", plant.name))?;
    bar.finish();
    let summary = BakeSummary {
        plant: plant.name.clone(),
        technique: "boxtree",
        from_cache: report.from_cache,
        bake_ms: report.ms,
        file: report.path.as_ref().map(|p| p.display().to_string()),
        file_bytes: report
            .path
            .as_ref()
            .and_then(|p| std::fs::metadata(p).ok())
            .map_or(0, |m| m.len()),
        image_bytes: baked.image_bytes(),
        boxes: baked.boxes.len(),
        images: baked.tiles.len(),
        tile: baked.tile,
        planes: baked.layout.name(),
        rebaked_because: report.stale.clone(),
    };
    if args.json {
        println!("{}", serde_json::to_string(&summary)?);
    } else {
        println!(
            "{}: {} boxes, {} images of {}² ({} planes), {:.1} MB of images, {} in {:.0} ms{}",
            summary.plant,
            summary.boxes,
            summary.images,
            summary.tile,
            summary.planes,
            summary.image_bytes as f64 / 1e6,
            if summary.from_cache {
                "read from cache"
            } else {
                "baked"
            },
            summary.bake_ms,
            summary
                .file
                .as_ref()
                .map(|f| format!(" → {f}"))
                .unwrap_or_default()
        );
    }
    Ok(())
}

#[derive(Serialize)]
struct HbtBakeSummary {
    plant: String,
    technique: &'static str,
    from_cache: bool,
    bake_ms: f64,
    file: Option<String>,
    file_bytes: u64,
    /// GPU texture bytes of the images (all mips).
    image_bytes: u64,
    views: usize,
    lights: usize,
    /// Main-branch base objects with their own BTF (`--hbt-levels 2`).
    branch_objects: usize,
    images: usize,
    tile: u32,
    #[serde(skip_serializing_if = "Option::is_none")]
    rebaked_because: Option<String>,
}

/// `sylvan bake --technique hbt`: the plant's top-level BTF (MNP01).
fn run_hbt(args: &BakeCmdArgs, plant: &sylvan_plant::Plant) -> anyhow::Result<()> {
    let params = args.bake.hbt()?;
    let policy = match &args.out {
        Some(f) => CachePolicy::File(f.clone()),
        None => args.bake.cache(),
    };
    let gpu = sylvan_gpu::Gpu::new()?;
    let bar = BakeBar::new();
    let (baked, report) = bake::load_or_bake::<Hbt>(&gpu, plant, &params, &policy, &mut |d, t| {
        bar.update(&plant.name, d, t)
    })
    .with_context(|| format!("baking {}", plant.name))?;
    bar.finish();
    let summary = HbtBakeSummary {
        plant: plant.name.clone(),
        technique: "hbt",
        from_cache: report.from_cache,
        bake_ms: report.ms,
        file: report.path.as_ref().map(|p| p.display().to_string()),
        file_bytes: report
            .path
            .as_ref()
            .and_then(|p| std::fs::metadata(p).ok())
            .map_or(0, |m| m.len()),
        image_bytes: baked.image_bytes(),
        views: baked.views(),
        lights: baked.lights(),
        branch_objects: baked.objects.len(),
        images: baked.direct.len()
            + baked.ambient.len()
            + baked
                .objects
                .iter()
                .map(|o| o.direct.len() + o.ambient.len())
                .sum::<usize>(),
        tile: baked.tile,
        rebaked_because: report.stale.clone(),
    };
    if args.json {
        println!("{}", serde_json::to_string(&summary)?);
    } else {
        println!(
            "{}: {} views × {} lights + {} ambient images of {}² for the tree, {} branch objects, {} images in all, {:.2} MB of images, {} in {:.0} ms{}",
            summary.plant,
            summary.views,
            summary.lights,
            baked.ambient.len(),
            summary.tile,
            summary.branch_objects,
            summary.images,
            summary.image_bytes as f64 / 1e6,
            if summary.from_cache {
                "read from cache"
            } else {
                "baked"
            },
            summary.bake_ms,
            summary
                .file
                .as_ref()
                .map(|f| format!(" → {f}"))
                .unwrap_or_default()
        );
    }
    Ok(())
}
