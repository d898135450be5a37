//! The bake of `billboard-cloud`: three clouds of decreasing plane count (GPSS07 §6), each
//! clustered (§4.1) and laid out into hash cells, lists, leaf records and low-resolution tiles
//! (§4.2, §5.1, §5.2). All on the CPU (no GPU work: the layers are exact geometry).

use super::BillboardCloudBakeParams;
use super::cluster;
use super::layers::{self, Cloud, CloudSpec, LeafRecord, PlaneRecord};
use crate::RenderError;
use crate::bake::codec::{DecodeError, Decoder, Encoder};
use crate::bake::image::TileLevel;
use crate::bake::{AssetSummary, Bake};
use sylvan_gpu::Gpu;
use sylvan_plant::Plant;

/// Bumped whenever the payload below or the bake's result changes.
pub const FORMAT_VERSION: u32 = 6;

/// One plant's three clouds, nearest first.
#[derive(Debug, Clone, PartialEq)]
pub struct BillboardCloudBaked {
    /// Near, mid and far cloud (the far one keeps only its low-resolution tiles).
    pub clouds: Vec<Cloud>,
    /// Leaves of the plant (the near cloud holds their flat parts, [`cluster::parts`]).
    pub leaves: u32,
}

impl BillboardCloudBaked {
    /// GPU bytes of all three clouds.
    pub fn bytes(&self) -> u64 {
        self.clouds.iter().map(Cloud::bytes).sum()
    }
}

/// The bake.
pub struct BillboardCloudBake;

/// Leaves of a plant as the bake counts them.
pub fn leaf_count(plant: &Plant) -> usize {
    cluster::leaves(plant, false).len()
}

/// Whether cloud `level` (0 nearest) is made of the leaves' flat parts: only the near cloud,
/// which serves close views, where a folded blade drawn as one plane shows (the chestnut at 800
/// px: 1.56× → 1.26× 1-spp geometry's ꟻLIP); farther, the parts cost walk time (twice the
/// list entries: 100 chestnuts 0.37× → 0.49× geometry's frame) for no measured gain (200 px
/// 1.05× either way).
pub fn cut_leaves(level: usize) -> bool {
    level == 0
}

/// Bakes the three clouds of `plant` (CPU only).
pub fn bake_clouds(
    plant: &Plant,
    p: &BillboardCloudBakeParams,
    progress: &mut dyn FnMut(usize, usize),
) -> Result<BillboardCloudBaked, RenderError> {
    let whole = cluster::leaves(plant, false);
    let cut = cluster::leaves(plant, true);
    let specs = [
        (p.planes, p.cells, p.tile, true),
        (p.planes_mid, (p.cells / 4).max(64), p.tile * 2, true),
        (p.planes_far, (p.cells / 16).max(16), p.tile * 2, false),
    ];
    let mut clouds = Vec::with_capacity(3);
    for (i, &(k, cells, tile, layered)) in specs.iter().enumerate() {
        progress(i, 3);
        let leaves = if cut_leaves(i) { &cut } else { &whole };
        let planes = cluster::cluster(plant, leaves, k as usize, p.iterations);
        let cloud = layers::build(
            plant,
            leaves,
            &planes,
            CloudSpec {
                cells,
                tile,
                supersample: p.supersample,
                layered,
            },
        )
        .map_err(RenderError::Plant)?;
        clouds.push(cloud);
    }
    progress(3, 3);
    Ok(BillboardCloudBaked {
        clouds,
        leaves: whole.len() as u32,
    })
}

impl Bake for BillboardCloudBake {
    const NAME: &'static str = "billboard-cloud";
    const FORMAT_VERSION: u32 = FORMAT_VERSION;
    type Params = BillboardCloudBakeParams;
    type Asset = BillboardCloudBaked;

    fn bake(
        _: &Gpu,
        plant: &Plant,
        params: &Self::Params,
        progress: &mut dyn FnMut(usize, usize),
    ) -> Result<Self::Asset, RenderError> {
        bake_clouds(plant, params, progress)
    }

    fn describe(a: &Self::Asset) -> AssetSummary {
        let planes: Vec<usize> = a.clouds.iter().map(|c| c.planes.len()).collect();
        let entries: usize = a.clouds.iter().map(|c| c.lists.len()).sum();
        let mut fields = serde_json::Map::new();
        fields.insert("planes".into(), serde_json::json!(planes));
        fields.insert("leaves".into(), serde_json::json!(a.leaves));
        fields.insert("list_entries".into(), serde_json::json!(entries));
        fields.insert("bytes".into(), serde_json::json!(a.bytes()));
        // Rectangle area of each cloud's planes (plant units²): what a plain billboard cloud
        // of the same planes would have to texture.
        let areas: Vec<f32> = a
            .clouds
            .iter()
            .map(|c| c.planes.iter().map(|p| p.size().x * p.size().y).sum())
            .collect();
        fields.insert("plane_area".into(), serde_json::json!(areas));
        AssetSummary {
            line: format!(
                "{} leaves in clouds of {:?} planes, {} list entries, {:.2} MB",
                a.leaves,
                planes,
                entries,
                a.bytes() as f64 / 1e6
            ),
            image_bytes: a.bytes(),
            images: a.clouds.iter().map(|c| c.lowres.len()).sum(),
            tile: a.clouds.first().map_or(0, |c| c.tile),
            fields,
        }
    }

