//! `room`: a Bevy app with octolux's GI. It loads the room that ships with octolux
//! (examples/deferred/assets/room.gltf: a box room with a red and a green wall, a white block and
//! a ceiling lamp); the block slides and the lamp circles.
//!
//! In a window: `T` next technique, `G` GI on/off, `Esc` quit; the title shows the technique
//! and octolux's GPU time. Headless: `--frames 60 --screenshot out.png` renders 60 frames
//! (30 per second of animation) into an image and writes the last one.
//!
//! ```sh
//! cargo run --release -p octolux-bevy --example room
//! cargo run --release -p octolux-bevy --example room -- --frames 60 --screenshot out.png --technique vct-svo
//! ```

use bevy::app::ScheduleRunnerPlugin;
use bevy::asset::RenderAssetUsages;
use bevy::camera::{Exposure, RenderTarget, ShadowLodOrigin};
use bevy::core_pipeline::tonemapping::Tonemapping;
use bevy::diagnostic::DiagnosticsStore;
use bevy::gltf::GltfLoaderSettings;
use bevy::light::GlobalAmbientLight;
use bevy::prelude::*;
use bevy::render::pipelined_rendering::PipelinedRenderingPlugin;
use bevy::render::render_asset::RenderAssets;
use bevy::render::renderer::{RenderDevice, RenderQueue};
use bevy::render::texture::GpuImage;
use bevy::render::{RenderApp, RenderPlugin};
use bevy::window::{ExitCondition, WindowResolution};
use bevy::winit::WinitPlugin;
use bevy::world_serialization::WorldAssetRoot;
use octolux_bevy::{GiDiagnostics, OctoluxGi, OctoluxGiPlugin, OctoluxGiStatus};
use std::path::PathBuf;
use std::time::Duration;

/// What to run.
#[derive(Clone, Debug)]
pub struct Options {
    /// The glTF file (its node "block" slides, its first point light circles).
    pub gltf: PathBuf,
    /// The technique to start with.
    pub technique: String,
    /// Whether octolux's GI starts on.
    pub gi: bool,
    /// Image size.
    pub width: u32,
    /// Image height.
    pub height: u32,
    /// Headless: frames to render after the scene is up.
    pub frames: Option<u32>,
    /// Headless: where to write the last frame.
    pub screenshot: Option<PathBuf>,
    /// Whether the block and lamp move.
    pub animate: bool,
    /// Side of octolux's shadow maps (texels).
    pub shadow_map_size: u32,
    /// Whether Bevy logs (one app per process may install the logger).
    pub log: bool,
}

impl Default for Options {
    fn default() -> Self {
        Options {
            gltf: PathBuf::from(concat!(
                env!("CARGO_MANIFEST_DIR"),
                "/../../examples/deferred/assets/room.gltf"
            )),
            technique: "probes-grid".into(),
            gi: true,
            width: 960,
            height: 540,
            frames: None,
            screenshot: None,
            animate: true,
            shadow_map_size: 2048,
            log: true,
        }
    }
}

impl Options {
    /// Options from command-line arguments.
    pub fn parse(args: impl IntoIterator<Item = String>) -> Result<Options, String> {
        let mut o = Options::default();
        let mut args = args.into_iter();
        while let Some(arg) = args.next() {
            let mut value = || args.next().ok_or_else(|| format!("{arg} needs a value"));
            let number = |v: String| v.parse::<u32>().map_err(|e| format!("{arg} {v}: {e}"));
            match arg.as_str() {
                "--gltf" => o.gltf = value()?.into(),
                "--technique" => o.technique = value()?,
                "--no-gi" => o.gi = false,
                "--static" => o.animate = false,
                "--width" => o.width = number(value()?)?,
                "--height" => o.height = number(value()?)?,
                "--frames" => o.frames = Some(number(value()?)?),
                "--shadow-map-size" => o.shadow_map_size = number(value()?)?,
                "--screenshot" => o.screenshot = Some(value()?.into()),
                "-h" | "--help" => {
                    return Err("usage: room [--gltf FILE] [--technique NAME] [--no-gi] [--static] \
                         [--width W] [--height H] [--shadow-map-size N] [--frames N --screenshot OUT.png]"
                        .into())
                }
                other => return Err(format!("unknown argument {other}")),
            }
        }
        if !octolux_bevy::TECHNIQUES.contains(&o.technique.as_str()) {
            return Err(format!(
                "unknown technique '{}' (available: {})",
                o.technique,
                octolux_bevy::TECHNIQUES.join(", ")
            ));
        }
        Ok(o)
    }
}

