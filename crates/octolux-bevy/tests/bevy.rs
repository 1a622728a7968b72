//! Octolux's GI inside a headless Bevy app (the `room` example), on whatever adapter wgpu finds
//! (Mesa's lavapipe without a GPU):
//! - the example's image with GI differs from the one without where only indirect light
//!   reaches (the block's face turned away from the lamp);
//! - every technique's indirect irradiance, computed from Bevy's G-buffer (its depth and
//!   normal prepasses) and Bevy's scene mirrored by the plugin, equals octolux's own renderer on
//!   the same glTF file and camera, and switching between them works;
//! - after the block and the lamp moved for frames, the image equals a fresh render of where
//!   they ended;
//! - a device that cannot run octolux leaves the app running, without GI, with a message that
//!   names what it lacks.

#[path = "../examples/room.rs"]
#[allow(dead_code)]
mod room;

use bevy::light::GlobalAmbientLight;
use bevy::prelude::*;
use bevy::render::settings::{RenderCreation, WgpuSettings};
use bevy::render::{RenderApp, RenderPlugin};
use glam::{Mat4, Quat, Vec3 as OVec3};
use octolux::gi::GiSettings;
use octolux::gpu::{GpuContext, GpuOptions};
use octolux::image_io::HdrImage;
use octolux::render::{RenderSettings, Renderer};
use octolux::scene::SkyRadiance;
use octolux::scene::{Keyframe, Scene, Track};
use octolux_bevy::{DeviceStatus, GiAmbient, GiViews, OctoluxGiStatus};
use room::{MainCamera, Options};
use std::sync::Mutex;

/// One Bevy app at a time: they share the process's task pools, and the machine's cores.
static SERIAL: Mutex<()> = Mutex::new(());

/// The comparisons' image size (as examples/deferred's test).
const SIZE: (u32, u32) = (64, 48);
/// Frames per comparison: enough for the techniques that accumulate over frames to settle the
/// same way on both sides.
const FRAMES: u32 = 3;
/// Octolux's shadow maps (both sides): a quarter of the default side keeps lavapipe's frames
/// short; the comparisons do not depend on it.
const SHADOW_MAP: u32 = 512;

fn serial() -> std::sync::MutexGuard<'static, ()> {
    SERIAL.lock().unwrap_or_else(|p| p.into_inner())
}

fn options(technique: &str, gi: bool, size: (u32, u32)) -> Options {
    Options {
        technique: technique.into(),
        gi,
        width: size.0,
        height: size.1,
        animate: false,
        shadow_map_size: SHADOW_MAP,
        log: false,
        ..Options::default()
    }
}

/// The example headless, loaded and drawn, its GI on with `technique`.
fn started(options: &Options) -> App {
    let mut app = room::app(options, true);
    app.finish();
    app.cleanup();
    room::warm_up(&mut app, options.gi);
    app
}

fn camera(app: &mut App) -> Entity {
    app.world_mut()
        .query_filtered::<Entity, With<MainCamera>>()
        .single(app.world())
        .expect("the example's camera")
}

/// The indirect irradiance octolux computed in the Bevy app's last frame.
fn bevy_indirect(app: &mut App) -> HdrImage {
    let camera = camera(app);
    let views = app.sub_app(RenderApp).world().resource::<GiViews>();
    let engine = views
        .engine(camera)
        .expect("an octolux engine for the camera");
    engine.read_indirect().expect("indirect irradiance")
}

/// The room as octolux's importer reads it, as Bevy sees it: Bevy's glTF loader reads light
/// colours as sRGB (the file's colours are linear), so the lamp's colour is Bevy's; the block
/// where the example's animation puts it at `t` (marked moving when it moved, as the plugin
/// marks an entity that moves), the lamp likewise.
fn room_scene(t: f32, moving: bool) -> Scene {
    let mut scene = Scene::load(Options::default().gltf).expect("room.gltf");
    for object in scene.objects.iter_mut().filter(|o| o.name == "block") {
        let offset = room::block_offset(t);
        object.transform =
            Mat4::from_translation(OVec3::new(offset.x, offset.y, offset.z)) * object.transform;
        if moving {
            object.animation = Some(Track {
                keys: vec![Keyframe {
                    time: 0.0,
                    translation: OVec3::ZERO,
                    rotation: Quat::IDENTITY,
                }],
                looping: false,
            });
        }
    }
    assert_eq!(scene.lights.len(), 1, "the room has one lamp");
    let lamp = &mut scene.lights[0];
    let srgb = Color::srgb(lamp.color.x, lamp.color.y, lamp.color.z);
    lamp.color = octolux_bevy::units::linear_rgb(srgb);
    let offset = room::lamp_offset(t);
    lamp.position += OVec3::new(offset.x, offset.y, offset.z);
    scene
}

