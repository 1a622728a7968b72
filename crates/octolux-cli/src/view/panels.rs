//! The egui panels: technique and its settings, what is shown, the animation, compare mode,
//! live pass times and GPU memory, and the central view with the rendered image. The panels
//! only edit [`Controls`] and return [`Action`]s; the window applies them.

use super::compare::{Compare, Progress, Shown};
use super::timing::TimingHistory;
use egui::{ComboBox, DragValue, Slider, Ui};
use octolux::gi::{GiSettings, TECHNIQUES};
use octolux::gpu::{GpuContext, MemoryLedger};
use octolux::render::Output;

/// What the panels edit.
pub struct Controls {
    /// Technique in use.
    pub technique: String,
    /// Technique settings as edited (applied when `settings_dirty` and no drag is under way).
    pub settings: GiSettings,
    /// A setting changed since it was last applied.
    pub settings_dirty: bool,
    /// What the renderer outputs.
    pub output: Output,
    /// Whether scene time advances.
    pub playing: bool,
    /// Scene time in seconds.
    pub time: f32,
    /// Length of the scene's animation in seconds (0: static).
    pub animation_length: f32,
    /// Exposure in EV.
    pub exposure: f32,
    /// Render resolution relative to the view area (ignored with a fixed size).
    pub scale: f32,
    /// The last status line (saved files, errors).
    pub status: String,
    /// The technique of the split screen's right half (None: no split screen).
    pub split: Option<String>,
}

/// What the window must do after the panels ran.
#[derive(Clone, Debug, PartialEq)]
pub enum Action {
    /// Switch to this technique (with the edited settings).
    SwitchTechnique(String),
    /// Rebuild the technique with the edited settings.
    ApplySettings,
    /// Show another output.
    SetOutput(Output),
    /// Return to the scene camera.
    ResetCamera,
    /// Save a screenshot.
    Screenshot,
}

/// Read-only facts the panels show.
pub struct Facts<'a> {
    /// Scene name and triangle count.
    pub scene: &'a str,
    /// Adapter description.
    pub adapter: &'a str,
    /// Render size in pixels.
    pub render_size: (u32, u32),
    /// Mean wall-clock frame time over the last frames (s).
    pub frame_time: Option<f32>,
    /// Camera speed (m/s).
    pub speed: f32,
    /// Pass-time history.
    pub history: &'a TimingHistory,
    /// The memory ledger.
    pub ledger: &'a MemoryLedger,
    /// The split screen's technique and the bytes of its renderer (a ledger of its own).
    pub split_memory: Option<(String, u64)>,
    /// The device (for wgpu's count of live objects).
    pub ctx: &'a GpuContext,
}

/// Draws the side panel; returns the actions asked for.
pub fn side_panel(
    ui: &mut Ui,
    controls: &mut Controls,
    compare: &mut Compare,
    progress: Option<&Progress>,
    facts: &Facts,
) -> Vec<Action> {
    let mut actions = Vec::new();
    egui::Panel::left("controls")
        .resizable(true)
        .default_size(300.0)
        .show(ui, |ui| {
            egui::ScrollArea::vertical().show(ui, |ui| {
                ui.heading("octolux");
                ui.label(facts.scene);
                ui.small(facts.adapter);
                let (w, h) = facts.render_size;
                match facts.frame_time {
                    Some(s) => ui.label(format!(
                        "{w}x{h}, {:.1} ms/frame ({:.1} fps)",
                        s * 1e3,
                        1.0 / s.max(1e-6)
                    )),
                    None => ui.label(format!("{w}x{h}")),
                };
                ui.separator();
                technique_section(ui, controls, &mut actions);
                ui.separator();
                view_section(ui, controls, facts, &mut actions);
                ui.separator();
                animation_section(ui, controls);
                ui.separator();
                compare_section(ui, compare, progress);
                ui.separator();
                egui::CollapsingHeader::new("Pass times")
                    .default_open(true)
                    .show(ui, |ui| facts.history.graph(ui));
                egui::CollapsingHeader::new("GPU memory")
                    .default_open(true)
                    .show(ui, |ui| memory_section(ui, facts));
                if !controls.status.is_empty() {
                    ui.separator();
                    ui.label(&controls.status);
                }
            });
        });
    actions
}

