//! The window and its event loop: a winit [`ApplicationHandler`] that owns the wgpu surface, the
//! egui state and the [`Renderer`], renders one frame per redraw, and applies what the panels,
//! the keys and the scripted flags ask for.

use super::camera::FlyCamera;
use super::compare::{Compare, Key, Progress, Shown, TestImage};
use super::panels::{self, Action, Controls, Facts};
use super::screenshot;
use super::timing::TimingHistory;
use super::{parse_size, ViewArgs, NO_DISPLAY_HINT};
use crate::gi_args::GiArgs;
use crate::inputs::parse_output;
use anyhow::{anyhow, bail, Context, Result};
use octolux::gi::{GiSettings, TECHNIQUES};
use octolux::gpu::{GpuContext, GpuOptions, ResourceCounts};
use octolux::image_io::check_image_size;
use octolux::render::{Output, RenderSettings, Renderer};
use octolux::scene::{Camera, Scene};
use octolux::transport::{Bounces, Transport};
use std::path::PathBuf;
use std::sync::Arc;
use std::time::{Duration, Instant};
use winit::application::ApplicationHandler;
use winit::event::{ElementState, WindowEvent};
use winit::event_loop::{ActiveEventLoop, ControlFlow, EventLoop};
use winit::keyboard::{KeyCode, PhysicalKey};
use winit::window::{Window, WindowId};

/// Frames a scripted run renders before its screenshot when --frames is not given.
const DEFAULT_SCRIPTED_FRAMES: u32 = 10;
/// Wheel scroll, in egui points, that counts as one notch of camera speed (egui's scroll per
/// wheel line on native platforms).
const POINTS_PER_NOTCH: f32 = 40.0;

/// The checked command line.
pub struct Config {
    scene: Option<PathBuf>,
    gi: String,
    camera: String,
    time: f32,
    play: bool,
    output: Output,
    exposure: Option<f32>,
    window: (u32, u32),
    size: Option<(u32, u32)>,
    scale: f32,
    compare: bool,
    compare_view: Shown,
    spp: u32,
    screenshot: Option<PathBuf>,
    screenshot_window: Option<PathBuf>,
    frames: Option<u32>,
    seconds: Option<f64>,
    then_gi: Option<String>,
    split: Option<String>,
    gpu: GpuOptions,
    shadow_map_size: u32,
    soft_sky_shadows: bool,
    gi_args: GiArgs,
    sky_args: crate::sky_args::SkyArgs,
    budget: crate::inputs::BudgetArgs,
}

impl Config {
    /// Renderer settings for an image of `size` with technique `gi` and technique settings
    /// `applied` (the last ones a technique accepted, not the panel's edits).
    fn render_settings(
        &self,
        size: (u32, u32),
        camera: usize,
        gi: &str,
        applied: &GiSettings,
    ) -> RenderSettings {
        RenderSettings {
            width: size.0,
            height: size.1,
            shadow_map_size: self.shadow_map_size,
            soft_sky_shadows: self.soft_sky_shadows,
            camera,
            gi: gi.to_string(),
            gi_settings: applied.clone(),
        }
    }
}

fn check_technique(name: &str, flag: &str) -> Result<()> {
    if octolux::gi::technique(name).is_err() {
        bail!(
            "{flag} {name}: the viewer shows the GPU techniques ({}); the CPU reference is its \
             compare mode (--compare)",
            TECHNIQUES.join(", ")
        );
    }
    Ok(())
}

impl Config {
    /// Checks every flag before a window opens, so a mistake is reported at once.
    pub fn from_args(args: &ViewArgs) -> Result<Config> {
        check_technique(&args.gi, "--gi")?;
        if let Some(then) = &args.then_gi {
            check_technique(then, "--then-gi")?;
        }
        if let Some(split) = &args.split {
            check_technique(split, "--split")?;
        }
        let window = parse_size(&args.window, "--window")?;
        check_image_size(window.0, window.1)
            .with_context(|| format!("--window {}", args.window))?;
        let size = match &args.size {
            Some(s) => {
                let size = parse_size(s, "--size")?;
                check_image_size(size.0, size.1).with_context(|| format!("--size {s}"))?;
                Some(size)
            }
            None => None,
        };
        if !(0.1..=2.0).contains(&args.scale) {
            bail!("--scale {}: expected 0.1..=2", args.scale);
        }
        if args.spp == 0 {
            bail!("--spp must be at least 1");
        }
        if !args.time.is_finite() {
            bail!("--time must be finite");
        }
        if let Some(ev) = args.exposure {
            if !ev.is_finite() || ev.abs() > 64.0 {
                bail!("--exposure {ev}: expected a finite EV within -64..=64");
            }
        }
        if args.frames == Some(0) {
            bail!("--frames must be at least 1");
        }
        if let Some(s) = args.seconds {
            if !(s.is_finite() && s > 0.0) {
                bail!("--seconds {s}: expected a positive number");
            }
        }
        if args.then_gi.is_some() && args.frames.unwrap_or(0) < 2 {
            bail!("--then-gi switches after half of --frames: give --frames 2 or more");
        }
        for (path, flag) in [
            (&args.screenshot, "--screenshot"),
            (&args.screenshot_window, "--screenshot-window"),
        ] {
            if let Some(p) = path {
                screenshot::check_png(p, flag)?;
            }
        }
        Ok(Config {
            scene: args.scene.clone(),
            gi: args.gi.clone(),
            camera: args.camera.clone(),
            time: args.time,
            play: args.play,
            output: parse_output(&args.output)?,
            exposure: args.exposure,
            window,
            size,
            scale: args.scale,
            compare: args.compare,
            compare_view: match args.compare_view.as_str() {
                "technique" => Shown::Technique,
                "reference" => Shown::Reference,
                "error" => Shown::ErrorMap,
                other => bail!("--compare-view {other}: expected technique, reference or error"),
            },
            spp: args.spp,
            screenshot: args.screenshot.clone(),
            screenshot_window: args.screenshot_window.clone(),
            frames: args.frames,
            seconds: args.seconds,
            then_gi: args.then_gi.clone(),
            split: args.split.clone(),
            gpu: args.gpu.options(),
            shadow_map_size: args.gpu.shadow_map_size,
            soft_sky_shadows: args.gpu.soft_sky_shadows,
            gi_args: args.gi_args.clone(),
            sky_args: args.sky_args.clone(),
            budget: args.budget.clone(),
        })
    }