/// Every triangle of `scene` in world space with its albedo, sorted: two scenes built
/// differently (instances, mesh order) compare equal when they hold the same surfaces.
fn world_triangles(scene: &Scene) -> Vec<[f32; 12]> {
    let mut out = Vec::new();
    for object in &scene.objects {
        let m = object.transform_at(0.0);
        for &mesh in &object.meshes {
            let mesh = &scene.meshes[mesh as usize];
            let albedo = scene.materials[mesh.material as usize].base_color;
            for t in mesh.indices.chunks_exact(3) {
                let mut v =
                    [t[0], t[1], t[2]].map(|i| m.transform_point3(mesh.positions[i as usize]));
                // A triangle's corners from its smallest one, keeping the winding.
                let first = (0..3)
                    .min_by(|&i, &j| v[i].to_array().partial_cmp(&v[j].to_array()).unwrap())
                    .unwrap();
                v.rotate_left(first);
                let mut row = [0.0; 12];
                for (k, p) in v.iter().enumerate() {
                    row[3 * k..3 * k + 3].copy_from_slice(&p.to_array());
                }
                row[9..].copy_from_slice(&albedo.to_array());
                out.push(row);
            }
        }
    }
    // Rounded for the order only, so that rounding noise does not reorder equal rows.
    out.sort_by_key(|r| r.map(|x| (x * 1e4).round() as i64));
    out
}

/// Octolux's own renderer (what `octolux render` runs) on `scene` after `frames` frames.
fn octolux_indirect(
    scene: &Scene,
    technique: &str,
    settings: &GiSettings,
    frames: u32,
) -> HdrImage {
    let ctx = GpuContext::shared(&GpuOptions::default()).expect("context");
    let settings = RenderSettings {
        width: SIZE.0,
        height: SIZE.1,
        gi: technique.into(),
        gi_settings: settings.clone(),
        shadow_map_size: SHADOW_MAP,
        ..RenderSettings::default()
    };
    let mut renderer = Renderer::new(&ctx, scene, settings).expect("renderer");
    for _ in 0..frames {
        renderer.render(scene, 0.0).expect("frame");
    }
    renderer.engine().read_indirect().expect("indirect")
}

/// A bound on relMSE between two images of one technique that differ only by how the G-buffer
/// reached octolux: Bevy's normals are 10-bit unsigned normalised (a step of 2/1023 per
/// component: at most about 2e-3 rad), its depth reversed and infinite (another projection's
/// rounding); both move sample positions and directions by that much. 1e-3 relMSE is far below
/// what any change of technique or scene shows (0.01 to 0.3; the moved room differs from the
/// still one by more than 1e-2, checked below).
const SAME_IMAGE: f64 = 1e-3;

fn check_close(what: &str, ours: &HdrImage, theirs: &HdrImage) {
    if let Err(e) = compare(what, ours, theirs) {
        panic!("{e}");
    }
}

