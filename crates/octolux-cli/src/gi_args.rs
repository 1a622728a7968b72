//! Command-line settings of the GI techniques, shared by `render` and `bench`.

use clap::Args;
use octolux::gi::GiSettings;

/// Per-technique settings; each flag overrides the scene file's `[settings]` and the default.
#[derive(Args, Debug, Clone, Default)]
pub struct GiArgs {}

impl GiArgs {
    /// Applies the flags that were given to `settings`.
    pub fn apply(&self, _settings: &mut GiSettings) {}
}