    /// Frames after which a scripted run ends (None: runs until closed).
    fn last_frame(&self) -> Option<u32> {
        match (self.frames, &self.screenshot, &self.screenshot_window) {
            (Some(n), _, _) => Some(n),
            (None, None, None) => None,
            _ => Some(DEFAULT_SCRIPTED_FRAMES),
        }
    }
}

/// Opens the window and runs until it is closed or a scripted run ends.
pub fn run(config: Config, verbose: bool) -> Result<()> {
    let (mut scene, gi_settings) = crate::inputs::load_scene(
        config.scene.as_deref(),
        &config.gi_args,
        &config.sky_args,
        &config.budget,
    )?;
    let camera_index = scene.camera_index(&config.camera)?;
    if let Some(ev) = config.exposure {
        scene.exposure = ev;
    }
    if scene.cameras.is_empty() {
        // The fly camera replaces a scene camera; give a scene without one its framing camera.
        scene
            .cameras
            .push(Camera::framing(scene.bounds_at(config.time)));
    }
    let event_loop =
        EventLoop::new().map_err(|e| anyhow!("cannot open a window ({e}). {NO_DISPLAY_HINT}"))?;
    event_loop.set_control_flow(ControlFlow::Poll);
    let ctx = GpuContext::new(&config.gpu)?;
    log::info!("adapter: {}", ctx.describe());
    let mut app = App::new(config, scene, camera_index, gi_settings, ctx);
    event_loop
        .run_app(&mut app)
        .map_err(|e| anyhow!("the window's event loop failed: {e}"))?;
    if let Some(e) = app.error.take() {
        return Err(e);
    }
    if verbose {
        println!("{}", app.history.summary());
        if let Some((bytes, objects)) = app.after_first_frame {
            println!(
                "GPU memory (ledger) after the first frame {:.3} MiB, at exit {:.3} MiB",
                crate::stats::mib(bytes),
                crate::stats::mib(app.ctx.ledger.total())
            );
            if let (Some(a), Some(b)) = (objects, app.ctx.resource_counts()) {
                println!(
                    "wgpu objects after the first frame: {} buffers, {} textures, {} bind groups; \
                     at exit: {} buffers, {} textures, {} bind groups",
                    a.buffers, a.textures, a.bind_groups, b.buffers, b.textures, b.bind_groups
                );
            }
        }
        println!("adapter: {}", app.ctx.describe());
        crate::stats::print_memory(&app.ctx.ledger);
        if let Some(split) = app.gfx.as_ref().and_then(|g| g.split.as_ref()) {
            println!(
                "split screen ({}), its own renderer: {:.3} MiB",
                split.renderer.settings().gi,
                crate::stats::mib(split.ctx.ledger.total())
            );
        }
        crate::stats::print_objects(&app.ctx);
    }
    Ok(())
}

/// The split screen's second technique: a renderer of its own, whose memory is counted in a
/// ledger of its own (its resources have the same owners and names as the first one's), and
/// the copy of its image that egui shows.
struct Split {
    ctx: GpuContext,
    renderer: Renderer,
    texture: wgpu::Texture,
    id: egui::TextureId,
    /// `App::settings_generation` when its technique was last built.
    settings_generation: u64,
}