/// relMSE within [`SAME_IMAGE`] and some indirect light, else what went wrong.
fn compare(what: &str, ours: &HdrImage, theirs: &HdrImage) -> Result<(), String> {
    let mean = |i: &HdrImage| {
        i.pixels.iter().map(|p| p.element_sum()).sum::<f32>() / i.pixels.len() as f32
    };
    let error = octolux::metrics::rel_mse(ours, theirs, None).expect("same size");
    println!(
        "{what}: relMSE {error:.2e}, mean irradiance {:.4} (octolux's own {:.4})",
        mean(ours),
        mean(theirs)
    );
    if mean(theirs) <= 0.0 && !what.starts_with("none") {
        return Err(format!("{what}: no indirect light at all"));
    }
    if error > SAME_IMAGE {
        // Where they differ most, to tell an edge from a whole surface.
        let mut worst: Vec<(f32, usize)> = (ours.pixels.iter().zip(&theirs.pixels))
            .map(|(a, b)| (*a - *b).abs().element_sum() / (b.element_sum() + 1e-3))
            .zip(0..)
            .collect();
        worst.sort_by(|a, b| b.0.total_cmp(&a.0));
        let worst: Vec<String> = worst
            .iter()
            .take(5)
            .map(|&(d, i)| {
                format!(
                    "({}, {}) {d:.3}",
                    i % ours.width as usize,
                    i / ours.width as usize
                )
            })
            .collect();
        return Err(format!(
            "{what}: relMSE {error:.3e} between octolux in Bevy and octolux's own renderer; \
             largest relative differences at {}",
            worst.join(", ")
        ));
    }
    Ok(())
}

/// Defaults, with the two largest structures smaller to keep the test short (the comparison
/// does not depend on their size), as examples/deferred's test; and the cone tracers tracing
/// every pixel. Their default traces one pixel per 2 x 2 block and reconstructs the others from
/// alike neighbours, switching to the single most alike one when the alike weight falls under
/// a threshold (`frame/upsample.wgsl`): on the block's top face, one pixel row thin at this
/// size, that switch flips with the G-buffer's last bits (Bevy's 10-bit normals cannot hold an
/// exact 0), and those 9 pixels alone made relMSE 1.1e-3 to 1.5e-3 against every other
/// pixel's agreement. Tracing every pixel compares the G-buffer path itself.
fn small_settings() -> GiSettings {
    let mut settings = GiSettings::default();
    settings.vct.octree_resolution = 64;
    settings.vct.sparse = 1;
    settings.clpv.cascades = 2;
    settings
}

#[test]
fn every_technique_in_bevy_equals_octolux_own_renderer_and_switches_at_run_time() {
    let _serial = serial();
    let mut app = started(&options("none", true, SIZE));
    let camera = camera(&mut app);
    let settings = small_settings();
    let scene = room_scene(0.0, false);
    // One app: each technique is switched to from the previous one, as a user switches.
    let mut failures = Vec::new();
    for &technique in octolux::gi::TECHNIQUES {
        room::set_gi(&mut app, |gi| {
            gi.technique = technique.into();
            gi.settings = settings.clone();
        });
        for _ in 0..FRAMES {
            app.update();
        }
        let status = app
            .world()
            .resource::<OctoluxGiStatus>()
            .camera(camera)
            .expect("the camera's GI status");
        assert!(
            status.active && status.error.is_none() && status.technique == technique,
            "{technique}: {status:?}"
        );
        let ours = bevy_indirect(&mut app);
        let theirs = octolux_indirect(&scene, technique, &settings, FRAMES);
        failures.extend(compare(technique, &ours, &theirs).err());
    }
    assert!(failures.is_empty(), "{}", failures.join("\n"));

    // The scene the plugin mirrored is the file's: the same triangles, albedos and lamp.
    let mirrored = {
        let views = app.sub_app(RenderApp).world().resource::<GiViews>();
        views.engine(camera).expect("engine").scene().clone()
    };
    let (a, b) = (world_triangles(&mirrored), world_triangles(&scene));
    assert_eq!(a.len(), b.len(), "triangle count");
    for (x, y) in a.iter().zip(&b) {
        let close = x.iter().zip(y).all(|(p, q)| (p - q).abs() <= 1e-5);
        assert!(close, "mirrored triangle {x:?}, in the file {y:?}");
    }
    assert_eq!(mirrored.lights.len(), 1);
    let (l, m) = (&mirrored.lights[0], &scene.lights[0]);
    assert!(
        l.position.distance(m.position) < 1e-6
            && (l.radiant() - m.radiant()).abs().max_element() < 1e-4,
        "mirrored lamp {l:?}, in the file {m:?}"
    );

    // Bevy's ambient light is off on the camera while the GI runs, back when it stops.
    let brightness = |app: &App| {
        app.world()
            .get::<AmbientLight>(camera)
            .map(|a| a.brightness)
    };
    assert_eq!(brightness(&app), Some(0.0));
    room::set_gi(&mut app, |gi| gi.enabled = false);
    app.update();
    assert_eq!(
        brightness(&app),
        None,
        "the camera had no ambient light of its own"
    );

    // With `GiAmbient::Sky` the ambient light stays and octolux takes it as a uniform sky.
    app.insert_resource(GlobalAmbientLight {
        brightness: 68.3,
        ..GlobalAmbientLight::default()
    });
    room::set_gi(&mut app, |gi| {
        gi.enabled = true;
        gi.technique = "none".into();
        gi.ambient = GiAmbient::Sky;
    });
    app.update();
    assert_eq!(brightness(&app), None, "the ambient light stays");
    let views = app.sub_app(RenderApp).world().resource::<GiViews>();
    let sky = views.engine(camera).expect("engine").scene().sky.clone();
    match sky.map(|s| s.radiance) {
        Some(SkyRadiance::Constant(radiance)) => {
            assert!(
                (radiance - OVec3::splat(0.1)).abs().max_element() < 1e-6,
                "{radiance}"
            )
        }
        other => panic!("no uniform sky: {other:?}"),
    }
}

