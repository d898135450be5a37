//! Tile production on worker threads: a tile's trees from the scene's placed trees (binned by
//! tile once, at start) and its seeded forest, turned into GPU records — or anything else made
//! per tile from the same trees (the ground cover, [`super::cover`]). Jobs are taken nearest
//! first; the render thread can run jobs itself while it waits for a tile it must have.

use super::{PoolTree, TileKey};
use crate::instances::{SpeciesBounds, tint_seed, tree_sphere};
use glam::{Vec2, Vec3};
use std::collections::{HashMap, HashSet};
use std::sync::mpsc::{Receiver, Sender, channel};
use std::sync::{Arc, Condvar, Mutex};
use std::thread::JoinHandle;
use sylvan_scene::{SeededForest, Terrain, TreeInstance};

/// A produced tile: its trees as GPU records and what culling needs to know of them.
pub(crate) struct TileTrees {
    pub key: TileKey,
    pub trees: Vec<PoolTree>,
    /// Trees per species.
    pub species_counts: Vec<u32>,
    /// World bounds of every tree's sphere (empty tile: min > max).
    pub min: Vec3,
    pub max: Vec3,
}

/// What every worker reads: immutable for the renderer's life.
pub(crate) struct Source {
    pub terrain: Terrain,
    pub seeded: Option<Arc<SeededForest>>,
    /// Placed trees (positions files, `poisson` placement) by tile.
    pub placed: HashMap<TileKey, Vec<TreeInstance>>,
    pub bounds: Vec<SpeciesBounds>,
    pub tile_m: f32,
}

impl Source {
    /// Bins `placed` by tile (time ∝ the placed trees, which the scene already holds).
    pub fn new(
        terrain: Terrain,
        seeded: Option<Arc<SeededForest>>,
        placed: &[TreeInstance],
        bounds: Vec<SpeciesBounds>,
        tile_m: f32,
    ) -> Self {
        let mut bins: HashMap<TileKey, Vec<TreeInstance>> = HashMap::new();
        for t in placed {
            bins.entry(TileKey::of(t.position.x, t.position.z, tile_m))
                .or_default()
                .push(*t);
        }
        Self {
            terrain,
            seeded,
            placed: bins,
            bounds,
            tile_m,
        }
    }

    /// Every tree whose trunk base lies in `[min, max)` (world X, Z): the placed ones of the
    /// tiles the rectangle touches, then the seeded ones (deterministic, whatever was asked
    /// before).
    pub fn trees_in(&self, min: Vec2, max: Vec2) -> Vec<TreeInstance> {
        let lo = TileKey::of(min.x, min.y, self.tile_m);
        let hi = TileKey::of(max.x, max.y, self.tile_m);
        let mut trees = Vec::new();
        for z in lo.z..=hi.z {
            for x in lo.x..=hi.x {
                let Some(bin) = self.placed.get(&TileKey { x, z }) else {
                    continue;
                };
                trees.extend(bin.iter().filter(|t| {
                    let p = Vec2::new(t.position.x, t.position.z);
                    p.cmpge(min).all() && p.cmplt(max).all()
                }));
            }
        }
        if let Some(forest) = &self.seeded {
            forest.produce(&self.terrain, min, max, &mut trees);
        }
        trees
    }

    /// Produces one tile (deterministic: the same records in the same order every time).
    pub fn produce(&self, key: TileKey) -> TileTrees {
        let min = Vec2::new(key.x as f32, key.z as f32) * self.tile_m;
        let max = min + Vec2::splat(self.tile_m);
        let trees = self.trees_in(min, max);
        let mut out = TileTrees {
            key,
            trees: Vec::with_capacity(trees.len()),
            species_counts: vec![0; self.bounds.len()],
            min: Vec3::splat(f32::MAX),
            max: Vec3::splat(f32::MIN),
        };
        for t in &trees {
            let Some(b) = self.bounds.get(t.species as usize) else {
                continue;
            };
            let rec = PoolTree::new(t, b);
            let (c, r) = tree_sphere(t, b);
            out.min = out.min.min(c - r);
            out.max = out.max.max(c + r);
            out.species_counts[t.species as usize] += 1;
            out.trees.push(rec);
        }
        out
    }
}

impl PoolTree {
    /// The record of tree `t` of a species with model bounds `b` (scaled from plant height to
    /// tree height, as [`crate::instances::Instances`] places it).
    pub(crate) fn new(t: &TreeInstance, b: &SpeciesBounds) -> Self {
        let scale = t.height / b.max.y.max(1e-3);
        let (s, c) = t.rotation.sin_cos();
        Self {
            base_scale: [t.position.x, t.position.y, t.position.z, scale],
            rot: [c, s, tint_seed(t.seed), f32::from_bits(t.species)],
        }
    }
}