fn technique_section(ui: &mut Ui, controls: &mut Controls, actions: &mut Vec<Action>) {
    let mut chosen = controls.technique.clone();
    ComboBox::from_label("technique")
        .selected_text(&chosen)
        .show_ui(ui, |ui| {
            for name in TECHNIQUES {
                ui.selectable_value(&mut chosen, name.to_string(), *name);
            }
        });
    if chosen != controls.technique {
        actions.push(Action::SwitchTechnique(chosen));
    }
    split_widgets(ui, controls);
    let changed = settings_widgets(ui, &controls.technique, &mut controls.settings);
    controls.settings_dirty |= changed;
    // Rebuild once a drag ends, not at every step of it.
    if controls.settings_dirty && !ui.input(|i| i.pointer.any_down()) {
        controls.settings_dirty = false;
        actions.push(Action::ApplySettings);
    }
}

/// The split screen: on or off, and the right half's technique.
fn split_widgets(ui: &mut Ui, controls: &mut Controls) {
    ui.horizontal(|ui| {
        let mut on = controls.split.is_some();
        if ui.checkbox(&mut on, "split screen, right:").changed() {
            controls.split = on.then(|| {
                let other = if controls.technique == "none" {
                    "lpv"
                } else {
                    "none"
                };
                other.to_string()
            });
        }
        if let Some(split) = &mut controls.split {
            ComboBox::from_id_salt("split technique")
                .selected_text(split.as_str())
                .show_ui(ui, |ui| {
                    for name in TECHNIQUES {
                        ui.selectable_value(split, name.to_string(), *name);
                    }
                });
        }
    });
}