/// The drift test's settings: the cone tracers and probes without their multiple bounces and
/// history, which converge over frames (an image after motion would differ from a fresh one by
/// their convergence, not by drift); a smaller octree to keep the test short.
fn drift_settings() -> GiSettings {
    let mut settings = small_settings();
    settings.vct.multi_bounce = false;
    settings.probes.multi_bounce = Some(false);
    settings.probes.history = 0;
    settings
}

#[test]
fn block_and_lamp_moved_for_frames_end_where_a_fresh_render_does() {
    let _serial = serial();
    let settings = drift_settings();
    for technique in ["lpv", "vct-svo", "vpl", "probes-grid"] {
        let mut o = options(technique, true, SIZE);
        o.animate = true;
        let mut app = started(&o);
        room::set_gi(&mut app, |gi| gi.settings = settings.clone());
        app.update();
        let start = bevy_indirect(&mut app);
        // The block (promoted to moving by its first move: one rebuild) and the lamp move
        // every frame.
        app.world_mut().resource_mut::<room::Clock>().running = true;
        for _ in 0..8 {
            app.update();
        }
        app.world_mut().resource_mut::<room::Clock>().running = false;
        app.update();
        let t = app.world().resource::<room::Clock>().t;
        let ours = bevy_indirect(&mut app);
        let theirs = octolux_indirect(&room_scene(t, true), technique, &settings, 2);
        check_close(
            &format!("{technique} after moving (t = {t:.3} s)"),
            &ours,
            &theirs,
        );
        let moved = octolux::metrics::rel_mse(&ours, &start, None).expect("same size");
        assert!(
            moved > 10.0 * SAME_IMAGE,
            "{technique}: the moved state looks like the start (relMSE {moved:.2e}); the test \
             would not see drift"
        );
    }
}

/// The pixels of the block's face turned towards the camera (+z), away from the lamp: only
/// indirect light reaches it. Its corners projected with the example's camera (at (1, 1, 4.2)
/// looking down -z, vertical field of view 0.75 rad), shrunk to the inner half so that edges
/// do not count.
fn shadowed_face(size: (u32, u32)) -> (std::ops::Range<u32>, std::ops::Range<u32>) {
    let (w, h) = (size.0 as f32, size.1 as f32);
    let f = 1.0 / (0.75f32 / 2.0).tan();
    let project = |x: f32, y: f32, z: f32| {
        let (dx, dy, dz) = (x - 1.0, y - 1.0, 4.2 - z);
        let ndc = (f * h / w * dx / dz, f * dy / dz);
        ((ndc.0 + 1.0) * 0.5 * w, (1.0 - ndc.1) * 0.5 * h)
    };
    // The block spans x 0.45..0.95, y 0..0.6, its front face at z = 1.15.
    let (x0, y0) = project(0.45, 0.6, 1.15);
    let (x1, y1) = project(0.95, 0.0, 1.15);
    let shrink = |a: f32, b: f32| {
        let m = (b - a) * 0.25;
        (a + m).ceil() as u32..(b - m).floor() as u32
    };
    (shrink(x0, x1), shrink(y0, y1))
}