/// What exists only while the window does.
struct Gfx {
    window: Arc<Window>,
    surface: wgpu::Surface<'static>,
    surface_config: wgpu::SurfaceConfiguration,
    egui_ctx: egui::Context,
    egui_state: egui_winit::State,
    egui_renderer: egui_wgpu::Renderer,
    /// Built at the first frame, when the view area's size is known; rebuilt on resize.
    renderer: Option<Renderer>,
    /// A copy of the renderer's display image that egui can sample, and its egui id.
    view: Option<(wgpu::Texture, egui::TextureId)>,
    reference_texture: Option<egui::TextureHandle>,
    error_texture: Option<egui::TextureHandle>,
    split: Option<Split>,
    /// The egui id of the last split-screen image, reused by the next one.
    split_id: Option<egui::TextureId>,
}

struct App {
    config: Config,
    ctx: GpuContext,
    /// The scene; its camera `camera_index` follows the fly camera.
    scene: Scene,
    camera_index: usize,
    /// The scene camera as loaded (with its animation), for resets.
    scene_camera: Camera,
    scene_size: f32,
    fly: FlyCamera,
    controls: Controls,
    /// The technique settings in use: the last ones the technique accepted.
    applied: GiSettings,
    /// Bumped when `applied` changes, so the split screen's technique follows.
    settings_generation: u64,
    compare: Compare,
    history: TimingHistory,
    gfx: Option<Gfx>,
    error: Option<anyhow::Error>,
    frames_done: u32,
    started: Instant,
    last_frame: Instant,
    title_at: Instant,
    /// Bumped when the technique's image changes for another reason than the view (technique,
    /// settings, output, exposure), so compare mode judges the new one.
    image_generation: u64,
    judged_generation: u64,
    /// The area of the window the image is shown in, in pixels (0 until the first frame).
    view_area: (u32, u32),
    /// GPU memory (ledger total) and wgpu's live objects after the first frame, to compare
    /// with those at exit.
    after_first_frame: Option<(u64, Option<ResourceCounts>)>,
    /// The panels' first layout pass is done.
    laid_out: bool,
}

fn animation_length(scene: &Scene) -> f32 {
    let tracks = scene
        .objects
        .iter()
        .filter_map(|o| o.animation.as_ref())
        .chain(scene.lights.iter().filter_map(|l| l.animation.as_ref()))
        .chain(scene.cameras.iter().filter_map(|c| c.animation.as_ref()));
    tracks
        .filter_map(|t| t.keys.last().map(|k| k.time))
        .fold(0.0, f32::max)
}

impl App {
    fn new(
        config: Config,
        scene: Scene,
        camera_index: usize,
        gi_settings: GiSettings,
        ctx: GpuContext,
    ) -> App {
        let scene_camera = scene.cameras[camera_index].clone();
        let (lo, hi) = scene.bounds_at(config.time);
        let scene_size = (hi - lo).length();
        let fly = FlyCamera::new(&scene_camera.at_time(config.time), scene_size);
        let controls = Controls {
            technique: config.gi.clone(),
            settings: gi_settings.clone(),
            settings_dirty: false,
            output: config.output,
            playing: config.play,
            time: config.time,
            animation_length: animation_length(&scene),
            exposure: scene.exposure,
            scale: config.scale,
            status: String::new(),
            split: config.split.clone(),
        };
        let mut compare = Compare::new(config.compare, config.spp);
        compare.shown = config.compare_view;
        let now = Instant::now();
        App {
            config,
            ctx,
            scene,
            camera_index,
            scene_camera,
            scene_size,
            fly,
            controls,
            applied: gi_settings,
            settings_generation: 0,
            compare,
            history: TimingHistory::default(),
            gfx: None,
            error: None,
            frames_done: 0,
            started: now,
            last_frame: now,
            title_at: now,
            image_generation: 0,
            judged_generation: 0,
            view_area: (0, 0),
            after_first_frame: None,
            laid_out: false,
        }
    }

    fn open_window(&mut self, event_loop: &ActiveEventLoop) -> Result<Gfx> {
        let (w, h) = self.config.window;
        let attributes = Window::default_attributes()
            .with_title("octolux view")
            .with_inner_size(winit::dpi::PhysicalSize::new(w, h));
        let window = Arc::new(
            event_loop
                .create_window(attributes)
                .map_err(|e| anyhow!("cannot open a window ({e}). {NO_DISPLAY_HINT}"))?,
        );
        let (Some(instance), Some(adapter)) = (&self.ctx.instance, &self.ctx.adapter) else {
            bail!("the viewer needs a device it created itself (it has no instance to draw with)");
        };
        let surface = instance
            .create_surface(window.clone())
            .map_err(|e| anyhow!("cannot draw into the window: {e}. {NO_DISPLAY_HINT}"))?;
        if !adapter.is_surface_supported(&surface) {
            bail!(
                "the adapter '{}' cannot present to this window; choose another with --adapter",
                self.ctx.info.name
            );
        }
        let size = window.inner_size();
        let surface_config = surface_config(&self.ctx, &surface, size.width, size.height)?;
        if size.width > 0 && size.height > 0 {
            surface.configure(&self.ctx.device, &surface_config);
        }
        let egui_ctx = egui::Context::default();
        let max_side = self.ctx.device.limits().max_texture_dimension_2d as usize;
        let egui_state = egui_winit::State::new(
            egui_ctx.clone(),
            egui::ViewportId::ROOT,
            &window,
            Some(window.scale_factor() as f32),
            None,
            Some(max_side),
        );
        let egui_renderer = egui_wgpu::Renderer::new(
            &self.ctx.device,
            surface_config.format,
            egui_wgpu::RendererOptions::default(),
        );
        Ok(Gfx {
            window,
            surface,
            surface_config,
            egui_ctx,
            egui_state,
            egui_renderer,
            renderer: None,
            view: None,
            reference_texture: None,
            error_texture: None,
            split: None,
            split_id: None,
        })
    }