/// The settings of `technique` as widgets; returns whether one changed.
fn settings_widgets(ui: &mut Ui, technique: &str, s: &mut GiSettings) -> bool {
    use octolux::gi::{lpv, lpv::Variant, probes, vct, Family};
    let Ok(technique) = octolux::gi::technique(technique) else {
        return false;
    };
    let mut changed = false;
    let drag = |ui: &mut Ui, label: &str, v: &mut u32, range: std::ops::RangeInclusive<u32>| {
        ui.horizontal(|ui| {
            let changed = ui.add(DragValue::new(v).range(range)).changed();
            ui.label(label);
            changed
        })
        .inner
    };
    match technique.family {
        Family::Lpv(Variant::Uniform) => {
            changed |= drag(ui, "cells per side", &mut s.lpv.size, lpv::LPV_SIZE.range());
            changed |= drag(
                ui,
                "iterations",
                &mut s.lpv.iterations,
                lpv::LPV_ITERATIONS.range(),
            );
        }
        Family::Lpv(Variant::Cascaded) => {
            changed |= drag(
                ui,
                "cascades",
                &mut s.clpv.cascades,
                lpv::CLPV_CASCADES.range(),
            );
            changed |= drag(
                ui,
                "cells per side",
                &mut s.clpv.size,
                lpv::CLPV_SIZE.range(),
            );
            changed |= drag(
                ui,
                "iterations",
                &mut s.clpv.iterations,
                lpv::CLPV_ITERATIONS.range(),
            );
        }
        Family::Lpv(Variant::Octree) => {
            let mut size = s.olpv.size;
            ComboBox::from_label("level-0 side")
                .selected_text(size.to_string())
                .show_ui(ui, |ui| {
                    for n in [8, 16, 32, 64, 128] {
                        ui.selectable_value(&mut size, n, n.to_string());
                    }
                });
            if size != s.olpv.size {
                s.olpv.size = size;
                changed = true;
            }
            changed |= drag(
                ui,
                "iterations per level",
                &mut s.olpv.iterations,
                lpv::OLPV_ITERATIONS.range(),
            );
        }
        Family::ConeTracing(structure) => {
            use octolux::gi::vct::VctStructure;
            let v = &mut s.vct;
            let combo = |ui: &mut Ui, label: &str, value: &mut u32, choices: &[u32]| {
                let mut chosen = *value;
                ComboBox::from_label(label)
                    .selected_text(chosen.to_string())
                    .show_ui(ui, |ui| {
                        for &n in choices {
                            ui.selectable_value(&mut chosen, n, n.to_string());
                        }
                    });
                let changed = chosen != *value;
                *value = chosen;
                changed
            };
            if structure == VctStructure::Octree {
                changed |= combo(
                    ui,
                    "octree voxels per side",
                    &mut v.octree_resolution,
                    &[32, 64, 128, 256],
                );
                changed |= ui
                    .checkbox(&mut v.anisotropic, "anisotropic radiance")
                    .changed();
                changed |= ui
                    .checkbox(&mut v.anisotropic_bounce, "anisotropic in the bounce only")
                    .changed();
                changed |= ui
                    .checkbox(&mut v.facing, "radiance facing (thin walls)")
                    .changed();
            } else {
                changed |= combo(
                    ui,
                    "voxels per level side",
                    &mut v.resolution,
                    &[16, 32, 64, 128],
                );
                changed |= drag(ui, "levels", &mut v.levels, vct::LEVELS.range());
            }
            changed |= ui
                .checkbox(&mut v.multi_bounce, "multiple bounces")
                .changed();
            if v.multi_bounce {
                changed |= drag(
                    ui,
                    "bounce gather frames",
                    &mut v.bounce_frames,
                    vct::BOUNCE_FRAMES.range(),
                );
            }
            let slider = |ui: &mut Ui, label: &str, x: &mut f32, lo: f32, hi: f32| {
                ui.add(Slider::new(x, lo..=hi).text(label)).changed()
            };
            // The diffuse cones' settings are optional (the technique's own defaults); the
            // sliders show the technique's values and an edit sets them.
            let cones = v.diffuse_cones(structure);
            let (mut aperture, mut start) = (cones.aperture, cones.start);
            if slider(ui, "aperture (degrees)", &mut aperture, 10.0, 120.0) {
                v.aperture = Some(aperture);
                changed = true;
            }
            changed |= slider(
                ui,
                "step (x footprint)",
                &mut v.step,
                vct::STEP.min,
                vct::STEP.max,
            );
            if slider(
                ui,
                "start (voxels)",
                &mut start,
                vct::START.min,
                vct::START.max,
            ) {
                v.start = Some(start);
                changed = true;
            }
            changed |= slider(ui, "stop opacity", &mut v.stop_opacity, 0.5, 1.0);
            if structure == VctStructure::Clipmap {
                changed |= drag(
                    ui,
                    "injection steps",
                    &mut v.inject_steps,
                    vct::INJECT_STEPS.range(),
                );
            }
            changed |= drag(
                ui,
                "sparse (N x N block, 0: auto)",
                &mut v.sparse,
                vct::SPARSE.range(),
            );
            return changed;
        }
        Family::Probes { octree } => {
            use octolux::gi::probes::{
                Encoding, Lattice, OctreeGather, RayBackend, SurfelRange, Visibility,
            };
            let p = &mut s.probes;
            changed |= drag(
                ui,
                "history (frames, 0: fixed rays)",
                &mut p.history,
                probes::HISTORY.range(),
            );
            if !octree {
                let mut side = p.grid[0];
                changed |= drag(ui, "probes per axis", &mut side, probes::GRID.range());
                p.grid = [side; 3];
            } else {
                changed |= drag(ui, "max depth", &mut p.max_depth, probes::MAX_DEPTH.range());
                changed |= drag(
                    ui,
                    "min depth (complete down to)",
                    &mut p.min_depth,
                    0..=probes::MAX_DEPTH.max,
                );
                // Keep it within the depth, as the settings require.
                p.min_depth = p.min_depth.min(p.max_depth);
                changed |= drag(
                    ui,
                    "max probes (0: full tree)",
                    &mut p.max_probes,
                    0..=36864,
                );
                changed |= ui
                    .add(Slider::new(&mut p.split_fraction, 0.05..=1.0).text("split fraction"))
                    .changed();
                changed |= ui
                    .add(Slider::new(&mut p.free_fraction, 0.0..=0.95).text("free fraction"))
                    .changed();
                // Keep the two bounds ordered, as the settings require.
                p.free_fraction = p.free_fraction.min(p.split_fraction - 0.05);
                let before = (p.gather, p.surfel_range);
                ComboBox::from_label("gather")
                    .selected_text(format!("{:?}", p.gather))
                    .show_ui(ui, |ui| {
                        ui.selectable_value(&mut p.gather, OctreeGather::Octree, "octree");
                        ui.selectable_value(&mut p.gather, OctreeGather::All, "all probes");
                    });
                ComboBox::from_label("surfel range")
                    .selected_text(format!("{:?}", p.surfel_range))
                    .show_ui(ui, |ui| {
                        ui.selectable_value(&mut p.surfel_range, SurfelRange::Scene, "scene");
                        ui.selectable_value(&mut p.surfel_range, SurfelRange::Cube, "cube");
                    });
                changed |= before != (p.gather, p.surfel_range);
            }
            let before = (p.surfels, p.lattice, p.encoding, p.visibility, p.rays);
            ComboBox::from_label("surfels per probe")
                .selected_text(p.surfels.map_or("default".to_string(), |n| n.to_string()))
                .show_ui(ui, |ui| {
                    ui.selectable_value(&mut p.surfels, None, "default (grid 64, octree 128)");
                    for n in [32, 64, 128, 256] {
                        ui.selectable_value(&mut p.surfels, Some(n), n.to_string());
                    }
                });
            ComboBox::from_label("lattice")
                .selected_text(format!("{:?}", p.lattice))
                .show_ui(ui, |ui| {
                    ui.selectable_value(&mut p.lattice, Lattice::Fibonacci, "Fibonacci");
                    ui.selectable_value(&mut p.lattice, Lattice::LatLong, "lat-long");
                });
            ComboBox::from_label("encoding")
                .selected_text(format!("{:?}", p.encoding))
                .show_ui(ui, |ui| {
                    ui.selectable_value(&mut p.encoding, Encoding::ShL1, "SH L1");
                    ui.selectable_value(&mut p.encoding, Encoding::Octahedron, "octahedron");
                });
            ComboBox::from_label("visibility")
                .selected_text(format!("{:?}", p.visibility))
                .show_ui(ui, |ui| {
                    ui.selectable_value(&mut p.visibility, Visibility::Moments, "depth moments");
                    ui.selectable_value(&mut p.visibility, Visibility::None, "none");
                });
            ComboBox::from_label("rays")
                .selected_text(format!("{:?}", p.rays))
                .show_ui(ui, |ui| {
                    ui.selectable_value(&mut p.rays, RayBackend::Bvh, "BVH (exact)");
                    ui.selectable_value(&mut p.rays, RayBackend::Voxels, "voxel octree");
                });
            changed |= before != (p.surfels, p.lattice, p.encoding, p.visibility, p.rays);
            let mut bounces = p.multi_bounce.unwrap_or(true);
            if ui.checkbox(&mut bounces, "multiple bounces").changed() {
                p.multi_bounce = Some(bounces);
                changed = true;
            }
            changed |= ui
                .add(
                    Slider::new(&mut p.normal_bias, probes::NORMAL_BIAS.range())
                        .text("normal bias (spacings)"),
                )
                .changed();
            return changed;
        }
        Family::None | Family::Vpl => return false,
    }
    // Reflective shadow maps, injection and lookup, shared by the LPV family.
    changed |= drag(ui, "RSM side", &mut s.lpv.rsm_size, 16..=2048);
    changed |= drag(ui, "RSM stride", &mut s.lpv.rsm_stride, 1..=16);
    changed |= drag(ui, "sky RSMs", &mut s.lpv.sky_rsms, 1..=64);
    changed |= ui
        .add(
            Slider::new(&mut s.lpv.directional, lpv::DIRECTIONAL.range())
                .text("directional transfer"),
        )
        .changed();
    changed |= ui
        .add(Slider::new(&mut s.lpv.damping, 0.0..=1.0).text("damping"))
        .changed();
    changed |= ui
        .add(Slider::new(&mut s.lpv.gain, 0.0..=4.0).text("gain"))
        .changed();
    changed |= ui
        .checkbox(&mut s.lpv.occlusion, "occlusion (geometry volume)")
        .changed();
    changed
}

