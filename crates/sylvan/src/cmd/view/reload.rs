//! Scene hot reload: the scene file's modification time is polled once a second; when it
//! changes the file is loaded again. The caller keeps the last good scene when loading fails and
//! shows the one-line error instead.

use std::path::{Path, PathBuf};
use std::time::{Duration, Instant, SystemTime};
use sylvan_scene::Scene;

/// How often the file is looked at.
pub const POLL_INTERVAL: Duration = Duration::from_secs(1);

/// Watches one scene file.
pub struct SceneWatcher {
    path: PathBuf,
    seen: Option<SystemTime>,
    last_poll: Instant,
}

impl SceneWatcher {
    /// Starts watching `path` (its current version counts as seen).
    pub fn new(path: &Path) -> Self {
        Self {
            path: path.to_path_buf(),
            seen: modified(path),
            last_poll: Instant::now(),
        }
    }

    /// At most once per [`POLL_INTERVAL`] (as of `now`): when the file changed since the last
    /// load, loads it again — `Some(Ok(scene))`, or `Some(Err(one line))`; `None` otherwise.
    pub fn poll(&mut self, now: Instant) -> Option<Result<Scene, String>> {
        if now.duration_since(self.last_poll) < POLL_INTERVAL {
            return None;
        }
        self.last_poll = now;
        let m = modified(&self.path);
        if m == self.seen {
            return None;
        }
        self.seen = m;
        if m.is_none() {
            return Some(Err(format!(
                "{}: cannot read the scene file — restore it; the last good scene keeps running",
                self.path.display()
            )));
        }
        Some(Scene::load(&self.path).map_err(|e| e.to_string().replace('\n', " ")))
    }
}

fn modified(path: &Path) -> Option<SystemTime> {
    std::fs::metadata(path).and_then(|m| m.modified()).ok()
}

#[cfg(test)]
mod tests {
    use super::*;

    const GOOD: &str = "[terrain]\nprocedural = { seed = 3, size_m = 60, relief_m = 6 }\n\n[[species]]\nname = \"bush\"\npreset = \"bush\"\ndensity_per_ha = 20\nheight_m = [2, 3]\n";

    #[test]
    fn reloads_on_change_and_reports_bad_edits() {
        let dir = std::env::temp_dir().join(format!("sylvan-reload-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let file = dir.join("s.toml");
        std::fs::write(&file, GOOD).unwrap();
        let mut w = SceneWatcher::new(&file);
        let later = |s: u64| Instant::now() + Duration::from_secs(s);
        assert!(w.poll(later(2)).is_none(), "unchanged file");

        // mtime granularity can be coarse: set it explicitly.
        let bump = |secs: u64| {
            let f = std::fs::File::options().write(true).open(&file).unwrap();
            f.set_modified(SystemTime::now() + Duration::from_secs(secs))
                .unwrap();
        };
        std::fs::write(&file, GOOD.replace("[2, 3]", "[2, 3")).unwrap();
        bump(10);
        let e = w.poll(later(4)).expect("changed").unwrap_err();
        assert!(e.contains("s.toml:"), "{e}");
        assert!(!e.contains('\n'));
        assert!(w.poll(later(6)).is_none(), "reported once");

        std::fs::write(&file, GOOD).unwrap();
        bump(20);
        assert!(w.poll(later(6)).is_none(), "polled less than a second ago");
        let scene = w.poll(later(8)).expect("changed").expect("loads");
        assert_eq!(scene.species.len(), 1);
        std::fs::remove_dir_all(&dir).ok();
    }
}