    /// The render size for the current view area.
    fn render_size(&self) -> Option<(u32, u32)> {
        if let Some(size) = self.config.size {
            return Some(size);
        }
        let (w, h) = self.view_area;
        let s = self.controls.scale;
        let size = (
            ((w as f32 * s).round() as u32).max(1),
            ((h as f32 * s).round() as u32).max(1),
        );
        (w > 0 && h > 0 && check_image_size(size.0, size.1).is_ok()).then_some(size)
    }

    /// Builds the renderer (again) when the render size changed.
    fn ensure_renderer(&mut self, size: (u32, u32)) -> Result<()> {
        let gfx = self.gfx.as_mut().context("no window")?;
        let current = gfx
            .renderer
            .as_ref()
            .map(|r| (r.settings().width, r.settings().height));
        if current == Some(size) {
            return Ok(());
        }
        // Free the old renderer's GPU memory before the new one allocates.
        gfx.renderer = None;
        self.ctx.wait_idle()?;
        let settings = self.config.render_settings(
            size,
            self.camera_index,
            &self.controls.technique,
            &self.applied,
        );
        let mut renderer =
            Renderer::new(&self.ctx, &self.scene, settings).context("setting up the renderer")?;
        renderer.set_output(self.controls.output);
        let reuse = gfx.view.as_ref().map(|(_, id)| *id);
        gfx.view = Some(view_texture(&self.ctx, &mut gfx.egui_renderer, size, reuse));
        gfx.renderer = Some(renderer);
        self.history.clear_passes();
        self.image_generation += 1;
        Ok(())
    }

    /// Builds, updates or drops the split screen's renderer to match the panel.
    fn ensure_split(&mut self, size: (u32, u32)) {
        let Some(gfx) = self.gfx.as_mut() else {
            return;
        };
        let wanted = self.controls.split.clone();
        let stale = gfx.split.as_ref().is_some_and(|s| {
            wanted.is_none() || (s.renderer.settings().width, s.renderer.settings().height) != size
        });
        if stale {
            // Its egui id is kept for the next split screen: this frame's panels may still
            // draw it.
            gfx.split_id = gfx.split.take().map(|old| old.id).or(gfx.split_id);
        }
        let Some(technique) = wanted else {
            return;
        };
        let result = match gfx.split.as_mut() {
            Some(split)
                if split.renderer.settings().gi == technique
                    && split.settings_generation == self.settings_generation =>
            {
                Ok(())
            }
            Some(split) => split
                .renderer
                .set_technique(&self.scene, &technique, &self.applied)
                .map(|()| split.settings_generation = self.settings_generation),
            None => {
                let ctx = self.ctx.with_own_ledger();
                let settings =
                    self.config
                        .render_settings(size, self.camera_index, &technique, &self.applied);
                Renderer::new(&ctx, &self.scene, settings).map(|renderer| {
                    let (texture, id) =
                        view_texture(&ctx, &mut gfx.egui_renderer, size, gfx.split_id);
                    gfx.split = Some(Split {
                        ctx,
                        renderer,
                        texture,
                        id,
                        settings_generation: self.settings_generation,
                    });
                })
            }
        };
        if let Err(e) = result {
            self.controls.status = format!("split screen with {technique}: {e}");
            self.controls.split = None;
        }
    }

    /// Switches the technique: the one function the panel's technique menu and `--then-gi`
    /// both go through. Only the technique is rebuilt (`Renderer::set_technique`).
    fn switch_technique(&mut self, name: &str) {
        let gfx = self.gfx.as_mut();
        let Some(renderer) = gfx.and_then(|g| g.renderer.as_mut()) else {
            self.controls.technique = name.to_string();
            return;
        };
        let start = Instant::now();
        match renderer.set_technique(&self.scene, name, &self.controls.settings) {
            Ok(()) => {
                self.controls.technique = name.to_string();
                self.applied = self.controls.settings.clone();
                self.settings_generation += 1;
                self.controls.status = format!(
                    "switched to {name} in {:.0} ms",
                    start.elapsed().as_secs_f64() * 1e3
                );
                self.history.clear_passes();
                self.image_generation += 1;
            }
            Err(e) => self.controls.status = format!("cannot switch to {name}: {e}"),
        }
    }

