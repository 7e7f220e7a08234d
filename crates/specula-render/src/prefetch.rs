//! Mesh files read and parsed ahead of their use, on the thread pool, while the scene loader
//! does other work (decoding waits, BSDF tables, other meshes): the scene's mesh files are
//! independent, so on several cores they load at the same time, and the loader, which meets
//! the shapes one after the other in document order, mostly finds them ready.
//!
//! As [`crate::image_io::prefetch`] does for images: each (format, file, shape index) is
//! loaded once and taken once (a second shape on the same data loads it again itself); a
//! load that has not started when the loader needs it is done by the loader itself, so
//! waiting never depends on a busy pool; the prefetch belongs to the thread that started it
//! and lasts as long as the returned guard, and what is still unclaimed then is dropped. The
//! result is the one the loader would compute itself (the same parser on the same bytes),
//! errors included: the loader reports them where it meets the shape.

use crate::core::Result;
use crate::mesh_io::MeshData;
use std::collections::HashMap;
use std::path::{Path, PathBuf};
use std::sync::{Arc, Condvar, Mutex, MutexGuard};

/// What to load: the shape's plugin (`obj`, `ply` or `serialized`), the resolved file and,
/// for `serialized`, the shape index (0 otherwise).
pub type MeshKey = (String, PathBuf, i64);

/// Loads a mesh file as the scene loader does.
pub fn load_mesh(kind: &str, path: &Path, shape_index: i64) -> Result<MeshData> {
    match kind {
        "obj" => crate::mesh_io::load_obj(path),
        "ply" => crate::mesh_io::load_ply(path),
        _ => crate::serialized::load_serialized(path, shape_index),
    }
}

enum State {
    Pending,
    Running,
    Done(Result<MeshData>),
    /// Taken, claimed by the loader, or abandoned.
    Gone,
}

struct Slot {
    state: Mutex<State>,
    done: Condvar,
}

impl Slot {
    fn lock(&self) -> MutexGuard<'_, State> {
        self.state.lock().unwrap_or_else(|e| e.into_inner())
    }

    /// The pool's job: loads unless the loader claimed the mesh first.
    fn run(&self, key: &MeshKey) {
        {
            let mut s = self.lock();
            if !matches!(*s, State::Pending) {
                return;
            }
            *s = State::Running;
        }
        let r = load_mesh(&key.0, &key.1, key.2);
        let mut s = self.lock();
        *s = State::Done(r);
        self.done.notify_all();
    }

    fn take(&self, key: &MeshKey) -> Result<MeshData> {
        let mut s = self.lock();
        loop {
            match std::mem::replace(&mut *s, State::Gone) {
                State::Done(r) => return r,
                State::Running => {
                    *s = State::Running;
                    s = self.done.wait(s).unwrap_or_else(|e| e.into_inner());
                }
                // not started (claimed now: the job will skip it), or already taken
                State::Pending | State::Gone => {
                    drop(s);
                    return load_mesh(&key.0, &key.1, key.2);
                }
            }
        }
    }
}

type Map = HashMap<MeshKey, Arc<Slot>>;

thread_local! {
    static PREFETCH: std::cell::RefCell<Option<Map>> = const { std::cell::RefCell::new(None) };
}

/// Starts loading `meshes` on the thread pool (files that do not exist are left to the
/// loader, which reports them); ends when the guard drops.
pub fn prefetch_meshes(meshes: impl IntoIterator<Item = MeshKey>) -> MeshPrefetchGuard {
    let mut map = Map::new();
    for key in meshes {
        if map.contains_key(&key) || !key.1.is_file() {
            continue;
        }
        let slot = Arc::new(Slot {
            state: Mutex::new(State::Pending),
            done: Condvar::new(),
        });
        let (job, k) = (slot.clone(), key.clone());
        rayon::spawn(move || job.run(&k));
        map.insert(key, slot);
    }
    let outer = PREFETCH.with(|c| c.replace(Some(map)));
    MeshPrefetchGuard { outer }
}

/// The mesh `kind`/`path`/`shape_index` from the current prefetch (waiting for it, or
/// loading it here if its job has not started), or loaded here when no prefetch holds it.
pub fn take_mesh(kind: &str, path: &Path, shape_index: i64) -> Result<MeshData> {
    let key: MeshKey = (kind.to_string(), path.to_path_buf(), shape_index);
    let slot = PREFETCH.with(|c| c.borrow().as_ref().and_then(|m| m.get(&key).cloned()));
    match slot {
        Some(slot) => slot.take(&key),
        None => load_mesh(kind, path, shape_index),
    }
}

/// Ends a [`prefetch_meshes`] when dropped.
pub struct MeshPrefetchGuard {
    outer: Option<Map>,
}

impl Drop for MeshPrefetchGuard {
    fn drop(&mut self) {
        let map = PREFETCH.with(|c| c.replace(self.outer.take()));
        for slot in map.into_iter().flat_map(|m| m.into_values()) {
            let mut s = slot.lock();
            if !matches!(*s, State::Running) {
                *s = State::Gone;
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn asset(name: &str) -> PathBuf {
        specula_testdata::root().join("scenes/assets").join(name)
    }

    fn same(a: &Result<MeshData>, b: &Result<MeshData>) -> bool {
        match (a, b) {
            (Ok(a), Ok(b)) => a == b,
            (Err(a), Err(b)) => a.to_string() == b.to_string(),
            _ => false,
        }
    }

    /// Prefetched meshes are the files as loaded directly (errors too), taken once each; a
    /// second take, and a take after the prefetch ended, load the file again.
    #[test]
    fn prefetched_meshes_are_the_files() {
        let keys: Vec<MeshKey> = vec![
            ("obj".into(), asset("bumpy.obj"), 0),
            ("ply".into(), asset("icosphere.ply"), 0),
            ("ply".into(), asset("bumpy.obj"), 0), // the wrong parser: an error
        ];
        let direct: Vec<Result<MeshData>> =
            keys.iter().map(|k| load_mesh(&k.0, &k.1, k.2)).collect();
        assert!(direct[0].is_ok() && direct[1].is_ok() && direct[2].is_err());
        {
            let _g = prefetch_meshes(keys.iter().cloned().chain([keys[0].clone()]));
            for (k, want) in keys.iter().zip(&direct).chain([(&keys[0], &direct[0])]) {
                assert!(same(&take_mesh(&k.0, &k.1, k.2), want), "{k:?}");
            }
        }
        assert!(PREFETCH.with(|c| c.borrow().is_none()));
        let k = &keys[1];
        assert!(same(&take_mesh(&k.0, &k.1, k.2), &direct[1]));
    }
}
