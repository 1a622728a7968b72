//! Octolux's per-pass GPU times as Bevy diagnostics, so that a Bevy app sees what its GI costs
//! next to its frame time (`LogDiagnosticsPlugin` prints them; any diagnostics UI shows them).

use crate::{OctoluxGi, OctoluxGiStatus};
use bevy::diagnostic::{Diagnostic, DiagnosticMeasurement, DiagnosticPath, DiagnosticsStore};
use bevy::ecs::prelude::*;
use bevy::platform::time::Instant;
use std::collections::HashMap;

/// The diagnostic paths of octolux's GPU times, in milliseconds: `octolux/total` (all of a
/// frame's GI passes) and `octolux/<pass>` per pass, named as octolux's bench names them
/// (`shadow maps`, `gbuffer input`, `<technique> <pass>`). Measured with GPU timestamp queries
/// where the device has them (not on CPU adapters such as lavapipe, where no times come).
/// With several GI cameras the times are their sums.
pub struct GiDiagnostics;

impl GiDiagnostics {
    /// All of a frame's GI passes.
    pub const TOTAL: DiagnosticPath = DiagnosticPath::const_new("octolux/total");

    /// The path of one pass.
    pub fn pass(name: &str) -> DiagnosticPath {
        // Diagnostic paths separate components with '/'.
        DiagnosticPath::new(format!("octolux/{}", name.replace('/', "-")))
    }
}

/// Per camera, the timings serial already published.
#[derive(Default)]
pub(crate) struct Published(HashMap<Entity, u64>);

/// Moves the render world's newest timings into Bevy's diagnostics.
pub(crate) fn publish_timings(
    status: Res<OctoluxGiStatus>,
    store: Option<ResMut<DiagnosticsStore>>,
    cameras: Query<Entity, With<OctoluxGi>>,
    mut published: Local<Published>,
) {
    let Some(mut store) = store else {
        return;
    };
    let mut sums: HashMap<String, f64> = HashMap::new();
    let mut fresh = false;
    for camera in &cameras {
        let Some(s) = status.camera(camera) else {
            continue;
        };
        if s.timings.is_empty() || published.0.get(&camera) == Some(&s.timings_serial) {
            continue;
        }
        published.0.insert(camera, s.timings_serial);
        fresh = true;
        for (name, ms) in s.timings {
            *sums.entry(name).or_default() += ms;
        }
    }
    if !fresh {
        return;
    }
    let now = Instant::now();
    let total: f64 = sums.values().sum();
    let mut record = |path: DiagnosticPath, value: f64| {
        if store.get(&path).is_none() {
            store.add(Diagnostic::new(path.clone()).with_suffix("ms"));
        }
        if let Some(d) = store.get_mut(&path) {
            d.add_measurement(DiagnosticMeasurement { time: now, value });
        }
    };
    record(GiDiagnostics::TOTAL, total);
    for (name, ms) in sums {
        record(GiDiagnostics::pass(&name), ms);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn new_timings_become_diagnostics_once() {
        let mut world = World::new();
        world.init_resource::<DiagnosticsStore>();
        let status = OctoluxGiStatus::default();
        world.insert_resource(status.clone());
        let camera = world.spawn(OctoluxGi::default()).id();
        status.update_camera(camera, |s| {
            s.timings = vec![("shadow maps".into(), 1.5), ("lpv inject".into(), 0.5)];
            s.timings_serial = 1;
        });
        let system = world.register_system(publish_timings);
        for _ in 0..2 {
            world.run_system(system).expect("system");
        }
        let store = world.resource::<DiagnosticsStore>();
        let total = store.get(&GiDiagnostics::TOTAL).expect("total");
        assert_eq!(total.measurement().map(|m| m.value), Some(2.0));
        // The same timings are published once, not again every frame.
        assert_eq!(total.history_len(), 1);
        let pass = store
            .get(&GiDiagnostics::pass("lpv inject"))
            .expect("a pass");
        assert_eq!(pass.measurement().map(|m| m.value), Some(0.5));
    }
}