    fn apply(&mut self, action: Action) {
        match action {
            Action::SwitchTechnique(name) => self.switch_technique(&name),
            Action::ApplySettings => {
                let name = self.controls.technique.clone();
                self.switch_technique(&name);
            }
            Action::SetOutput(output) => {
                self.controls.output = output;
                if let Some(r) = self.gfx.as_mut().and_then(|g| g.renderer.as_mut()) {
                    r.set_output(output);
                }
                self.image_generation += 1;
            }
            Action::ResetCamera => {
                let speed = self.fly.speed;
                let camera = self.scene_camera.at_time(self.controls.time);
                self.fly = FlyCamera::new(&camera, self.scene_size);
                self.fly.speed = speed;
            }
            Action::Screenshot => {
                let path = screenshot::next_name();
                self.controls.status = match self.save_view(&path) {
                    Ok(msg) => msg,
                    Err(e) => format!("screenshot failed: {e:#}"),
                };
            }
        }
    }

    fn save_view(&self, png: &std::path::Path) -> Result<String> {
        let renderer = self
            .gfx
            .as_ref()
            .and_then(|g| g.renderer.as_ref())
            .context("nothing rendered yet")?;
        let exr = screenshot::save_view(renderer, png)?;
        Ok(format!("saved {} and {}", png.display(), exr.display()))
    }

    fn key(&mut self, code: KeyCode, down: bool, repeat: bool, event_loop: &ActiveEventLoop) {
        if self.fly.key(code, down) || !down || repeat {
            return;
        }
        match code {
            KeyCode::KeyR => self.apply(Action::ResetCamera),
            KeyCode::KeyP | KeyCode::F12 => self.apply(Action::Screenshot),
            KeyCode::Escape => event_loop.exit(),
            _ => {}
        }
    }

    /// Uploads the compare mode's fresh images as egui textures.
    fn upload_compare_images(&mut self, progress: &Progress) {
        let Some(gfx) = self.gfx.as_mut() else {
            return;
        };
        let (w, h) = progress.size;
        let size = [w as usize, h as usize];
        for (rgb, slot, name) in [
            (
                &progress.reference_rgb,
                &mut gfx.reference_texture,
                "reference",
            ),
            (&progress.error_rgb, &mut gfx.error_texture, "flip"),
        ] {
            if let Some(rgb) = rgb {
                let image = egui::ColorImage::from_rgb(size, rgb);
                match slot {
                    Some(handle) => handle.set(image, egui::TextureOptions::LINEAR),
                    None => {
                        *slot = Some(gfx.egui_ctx.load_texture(
                            name,
                            image,
                            egui::TextureOptions::LINEAR,
                        ))
                    }
                }
            }
        }
    }

