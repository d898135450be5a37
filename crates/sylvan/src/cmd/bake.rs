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

/// What every bake reports, whatever the technique (flattened into the JSON).
#[derive(Serialize)]
struct Common {
    plant: String,
    technique: &'static str,
    from_cache: bool,
    bake_ms: f64,
    file: Option<String>,
    file_bytes: u64,
    /// GPU texture bytes of the images (all mips).
    image_bytes: u64,
    images: usize,
    tile: u32,
    #[serde(skip_serializing_if = "Option::is_none")]
    rebaked_because: Option<String>,
}

impl Common {
    /// ", 2.9 MB of images, baked in 412 ms → FILE".
    fn tail(&self) -> String {
        format!(
            "{:.2} MB of images, {} in {:.0} ms{}",
            self.image_bytes as f64 / 1e6,
            if self.from_cache {
                "read from cache"
            } else {
                "baked"
            },
            self.bake_ms,
            self.file
                .as_ref()
                .map(|f| format!(" → {f}"))
                .unwrap_or_default()
        )
    }
}

#[derive(Serialize)]
struct BoxTreeSummary {
    #[serde(flatten)]
    common: Common,
    boxes: usize,
    planes: &'static str,
}

#[derive(Serialize)]
struct HbtSummary {
    #[serde(flatten)]
    common: Common,
    views: usize,
    lights: usize,
    /// Objects of the level below with their own BTF (`--hbt-levels 2`): representative main
    /// branches and the plant's rest.
    branch_objects: usize,
    /// Where the level below places them.
    branch_placements: usize,
    /// Small-branch level (`--hbt-small-branches`): its objects (representatives and main
    /// branches' rests).
    small_objects: usize,
    /// Their placements in the main branches.
    small_placements: usize,
    /// Image bytes of the tree level (all mips).
    tree_bytes: u64,
    /// Image bytes of the levels below (main and small branches).
    branch_bytes: u64,
    /// Bytes of the branch levels' visibility cube-maps.
    cube_bytes: u64,
}

/// Bakes (or reads) `R`'s asset for `plant` with a progress bar, into `--out` or the cache.
fn bake_one<R: sylvan_render::technique::Representation>(
    args: &BakeCmdArgs,
    plant: &sylvan_plant::Plant,
    params: &R::Params,
) -> anyhow::Result<(R::Baked, Common)> {
    let policy = match &args.out {
        Some(f) => CachePolicy::File(f.clone()),
        None => args.bake.cache(),
    };
    let gpu = sylvan_gpu::Gpu::new()?;
    let bar = BakeBar::new();
    let (baked, report) = bake::load_or_bake::<R>(&gpu, plant, params, &policy, &mut |d, t| {
        bar.update(&plant.name, d, t)
    })
    .with_context(|| format!("baking {}", plant.name))?;
    bar.finish();
    let common = Common {
        plant: plant.name.clone(),
        technique: R::NAME,
        from_cache: report.from_cache,
        bake_ms: report.ms,
        file: report.path.as_ref().map(|p| p.display().to_string()),
        file_bytes: report
            .path
            .as_ref()
            .and_then(|p| std::fs::metadata(p).ok())
            .map_or(0, |m| m.len()),
        image_bytes: 0,
        images: 0,
        tile: 0,
        rebaked_because: report.stale.clone(),
    };
    Ok((baked, common))
}

/// Prints `summary` as JSON, or `line` for people.
fn print(json: bool, summary: &impl Serialize, line: String) -> anyhow::Result<()> {
    if json {
        println!("{}", serde_json::to_string(summary)?);
    } else {
        println!("{line}");
    }
    Ok(())
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
    match TechniqueKind::parse(&args.technique)? {
        TechniqueKind::BoxTree => {
            let (baked, mut common) = bake_one::<BoxTree>(&args, &plant, &args.bake.boxtree()?)?;
            common.image_bytes = baked.image_bytes();
            common.images = baked.tiles.len();
            common.tile = baked.tile;
            let s = BoxTreeSummary {
                boxes: baked.boxes.len(),
                planes: baked.layout.name(),
                common,
            };
            let line = format!(
                "{}: {} boxes, {} images of {}² ({} planes), {}",
                s.common.plant,
                s.boxes,
                s.common.images,
                s.common.tile,
                s.planes,
                s.common.tail()
            );
            print(args.json, &s, line)
        }
        TechniqueKind::Hbt => {
            let (baked, mut common) = bake_one::<Hbt>(&args, &plant, &args.bake.hbt()?)?;
            let (tree_bytes, branch_bytes) = baked.image_bytes();
            let cube_bytes = (baked.cubes.len() + baked.small.cubes.len()) as u64;
            common.image_bytes = tree_bytes + branch_bytes + cube_bytes;
            common.images = baked.direct.len()
                + baked.ambient.len()
                + baked
                    .objects
                    .iter()
                    .chain(&baked.small.objects)
                    .map(|o| o.direct.len() + o.ambient.len())
                    .sum::<usize>();
            common.tile = baked.tile;
            let s = HbtSummary {
                views: baked.views(),
                lights: baked.lights(),
                branch_objects: baked.objects.len(),
                branch_placements: baked.placements.len(),
                small_objects: baked.small.objects.len(),
                small_placements: baked.small.placements.len(),
                tree_bytes,
                branch_bytes,
                cube_bytes,
                common,
            };
            let line = format!(
                "{}: {} views × {} lights + {} ambient images of {}² for the tree ({:.1} MB), {} branch objects for {} placements ({:.1} MB, cube-maps {:.2} MB), {} images in all, {}",
                s.common.plant,
                s.views,
                s.lights,
                baked.ambient.len(),
                s.common.tile,
                tree_bytes as f64 / 1e6,
                s.branch_objects,
                s.branch_placements,
                branch_bytes as f64 / 1e6,
                s.cube_bytes as f64 / 1e6,
                s.common.images,
                s.common.tail()
            );
            print(args.json, &s, line)
        }
        _ => bail!(
            "--technique {}: nothing to bake (only boxtree and hbt bake so far) — use --technique boxtree or hbt",
            args.technique
        ),
    }
}
