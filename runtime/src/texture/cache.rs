//! The process-wide texture cache: every material that reads a file shares one decoded
//! pyramid ([`Arc`]), under a memory budget, with statistics.
//!
//! An entry's key is the file (its canonical path), the color space it is decoded in, and
//! the file's length and modification time (a file rewritten between two renders is decoded
//! again). Loading a file that would take the resident bytes over the budget
//! (`SHADENET_TEXTURE_MEMORY_MB`, default [`DEFAULT_BUDGET_MB`]) first evicts the least
//! recently used entries that no live material holds; textures that live materials hold are
//! never evicted, so a scene whose live textures exceed the budget still renders (the
//! statistics' peak shows it). A single texture whose pyramid alone exceeds the budget is
//! refused before it is decoded (`decode::check_size`).
//!
//! Decoding happens outside the lock: two threads opening different files decode in
//! parallel; two opening the same file may both decode it and the second keeps the first's.

use super::decode;
use super::mip::Pyramid;
use super::{TextureError, colorspace};
use shadenet_graph::ir::ColorSpace;
use std::collections::HashMap;
use std::path::{Path, PathBuf};
use std::sync::{Arc, Mutex};
use std::time::SystemTime;

/// The budget in MiB when `SHADENET_TEXTURE_MEMORY_MB` is not set.
pub const DEFAULT_BUDGET_MB: u64 = 4096;

/// The variable that sets the budget (MiB).
pub const BUDGET_VAR: &str = "SHADENET_TEXTURE_MEMORY_MB";

/// What the cache has done since the process started.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct TextureStats {
    /// Files opened and decoded.
    pub files_opened: u64,
    /// Opens served from the cache without decoding.
    pub cache_hits: u64,
    /// Entries evicted to stay within the budget.
    pub evictions: u64,
    /// Bytes of texels resident now (every level of every cached pyramid).
    pub bytes_resident: u64,
    /// The most bytes ever resident at once.
    pub peak_bytes: u64,
    /// The budget in bytes.
    pub budget_bytes: u64,
}

impl std::fmt::Display for TextureStats {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        let mib = |b: u64| b as f64 / (1u64 << 20) as f64;
        write!(
            f,
            "textures: {} files opened, {} cache hits, {} evictions, {:.1} MiB resident \
             (peak {:.1} MiB, budget {:.0} MiB)",
            self.files_opened,
            self.cache_hits,
            self.evictions,
            mib(self.bytes_resident),
            mib(self.peak_bytes),
            mib(self.budget_bytes)
        )
    }
}

#[derive(Clone, Debug, PartialEq, Eq, Hash)]
struct Key {
    path: PathBuf,
    colorspace: ColorSpace,
    len: u64,
    mtime: Option<SystemTime>,
}

struct Entry {
    pyramid: Arc<Pyramid>,
    bytes: u64,
    last_use: u64,
}

/// A cache of decoded pyramids under a budget (the process has one, [`open`]; tests make
/// their own).
pub struct Cache {
    entries: HashMap<Key, Entry>,
    tick: u64,
    stats: TextureStats,
}

impl Cache {
    /// An empty cache with a budget in bytes.
    pub fn new(budget_bytes: u64) -> Cache {
        Cache {
            entries: HashMap::new(),
            tick: 0,
            stats: TextureStats {
                budget_bytes,
                ..TextureStats::default()
            },
        }
    }

    /// The statistics.
    pub fn stats(&self) -> TextureStats {
        self.stats
    }

    /// The resident entry of `key`, counted as a hit.
    fn hit(&mut self, key: &Key) -> Option<Arc<Pyramid>> {
        self.tick += 1;
        let e = self.entries.get_mut(key)?;
        e.last_use = self.tick;
        self.stats.cache_hits += 1;
        Some(e.pyramid.clone())
    }

    /// Evicts unheld entries, least recently used first, until `bytes` more fit the budget
    /// (or nothing unheld is left).
    fn make_room(&mut self, bytes: u64) {
        let budget = self.stats.budget_bytes;
        if self.stats.bytes_resident + bytes <= budget {
            return;
        }
        let mut unheld: Vec<(u64, Key)> = self
            .entries
            .iter()
            .filter(|(_, e)| Arc::strong_count(&e.pyramid) == 1)
            .map(|(k, e)| (e.last_use, k.clone()))
            .collect();
        unheld.sort_by_key(|(t, _)| *t);
        for (_, key) in unheld {
            if self.stats.bytes_resident + bytes <= budget {
                break;
            }
            if let Some(e) = self.entries.remove(&key) {
                self.stats.bytes_resident -= e.bytes;
                self.stats.evictions += 1;
            }
        }
    }