    fn frame(&mut self, event_loop: &ActiveEventLoop) -> Result<()> {
        let now = Instant::now();
        let dt = (now - self.last_frame).as_secs_f32();
        self.last_frame = now;
        if self.minimised() {
            return Ok(());
        }
        if self.controls.playing && self.controls.animation_length > 0.0 {
            self.controls.time = (self.controls.time + dt) % self.controls.animation_length;
        }
        self.fly.advance(dt);

        // Panels first: they decide the view area and what changes this frame.
        let progress = self.compare.progress();
        if let Some((p, true)) = &progress {
            self.upload_compare_images(p);
        }
        let progress = progress.map(|(p, _)| p);
        let gfx = self.gfx.as_mut().context("no window")?;
        let raw_input = gfx.egui_state.take_egui_input(&gfx.window);
        let renderer_size = gfx
            .renderer
            .as_ref()
            .map(|r| (r.settings().width, r.settings().height));
        let shown = match (self.compare.enabled, self.compare.shown, &progress) {
            (true, Shown::Reference, Some(p)) => {
                gfx.reference_texture.as_ref().map(|t| (t.id(), p.size))
            }
            (true, Shown::ErrorMap, Some(p)) => {
                gfx.error_texture.as_ref().map(|t| (t.id(), p.size))
            }
            _ => None,
        };
        let showing_reference = self.compare.enabled && self.compare.shown != Shown::Technique;
        let split = match (&gfx.split, showing_reference) {
            (Some(s), false) => Some(panels::SplitView {
                right: s.id,
                left_name: self.controls.technique.clone(),
                right_name: s.renderer.settings().gi.clone(),
            }),
            _ => None,
        };
        let split_memory = gfx
            .split
            .as_ref()
            .map(|s| (s.renderer.settings().gi.clone(), s.ctx.ledger.total()));
        let shown = shown.or_else(|| Some((gfx.view.as_ref()?.1, renderer_size?)));
        let title = format!(
            "{} ({} triangles)",
            self.scene.name,
            self.scene.triangle_count()
        );
        let adapter = self.ctx.describe();
        let facts = Facts {
            scene: &title,
            adapter: &adapter,
            render_size: renderer_size.unwrap_or((0, 0)),
            frame_time: self.history.mean_wall(30),
            speed: self.fly.speed,
            history: &self.history,
            ledger: &self.ctx.ledger,
            split_memory,
            ctx: &self.ctx,
        };
        let mut actions = Vec::new();
        let mut area = self.view_area;
        let mut look = (0.0, 0.0);
        let mut wheel = 0.0;
        let controls = &mut self.controls;
        let compare = &mut self.compare;
        let full_output = gfx.egui_ctx.run_ui(raw_input, |ui| {
            actions = panels::side_panel(ui, controls, compare, progress.as_ref(), &facts);
            let (response, central) = panels::central_view(ui, shown, split.as_ref());
            area = central;
            if let Some(r) = response {
                let ppp = ui.ctx().pixels_per_point();
                if r.dragged() {
                    let d = r.drag_delta() * ppp;
                    look = (d.x, d.y);
                }
                if r.hovered() {
                    wheel = ui.input(|i| i.smooth_scroll_delta.y) / POINTS_PER_NOTCH;
                }
            }
        });
        let mut full_output = full_output;
        gfx.egui_state.handle_platform_output(
            &gfx.window,
            std::mem::take(&mut full_output.platform_output),
        );
        // Texture uploads need no surface: apply them now, whatever happens to this frame.
        let mut textures = std::mem::take(&mut full_output.textures_delta);
        for (id, deltas) in &textures.set {
            for delta in deltas {
                gfx.egui_renderer
                    .update_texture(&self.ctx.device, &self.ctx.queue, *id, delta);
            }
        }
        let freed: Vec<egui::TextureId> = textures.free.iter().copied().collect();
        textures.clear();
        self.view_area = area;
        self.fly.look(look.0, look.1);
        if wheel != 0.0 {
            self.fly.wheel(wheel);
        }
        if let (Some(then), Some(n)) = (&self.config.then_gi, self.config.frames) {
            if self.frames_done == n / 2 {
                actions.push(Action::SwitchTechnique(then.clone()));
            }
        }

        // The renderer, at the size the view area asks for, once the panels have settled their
        // layout (the first pass only lays them out; it does not count as a frame).
        let rendering = self.laid_out;
        if let Some(size) = self.render_size().filter(|_| rendering) {
            self.ensure_renderer(size)?;
            self.ensure_split(size);
        }
        for action in actions {
            self.apply(action);
        }
        if (self.scene.exposure - self.controls.exposure).abs() > 0.0 {
            self.scene.exposure = self.controls.exposure;
            self.image_generation += 1;
        }
        self.scene.cameras[self.camera_index] = self.fly.camera();
        let t = self.controls.time;
        let gfx = self.gfx.as_mut().context("no window")?;
        if let Some(renderer) = gfx.renderer.as_mut() {
            if let Some(timings) = renderer.render_pipelined(&self.scene, t)? {
                self.history.push(timings);
            }
            if let Some(split) = gfx.split.as_mut() {
                split.renderer.set_output(self.controls.output);
                split.renderer.render_pipelined(&self.scene, t)?;
            }
            let transport = if self.compare.unlimited {
                Transport::uniform(Bounces::Unlimited)
            } else {
                renderer
                    .technique()
                    .reference_transport()
                    .for_scene(self.scene.has_emissive_surfaces())
            };
            let camera = &self.scene.cameras[self.camera_index];
            let key = Key {
                camera: [camera.position, camera.target],
                time: t,
                size: (renderer.settings().width, renderer.settings().height),
                transport,
            };
            let scene = &self.scene;
            let index = self.camera_index;
            let started = self.compare.update(key, scene, || scene.frame(t, index));
            if self.compare.active() && (started || self.judged_generation != self.image_generation)
            {
                self.judged_generation = self.image_generation;
                self.compare.set_test(TestImage {
                    image: renderer.read_hdr()?,
                    output: self.controls.output,
                    exposure: self.scene.exposure,
                });
            }
        }

        self.present(full_output, &freed)?;
        if !rendering {
            self.laid_out = true;
            return Ok(());
        }
        self.frames_done += 1;
        if self.frames_done == 1 {
            self.after_first_frame = Some((self.ctx.ledger.total(), self.ctx.resource_counts()));
        }
        self.history.push_wall(dt);
        if now - self.title_at > Duration::from_millis(500) {
            self.title_at = now;
            if let (Some(gfx), Some(s)) = (&self.gfx, self.history.mean_wall(30)) {
                gfx.window.set_title(&format!(
                    "octolux view: {} | {} | {:.1} ms/frame",
                    self.scene.name,
                    self.controls.technique,
                    s * 1e3
                ));
            }
        }
        self.scripted_end(event_loop)
    }