/// The animation clock: seconds of animation (fixed steps when headless, so that a run is
/// reproducible).
#[derive(Resource)]
pub struct Clock {
    /// Seconds.
    pub t: f32,
    /// Seconds per frame when headless; None follows real time.
    pub step: Option<f32>,
    /// Whether things move.
    pub running: bool,
}

/// Where headless frames go.
#[derive(Resource, Clone)]
pub struct Target(pub Handle<Image>);

/// The example's camera.
#[derive(Component)]
pub struct MainCamera;

/// A node's transform in the file (the animation is an offset from it).
#[derive(Component)]
struct Rest(Transform);

/// The app, without a window when `headless` (frames then go to [`Target`]). Headless apps
/// render each frame completely within `update` (no pipelined rendering, pipelines compiled
/// when first used) so that tests can drive them frame by frame.
pub fn app(options: &Options, headless: bool) -> App {
    app_with(options, headless, None)
}

/// [`app`] with the renderer's settings (`render`; None: Bevy's defaults).
pub fn app_with(options: &Options, headless: bool, render: Option<RenderPlugin>) -> App {
    let mut app = App::new();
    let assets = options
        .gltf
        .parent()
        .map(|p| p.to_string_lossy().into_owned())
        .unwrap_or_default();
    let plugins = DefaultPlugins.set(AssetPlugin {
        file_path: assets,
        ..default()
    });
    let plugins = if options.log {
        plugins
    } else {
        plugins.disable::<bevy::log::LogPlugin>()
    };
    if headless {
        app.add_plugins(
            plugins
                .set(WindowPlugin {
                    primary_window: None,
                    exit_condition: ExitCondition::DontExit,
                    ..default()
                })
                .set(render.unwrap_or(RenderPlugin {
                    synchronous_pipeline_compilation: true,
                    ..default()
                }))
                .disable::<WinitPlugin>()
                .disable::<PipelinedRenderingPlugin>(),
        )
        .add_plugins(ScheduleRunnerPlugin::run_loop(Duration::ZERO));
    } else {
        let plugins = match render {
            Some(render) => plugins.set(render),
            None => plugins,
        };
        app.add_plugins(plugins.set(WindowPlugin {
            primary_window: Some(Window {
                title: "octolux GI in Bevy".into(),
                resolution: WindowResolution::new(options.width, options.height),
                ..default()
            }),
            ..default()
        }));
    }
    // A closed room lit by its lamp: no light comes from anywhere else.
    app.insert_resource(GlobalAmbientLight::NONE)
        .insert_resource(ClearColor(Color::BLACK))
        .add_plugins(OctoluxGiPlugin)
        .insert_resource(Clock {
            t: 0.0,
            step: headless.then_some(1.0 / 30.0),
            running: options.animate,
        })
        .add_systems(Update, (animate, light_shadows, keys, title));
    let options = options.clone();
    let target = headless.then(|| {
        let mut images = app.world_mut().resource_mut::<Assets<Image>>();
        let mut image = Image::new_target_texture(
            options.width,
            options.height,
            bevy::render::render_resource::TextureFormat::Rgba8UnormSrgb,
            None,
        );
        // Read back for the screenshot.
        image.texture_descriptor.usage |= bevy::render::render_resource::TextureUsages::COPY_SRC;
        Target(images.add(image))
    });
    if let Some(target) = &target {
        app.insert_resource(target.clone());
    }
    app.add_systems(
        Startup,
        move |mut commands: Commands, assets: Res<AssetServer>| {
            let file = options
                .gltf
                .file_name()
                .map(|f| f.to_string_lossy().into_owned())
                .unwrap_or_default();
            // The file's camera is replaced by the example's (same place and field of view).
            let scene = assets
                .load_builder()
                .with_settings(|s: &mut GltfLoaderSettings| {
                    s.load_cameras = false;
                    // Octolux reads the meshes on the CPU: they stay in the main world too.
                    s.load_meshes = RenderAssetUsages::default();
                })
                .load(GltfAssetLabel::Scene(0).from_asset(file));
            commands.spawn(WorldAssetRoot(scene));
            let mut camera = commands.spawn((
                MainCamera,
                Camera3d::default(),
                Transform::from_xyz(1.0, 1.0, 4.2),
                Projection::Perspective(PerspectiveProjection {
                    fov: 0.75,
                    near: 0.05,
                    ..default()
                }),
                Exposure { ev100: 8.0 },
                Tonemapping::AcesFitted,
                OctoluxGi {
                    enabled: options.gi,
                    shadow_map_size: options.shadow_map_size,
                    ..OctoluxGi::new(&options.technique)
                },
            ));
            if let Some(target) = &target {
                // Shadow cascades and LODs are chosen from this camera, as from a window's.
                camera.insert((
                    RenderTarget::Image(target.0.clone().into()),
                    ShadowLodOrigin,
                ));
            }
        },
    );
    app
}