#[derive(Default)]
struct Queue {
    /// Jobs waiting, with their priority (lower first).
    waiting: Vec<(f32, TileKey)>,
    stop: bool,
}

/// What a producer makes per tile.
pub(crate) trait Produced: Send + 'static {
    /// The tile it was made for.
    fn key(&self) -> TileKey;
}

impl Produced for TileTrees {
    fn key(&self) -> TileKey {
        self.key
    }
}

/// The job a producer runs per tile.
pub(crate) type Job<T> = Arc<dyn Fn(TileKey) -> T + Send + Sync>;

/// Worker threads producing tiles, nearest first.
pub(crate) struct Producer<T: Produced> {
    job: Job<T>,
    queue: Arc<(Mutex<Queue>, Condvar)>,
    done_tx: Sender<T>,
    done: Receiver<T>,
    /// Requested and not yet received.
    pending: HashSet<TileKey>,
    /// Requests not made yet: the queue was locked by a worker ([`Producer::request`]).
    deferred: Vec<(f32, TileKey)>,
    workers: Vec<JoinHandle<()>>,
}

impl<T: Produced> Producer<T> {
    /// Starts `threads` workers running `job` (0: the render thread produces everything).
    pub fn new(job: Job<T>, threads: usize, name: &str) -> Self {
        let queue = Arc::new((Mutex::new(Queue::default()), Condvar::new()));
        let (done_tx, done) = channel();
        let workers = (0..threads)
            .map(|i| {
                let (job, queue, tx) = (job.clone(), queue.clone(), done_tx.clone());
                std::thread::Builder::new()
                    .name(format!("sylvan-{name}-{i}"))
                    .spawn(move || {
                        background_priority();
                        worker(&*job, &queue, &tx)
                    })
                    .expect("spawning a tile worker")
            })
            .collect();
        Self {
            job,
            queue,
            done_tx,
            done,
            pending: HashSet::new(),
            deferred: Vec::new(),
            workers,
        }
    }

    /// Tiles requested and not yet received.
    pub fn pending(&self) -> usize {
        self.pending.len()
    }

    /// Asks for each `(priority, key)` (lower priority first); re-asking updates the
    /// priority. The queue is locked once for all of them: a worker runs at a lower priority
    /// ([`WORKER_NICE`]), and one preempted while holding the lock would stall the render
    /// thread at every lock it takes.
    ///
    /// The render thread does not wait for the lock: when a worker holds it, the requests are
    /// kept and made at the next call (a frame later).
    pub fn request(&mut self, tiles: impl IntoIterator<Item = (f32, TileKey)>) {
        self.deferred.extend(tiles);
        let queue = self.queue.clone();
        let Ok(mut q) = queue.0.try_lock() else {
            return;
        };
        self.enqueue(&mut q);
    }

    /// Makes the deferred requests (the queue locked by the caller).
    fn enqueue(&mut self, q: &mut Queue) {
        let mut added = false;
        let mut at: HashMap<TileKey, usize> = HashMap::new();
        for (priority, key) in self.deferred.drain(..) {
            if self.pending.insert(key) {
                q.waiting.push((priority, key));
                added = true;
            } else {
                if at.is_empty() {
                    at = q
                        .waiting
                        .iter()
                        .enumerate()
                        .map(|(i, j)| (j.1, i))
                        .collect();
                }
                if let Some(&i) = at.get(&key) {
                    q.waiting[i].0 = priority;
                }
            }
        }
        if added {
            self.queue.1.notify_all();
        }
    }

    /// Drops requests for tiles no longer wanted (not yet started).
    /// Not waiting for the lock either: returns false when a worker held it (the queued
    /// requests were not cancelled: call again later, or drop what they produce).
    pub fn cancel(&mut self, keep: impl Fn(TileKey) -> bool) -> bool {
        self.deferred.retain(|&(_, k)| keep(k));
        let Ok(mut q) = self.queue.0.try_lock() else {
            return false;
        };
        let pending = &mut self.pending;
        q.waiting.retain(|&(_, k)| {
            let kept = keep(k);
            if !kept {
                pending.remove(&k);
            }
            kept
        });
        true
    }

    /// Tiles finished since the last call, without waiting.
    pub fn finished(&mut self) -> Vec<T> {
        let out: Vec<T> = self.done.try_iter().collect();
        for t in &out {
            self.pending.remove(&t.key());
        }
        out
    }