    /// Copies the rendered image for egui, draws the panels and presents.
    fn present(&mut self, full_output: egui::FullOutput, freed: &[egui::TextureId]) -> Result<()> {
        let window_shot = self.is_last_frame() && self.config.screenshot_window.is_some();
        let gfx = self.gfx.as_mut().context("no window")?;
        let Some(frame) = acquire(&self.ctx, gfx)? else {
            if window_shot {
                log::warn!("the window could not be drawn in the last frame: no window screenshot");
            }
            // Nothing to draw into this time; free what egui asked to free all the same.
            for id in freed {
                gfx.egui_renderer.free_texture(id);
            }
            return Ok(());
        };
        let device = &self.ctx.device;
        let queue = &self.ctx.queue;
        let ppp = full_output.pixels_per_point;
        let jobs = gfx.egui_ctx.tessellate(full_output.shapes, ppp);
        let screen = egui_wgpu::ScreenDescriptor {
            size_in_pixels: [gfx.surface_config.width, gfx.surface_config.height],
            pixels_per_point: ppp,
        };
        let mut encoder = device.create_command_encoder(&Default::default());
        if let (Some(renderer), Some((texture, _))) = (&gfx.renderer, &gfx.view) {
            encoder.copy_texture_to_texture(
                renderer.display_texture().as_image_copy(),
                texture.as_image_copy(),
                texture.size(),
            );
        }
        if let Some(split) = &gfx.split {
            encoder.copy_texture_to_texture(
                split.renderer.display_texture().as_image_copy(),
                split.texture.as_image_copy(),
                split.texture.size(),
            );
        }
        let extra = gfx
            .egui_renderer
            .update_buffers(device, queue, &mut encoder, &jobs, &screen);
        let target = frame.texture.create_view(&Default::default());
        {
            let pass = encoder.begin_render_pass(&wgpu::RenderPassDescriptor {
                label: Some("panels"),
                color_attachments: &[Some(wgpu::RenderPassColorAttachment {
                    view: &target,
                    depth_slice: None,
                    resolve_target: None,
                    ops: wgpu::Operations {
                        load: wgpu::LoadOp::Clear(wgpu::Color {
                            r: 0.02,
                            g: 0.02,
                            b: 0.02,
                            a: 1.0,
                        }),
                        store: wgpu::StoreOp::Store,
                    },
                })],
                depth_stencil_attachment: None,
                timestamp_writes: None,
                occlusion_query_set: None,
                multiview_mask: None,
            });
            gfx.egui_renderer
                .render(&mut pass.forget_lifetime(), &jobs, &screen);
        }
        queue.submit(extra.into_iter().chain([encoder.finish()]));
        for id in freed {
            gfx.egui_renderer.free_texture(id);
        }
        if window_shot {
            if let Some(path) = &self.config.screenshot_window {
                let rgb = screenshot::read_window(&self.ctx, &frame.texture)?;
                let (w, h) = (gfx.surface_config.width, gfx.surface_config.height);
                octolux::image_io::write_rgb8_png(path, w, h, rgb)?;
                println!("window -> {}", path.display());
            }
        }
        gfx.window.pre_present_notify();
        queue.present(frame);
        self.ctx.check_errors()?;
        Ok(())
    }

    /// A minimised window is 0x0: nothing is rendered until it is back.
    fn minimised(&self) -> bool {
        self.gfx
            .as_ref()
            .is_some_and(|g| g.surface_config.width == 0 || g.surface_config.height == 0)
    }

    fn is_last_frame(&self) -> bool {
        self.config.last_frame() == Some(self.frames_done + 1)
    }

    /// Ends a scripted run: after --frames (saving the screenshots) or --seconds.
    fn scripted_end(&mut self, event_loop: &ActiveEventLoop) -> Result<()> {
        if self.config.last_frame() == Some(self.frames_done) {
            if let Some(path) = &self.config.screenshot {
                println!("{}", self.save_view(path)?);
            }
            event_loop.exit();
        }
        if let Some(s) = self.config.seconds {
            if self.started.elapsed().as_secs_f64() >= s {
                event_loop.exit();
            }
        }
        Ok(())
    }

    fn fail(&mut self, event_loop: &ActiveEventLoop, e: anyhow::Error) {
        if self.error.is_none() {
            self.error = Some(e);
        }
        event_loop.exit();
    }
}

/// A texture of `size` that egui shows, for a copy of a renderer's display image; `reuse`
/// keeps an egui id that already names the previous one.
fn view_texture(
    ctx: &GpuContext,
    egui_renderer: &mut egui_wgpu::Renderer,
    size: (u32, u32),
    reuse: Option<egui::TextureId>,
) -> (wgpu::Texture, egui::TextureId) {
    let texture = ctx.create_texture(
        "viewer",
        &wgpu::TextureDescriptor {
            label: Some("view"),
            size: wgpu::Extent3d {
                width: size.0,
                height: size.1,
                depth_or_array_layers: 1,
            },
            mip_level_count: 1,
            sample_count: 1,
            dimension: wgpu::TextureDimension::D2,
            // egui samples textures as gamma-encoded Rgba8Unorm: the display image as is.
            format: wgpu::TextureFormat::Rgba8Unorm,
            usage: wgpu::TextureUsages::TEXTURE_BINDING | wgpu::TextureUsages::COPY_DST,
            view_formats: &[],
        },
    );
    let view = texture.create_view(&Default::default());
    let filter = wgpu::FilterMode::Linear;
    let id = match reuse {
        Some(id) => {
            egui_renderer.update_egui_texture_from_wgpu_texture(&ctx.device, &view, filter, id);
            id
        }
        None => egui_renderer.register_native_texture(&ctx.device, &view, filter),
    };
    (texture, id)
}