/// Moves the node called "block" and the first point light over the clock's time: the block
/// slides along x, the lamp circles (the animation of examples/deferred).
#[allow(clippy::type_complexity)]
fn animate(
    mut commands: Commands,
    time: Res<Time>,
    mut clock: ResMut<Clock>,
    mut nodes: Query<(
        Entity,
        &Name,
        &mut Transform,
        Option<&Rest>,
        Has<PointLight>,
    )>,
) {
    if clock.running {
        clock.t += clock.step.unwrap_or(time.delta_secs());
    }
    let t = clock.t;
    for (entity, name, mut transform, rest, light) in &mut nodes {
        let offset = if light {
            lamp_offset(t)
        } else if name.as_str() == "block" {
            block_offset(t)
        } else {
            continue;
        };
        let Some(rest) = rest else {
            commands.entity(entity).insert(Rest(*transform));
            continue;
        };
        let target = rest.0.translation + offset;
        if transform.translation != target {
            transform.translation = target;
        }
    }
}

/// Where the block is at `t` seconds, from where the file puts it.
pub fn block_offset(t: f32) -> Vec3 {
    Vec3::new(0.45 * (0.9 * t).sin(), 0.0, 0.0)
}

/// Where the lamp is at `t` seconds, from where the file puts it.
pub fn lamp_offset(t: f32) -> Vec3 {
    Vec3::new(0.5 * (1.3 * t).sin(), 0.0, 0.3 * (1.0 - (1.3 * t).cos()))
}

/// The lamp casts shadows, as octolux's lights always do.
fn light_shadows(mut lights: Query<&mut PointLight, Added<PointLight>>) {
    for mut light in &mut lights {
        light.shadow_maps_enabled = true;
    }
}

fn keys(
    keys: Option<Res<ButtonInput<KeyCode>>>,
    mut cameras: Query<&mut OctoluxGi>,
    mut exit: MessageWriter<AppExit>,
) {
    let Some(keys) = keys else {
        return;
    };
    for mut gi in &mut cameras {
        if keys.just_pressed(KeyCode::KeyT) {
            gi.next_technique();
        }
        if keys.just_pressed(KeyCode::KeyG) {
            gi.enabled = !gi.enabled;
        }
    }
    if keys.just_pressed(KeyCode::Escape) {
        exit.write(AppExit::Success);
    }
}

/// The window title: technique, GI on/off and octolux's GPU time.
fn title(
    mut windows: Query<&mut Window>,
    cameras: Query<&OctoluxGi>,
    diagnostics: Res<DiagnosticsStore>,
    status: Res<OctoluxGiStatus>,
) {
    let (Ok(mut window), Ok(gi)) = (windows.single_mut(), cameras.single()) else {
        return;
    };
    let ms = diagnostics
        .get(&GiDiagnostics::TOTAL)
        .and_then(|d| d.smoothed())
        .map_or(String::new(), |ms| format!(" {ms:.2} ms"));
    let state = match status.device() {
        octolux_bevy::DeviceStatus::Unavailable(_) => "unavailable",
        _ if gi.enabled => "on",
        _ => "off",
    };
    let title = format!(
        "octolux GI in Bevy: {} {state}{ms} (T: next technique, G: GI on/off)",
        gi.technique
    );
    if window.title != title {
        window.title = title;
    }
}

/// Runs headless frames until the scene is loaded and drawn: the image stops changing.
/// The GI is held off meanwhile (nothing to see yet), then set as `gi`.
pub fn warm_up(app: &mut App, gi: bool) {
    // The first frame spawns the camera (and its GI on an empty scene, a cheap start).
    app.update();
    set_gi(app, |g| g.enabled = false);
    app.world_mut().resource_mut::<Clock>().running = false;
    let mut last = None;
    let mut stable = 0;
    for _ in 0..600 {
        app.update();
        let image = read_target(app);
        let lit = image.as_ref().map_or(0, lit_pixels);
        if lit > 0 && last == image {
            stable += 1;
            if stable == 3 {
                break;
            }
        } else {
            stable = 0;
        }
        last = image;
    }
    set_gi(app, |g| g.enabled = gi);
}