    /// Inserts a freshly decoded pyramid (or returns the one another thread inserted
    /// meanwhile).
    fn insert(&mut self, key: Key, pyramid: Pyramid) -> Arc<Pyramid> {
        if let Some(p) = self.hit(&key) {
            return p;
        }
        let bytes = pyramid.bytes();
        self.make_room(bytes);
        let pyramid = Arc::new(pyramid);
        self.tick += 1;
        self.stats.files_opened += 1;
        self.stats.bytes_resident += bytes;
        self.stats.peak_bytes = self.stats.peak_bytes.max(self.stats.bytes_resident);
        self.entries.insert(
            key,
            Entry {
                pyramid: pyramid.clone(),
                bytes,
                last_use: self.tick,
            },
        );
        pyramid
    }
}

/// The budget in bytes: `SHADENET_TEXTURE_MEMORY_MB` MiB, else [`DEFAULT_BUDGET_MB`].
pub fn budget_bytes() -> Result<u64, TextureError> {
    match std::env::var(BUDGET_VAR) {
        Err(_) => Ok(DEFAULT_BUDGET_MB << 20),
        Ok(v) => match v.trim().parse::<u64>() {
            Ok(mb) if mb > 0 && mb < (1 << 40) => Ok(mb << 20),
            _ => Err(TextureError::Budget { value: v }),
        },
    }
}

static CACHE: Mutex<Option<Cache>> = Mutex::new(None);

fn with_cache<T>(f: impl FnOnce(&mut Cache) -> T) -> Result<T, TextureError> {
    let budget = budget_bytes()?;
    // A panic elsewhere while holding the lock leaves consistent data: keep going.
    let mut guard = CACHE.lock().unwrap_or_else(|e| e.into_inner());
    let cache = guard.get_or_insert_with(|| Cache::new(budget));
    cache.stats.budget_bytes = budget;
    Ok(f(cache))
}

/// The process-wide cache's statistics.
pub fn stats() -> TextureStats {
    with_cache(|c| c.stats()).unwrap_or_else(|_| {
        let guard = CACHE.lock().unwrap_or_else(|e| e.into_inner());
        guard.as_ref().map(Cache::stats).unwrap_or_default()
    })
}

/// Opens `path` decoded in `colorspace` through the process-wide cache.
pub fn open(path: &Path, colorspace: ColorSpace) -> Result<Arc<Pyramid>, TextureError> {
    let budget = budget_bytes()?;
    let key = key(path, colorspace)?;
    if let Some(p) = with_cache(|c| c.hit(&key))? {
        return Ok(p);
    }
    let pyramid = load(path, colorspace, budget)?;
    with_cache(|c| c.insert(key, pyramid))
}

/// Opens `path` through `cache` (the same as [`open`], on a cache of one's own).
pub fn open_in(
    cache: &mut Cache,
    path: &Path,
    colorspace: ColorSpace,
) -> Result<Arc<Pyramid>, TextureError> {
    let key = key(path, colorspace)?;
    if let Some(p) = cache.hit(&key) {
        return Ok(p);
    }
    let pyramid = load(path, colorspace, cache.stats.budget_bytes)?;
    Ok(cache.insert(key, pyramid))
}

fn key(path: &Path, colorspace: ColorSpace) -> Result<Key, TextureError> {
    let err = |reason: String| TextureError::Load {
        path: path.to_path_buf(),
        reason,
    };
    // A device, a FIFO or an oversized file is refused before anything else.
    let len =
        crate::input::check(path, crate::input::FileKind::Image, "texture").map_err(
            |e| match e {
                crate::input::InputError::Io { source, .. } => err(source.to_string()),
                other => err(other.to_string()),
            },
        )?;
    let mtime = std::fs::metadata(path).and_then(|m| m.modified()).ok();
    Ok(Key {
        path: std::fs::canonicalize(path).unwrap_or_else(|_| path.to_path_buf()),
        colorspace,
        len,
        mtime,
    })
}

/// Decodes a file, converts it to the working space and builds its pyramid.
pub fn load(path: &Path, colorspace: ColorSpace, budget: u64) -> Result<Pyramid, TextureError> {
    let decoded = decode::decode(path, budget).map_err(|reason| TextureError::Load {
        path: path.to_path_buf(),
        reason,
    })?;
    let (w, h) = (decoded.width, decoded.height);
    let texels = colorspace::to_working(decoded, colorspace);
    Ok(Pyramid::build(w, h, texels))
}