/// A surface configuration for the window: a gamma-space (non-sRGB) format as egui prefers,
/// readable back for window screenshots when the surface allows it.
fn surface_config(
    ctx: &GpuContext,
    surface: &wgpu::Surface,
    width: u32,
    height: u32,
) -> Result<wgpu::SurfaceConfiguration> {
    let adapter = ctx.adapter.as_ref().context("no adapter to present with")?;
    let caps = surface.get_capabilities(adapter);
    let mut config = surface
        .get_default_config(adapter, width.max(1), height.max(1))
        .context("the adapter cannot present to this window")?;
    if let Some(f) = caps.formats.iter().find(|f| !f.is_srgb()) {
        config.format = *f;
    }
    if caps.usages.contains(wgpu::TextureUsages::COPY_SRC) {
        config.usage |= wgpu::TextureUsages::COPY_SRC;
    }
    config.present_mode = wgpu::PresentMode::AutoVsync;
    Ok(config)
}

/// The next surface texture, or None when this frame cannot be drawn (minimised, timed out);
/// an outdated or lost surface is configured (or created) again.
fn acquire(ctx: &GpuContext, gfx: &mut Gfx) -> Result<Option<wgpu::SurfaceTexture>> {
    if gfx.surface_config.width == 0 || gfx.surface_config.height == 0 {
        return Ok(None);
    }
    use wgpu::CurrentSurfaceTexture as C;
    match gfx.surface.get_current_texture() {
        C::Success(t) => Ok(Some(t)),
        C::Suboptimal(t) => {
            // Draw this one; the next frame gets a matching configuration.
            gfx.surface.configure(&ctx.device, &gfx.surface_config);
            Ok(Some(t))
        }
        C::Timeout | C::Occluded => Ok(None),
        C::Outdated => {
            gfx.surface.configure(&ctx.device, &gfx.surface_config);
            Ok(None)
        }
        C::Lost => {
            gfx.surface = ctx
                .instance
                .as_ref()
                .context("no instance to draw with")?
                .create_surface(gfx.window.clone())
                .map_err(|e| {
                    anyhow!("the window's surface was lost and cannot be made again: {e}")
                })?;
            gfx.surface.configure(&ctx.device, &gfx.surface_config);
            Ok(None)
        }
        C::Validation => {
            ctx.check_errors()?;
            Ok(None)
        }
    }
}

impl ApplicationHandler for App {
    fn resumed(&mut self, event_loop: &ActiveEventLoop) {
        if self.gfx.is_some() {
            return;
        }
        match self.open_window(event_loop) {
            Ok(gfx) => {
                gfx.window.request_redraw();
                self.gfx = Some(gfx);
                self.last_frame = Instant::now();
            }
            Err(e) => self.fail(event_loop, e),
        }
    }

    fn window_event(&mut self, event_loop: &ActiveEventLoop, _id: WindowId, event: WindowEvent) {
        let Some(gfx) = self.gfx.as_mut() else {
            return;
        };
        let consumed = gfx.egui_state.on_window_event(&gfx.window, &event).consumed;
        match event {
            WindowEvent::CloseRequested => event_loop.exit(),
            WindowEvent::Resized(size) => {
                // A minimised window is 0x0: keep the configuration and skip frames until it
                // is back (acquire checks the size).
                gfx.surface_config.width = size.width;
                gfx.surface_config.height = size.height;
                if size.width > 0 && size.height > 0 {
                    gfx.surface.configure(&self.ctx.device, &gfx.surface_config);
                }
            }
            WindowEvent::Focused(false) => self.fly.release_keys(),
            WindowEvent::KeyboardInput { event, .. } if !consumed => {
                if let PhysicalKey::Code(code) = event.physical_key {
                    let down = event.state == ElementState::Pressed;
                    self.key(code, down, event.repeat, event_loop);
                }
            }
            WindowEvent::RedrawRequested => {
                if let Err(e) = self.frame(event_loop) {
                    self.fail(event_loop, e);
                }
            }
            _ => {}
        }
    }

    fn about_to_wait(&mut self, event_loop: &ActiveEventLoop) {
        if self.minimised() {
            // Nothing to draw: wake up now and then instead of spinning until restored.
            event_loop.set_control_flow(ControlFlow::WaitUntil(
                Instant::now() + Duration::from_millis(100),
            ));
        } else if let Some(gfx) = &self.gfx {
            event_loop.set_control_flow(ControlFlow::Poll);
            gfx.window.request_redraw();
        }
    }
}
