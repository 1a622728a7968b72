//! The GPU frame: shadow maps, G-buffer, direct light, compose and tone map.