#[test]
fn the_example_with_gi_lights_what_only_indirect_light_reaches() {
    let _serial = serial();
    let size = (128, 96);
    let dir = std::env::temp_dir().join(format!("octolux-bevy-{}", std::process::id()));
    std::fs::create_dir_all(&dir).expect("temp dir");
    let shot = |gi: bool| {
        let mut o = options("lpv", gi, size);
        o.frames = Some(4);
        o.screenshot = Some(dir.join(if gi { "on.png" } else { "off.png" }));
        room::run_headless(&o).expect("headless run");
        image::open(o.screenshot.unwrap())
            .expect("screenshot")
            .to_rgba8()
    };
    let off = shot(false);
    let on = shot(true);
    let _ = std::fs::remove_dir_all(&dir);
    assert_eq!(on.dimensions(), size);
    assert!(
        room::lit_pixels(&off) > (size.0 * size.1 / 3) as usize,
        "the lamp lights the room"
    );
    let (xs, ys) = shadowed_face(size);
    let mut n = 0;
    let (mut sum_off, mut sum_on, mut dark_off) = (0.0, 0.0, 0);
    for y in ys.clone() {
        for x in xs.clone() {
            let luma = |p: &image::Rgba<u8>| p.0[..3].iter().map(|&c| c as f64).sum::<f64>() / 3.0;
            let (a, b) = (luma(off.get_pixel(x, y)), luma(on.get_pixel(x, y)));
            sum_off += a;
            sum_on += b;
            dark_off += (a <= 2.0) as u32;
            n += 1;
        }
    }
    let (mean_off, mean_on) = (sum_off / n as f64, sum_on / n as f64);
    println!(
        "block face x {xs:?} y {ys:?} ({n} pixels): mean {mean_off:.1} without GI, {mean_on:.1} \
         with ({dark_off} dark without)"
    );
    assert!(n >= 50, "the face covers {n} pixels");
    // Without GI the face gets no light at all (no ambient light in the example's room).
    assert!(
        dark_off == n,
        "{dark_off} of {n} pixels of the face are dark without GI"
    );
    // With GI it shows the light bounced off the lit floor and walls.
    assert!(
        mean_on >= mean_off + 10.0,
        "the face with GI ({mean_on:.1}) is not brighter than without ({mean_off:.1})"
    );
}

#[test]
fn a_device_that_cannot_run_octolux_leaves_the_app_running_without_gi() {
    let _serial = serial();
    // The adapter's own limits but one storage buffer per stage short of what octolux needs.
    let needed = octolux::embed::required_limits().max_storage_buffers_per_shader_stage;
    let instance =
        wgpu::Instance::new(wgpu::InstanceDescriptor::new_without_display_handle_from_env());
    let adapter =
        pollster::block_on(instance.request_adapter(&Default::default())).expect("adapter");
    let mut limits = adapter.limits();
    limits.max_storage_buffers_per_shader_stage = needed - 1;
    let render = RenderPlugin {
        render_creation: RenderCreation::Automatic(Box::new(WgpuSettings {
            constrained_limits: Some(limits),
            ..default()
        })),
        synchronous_pipeline_compilation: true,
        ..default()
    };
    let o = options("probes-grid", true, (64, 48));
    let mut app = room::app_with(&o, true, Some(render));
    app.finish();
    app.cleanup();
    room::warm_up(&mut app, true);
    for _ in 0..3 {
        app.update();
    }
    let camera = camera(&mut app);
    match app.world().resource::<OctoluxGiStatus>().device() {
        DeviceStatus::Unavailable(why) => assert!(
            why.contains(&format!(
                "max_storage_buffers_per_shader_stage is {}, octolux needs {needed}",
                needed - 1
            )),
            "{why}"
        ),
        other => panic!("the device was accepted: {other:?}"),
    }
    let views = app.sub_app(RenderApp).world().resource::<GiViews>();
    assert!(
        views.engine(camera).is_none(),
        "an engine on a device without GI"
    );
    let image = room::read_target(&mut app).expect("frames");
    assert!(
        room::lit_pixels(&image) > 64 * 48 / 3,
        "the app stops drawing without GI"
    );
}