    fn check(a: &Self::Asset, plant: &Plant) -> Result<(), String> {
        let n = leaf_count(plant);
        if a.leaves as usize != n {
            return Err(format!("{} leaves baked, the plant has {n}", a.leaves));
        }
        let parts = cluster::leaves(plant, true).len();
        for (i, c) in a.clouds.iter().enumerate() {
            let n = if cut_leaves(i) { parts } else { n };
            if c.layered && c.records.len() != n {
                return Err(format!("{} leaf records for {n} leaves", c.records.len()));
            }
            if c.members.iter().flatten().any(|&l| l as usize >= n) {
                return Err("a plane lists a leaf the plant does not have".into());
            }
        }
        Ok(())
    }
}

fn encode_cloud(e: &mut Encoder, c: &Cloud) {
    e.u32(c.tile);
    e.u32(c.layered as u32);
    e.u32s(bytemuck::cast_slice(&c.planes));
    e.u64(c.members.len() as u64);
    for m in &c.members {
        e.u32s(m);
    }
    e.u32s(&c.cells);
    e.u32s(&c.lists);
    e.u32s(bytemuck::cast_slice(&c.records));
    e.u64(c.lowres.len() as u64);
    for chain in &c.lowres {
        TileLevel::encode_chain(e, chain);
    }
}

fn decode_cloud(d: &mut Decoder<'_>) -> Result<Cloud, DecodeError> {
    let bad = |m: String| DecodeError(m);
    let tile = d.u32()?;
    let layered = d.u32()? != 0;
    let raw = d.u32s()?;
    let ps = std::mem::size_of::<PlaneRecord>() / 4;
    if raw.len() % ps != 0 {
        return Err(bad("plane table is not whole records".into()));
    }
    let planes: Vec<PlaneRecord> = bytemuck::pod_collect_to_vec(&raw);
    let nm = d.u64()?;
    if nm != planes.len() as u64 {
        return Err(bad(format!(
            "{nm} member lists for {} planes",
            planes.len()
        )));
    }
    let members = (0..nm).map(|_| d.u32s()).collect::<Result<Vec<_>, _>>()?;
    let cells = d.u32s()?;
    let lists = d.u32s()?;
    let raw = d.u32s()?;
    let rs = std::mem::size_of::<LeafRecord>() / 4;
    if raw.len() % rs != 0 {
        return Err(bad("leaf records are not whole records".into()));
    }
    let records: Vec<LeafRecord> = bytemuck::pod_collect_to_vec(&raw);
    let nt = d.u64()?;
    if nt != 2 * planes.len() as u64 {
        return Err(bad(format!("{nt} tiles for {} planes", planes.len())));
    }
    let lowres = (0..nt)
        .map(|_| TileLevel::decode_chain(d, tile))
        .collect::<Result<Vec<_>, _>>()?;
    for p in &planes {
        let (nx, ny) = p.cells();
        let cm = p.origin_cell[3];
        if nx == 0 || ny == 0 || !(cm.is_finite() && cm > 0.0) {
            return Err(bad("a plane has no cells".into()));
        }
        if layered && p.grid[2] as u64 + nx as u64 * ny as u64 > cells.len() as u64 {
            return Err(bad("a plane's cells run past the hash table".into()));
        }
        if p.origin_cell
            .iter()
            .chain(&p.u)
            .chain(&p.v)
            .chain(&p.n)
            .chain(&p.slab)
            .any(|x| !x.is_finite())
        {
            return Err(bad("a plane is not finite".into()));
        }
        if p.slab[0] > p.slab[1] {
            return Err(bad("a plane's slab is upside down".into()));
        }
    }
    for &c in &cells {
        if (c >> 8) as usize + (c & 255) as usize > lists.len() {
            return Err(bad("a cell's list runs past the lists".into()));
        }
    }
    if lists.iter().any(|&r| r as usize >= records.len()) {
        return Err(bad("a list entry names a record that does not exist".into()));
    }
    Ok(Cloud {
        planes,
        members,
        cells,
        lists,
        records,
        tile,
        lowres,
        layered,
    })
}

impl crate::bake::codec::Codec for BillboardCloudBaked {
    fn encode(&self) -> Vec<u8> {
        let mut e = Encoder::default();
        e.u32(self.leaves);
        e.u64(self.clouds.len() as u64);
        for c in &self.clouds {
            encode_cloud(&mut e, c);
        }
        e.buf
    }

    fn decode(bytes: &[u8]) -> Result<Self, DecodeError> {
        let mut d = Decoder::new(bytes);
        let leaves = d.u32()?;
        let n = d.u64()?;
        if n != 3 {
            return Err(DecodeError(format!("{n} clouds, not 3")));
        }
        let clouds = (0..n)
            .map(|_| decode_cloud(&mut d))
            .collect::<Result<Vec<_>, _>>()?;
        d.finish()?;
        Ok(Self { clouds, leaves })
    }
}