    /// Waits until none of `keys` is pending, producing waiting jobs on this thread meanwhile;
    /// returns every tile finished meanwhile.
    pub fn wait_for(&mut self, keys: &[TileKey]) -> Vec<T> {
        let mut out = Vec::new();
        if !self.deferred.is_empty() {
            let queue = self.queue.clone();
            let mut q = queue.0.lock().expect("tile queue");
            self.enqueue(&mut q);
        }
        while keys.iter().any(|k| self.pending.contains(k)) {
            // Run a wanted job here if it has not started; else wait for a worker.
            let job = {
                let mut q = self.queue.0.lock().expect("tile queue");
                let at = q.waiting.iter().position(|j| keys.contains(&j.1));
                at.map(|i| q.waiting.swap_remove(i).1)
            };
            let tile = match job {
                Some(key) => (self.job)(key),
                None => match self.done.recv() {
                    Ok(t) => t,
                    Err(_) => break,
                },
            };
            self.pending.remove(&tile.key());
            out.push(tile);
        }
        out.extend(self.finished());
        out
    }
}

impl<T: Produced> Drop for Producer<T> {
    fn drop(&mut self) {
        self.queue.0.lock().expect("tile queue").stop = true;
        self.queue.1.notify_all();
        for w in self.workers.drain(..) {
            let _ = w.join();
        }
        let _ = &self.done_tx;
    }
}

/// Niceness of the tile workers: the render thread's per-frame work must not wait for a core
/// while they produce (on 2 cores, one tree worker and one cover worker beside the render
/// thread made its CPU time jump 3–10× in frames where they ran).
pub(crate) const WORKER_NICE: i32 = 10;

/// Makes the calling thread a background thread (Linux; elsewhere a no-op — `setpriority`
/// there would lower the whole process): scheduling class `SCHED_BATCH`, whose threads never
/// preempt a running thread when they wake (a woken worker took the render thread's core for
/// 2–5 ms in frames that queued tiles), at nice [`WORKER_NICE`].
fn background_priority() {
    #[cfg(target_os = "linux")]
    // SAFETY: both calls read only the parameter passed; pid/who 0 is the calling thread.
    unsafe {
        let param = libc::sched_param { sched_priority: 0 };
        libc::sched_setscheduler(0, libc::SCHED_BATCH, &param);
        libc::setpriority(libc::PRIO_PROCESS, 0, WORKER_NICE);
    }
}

fn worker<T>(
    job: &(dyn Fn(TileKey) -> T + Send + Sync),
    queue: &(Mutex<Queue>, Condvar),
    tx: &Sender<T>,
) {
    loop {
        let key = {
            let mut q = queue.0.lock().expect("tile queue");
            loop {
                if q.stop {
                    return;
                }
                if !q.waiting.is_empty() {
                    let best = (0..q.waiting.len())
                        .min_by(|&a, &b| q.waiting[a].0.total_cmp(&q.waiting[b].0))
                        .expect("not empty");
                    break q.waiting.swap_remove(best).1;
                }
                q = queue.1.wait(q).expect("tile queue");
            }
        };
        if tx.send(job(key)).is_err() {
            return;
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    struct Made(TileKey);
    impl Produced for Made {
        fn key(&self) -> TileKey {
            self.0
        }
    }

    #[test]
    fn requests_made_while_a_worker_holds_the_queue_are_not_lost() {
        let job: Job<Made> = Arc::new(Made);
        let mut p = Producer::new(job, 1, "test");
        let a = TileKey { x: 1, z: 2 };
        let b = TileKey { x: 3, z: 4 };
        {
            // A worker holding the queue: the request is deferred, not waited for.
            let queue = p.queue.clone();
            let _held = queue.0.lock().expect("tile queue");
            p.request([(1.0, a)]);
            assert_eq!(p.deferred.len(), 1);
            assert_eq!(p.pending(), 0);
        }
        // A tile that must be drawn is produced even though its request was deferred.
        let got = p.wait_for(&[a]);
        assert!(
            got.iter().any(|t| t.0 == a),
            "the deferred tile was not produced"
        );
        assert!(p.deferred.is_empty());
        // A deferred request no longer wanted is dropped by `cancel`.
        {
            let queue = p.queue.clone();
            let _held = queue.0.lock().expect("tile queue");
            p.request([(1.0, b)]);
        }
        p.cancel(|k| k != b);
        assert!(p.deferred.is_empty());
        // The next request (lock free) goes to the workers.
        p.request([(1.0, b)]);
        let got = p.wait_for(&[b]);
        assert!(got.iter().any(|t| t.0 == b));
    }
}
