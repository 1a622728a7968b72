//! Memory ledger: every GPU buffer and texture is recorded under its owner (a technique or a
//! renderer stage) and its own name. Re-registering a name replaces its entry, so a resource
//! that is recreated with the same name is never counted twice, and "no per-frame growth" can
//! be checked by comparing totals between frames.

use std::collections::BTreeMap;
use std::sync::{Arc, Mutex};

/// One recorded resource.
#[derive(Clone, Debug, PartialEq, Eq, serde::Serialize)]
pub struct LedgerEntry {
    /// Who owns it (e.g. "gbuffer", "shadow-maps", "lpv").
    pub owner: String,
    /// What it is (e.g. "albedo").
    pub name: String,
    /// Size in bytes.
    pub bytes: u64,
}

/// Thread-safe record of GPU memory by owner. Cloning shares the same ledger.
#[derive(Clone, Debug, Default)]
pub struct MemoryLedger {
    entries: Arc<Mutex<BTreeMap<(String, String), u64>>>,
}

impl MemoryLedger {
    fn lock(&self) -> std::sync::MutexGuard<'_, BTreeMap<(String, String), u64>> {
        // A panic elsewhere cannot leave the map half-updated, so a poisoned lock is still usable.
        self.entries.lock().unwrap_or_else(|e| e.into_inner())
    }

    /// Records (or replaces) `owner`/`name` with `bytes`.
    pub fn record(&self, owner: &str, name: &str, bytes: u64) {
        self.lock()
            .insert((owner.to_string(), name.to_string()), bytes);
    }

    /// Forgets the buffer `name` of `owner`: scratch that lived only while a build or a
    /// frame's commands were recorded, dropped now.
    pub fn forget(&self, owner: &str, name: &str) {
        self.lock().remove(&(owner.to_string(), name.to_string()));
    }

    /// Forgets everything recorded under `owner` (when it is dropped or rebuilt).
    pub fn release_owner(&self, owner: &str) {
        self.lock().retain(|(o, _), _| o != owner);
    }

    /// All entries, sorted by owner then name.
    pub fn entries(&self) -> Vec<LedgerEntry> {
        self.lock()
            .iter()
            .map(|((owner, name), &bytes)| LedgerEntry {
                owner: owner.clone(),
                name: name.clone(),
                bytes,
            })
            .collect()
    }

    /// Total bytes per owner, sorted by owner.
    pub fn by_owner(&self) -> Vec<(String, u64)> {
        let mut totals: BTreeMap<String, u64> = BTreeMap::new();
        for ((owner, _), bytes) in self.lock().iter() {
            *totals.entry(owner.clone()).or_default() += bytes;
        }
        totals.into_iter().collect()
    }

    /// Total bytes of everything recorded.
    pub fn total(&self) -> u64 {
        self.lock().values().sum()
    }
}

/// Bytes used by a texture with all its mip levels and layers.
pub(crate) fn texture_bytes(desc: &wgpu::TextureDescriptor) -> u64 {
    let (bw, bh) = desc.format.block_dimensions();
    let block = desc
        .format
        .block_copy_size(Some(wgpu::TextureAspect::All))
        .or_else(|| {
            desc.format
                .block_copy_size(Some(wgpu::TextureAspect::DepthOnly))
        })
        .unwrap_or(4) as u64;
    let layers = match desc.dimension {
        wgpu::TextureDimension::D3 => 1,
        _ => desc.size.depth_or_array_layers as u64,
    };
    (0..desc.mip_level_count)
        .map(|level| {
            let size = desc.size.mip_level_size(level, desc.dimension);
            let w = size.width.div_ceil(bw) as u64;
            let h = size.height.div_ceil(bh) as u64;
            let d = match desc.dimension {
                wgpu::TextureDimension::D3 => size.depth_or_array_layers as u64,
                _ => 1,
            };
            w * h * d * block * layers
        })
        .sum::<u64>()
        * desc.sample_count as u64
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn replaces_and_totals() {
        let ledger = MemoryLedger::default();
        ledger.record("a", "x", 10);
        ledger.record("a", "x", 12);
        ledger.record("a", "y", 3);
        ledger.record("b", "x", 5);
        assert_eq!(ledger.total(), 20);
        assert_eq!(ledger.by_owner(), vec![("a".into(), 15), ("b".into(), 5)]);
        ledger.release_owner("a");
        assert_eq!(ledger.total(), 5);
    }

    #[test]
    fn texture_sizes() {
        let desc = wgpu::TextureDescriptor {
            label: None,
            size: wgpu::Extent3d {
                width: 4,
                height: 4,
                depth_or_array_layers: 6,
            },
            mip_level_count: 1,
            sample_count: 1,
            dimension: wgpu::TextureDimension::D2,
            format: wgpu::TextureFormat::Depth32Float,
            usage: wgpu::TextureUsages::RENDER_ATTACHMENT,
            view_formats: &[],
        };
        assert_eq!(texture_bytes(&desc), 4 * 4 * 6 * 4);
        let volume = wgpu::TextureDescriptor {
            size: wgpu::Extent3d {
                width: 8,
                height: 8,
                depth_or_array_layers: 8,
            },
            dimension: wgpu::TextureDimension::D3,
            format: wgpu::TextureFormat::Rgba16Float,
            mip_level_count: 2,
            ..desc
        };
        assert_eq!(texture_bytes(&volume), 8 * 8 * 8 * 8 + 4 * 4 * 4 * 8);
    }
}