fn view_section(ui: &mut Ui, controls: &mut Controls, facts: &Facts, actions: &mut Vec<Action>) {
    let mut output = controls.output;
    ComboBox::from_label("show")
        .selected_text(output.name())
        .show_ui(ui, |ui| {
            for o in Output::ALL {
                ui.selectable_value(&mut output, o, o.name());
            }
        });
    if output != controls.output {
        actions.push(Action::SetOutput(output));
    }
    ui.add(Slider::new(&mut controls.exposure, -8.0..=8.0).text("exposure EV"));
    ui.add(Slider::new(&mut controls.scale, 0.1..=2.0).text("render scale"));
    ui.horizontal(|ui| {
        if ui.button("reset camera (R)").clicked() {
            actions.push(Action::ResetCamera);
        }
        if ui.button("screenshot (P)").clicked() {
            actions.push(Action::Screenshot);
        }
    });
    ui.small(format!(
        "WASD move, Q/E down/up, drag to look, wheel: speed ({:.2} m/s)",
        facts.speed
    ));
}

fn animation_section(ui: &mut Ui, controls: &mut Controls) {
    if controls.animation_length <= 0.0 {
        ui.label("static scene");
        return;
    }
    ui.horizontal(|ui| {
        let label = if controls.playing { "pause" } else { "play" };
        if ui.button(label).clicked() {
            controls.playing = !controls.playing;
        }
        ui.add(Slider::new(&mut controls.time, 0.0..=controls.animation_length).text("time s"));
    });
}

