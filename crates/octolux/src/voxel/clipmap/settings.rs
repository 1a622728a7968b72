//! What a clipmap is: its dimensions ([`ClipmapSettings`]: voxels per axis, levels, finest
//! voxel) with the level geometry they imply, and how its coarser levels are built
//! ([`ClipmapOptions`]).

use crate::{Error, Result};
use glam::{IVec3, Vec3};

/// Clipmap dimensions.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ClipmapSettings {
    /// Voxels per axis of every level (a power of two, 4..=512).
    pub resolution: u32,
    /// Number of levels (1..=8).
    pub levels: u32,
    /// Voxel edge of the finest level (m).
    pub voxel_size: f32,
}

impl ClipmapSettings {
    /// Checks the settings.
    pub fn validate(&self) -> Result<()> {
        if !(4..=512).contains(&self.resolution) || !self.resolution.is_power_of_two() {
            return Err(Error::InvalidArgument(format!(
                "clipmap resolution {}: must be a power of two from 4 to 512",
                self.resolution
            )));
        }
        if !(1..=8).contains(&self.levels) {
            return Err(Error::InvalidArgument(format!(
                "clipmap levels {}: must be 1 to 8",
                self.levels
            )));
        }
        if !(self.voxel_size.is_finite() && self.voxel_size > 0.0) {
            return Err(Error::InvalidArgument(format!(
                "clipmap voxel size {}: must be positive",
                self.voxel_size
            )));
        }
        Ok(())
    }

    /// Voxel slots of all levels together (`levels * resolution^3`): the length of every
    /// per-slot buffer.
    pub fn slots(&self) -> u64 {
        self.levels as u64 * (self.resolution as u64).pow(3)
    }

    /// Voxel edge of level `l`.
    pub fn level_voxel(&self, l: u32) -> f32 {
        self.voxel_size * (1u32 << l) as f32
    }

    /// First voxel (world-voxel coordinates of level `l`) of the level centred on `camera`.
    pub fn level_origin(&self, l: u32, camera: Vec3) -> IVec3 {
        (camera / self.level_voxel(l)).floor().as_ivec3() - IVec3::splat(self.resolution as i32 / 2)
    }
}

/// How the coarser levels are built (both off by default: per-level voxelization).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct ClipmapOptions {
    /// Rebuild each coarser level's voxels inside the finer level from the finer voxels.
    pub filtered: bool,
    /// Keep 6 directional values per voxel of levels 1 and up (implies `filtered`): 24 more
    /// bytes per voxel of those levels.
    pub anisotropic: bool,
}

impl ClipmapOptions {
    /// Whether coarser levels are filtered from finer ones.
    pub fn filters(&self) -> bool {
        self.filtered || self.anisotropic
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn bad_settings_are_rejected() {
        let ok = ClipmapSettings {
            resolution: 64,
            levels: 4,
            voxel_size: 0.1,
        };
        assert!(ok.validate().is_ok());
        for bad in [
            ClipmapSettings {
                resolution: 48,
                ..ok
            },
            ClipmapSettings {
                resolution: 1024,
                ..ok
            },
            ClipmapSettings { levels: 0, ..ok },
            ClipmapSettings { levels: 9, ..ok },
            ClipmapSettings {
                voxel_size: f32::NAN,
                ..ok
            },
        ] {
            assert!(matches!(bad.validate(), Err(Error::InvalidArgument(_))));
        }
    }
}