/// Changes the example camera's GI settings.
pub fn set_gi(app: &mut App, f: impl FnOnce(&mut OctoluxGi)) {
    let world = app.world_mut();
    let mut query = world.query_filtered::<&mut OctoluxGi, With<MainCamera>>();
    if let Ok(mut gi) = query.single_mut(world) {
        f(&mut gi);
    }
}

/// Pixels with any channel above 10 (of 255).
pub fn lit_pixels(image: &image::RgbaImage) -> usize {
    image
        .pixels()
        .filter(|p| p.0[..3].iter().any(|&c| c > 10))
        .count()
}

/// The headless target as it is after the last frame (sRGB, RGBA8).
pub fn read_target(app: &mut App) -> Option<image::RgbaImage> {
    let handle = app.world().get_resource::<Target>()?.0.clone();
    let world = app.sub_app(RenderApp).world();
    let texture = &world
        .resource::<RenderAssets<GpuImage>>()
        .get(&handle)?
        .texture;
    let device = world.resource::<RenderDevice>().wgpu_device();
    let queue: &wgpu::Queue = world.resource::<RenderQueue>();
    let (w, h) = (texture.width(), texture.height());
    let row = (w * 4).next_multiple_of(wgpu::COPY_BYTES_PER_ROW_ALIGNMENT);
    let staging = device.create_buffer(&wgpu::BufferDescriptor {
        label: Some("room screenshot"),
        size: row as u64 * h as u64,
        usage: wgpu::BufferUsages::COPY_DST | wgpu::BufferUsages::MAP_READ,
        mapped_at_creation: false,
    });
    let mut encoder = device.create_command_encoder(&Default::default());
    encoder.copy_texture_to_buffer(
        texture.as_image_copy(),
        wgpu::TexelCopyBufferInfo {
            buffer: &staging,
            layout: wgpu::TexelCopyBufferLayout {
                offset: 0,
                bytes_per_row: Some(row),
                rows_per_image: Some(h),
            },
        },
        texture.size(),
    );
    queue.submit([encoder.finish()]);
    staging.map_async(wgpu::MapMode::Read, .., |_| {});
    device.poll(wgpu::PollType::wait_indefinitely()).ok()?;
    let data = staging.get_mapped_range(..).ok()?;
    let mut pixels = Vec::with_capacity((w * h * 4) as usize);
    for y in 0..h as usize {
        let start = y * row as usize;
        pixels.extend_from_slice(&data[start..start + w as usize * 4]);
    }
    image::RgbaImage::from_raw(w, h, pixels)
}

/// Headless: warm up, render `frames` frames, write the screenshot, print the GI's state.
pub fn run_headless(options: &Options) -> Result<image::RgbaImage, String> {
    let mut app = app(options, true);
    app.finish();
    app.cleanup();
    warm_up(&mut app, options.gi);
    app.world_mut().resource_mut::<Clock>().running = options.animate;
    for _ in 0..options.frames.unwrap_or(10).max(1) {
        app.update();
    }
    let image = read_target(&mut app).ok_or("no frame was rendered")?;
    let status = app.world().resource::<OctoluxGiStatus>().clone();
    let camera = app
        .world_mut()
        .query_filtered::<Entity, With<MainCamera>>()
        .single(app.world())
        .map_err(|e| e.to_string())?;
    match (status.device(), status.camera(camera)) {
        (octolux_bevy::DeviceStatus::Unavailable(why), _) => {
            println!("octolux GI unavailable: {why}")
        }
        (_, Some(s)) => {
            let total: f64 = s.timings.iter().map(|t| t.1).sum();
            println!(
                "octolux GI: {} {}, {:.1} MiB{}{}",
                s.technique,
                if s.active { "on" } else { "off" },
                s.memory_bytes as f64 / (1 << 20) as f64,
                if s.timings.is_empty() {
                    String::new()
                } else {
                    format!(", {total:.2} ms over {} passes", s.timings.len())
                },
                s.error.map_or(String::new(), |e| format!(", error: {e}"))
            );
        }
        _ => println!("octolux GI: off"),
    }
    if let Some(path) = &options.screenshot {
        image
            .save(path)
            .map_err(|e| format!("cannot write {}: {e}", path.display()))?;
        println!("screenshot: {}", path.display());
    }
    Ok(image)
}

#[allow(dead_code)]
fn main() {
    let options = match Options::parse(std::env::args().skip(1)) {
        Ok(o) => o,
        Err(e) => {
            eprintln!("error: {e}");
            std::process::exit(2);
        }
    };
    if options.frames.is_some() || options.screenshot.is_some() {
        if let Err(e) = run_headless(&options) {
            eprintln!("error: {e}");
            std::process::exit(1);
        }
        return;
    }
    app(&options, false).run();
}