fn compare_section(ui: &mut Ui, compare: &mut Compare, progress: Option<&Progress>) {
    ui.checkbox(&mut compare.enabled, "compare with the CPU reference");
    if !compare.enabled {
        return;
    }
    ui.horizontal(|ui| {
        for s in Shown::ALL {
            ui.selectable_value(&mut compare.shown, s, s.label());
        }
    });
    ui.horizontal(|ui| {
        ui.add(DragValue::new(&mut compare.target_spp).range(1..=65536));
        ui.label("spp");
        ui.checkbox(&mut compare.unlimited, "all bounces");
    });
    match progress {
        None => ui.label("reference starts when the view rests"),
        Some(p) => {
            if let Some(e) = &p.error {
                ui.colored_label(egui::Color32::LIGHT_RED, e)
            } else {
                let numbers = match (p.flip, p.rel_mse) {
                    (Some(f), Some(r)) => format!("FLIP {f:.4}, relMSE {r:.4e}"),
                    _ => "measuring...".into(),
                };
                ui.label(format!("{} / {} spp: {numbers}", p.spp, p.target))
            }
        }
    };
}

fn memory_section(ui: &mut Ui, facts: &Facts) {
    egui::Grid::new("ledger").striped(true).show(ui, |ui| {
        for (owner, bytes) in facts.ledger.by_owner() {
            ui.label(owner);
            ui.monospace(format!("{:>9.3} MiB", crate::stats::mib(bytes)));
            ui.end_row();
        }
        ui.strong("total");
        ui.monospace(format!(
            "{:>9.3} MiB",
            crate::stats::mib(facts.ledger.total())
        ));
        ui.end_row();
        if let Some((technique, bytes)) = &facts.split_memory {
            ui.label(format!("split screen ({technique}), all owners"));
            ui.monospace(format!("{:>9.3} MiB", crate::stats::mib(*bytes)));
            ui.end_row();
        }
    });
    if let Some(c) = facts.ctx.resource_counts() {
        ui.small(format!(
            "wgpu objects: {} buffers, {} textures, {} bind groups",
            c.buffers, c.textures, c.bind_groups
        ));
    }
}

/// The split screen as drawn: the main image's left half beside the second image's right half.
pub struct SplitView {
    /// The second renderer's image (same size as the main one).
    pub right: egui::TextureId,
    /// Technique of the left half.
    pub left_name: String,
    /// Technique of the right half.
    pub right_name: String,
}

/// Draws `texture` (of `size` pixels) as large as fits in the central area, keeping its aspect
/// ratio, with the right half from `split` when given; returns the response of the image for
/// dragging and the area's size in pixels.
pub fn central_view(
    ui: &mut Ui,
    texture: Option<(egui::TextureId, (u32, u32))>,
    split: Option<&SplitView>,
) -> (Option<egui::Response>, (u32, u32)) {
    let mut result = (None, (0, 0));
    egui::CentralPanel::no_frame().show(ui, |ui| {
        let area = ui.available_rect_before_wrap();
        let ppp = ui.ctx().pixels_per_point();
        result.1 = (
            (area.width() * ppp).round().max(0.0) as u32,
            (area.height() * ppp).round().max(0.0) as u32,
        );
        if let Some((id, (w, h))) = texture {
            let scale = (area.width() / w as f32).min(area.height() / h as f32);
            let size = egui::vec2(w as f32, h as f32) * scale;
            let rect = egui::Rect::from_center_size(area.center(), size);
            let response = ui.put(
                rect,
                egui::Image::new((id, size)).sense(egui::Sense::click_and_drag()),
            );
            if let Some(split) = split {
                draw_split(ui, rect, split);
            }
            result.0 = Some(response);
        }
    });
    result
}

/// Paints the second image's right half over the main one, a divider and the two names.
fn draw_split(ui: &Ui, rect: egui::Rect, split: &SplitView) {
    let painter = ui.painter_at(rect);
    let half = egui::Rect::from_min_max(rect.center_top(), rect.max);
    let uv = egui::Rect::from_min_max(egui::pos2(0.5, 0.0), egui::pos2(1.0, 1.0));
    painter.image(split.right, half, uv, egui::Color32::WHITE);
    painter.line_segment(
        [rect.center_top(), rect.center_bottom()],
        egui::Stroke::new(1.0, egui::Color32::from_gray(220)),
    );
    let font = egui::FontId::proportional(14.0);
    let colour = egui::Color32::from_gray(230);
    let margin = egui::vec2(6.0, 4.0);
    painter.text(
        rect.left_top() + margin,
        egui::Align2::LEFT_TOP,
        &split.left_name,
        font.clone(),
        colour,
    );
    painter.text(
        rect.right_top() + egui::vec2(-margin.x, margin.y),
        egui::Align2::RIGHT_TOP,
        &split.right_name,
        font,
        colour,
    );
}
