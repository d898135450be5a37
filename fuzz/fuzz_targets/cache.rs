//! Fuzz target: the bake cache. The container (magic, versions, technique, key, length,
//! checksum) and every technique's payload codec must return an asset or an error, never panic
//! or allocate more than the bytes they were given justify. No GPU: decoding is plain CPU code.
//!
//! The first byte picks what the rest is: 0 a whole cache file (checked against each
//! technique's key; a payload that passes is decoded too), 1 an octahedral payload, 2 a box
//! tree payload, 3 an HBT payload. Seeds: `SYLVAN_FUZZ_CACHE_SEEDS=DIR` makes the target write
//! tiny valid entries of each kind to DIR and exit (`scripts/fuzz.sh` does this).
//! Run: `scripts/fuzz.sh cache`.
#![no_main]

use libfuzzer_sys::fuzz_target;
use sylvan_render::bake::Bake;
use sylvan_render::bake::cache::{self, CacheKey};
use sylvan_render::bake::codec::Codec;
use sylvan_render::bake::image::TileLevel;
use sylvan_render::technique::boxtree::{BoxTreeBake, BoxTreeBaked, PlaneLayout, bake::BakedBox};
use sylvan_render::technique::hbt::HbtBake;
use sylvan_render::technique::hbt::bake::{HbtBaked, ObjectBtf, Placement, SmallLevel};
use sylvan_render::technique::octahedral::{OctahedralBake, OctahedralBaked};

/// The key every fuzzed cache file is checked against (the seeds carry it).
fn key<B: Bake>() -> CacheKey {
    CacheKey {
        technique: B::NAME.to_string(),
        format_version: B::FORMAT_VERSION,
        hash: 0x5eed_f00d,
    }
}

fn container(bytes: &[u8]) {
    if let Ok(p) = cache::decode(bytes, &key::<OctahedralBake>()) {
        let _ = OctahedralBaked::decode(&p);
    }
    if let Ok(p) = cache::decode(bytes, &key::<BoxTreeBake>()) {
        let _ = BoxTreeBaked::decode(&p);
    }
    if let Ok(p) = cache::decode(bytes, &key::<HbtBake>()) {
        let _ = HbtBaked::decode(&p);
    }
}

fn chain(tile: u32) -> Vec<TileLevel> {
    (0..=tile.ilog2())
        .map(|m| {
            let size = (tile >> m).max(1);
            let n = (size * size * 4) as usize;
            TileLevel {
                size,
                color: vec![m as u8; n],
                normal: vec![128; n],
            }
        })
        .collect()
}

fn seeds() -> Vec<(&'static str, u8, Vec<u8>, CacheKey)> {
    let oct = OctahedralBaked {
        grid: 4,
        tile: 16,
        centre: [0.0, 1.0, 0.0],
        radius: 1.5,
        tiles: (0..16).map(|_| chain(16)).collect(),
    };
    let layout = PlaneLayout::Axis;
    let boxes = BoxTreeBaked {
        tile: 4,
        layout,
        bake_wood: false,
        boxes: vec![BakedBox {
            node: 0,
            parent: u32::MAX,
            children: vec![],
            min: [-1.0, 0.0, -1.0],
            max: [1.0, 2.0, 1.0],
            residual_leaves: 0..3,
            residual_wood: 0..0,
            metres_per_texel: 0.5,
            leaves: 1,
        }],
        leaf_indices: vec![0, 1, 2],
        wood_indices: vec![],
        tiles: (0..layout.images()).map(|_| chain(4)).collect(),
    };
    let mips = |t: u32| -> Vec<Vec<u8>> {
        (0..=t.ilog2())
            .map(|m| vec![m as u8; ((t >> m) * (t >> m) * 4) as usize])
            .collect()
    };
    let identity = glam::Affine3A::IDENTITY.to_cols_array();
    let hbt = HbtBaked {
        tile: 4,
        view_level: 0,
        light_level: 0,
        bbox_min: [0.0; 3],
        bbox_max: [1.0; 3],
        direct: vec![mips(4); 36],
        ambient: vec![mips(4); 12],
        branch_view_level: 0,
        branch_light_level: 0,
        objects: vec![ObjectBtf {
            object: 3,
            uses: 1,
            bbox_min: [0.0; 3],
            bbox_max: [1.0; 3],
            direct: vec![mips(4); 36],
            ambient: vec![mips(4); 12],
        }],
        placements: vec![Placement {
            object: 0,
            transform: identity,
        }],
        cube_resolution: 2,
        cubes: vec![7; 8 * 6 * 4],
        small: SmallLevel::default(),
    };
    vec![
        ("octahedral", 1, oct.encode(), key::<OctahedralBake>()),
        ("boxtree", 2, boxes.encode(), key::<BoxTreeBake>()),
        ("hbt", 3, hbt.encode(), key::<HbtBake>()),
    ]
}

fn write_seeds(dir: &std::path::Path) {
    std::fs::create_dir_all(dir).expect("create the seed folder");
    for (name, selector, payload, key) in seeds() {
        let ok = match selector {
            1 => OctahedralBaked::decode(&payload).map(|_| ()),
            2 => BoxTreeBaked::decode(&payload).map(|_| ()),
            _ => HbtBaked::decode(&payload).map(|_| ()),
        };
        eprintln!("seed {name}: {} bytes, decodes: {ok:?}", payload.len());
        let mut p = vec![selector];
        p.extend_from_slice(&payload);
        std::fs::write(dir.join(format!("{name}.payload")), p).expect("write a seed");
        let mut c = vec![0];
        c.extend_from_slice(&cache::encode(&key, &payload));
        std::fs::write(dir.join(format!("{name}.sylbake")), c).expect("write a seed");
    }
}

fuzz_target!(
    init: {
        if let Some(dir) = std::env::var_os("SYLVAN_FUZZ_CACHE_SEEDS") {
            write_seeds(std::path::Path::new(&dir));
            std::process::exit(0);
        }
    },
    |data: &[u8]| {
        let Some((&kind, rest)) = data.split_first() else { return };
        match kind % 4 {
            0 => container(rest),
            1 => drop(OctahedralBaked::decode(rest)),
            2 => drop(BoxTreeBaked::decode(rest)),
            _ => drop(HbtBaked::decode(rest)),
        }
    }
);
