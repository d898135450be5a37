//! `sylvan bake`: bake one plant's asset for a technique into the cache (or `--out FILE`), with
//! a progress bar; prints what was baked as one JSON object with `--json`. Which techniques
//! bake, and what they report, comes from the registry.

use super::common::{BakeArgs, BakeBar};
use anyhow::{Context, bail};
use std::path::PathBuf;
use sylvan_render::bake::CachePolicy;
use sylvan_render::registry::{self, BakeJob};

/// Flags of `sylvan bake`.
#[derive(clap::Args)]
pub struct BakeCmdArgs {
    /// A `.lsys`, `.glb`, `.gltf` or `.obj` file (or use --preset).
    pub source: Option<PathBuf>,
    /// A built-in plant: pine, prunus, bush, chestnut or beech.
    #[arg(long, value_name = "NAME", conflicts_with = "source")]
    pub preset: Option<String>,
    /// The technique to bake for (`sylvan params` lists them); `shadermap` measures BN12's
    /// ground tables for a scene's forest (`--scene`, default the built-in scene).
    #[arg(long, default_value = "boxtree")]
    pub technique: String,
    /// With `--technique shadermap`: the scene whose species mix the tables are for.
    #[arg(long, value_name = "SCENE.toml")]
    pub scene: Option<PathBuf>,
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

/// Runs `sylvan bake`.
pub fn run(args: BakeCmdArgs) -> anyhow::Result<()> {
    if args.technique == "shadermap" {
        return tables(args);
    }
    if args.scene.is_some() {
        bail!("--scene is for --technique shadermap — bake a plant with SOURCE or --preset");
    }
    let entry = registry::find(&args.technique)?;
    let Some(bake) = entry.bake else {
        let bakers: Vec<&str> = registry::REGISTRY
            .iter()
            .filter(|e| e.bake.is_some())
            .map(|e| e.name)
            .collect();
        bail!(
            "--technique {}: nothing to bake — use one of: {}",
            entry.name,
            bakers.join(", ")
        );
    };
    let settings = args.bake.settings()?;
    let plant = match (&args.preset, &args.source) {
        (Some(name), _) => sylvan_plant::preset(name)?,
        (None, Some(path)) => sylvan_plant::load_with(path, args.unit_scale)?,
        (None, None) => {
            bail!("no plant given — pass a SOURCE file (.lsys, .glb, .gltf, .obj) or --preset NAME")
        }
    };
    let policy = match &args.out {
        Some(f) => CachePolicy::File(f.clone()),
        None => args.bake.cache(),
    };
    let gpu = sylvan_gpu::Gpu::new()?;
    let bar = BakeBar::new();
    let mine: Vec<_> = settings
        .iter()
        .filter(|s| s.technique == entry.name)
        .collect();
    let summary = bake(BakeJob {
        gpu: &gpu,
        plant: &plant,
        settings: &mine,
        policy: &policy,
        progress: &mut |d, t| bar.update(&plant.name, d, t),
    })
    .with_context(|| format!("baking {}", plant.name))?;
    bar.finish();
    let r = &summary.report;
    let file = r.path.as_ref().map(|p| p.display().to_string());
    if args.json {
        let mut json = serde_json::json!({
            "plant": plant.name,
            "technique": entry.name,
            "from_cache": r.from_cache,
            "bake_ms": r.ms,
            "file": file,
            "file_bytes": r.path.as_ref().and_then(|p| std::fs::metadata(p).ok()).map_or(0, |m| m.len()),
            "image_bytes": summary.asset.image_bytes,
            "images": summary.asset.images,
            "tile": summary.asset.tile,
        });
        if let Some(obj) = json.as_object_mut() {
            if let Some(why) = &r.stale {
                obj.insert("rebaked_because".into(), why.clone().into());
            }
            obj.extend(summary.asset.fields.clone());
        }
        println!("{json}");
    } else {
        println!(
            "{}: {}, {:.2} MB of images, {} in {:.0} ms{}",
            plant.name,
            summary.asset.line,
            summary.asset.image_bytes as f64 / 1e6,
            if r.from_cache {
                "read from cache"
            } else {
                "baked"
            },
            r.ms,
            file.map(|f| format!(" → {f}")).unwrap_or_default()
        );
    }
    Ok(())
}

/// `sylvan bake --technique shadermap [--scene FILE]`: the `zfield` bakes of the scene's
/// species, then BN12's ground tables for its mix.
fn tables(args: BakeCmdArgs) -> anyhow::Result<()> {
    if args.source.is_some() || args.preset.is_some() {
        bail!(
            "--technique shadermap bakes for a scene's species mix, not one plant — pass --scene FILE (or nothing for the built-in scene)"
        );
    }
    let scene = super::common::load_scene(args.scene.as_deref())?;
    // The scene's own `[technique.*]` tables, then `--set`, as `render` applies them.
    let settings: Vec<_> = scene
        .technique_params
        .iter()
        .cloned()
        .chain(args.bake.settings()?)
        .collect();
    registry::check_settings(&settings)?;
    let plants = sylvan_render::load_plants(&scene)?;
    // `--out` names the tables' file; the z-field bakes stay in the cache.
    let cache = args.bake.cache();
    let policy = match &args.out {
        Some(f) => CachePolicy::File(f.clone()),
        None => cache.clone(),
    };
    let gpu = sylvan_gpu::Gpu::new()?;
    let bar = BakeBar::new();
    let params = sylvan_render::technique::shadermap::scene::params(&settings)?;
    let (t, r, _) = sylvan_render::technique::shadermap::bake_scene(
        &gpu,
        &scene,
        &plants,
        &settings,
        &cache,
        &policy,
        &mut |what, d, n| bar.update(what, d, n),
    )
    .context("baking the shadermap tables")?;
    bar.finish();
    let file = r.path.as_ref().map(|p| p.display().to_string());
    let (renders, evaluations) = sylvan_render::technique::shadermap::measure::work(&params);
    if args.json {
        let (nt, np) = (t.theta as usize, t.phi as usize);
        // Per density node, per zenith θ (view and sun at the same zenith): φ = 0 is the
        // hotspot, φ = 180° looks into the sun.
        let slice = |f: &dyn Fn(usize, usize) -> f32| -> Vec<Vec<f32>> {
            (0..t.lambdas.len())
                .map(|l| (0..nt).map(|v| f(l, v)).collect())
                .collect()
        };
        let mut json = serde_json::json!({
            "technique": "shadermap",
            "species": r.plant,
            "from_cache": r.from_cache,
            "bake_ms": r.ms,
            "file": file,
            "file_bytes": r.path.as_ref().and_then(|p| std::fs::metadata(p).ok()).map_or(0, |m| m.len()),
            "tables": {"theta": t.theta, "phi": t.phi, "lambda": t.lambdas.len()},
            // Of the measurement (also when the tables were read from the cache).
            "renders": renders,
            "evaluations": evaluations,
            "samples": t.samples,
            "lambdas_per_m2": t.lambdas,
            "crown_area_m2": t.crown_area_m2,
            "h": t.h,
            "gd_by_lambda": t.gd.chunks(nt).collect::<Vec<_>>(),
            "g_facing_sun_by_lambda": slice(&|l, v| t.g_node(l, v, v, np - 1)),
            "t_hotspot_by_lambda": slice(&|l, v| t.t_node(l, v, v, 0)),
            "t_facing_sun_by_lambda": slice(&|l, v| t.t_node(l, v, v, np - 1)),
            "e_by_lambda": t.e.chunks(nt).collect::<Vec<_>>(),
            "d_by_lambda": t.d,
        });
        if let (Some(obj), Some(why)) = (json.as_object_mut(), &r.stale) {
            obj.insert("rebaked_because".into(), why.clone().into());
        }
        println!("{json}");
    } else {
        println!(
            "shadermap tables for {}: 𝔾 and 𝕋 {}×{}×{}×{} ({} renders), {} in {:.0} ms{}",
            r.plant,
            t.theta,
            t.theta,
            t.phi,
            t.lambdas.len(),
            renders,
            if r.from_cache {
                "read from cache"
            } else {
                "measured"
            },
            r.ms,
            file.map(|f| format!(" → {f}")).unwrap_or_default()
        );
    }
    Ok(())
}
